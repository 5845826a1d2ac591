//! Step 3 of the marching method: a node surrounded by triangles of about 60° and replaced
//! in its front by the new points, or, for a needle, merged away (`collapse`); and the new
//! points Steps 0 and 3 make: graded by the local step, on the box's border or a face.

use glam::DVec3;

/// The smallest angle (degrees) a triangle moved by a collapse may keep, unless the sliver
/// the collapse avoids is thinner still.
const COLLAPSED_MIN: f64 = 5.0;

/// The smallest angle (degrees) of a fan that closes a small polygon (`close_fan`).
const FAN_MIN_ANGLE: f64 = 30.0;

use super::{GRADING_RETRIES, Marcher};
use crate::march::MarchError;
use crate::march::angle::{polar, triangle_count};
use crate::march::ring::{FrontId, NodeId, PointId};
use crate::solve::{SurfacePoint, surface_point, tangent_frame};

impl Marcher<'_> {
    /// A new point `r` from `parent` along the tangent `dir` (Steps 0 and 3), nearer where
    /// the point's own local step says that r jumped into a finer region than grading allows
    /// (h(q) < (1 − grading)·r, e.g. onto a thin rim): then it is made again at
    /// h(q)/(1 − grading), a few times.
    pub(super) fn graded_point(
        &mut self,
        parent: PointId,
        dir: DVec3,
        r: f64,
    ) -> Result<PointId, MarchError> {
        let from = self.pos[parent.index()];
        let keep = 1.0 - self.sizing.settings().grading;
        let mut r = r;
        for _ in 0..GRADING_RETRIES {
            let id = self.new_point(parent, from + r * dir)?;
            let hq = self.h[id.index()];
            if self.border[id.index()] || hq >= keep * r || self.sizing.is_uniform() {
                return Ok(id);
            }
            self.pop_point();
            r = hq / keep;
        }
        self.new_point(parent, from + r * dir)
    }

    /// Undoes the last `add_point` (a point nothing refers to yet).
    fn pop_point(&mut self) {
        self.pos.pop();
        self.normal.pop();
        self.t1.pop();
        self.t2.pop();
        self.border.pop();
        self.first_tri.pop();
        self.h.pop();
        self.size.pop();
    }

    /// A new point for the chord from point `parent` to q: surfacepoint of q, or, if the
    /// chord or its surface point leaves the box, a border point where the chord meets it.
    fn new_point(&mut self, parent: PointId, q: DVec3) -> Result<PointId, MarchError> {
        let from = self.pos[parent.index()];
        if !self.inside(q) {
            return self.border_point(parent, from, q);
        }
        let sp = surface_point(self.surface, q, self.step, &self.s.surface_point)
            .map_err(|source| MarchError::NewPoint { near: q, source })?;
        if !self.inside(sp.point) {
            return self.border_point(parent, from, sp.point);
        }
        if let Some((lo, hi)) = self.bbox {
            // A point this close to a face would leave slivers between it and the border
            // points beyond it: it goes onto the face instead.
            let p = sp.point;
            let snap = self.s.box_snap * self.h[parent.index()];
            let (mut best, mut axis, mut value) = (snap, usize::MAX, 0.0);
            for k in 0..3 {
                for bound in [lo[k], hi[k]] {
                    let d = (p[k] - bound).abs();
                    if d < best {
                        (best, axis, value) = (d, k, bound);
                    }
                }
            }
            if axis != usize::MAX {
                let mut u = p;
                u[axis] = value;
                return self.face_point(parent, u, axis);
            }
        }
        Ok(self.add_point(sp, false, Some(parent)))
    }

    /// The chord from → q (from inside, q outside the box) truncated at the box, then moved
    /// onto the surface within the box face it hit (Newton along the gradient projected into
    /// the face), so that border points lie on the box.
    fn border_point(
        &mut self,
        parent: PointId,
        from: DVec3,
        q: DVec3,
    ) -> Result<PointId, MarchError> {
        // Without a box (never the case: callers check `inside` first) nothing truncates.
        let (lo, hi) = self
            .bbox
            .unwrap_or((DVec3::splat(f64::NEG_INFINITY), DVec3::splat(f64::INFINITY)));
        let d = q - from;
        let (mut t, mut axis, mut value) = (1.0f64, 0usize, 0.0);
        for k in 0..3 {
            let bound = if d[k] > 0.0 && q[k] > hi[k] {
                hi[k]
            } else if d[k] < 0.0 && q[k] < lo[k] {
                lo[k]
            } else {
                continue;
            };
            let tk = ((bound - from[k]) / d[k]).clamp(0.0, 1.0);
            if tk < t {
                (t, axis, value) = (tk, k, bound);
            }
        }
        let mut u = from + t * d;
        u[axis] = value;
        self.face_point(parent, u, axis)
    }

    /// A border point: from `start` on the box face orthogonal to `axis`, onto the surface
    /// within that face (falling back to plain surfacepoint where the surface runs along
    /// the face).
    fn face_point(
        &mut self,
        parent: PointId,
        start: DVec3,
        axis: usize,
    ) -> Result<PointId, MarchError> {
        let value = start[axis];
        let mut u = start;
        let tol = self.s.surface_point.relative_step * self.step;
        let mut converged = false;
        for _ in 0..self.s.surface_point.max_iterations {
            let vg = self.surface.value_gradient(u);
            let mut g = vg.gradient;
            g[axis] = 0.0;
            let g2 = g.length_squared();
            if !(g2 > 0.0 && g2.is_finite() && vg.value.is_finite()) {
                break;
            }
            let delta = g * (vg.value / g2);
            if delta.length() > self.step {
                // The surface runs nearly parallel to the face here: give up on the face.
                break;
            }
            u -= delta;
            u[axis] = value;
            if delta.length() <= tol.max(8.0 * f64::EPSILON * u.abs().max_element()) {
                converged = true;
                break;
            }
        }
        let sp = if converged && self.inside_loose(u) {
            let vg = self.surface.value_gradient(u);
            let normal = vg.gradient.normalize_or_zero();
            let (t1, t2) = tangent_frame(normal);
            SurfacePoint {
                point: u,
                normal,
                t1,
                t2,
            }
        } else {
            surface_point(self.surface, start, self.step, &self.s.surface_point).map_err(
                |source| MarchError::NewPoint {
                    near: start,
                    source,
                },
            )?
        };
        if self.trace {
            eprintln!("march: border point {} (face axis {axis})", sp.point);
        }
        Ok(self.add_point(sp, true, Some(parent)))
    }

    /// Inside the box up to rounding of the face coordinate.
    fn inside_loose(&self, p: DVec3) -> bool {
        match self.bbox {
            Some((lo, hi)) => {
                let eps = 1e-12 * self.step;
                p.cmpge(lo - eps).all() && p.cmple(hi + eps).all()
            }
            None => true,
        }
    }

    /// Step 3 at node m: surround it with triangles of ≈ 60°, replace it in its front by the
    /// new points, and mark the neighbours changed.
    pub(super) fn complete(&mut self, m: NodeId) -> Result<(), MarchError> {
        let (v1, v2) = (self.rings.prev(m), self.rings.next(m));
        let (pm_id, p1_id, p2_id) = (
            self.rings.point(m),
            self.rings.point(v1),
            self.rings.point(v2),
        );
        let (pm, p1, p2) = (
            self.pos[pm_id.index()],
            self.pos[p1_id.index()],
            self.pos[p2_id.index()],
        );
        let omega = self.angle[m.index()];
        if omega < self.s.collapse_angle
            && self.rings.len(self.rings.front(m)) > 4
            && self.collapse(m, v1, v2)
        {
            return Ok(());
        }
        let hm = self.h[pm_id.index()];
        let mut nt = if self.rings.len(self.rings.front(m)) <= 3 {
            1
        } else {
            triangle_count(
                omega,
                pm.distance(p1),
                pm.distance(p2),
                p1.distance(p2),
                hm,
                &self.s,
            )
        };
        // A new point beside a neighbour would land within `close_neighbour`·δ of the node
        // beyond that neighbour — which Step 2 never joins to it (second neighbours are no
        // near partners), so the front would fold there: one triangle fewer. (A band 2.4
        // steps tall between a front and a bound: the point the paper's split of a wide
        // triangle makes lands just past the bound, beside its next node, and the march ran
        // out of the band.)
        let (t1, t2) = (self.t1[pm_id.index()], self.t2[pm_id.index()]);
        let w1 = polar(pm, t1, t2, p1);
        // The direction of the i-th of the nt − 1 new points.
        let along = |i: u32, nt: u32| {
            let w = w1 + i as f64 * (omega / nt as f64);
            w.cos() * t1 + w.sin() * t2
        };
        let beyond = [self.p(self.rings.prev(v1)), self.p(self.rings.next(v2))];
        while nt > 1 {
            let near = [1, nt - 1].iter().any(|&i| {
                let q = pm + hm * along(i, nt);
                beyond
                    .iter()
                    .any(|b| b.distance(q) < self.s.close_neighbour * hm)
            });
            if !near {
                break;
            }
            nt -= 1;
        }
        if self.trace {
            eprintln!(
                "march: complete {} (point {}) angle {:.4} with {} triangle(s)",
                pm, pm_id.0, omega, nt
            );
        }
        let mut new_points = Vec::with_capacity(nt as usize - 1);
        if nt > 1 {
            for i in 1..nt {
                new_points.push(self.graded_point(pm_id, along(i, nt), hm)?);
            }
        }
        let mut prev = p1_id;
        for &p in &new_points {
            self.add_triangle(prev, p, pm_id);
            prev = p;
        }
        self.add_triangle(prev, p2_id, pm_id);
        self.uncheck(m);
        let new_nodes = self.rings.replace(m, &new_points);
        self.grow();
        self.drop_spikes(v1);
        for n in new_nodes {
            self.update_angle(n);
        }
        for n in [v1, v2] {
            if self.rings.alive(n) {
                self.update_angle(n);
                if self.checkable[n.index()] {
                    self.mark_pending(n);
                }
            }
        }
        Ok(())
    }

    /// A front of five to eight given polygon points and nothing else (a blind hole's floor,
    /// a rod's end, a small face between creases), closed by a fan around one new point at
    /// its centre where every triangle of the fan has all angles of at least
    /// `FAN_MIN_ANGLE` and faces ∇f: completions one point at a time leave a thin triangle
    /// in such a polygon (13.8° on a hole's floor whose radius is the step). False, with
    /// nothing changed, where the fan would not be that good.
    pub(super) fn close_fan(&mut self, f: FrontId) -> Result<bool, MarchError> {
        // Asked at every step of the march: the length first, the walk only for a small front.
        let n = self.rings.len(f);
        if !(5..=8).contains(&n) {
            return Ok(false);
        }
        let nodes = self.rings.walk(f);
        let ids: Vec<PointId> = nodes.iter().map(|&v| self.rings.point(v)).collect();
        if ids
            .iter()
            .any(|p| p.0 >= self.fixed_points || self.border[p.index()])
            || (0..n).any(|i| (i + 1..n).any(|j| ids[i] == ids[j]))
        {
            return Ok(false);
        }
        let corners: Vec<DVec3> = ids.iter().map(|p| self.pos[p.index()]).collect();
        let centre = corners.iter().sum::<DVec3>() / n as f64;
        let Ok(c) = self.new_point(ids[0], centre) else {
            return Ok(false);
        };
        let pc = self.pos[c.index()];
        let mut turn = 0.0;
        let good = !self.border[c.index()]
            && (0..n).all(|i| {
                let (a, b) = (ids[i], ids[(i + 1) % n]);
                let (pa, pb) = (self.pos[a.index()], self.pos[b.index()]);
                let [x, y, z] = crate::mesh::quality::triangle_angles(pa, pc, pb);
                turn += y;
                let facing = (pc - pa).cross(pb - pa);
                x.min(y).min(z) >= FAN_MIN_ANGLE
                    && [a, c, b]
                        .iter()
                        .all(|p| facing.dot(self.normal[p.index()]) > 0.0)
            })
            && (turn - 360.0f64).abs() < 1.0;
        if !good {
            self.pop_point();
            return Ok(false);
        }
        for i in 0..n {
            self.add_triangle(ids[i], c, ids[(i + 1) % n]);
        }
        Ok(true)
    }

    /// Step 3 for a needle: m's front angle is tiny and its neighbours v1, v2 lie within
    /// `close_neighbour`·δ of each other, so the triangle (v1, v2, m) would be a sliver.
    /// Instead the newer of the two points is merged into the older (an edge collapse):
    /// its triangles take the older point, and m and its node leave the front. False
    /// (nothing done) where that is not safe: border or polygon points, a point with
    /// several nodes, or an existing edge between the two.
    fn collapse(&mut self, m: NodeId, v1: NodeId, v2: NodeId) -> bool {
        let (p1, p2) = (self.rings.point(v1), self.rings.point(v2));
        if p1 == p2
            || self.border[p1.index()]
            || self.border[p2.index()]
            || self.pos[p1.index()].distance(self.pos[p2.index()])
                > self.s.close_neighbour * self.h[self.rings.point(m).index()]
        {
            return false;
        }
        let (keep, gone, gone_node) = if p1 < p2 { (p1, p2, v2) } else { (p2, p1, v1) };
        if gone.0 < self.fixed_points || !self.checkable[gone_node.index()] {
            return false;
        }
        // A triangle moved from `gone` to `keep` must not be flattened into a sliver worse
        // than the one the collapse avoids (`keep` a polygon vertex in line with two others:
        // a triangle of three points on a crease).
        let min_angle = self.angle[m.index()].to_degrees().min(COLLAPSED_MIN);
        if !self.merge_point(gone, keep, min_angle) {
            return false;
        }
        if self.trace {
            eprintln!(
                "march: collapse point {} into {} at {} (front angle {:.4})",
                gone.0,
                keep.0,
                self.pos[keep.index()],
                self.angle[m.index()]
            );
        }
        self.uncheck(m);
        self.rings.replace(m, &[]);
        self.uncheck(gone_node);
        self.rings.replace(gone_node, &[]);
        let kept = if gone_node == v1 { v2 } else { v1 };
        for n in [self.rings.prev(kept), kept, self.rings.next(kept)] {
            self.update_angle(n);
            if self.checkable[n.index()] {
                self.mark_pending(n);
            }
        }
        true
    }

    /// Moves the triangles of point `gone` onto point `keep` (an edge collapse without the
    /// edge), if none of them then faces away from its corners' normals or has an angle
    /// below `min_angle` (degrees), and none has both corners already (the edge would fold).
    /// False, with nothing changed, otherwise. The ring is the caller's.
    pub(super) fn merge_point(&mut self, gone: PointId, keep: PointId, min_angle: f64) -> bool {
        let from = self.first_tri[gone.index()] as usize;
        let tris = &self.triangles[from.min(self.triangles.len())..];
        if tris
            .iter()
            .any(|t| t.contains(&gone.0) && t.contains(&keep.0))
        {
            return false;
        }
        let pk = self.pos[keep.index()];
        let flips = tris.iter().filter(|t| t.contains(&gone.0)).any(|t| {
            let [a, b, c] = t.map(|v| {
                if v == gone.0 {
                    pk
                } else {
                    self.pos[v as usize]
                }
            });
            let n = t.iter().map(|&v| self.normal[v as usize]).sum::<DVec3>();
            let [x, y, z] = crate::mesh::quality::triangle_angles(a, b, c);
            (b - a).cross(c - a).dot(n) <= 0.0 || x.min(y).min(z) < min_angle
        });
        if flips {
            return false;
        }
        for t in &mut self.triangles[from..] {
            for v in t.iter_mut() {
                if *v == gone.0 {
                    *v = keep.0;
                }
            }
        }
        let fk = self.first_tri[keep.index()].min(from as u32);
        self.first_tri[keep.index()] = fk;
        self.merged += 1;
        true
    }

    /// After a completion, two consecutive nodes of the same point (possible next to the
    /// doubled points of a union) would form a zero-length front edge: keep one.
    fn drop_spikes(&mut self, v: NodeId) {
        if !self.rings.alive(v) {
            return;
        }
        let n = self.rings.next(v);
        if n != v
            && self.rings.point(n) == self.rings.point(v)
            && self.rings.len(self.rings.front(v)) > 3
        {
            self.uncheck(n);
            self.rings.replace(n, &[]);
            self.update_angle(v);
            let nn = self.rings.next(v);
            self.update_angle(nn);
        }
    }
}
