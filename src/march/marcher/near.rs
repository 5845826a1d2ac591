//! Step 2 of the marching method: a front node near another node of the actual front, or
//! of another front (closer than the near distance, normals agreeing, each inside the
//! other's front angle), splits the front in two or unites the two fronts.

use std::cmp::Reverse;

use glam::DVec3;

use super::Marcher;
use crate::march::MarchError;
use crate::march::angle::{ccw, polar};
use crate::march::ring::{FrontId, NodeId, PointId};

/// A near pair closer than this fraction of the smaller local step is one point, not a
/// bridge: the free one is merged into the other (`snap`). United across so short a bridge,
/// the fronts closed it with slivers the quality stage could not always mend (a hole's wall
/// whose last row came within 0.005 of its rim: 28.8°; a boss's rim: a front angle of 358°).
const SNAP: f64 = 0.25;
/// How far inside each other's front angle (radians, from either front edge) a near pair
/// must lie. A b along a front edge of a lies beyond a's neighbour on that edge (or on the
/// edge itself), and a split or union there runs its bridge along the edge: the end of the
/// bridge kept a front angle of half a degree, and on a lattice of rods at three times their
/// radius the fronts then crossed and left the face. The neighbour is the nearer partner.
const INSIDE_MARGIN: f64 = 0.05;
/// The union completes the other of its first appearances at once only while its front angle
/// is below this (π). Completing the first can put a new point beside the other one's
/// neighbour: the other then has a front angle of 360° (its neighbours on one side) and
/// would be closed with a full fan across meshed area (a flange's rim wall, turned: the fan
/// left the wall and the piece was marched again finer). Left to Step 1, it waits until
/// Step 2 has joined the new point to that neighbour.
const AT_ONCE_BELOW: f64 = std::f64::consts::PI;
/// The smallest angle (degrees) a triangle moved by a snap may have.
const SNAP_MIN_ANGLE: f64 = 10.0;

