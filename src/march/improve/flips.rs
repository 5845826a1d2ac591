//! Edge flips: to the restricted Delaunay condition (`try_flip`, `flip_all` over a queue
//! of edges, screened by obtuse angles) and for the valences (`try_flip_as`, the ratios'
//! phase).

use rayon::prelude::*;

use crate::surface::Surface;

use super::{DELAUNAY_MARGIN, FOLD_COS, NONE, Stage, midpoint_within, prev};

/// Whether the angle opposite half-edge e (in its triangle) or opposite its twin f (in
/// theirs) is obtuse, by the triangles' `Stage::obtuse_corners` masks: the corner opposite
/// a half-edge is the next after its end.
/// The sine of a triangle's smallest angle below which an edge between two polygon
/// vertices beside it may be flipped (about 1°).
const SLIVER_SIN: f64 = 0.017;

fn obtuse_opposite(obtuse: &[u8], e: u32, f: u32) -> bool {
    let opposite = |g: u32| 1u8 << ((g + 2) % 3);
    obtuse[(e / 3) as usize] & opposite(e) != 0 || obtuse[(f / 3) as usize] & opposite(f) != 0
}

impl Stage<'_> {
    /// Flips the edge of half-edge e if the quad violates the Delaunay condition (the angles
    /// opposite the edge sum to more than π), the flip does not lower the smaller of the
    /// pair's smallest angles, both new triangles face ∇f, the pair is not folded, and the
    /// new edge's midpoint is within `tolerance` of the surface. Returns whether it flipped.
    fn try_flip(&mut self, e: u32, surface: &mut dyn Surface, tolerance: f64) -> bool {
        self.try_flip_as(e, surface, tolerance, None)
    }

    pub(super) fn try_flip_as(
        &mut self,
        e: u32,
        surface: &mut dyn Surface,
        tolerance: f64,
        valence_floor: Option<f64>,
    ) -> bool {
        let f = self.twin[e as usize];
        if f == NONE {
            return false;
        }
        let (a, b) = (self.org(e), self.dst(e));
        let c = self.org(prev(e));
        let d = self.org(prev(f));
        // An edge between two polygon vertices is kept, unless a triangle beside it is a
        // sliver: three polygon vertices in line on a crease (a polygon edge split at its
        // middle) make a triangle of no area over an edge that is no polygon edge (it has a
        // twin), and only its flip removes it.
        if c == d
            || (self.constrained(a, b)
                && (self.frozen[a as usize]
                    || self.frozen[b as usize]
                    || self.q([a, b, c]).min(self.q([b, a, d])) >= SLIVER_SIN))
        {
            return false;
        }
        let (nt, nu) = ([a, d, c], [d, b, c]);
        let old = || self.q([a, b, c]).min(self.q([b, a, d]));
        // The cheap tests first (most edges fail them): the valences before the vertices'
        // flags and positions.
        if let Some(floor) = valence_floor {
            let val = |v: u32| self.valence[v as usize] as f64;
            let en = |x: f64| (x - 6.0) * (x - 6.0);
            let before = en(val(a)) + en(val(b)) + en(val(c)) + en(val(d));
            let after = en(val(a) - 1.0) + en(val(b) - 1.0) + en(val(c) + 1.0) + en(val(d) + 1.0);
            if after >= before {
                return false;
            }
            if ![a, b, c, d].iter().all(|&v| self.free(v)) {
                return false;
            }
            if self.q(nt).min(self.q(nu)) < old().min(floor) {
                return false;
            }
        } else {
            // sin(α + β) of the angles at c and d opposite a–b, without inverse cosines:
            // α + β > π + margin exactly where it is below −sin(margin).
            let [pa, pb, pc, pd] = [a, b, c, d].map(|v| self.p(v));
            let (u1, v1, u2, v2) = (pa - pc, pb - pc, pa - pd, pb - pd);
            // Neither angle obtuse: both terms of sin(α + β) below are ≥ 0, so the test
            // fails; most edges of a marched mesh end here, before the lengths and crosses.
            let (cos1, cos2) = (u1.dot(v1), u2.dot(v2));
            if cos1 >= 0.0 && cos2 >= 0.0 {
                return false;
            }
            let lens = u1.length() * v1.length() * u2.length() * v2.length();
            let sin_sum = u1.cross(v1).length() * cos2 + cos1 * u2.cross(v2).length();
            if !(lens > 0.0 && sin_sum < -DELAUNAY_MARGIN.sin() * lens) {
                return false;
            }
            if self.q(nt).min(self.q(nu)) < old() {
                return false;
            }
        }
        let (pt, pu) = (self.corners(nt), self.corners(nu));
        if !self.facing(nt, pt) || !self.facing(nu, pu) {
            return false;
        }
        let n1 = (pt[1] - pt[0]).cross(pt[2] - pt[0]).normalize_or_zero();
        let n2 = (pu[1] - pu[0]).cross(pu[2] - pu[0]).normalize_or_zero();
        if n1.dot(n2) < FOLD_COS {
            return false;
        }
        // c–d must not already be an edge (the flip would make it non-manifold).
        if self.edge_exists(c, d) {
            return false;
        }
        if !midpoint_within(surface, self.p(c), self.p(d), tolerance) {
            return false;
        }
        let [o_ad, o_db, o_bc, o_ca] = self.outer(e, f);
        let (t, u) = (e / 3, f / 3);
        self.set(t, nt);
        self.set(u, nu);
        // t = [a, d, c]: a→d, d→c, c→a; u = [d, b, c]: d→b, b→c, c→d.
        self.link(3 * t, o_ad);
        self.link(3 * t + 1, 3 * u + 2);
        self.link(3 * t + 2, o_ca);
        self.link(3 * u, o_db);
        self.link(3 * u + 1, o_bc);
        if valence_floor.is_some() {
            self.valence[a as usize] -= 1;
            self.valence[b as usize] -= 1;
            self.valence[c as usize] += 1;
            self.valence[d as usize] += 1;
        }
        true
    }

    /// Flips until no edge of `queue` (and of what the flips touch) violates the Delaunay
    /// condition, at most `budget` flips. With `obtuse` (`delaunay_queue`'s screen), an
    /// edge the flips push is tried only where a triangle of its has an obtuse angle
    /// opposite it, the masks kept up to date through the flips. With `flipped`, the two
    /// triangles of every flip are listed there.
    pub(super) fn flip_all(
        &mut self,
        mut queue: Vec<u32>,
        mut obtuse: Option<Vec<u8>>,
        budget: usize,
        surface: &mut dyn Surface,
        tolerance: f64,
        mut flipped: Option<&mut Vec<u32>>,
    ) -> (usize, bool) {
        let mut flips = 0;
        queue.reverse();
        while let Some(e) = queue.pop() {
            if flips >= budget {
                return (flips, false);
            }
            let f = self.twin[e as usize];
            if f == NONE {
                continue;
            }
            let (t, u) = (e / 3, f / 3);
            if obtuse
                .as_deref()
                .is_some_and(|obtuse| !obtuse_opposite(obtuse, e, f))
            {
                continue;
            }
            if self.try_flip(e, surface, tolerance) {
                flips += 1;
                if let Some(flipped) = &mut flipped {
                    flipped.extend([t, u]);
                }
                if let Some(obtuse) = &mut obtuse {
                    obtuse[t as usize] = self.obtuse_corners(t);
                    obtuse[u as usize] = self.obtuse_corners(u);
                }
                // The four outer edges of the quad.
                for x in [3 * t, 3 * t + 2, 3 * u, 3 * u + 1] {
                    queue.push(x);
                }
            }
        }
        (flips, true)
    }

    /// Bit k: the angle of triangle t at its corner k is obtuse (the dot product of its
    /// sides there is negative, computed as `try_flip_as` does).
    fn obtuse_corners(&self, t: u32) -> u8 {
        let p = self.corners(self.tri[t as usize]);
        (0..3).fold(0, |bits, k| {
            // Corner k is opposite the side from corner k + 1 to k + 2.
            let (a, b, c) = (p[(k + 1) % 3], p[(k + 2) % 3], p[k]);
            if (a - c).dot(b - c) < 0.0 {
                bits | 1 << k
            } else {
                bits
            }
        })
    }

    /// The queue for `flip_all`: the interior edges with an end marked in `dirty`. Where at
    /// least half the vertices are marked (the first round marks all), only those with an
    /// obtuse angle opposite them in a triangle of theirs, and the triangles' obtuse
    /// corners (`obtuse_corners`) to screen the edges the flips push: an edge with neither
    /// opposite angle obtuse is not flipped (`try_flip_as`'s first test, on the same dot
    /// products), and an edge screened out here that a flip changes is one of the flipped
    /// quad's outer edges, which the flip pushes. On a marched mesh that is nearly every
    /// edge: the fine sphere's first queue is 7 451 edges instead of two million, built in
    /// two passes on the pool (screening every edge in the flips' loop, in one thread, was
    /// most of the first round's flips). Fewer marked vertices: `dirty_edges`, unscreened,
    /// without a pass over every triangle.
    pub(super) fn delaunay_queue(&self, dirty: &[bool]) -> (Vec<u32>, Option<Vec<u8>>) {
        let marked = dirty.iter().filter(|&&d| d).count();
        if 2 * marked < dirty.len() {
            return (self.dirty_edges(dirty), None);
        }
        let obtuse: Vec<u8> = (0..self.tri.len() as u32)
            .into_par_iter()
            .map(|t| self.obtuse_corners(t))
            .collect();
        let mut queue = Vec::new();
        // In parallel, in order: the queue is the same for any thread count.
        queue.par_extend((0..3 * self.tri.len() as u32).into_par_iter().filter(|&e| {
            let f = self.twin[e as usize];
            f != NONE
                && e < f
                && (dirty[self.org(e) as usize] || dirty[self.dst(e) as usize])
                && obtuse_opposite(&obtuse, e, f)
        }));
        (queue, Some(obtuse))
    }

    /// The interior edges (one half-edge each, the lower) with an end marked in `dirty`.
    pub(super) fn dirty_edges(&self, dirty: &[bool]) -> Vec<u32> {
        // Room for every inner edge up front: collecting into a growing vector copied the
        // first round's (every edge's) queue several times over.
        let mut queue = Vec::with_capacity(3 * self.tri.len() / 2 + 1);
        // In parallel, in order: the queue is the same for any thread count.
        queue.par_extend((0..3 * self.tri.len() as u32).into_par_iter().filter(|&e| {
            let f = self.twin[e as usize];
            f != NONE && e < f && (dirty[self.org(e) as usize] || dirty[self.dst(e) as usize])
        }));
        queue
    }
}