impl Marcher<'_> {
    /// Step 2 over the nodes that are new or changed. Splits or unites at the first near
    /// pair found and returns the new actual front.
    pub(super) fn distance_checks(
        &mut self,
        actual: FrontId,
    ) -> Result<Option<FrontId>, MarchError> {
        while let Some(a) = self.pending.pop() {
            self.pending_flag[a.index()] = false;
            if !self.rings.alive(a) || !self.checkable[a.index()] || self.rings.front(a) != actual {
                continue;
            }
            let Some(b) = self.near_partner(a) else {
                continue;
            };
            return if self.rings.front(b) == actual {
                Ok(Some(self.split(a, b)))
            } else {
                self.unite(a, b).map(Some)
            };
        }
        Ok(None)
    }

    /// The nearest node b that is near a in the sense of Step 2: closer than the near
    /// distance, not a or its (second) neighbour, normals agreeing, and each inside the
    /// other's front angle (Remark 3: otherwise the two are separated by meshed area).
    fn near_partner(&mut self, a: NodeId) -> Option<NodeId> {
        let pa_id = self.rings.point(a);
        let pa = self.pos[pa_id.index()];
        let (ap, an) = (self.rings.prev(a), self.rings.next(a));
        let (ap_id, an_id) = (self.rings.point(ap), self.rings.point(an));
        // Near within the smaller of the two local steps: with the larger, fronts across a
        // plate's tight rim were joined (docs/marcher.md, the local step). A given polygon
        // with edges longer than twice the local step beside it can thus be passed between
        // its vertices: the verification lays such flaws to the polygon (`CoarsePolygon`).
        let ha = self.h[pa_id.index()];
        let near = self.s.near_distance;
        let mut cands = std::mem::take(&mut self.scratch);
        cands.clear();
        self.hash.for_near(pa, |cell| {
            // Each written, and kept by moving the count on if near enough, without a
            // branch: about one candidate in three is kept, in no order a branch predictor
            // learns (the filter took 8 % of the fine sphere's run with a branch here). The
            // count is a local: as the vector's length it went through memory each node.
            let from = cands.len();
            cands.resize(from + cell.len(), (a, pa));
            let out = &mut cands[from..];
            let mut kept = 0;
            for &(b, pb, hb) in cell {
                let r = near * ha.min(hb);
                out[kept] = (b, pb);
                kept += usize::from(pb.distance_squared(pa) < r * r);
            }
            cands.truncate(from + kept);
        });
        let (t1a, t2a, na) = (
            self.t1[pa_id.index()],
            self.t2[pa_id.index()],
            self.normal[pa_id.index()],
        );
        // Computed at the first candidate that passes the cheap tests (most checks have none).
        let mut w1a = None;
        let mut best: Option<(f64, NodeId)> = None;
        for &(b, pb) in &cands {
            let pb_id = self.rings.point(b);
            if b == a || pb_id == pa_id || pb_id == ap_id || pb_id == an_id {
                continue;
            }
            let (bp, bn) = (self.rings.prev(b), self.rings.next(b));
            if self.rings.point(bp) == pa_id || self.rings.point(bn) == pa_id {
                continue;
            }
            if self.rings.front(b) == self.rings.front(a)
                && (b == self.rings.next(an) || b == self.rings.prev(ap))
            {
                continue;
            }
            let bi = pb_id.index();
            if na.dot(self.normal[bi]) < self.s.near_normal_cos {
                continue;
            }
            let w1 = *w1a.get_or_insert_with(|| polar(pa, t1a, t2a, self.pos[ap_id.index()]));
            let th = ccw(w1, polar(pa, t1a, t2a, pb));
            if !(th > INSIDE_MARGIN && th < self.angle[a.index()] - INSIDE_MARGIN) {
                continue;
            }
            let w1b = polar(pb, self.t1[bi], self.t2[bi], self.p(bp));
            let thb = ccw(w1b, polar(pb, self.t1[bi], self.t2[bi], pa));
            if !(thb > INSIDE_MARGIN && thb < self.angle[b.index()] - INSIDE_MARGIN) {
                continue;
            }
            let d = pa.distance(pb);
            if best.is_some_and(|(bd, bb)| (d, b) >= (bd, bb)) || !self.same_sheet(pa, pb) {
                continue;
            }
            best = Some((d, b));
        }
        self.scratch = cands;
        best.map(|(_, b)| b)
    }

    /// Do two near front points see each other across the surface, not across a gap between
    /// two sheets? The midpoint of their chord must lie within `near_midpoint`·|a − b| of
    /// the surface (linear estimate |f|/|∇f|): on one sheet it is the chord's sagitta, across
    /// a gap half the gap.
    fn same_sheet(&mut self, pa: DVec3, pb: DVec3) -> bool {
        let vg = self.surface.value_gradient(0.5 * (pa + pb));
        let g = vg.gradient.length();
        g > 0.0 && vg.value.abs() <= self.s.near_midpoint * pa.distance(pb) * g
    }

    /// Step 2, first case: a and b of the actual front are near. The shorter arc becomes a
    /// new front and the actual one; the ends take no part in later distance checks.
    fn split(&mut self, a: NodeId, b: NodeId) -> FrontId {
        let old = self.rings.front(a);
        let (x, y) = if self.rings.forward_arc_shorter(a, b) {
            (a, b)
        } else {
            (b, a)
        };
        let (nf, x2, y2) = self.rings.split(x, y);
        self.ensure_heap(nf);
        self.grow();
        for n in [x, y, x2, y2] {
            self.uncheck(n);
        }
        for n in self.rings.walk(nf) {
            if n != x2 && n != y2 && !self.border[self.rings.point(n).index()] {
                let e = Reverse((
                    self.angle[n.index()].to_bits(),
                    n.0,
                    self.version[n.index()],
                ));
                self.heaps[nf.index()].push(e);
            }
        }
        for n in [x, y, x2, y2] {
            self.update_angle(n);
        }
        if self.trace {
            eprintln!(
                "march: split front {} at {} – {}: new front {} of {} points, old keeps {}",
                old.0,
                self.p(x),
                self.p(y),
                nf.0,
                self.rings.len(nf),
                self.rings.len(old)
            );
        }
        self.passive.push(old);
        nf
    }

    /// Step 2, second case: a of the actual front is near b of another front. The fronts
    /// are united with a and b doubled; the first appearances are completed at once, the
    /// smaller front angle first (the other only while its angle is below `AT_ONCE_BELOW`),
    /// and the second ones take no part in later distance checks.
    fn unite(&mut self, a: NodeId, b: NodeId) -> Result<FrontId, MarchError> {
        if let Some(f) = self.snap(a, b) {
            return Ok(f);
        }
        let (fa, fb, b1, a2) = self.unite_rings(a, b);
        for n in [a, b, b1, a2] {
            self.update_angle(n);
        }
        if self.trace {
            eprintln!(
                "march: unite front {} with front {} at {} – {} ({} points)",
                fa.0,
                fb.0,
                self.p(a),
                self.p(b),
                self.rings.len(fa)
            );
        }
        let (first, second) = if self.angle[a.index()] <= self.angle[b1.index()] {
            (a, b1)
        } else {
            (b1, a)
        };
        self.complete(first)?;
        if self.rings.alive(second)
            && self.rings.len(fa) > 3
            && self.angle[second.index()] < AT_ONCE_BELOW
        {
            self.complete(second)?;
        }
        Ok(fa)
    }

    /// The rings of a (the actual front) and b (another) made one, a → b1 … b → a2 → …,
    /// the other front's heap moved to the actual one's, the four ends out of distance checks
    /// and the other front's nodes queued for them. Returns (a's front, b's old front, b1,
    /// a2).
    fn unite_rings(&mut self, a: NodeId, b: NodeId) -> (FrontId, FrontId, NodeId, NodeId) {
        let fa = self.rings.front(a);
        let fb = self.rings.front(b);
        let other: Vec<NodeId> = self.rings.walk(fb);
        let (b1, a2) = self.rings.unite(a, b);
        self.grow();
        let moved = std::mem::take(&mut self.heaps[fb.index()]);
        self.heaps[fa.index()].extend(moved);
        for n in [a, b, b1, a2] {
            self.uncheck(n);
        }
        for n in other {
            if self.checkable[n.index()] {
                self.mark_pending(n);
            }
        }
        (fa, fb, b1, a2)
    }

    /// Step 2's union where a and b are closer than `SNAP`·h: the one of them that is a free
    /// point (not on a polygon or the box, on the front once) is merged into the other —
    /// its triangles take the other point — and the fronts are united at that one point,
    /// which the united front then holds twice (as a union's doubled points, out of later
    /// distance checks). None, with nothing changed, where neither can go.
    fn snap(&mut self, a: NodeId, b: NodeId) -> Option<FrontId> {
        let (pa, pb) = (self.rings.point(a), self.rings.point(b));
        let h = self.h[pa.index()].min(self.h[pb.index()]);
        if self.pos[pa.index()].distance(self.pos[pb.index()]) >= SNAP * h {
            return None;
        }
        let free = |m: &Self, n: NodeId, p: PointId| {
            p.0 >= m.fixed_points && !m.border[p.index()] && m.checkable[n.index()]
        };
        let a_goes = if free(self, a, pa) && self.merge_point(pa, pb, SNAP_MIN_ANGLE) {
            true
        } else if free(self, b, pb) && self.merge_point(pb, pa, SNAP_MIN_ANGLE) {
            false
        } else {
            return None;
        };
        // a, b1, …, b, a2: the gone point's two nodes leave, the kept point's two stay.
        let (fa, fb, b1, a2) = self.unite_rings(a, b);
        let (gone, kept) = if a_goes {
            ([a, a2], [b1, b])
        } else {
            ([b1, b], [a, a2])
        };
        for n in gone {
            self.rings.replace(n, &[]);
        }
        for k in kept {
            for n in [self.rings.prev(k), k, self.rings.next(k)] {
                self.update_angle(n);
                if self.checkable[n.index()] {
                    self.mark_pending(n);
                }
            }
        }
        if self.trace {
            let (g, k) = if a_goes { (pa, pb) } else { (pb, pa) };
            eprintln!(
                "march: snap point {} into {} at {} (fronts {} and {}, {} points)",
                g.0,
                k.0,
                self.pos[k.index()],
                fa.0,
                fb.0,
                self.rings.len(fa)
            );
        }
        Some(fa)
    }
}
