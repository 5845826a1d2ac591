//! Where flips and smoothing do not mend a triangle below the target: insertion of an
//! off-centre on trial (split of the triangle, of an edge, or of a boundary edge on a box
//! face), kept only if it raises the smallest angle, removal of a free corner merged
//! into a neighbour, and two free vertices merged into one beside a fixed corner.

use glam::DVec3;

use crate::surface::Surface;

use super::shape::{barycentric, circumcentre};
use super::smooth::face_point;
use super::{FOLD_COS, NONE, Project, Stage, Undo, midpoint_within, min_sin, next, prev};

impl Stage<'_> {
    /// Inserts a vertex for bad triangle t on trial: kept only if, after flips around it
    /// and smoothing of it and its ring, every triangle the insertion changed has a larger
    /// smallest angle than t had. Returns whether it was kept.
    pub(super) fn insert_on_trial(
        &mut self,
        t: u32,
        surface: &mut dyn Surface,
        tolerance: f64,
        sliding: bool,
        project: &mut Project<'_>,
    ) -> (bool, usize) {
        let before = self.q(self.tri[t as usize]);
        let (points, triangles) = (self.pos.len(), self.tri.len());
        self.log = Some(Vec::new());
        let mut flips = 0;
        let kept = 'trial: {
            let Some(p) = self.insert(t, surface, project) else {
                break 'trial false;
            };
            let mut star = Vec::new();
            if self.star(p, &mut star) || (sliding && self.open_star(p, &mut star)) {
                let q: Vec<u32> = star.iter().map(|&e| next(e)).collect();
                flips = self.flip_all(q, None, 64, surface, tolerance, None).0;
            }
            // Smooth the new vertex, the corners of every triangle changed, and the new
            // vertex again.
            let mut ring: Vec<u32> = self
                .log
                .iter()
                .flatten()
                .filter_map(|u| match u {
                    Undo::Tri(t, _) => Some(self.tri[*t as usize]),
                    _ => None,
                })
                .flatten()
                .filter(|&v| v != p)
                .collect();
            ring.sort_unstable();
            ring.dedup();
            let mut moved = vec![p];
            for v in std::iter::once(p).chain(ring).chain(std::iter::once(p)) {
                if (sliding || self.free(v))
                    && self.relax(v, &mut star, f64::INFINITY, false, surface, project)
                {
                    moved.push(v);
                }
            }
            // The triangles changed: those whose slots were set, and the fans of moved
            // vertices.
            let mut after = f64::INFINITY;
            let slots: Vec<u32> = self
                .log
                .iter()
                .flatten()
                .filter_map(|u| match u {
                    Undo::Tri(t, _) => Some(*t),
                    _ => None,
                })
                .collect();
            for s in slots {
                after = after.min(self.q(self.tri[s as usize]));
            }
            for v in moved {
                if self.star(v, &mut star) || self.open_star(v, &mut star) {
                    for &e in &star {
                        after = after.min(self.q(self.tri[(e / 3) as usize]));
                    }
                }
            }
            after > before
        };
        let log = self.log.take().unwrap_or_default();
        if !kept {
            for u in log.into_iter().rev() {
                match u {
                    Undo::Tri(t, v) => self.tri[t as usize] = v,
                    Undo::Twin(e, f) => self.twin[e as usize] = f,
                    Undo::Out(v, e) => self.out[v as usize] = e,
                    Undo::Pos(v, p, n) => {
                        self.pos[v as usize] = p;
                        self.normal[v as usize] = n;
                    }
                }
            }
            self.pos.truncate(points);
            self.normal.truncate(points);
            self.border.truncate(points);
            self.h.truncate(points);
            self.out.truncate(points);
            self.frozen.truncate(points);
            self.tri.truncate(triangles);
            self.twin.truncate(3 * triangles);
            return (false, 0);
        }
        (true, flips)
    }

    /// Removes a free corner c of bad triangle t by merging it into one of t's other two
    /// corners (the kept corner stays where it is), where neither a flip, the smoothing nor
    /// an insertion mended t: a needle's short edge (the sweep's blobs had 8° triangles at
    /// their necks that the off-centres only ever made smaller), or an obtuse free corner
    /// resting on an edge no flip may change (a box's or a polygon's). Of every free corner
    /// and either kept corner, the merge that leaves the best smallest angle is taken, and
    /// only if every triangle it makes faces ∇f, folds no more than a flip may, has a
    /// smallest angle above the worst of c's fan before, and every new edge has its midpoint
    /// within `tolerance` of the surface; and only where the merge keeps the mesh a
    /// manifold (c's ring and the kept corner's neighbours share only the two corners next
    /// to it). The two triangles at the edge c–keep go, the others of c's fan take the kept
    /// corner instead of c, and c is left unused (dropped after the stage). Returns the
    /// kept corner.
    pub(super) fn remove_corner(
        &mut self,
        t: u32,
        surface: &mut dyn Surface,
        tolerance: f64,
    ) -> Option<u32> {
        debug_assert!(self.log.is_none());
        let tv = self.tri[t as usize];
        // (worst new sine, c, its star, index in c's ring of the kept corner).
        let mut best: Option<(f64, u32, Vec<u32>, usize)> = None;
        for k in 0..3 {
            let c = tv[k];
            let mut star = Vec::new();
            if !self.free(c) || !self.star(c, &mut star) {
                continue;
            }
            let others = [tv[(k + 1) % 3], tv[(k + 2) % 3]];
            if let Some((worst, i)) = self.best_merge(&star, others, surface, tolerance) {
                if best.as_ref().is_none_or(|b| worst > b.0) {
                    best = Some((worst, c, star, i));
                }
            }
        }
        let (_, c, star, i) = best?;
        Some(self.merge_into(c, &star, i))
    }

    /// Merges two free vertices into one at the surface point nearest their midpoint, where
    /// removing a corner of bad triangle t did not mend it: a free corner c of t and a free
    /// neighbour k of c. This is the change of topology beside a fixed corner that neither a
    /// move nor `remove_corner` makes: a crease corner's sector of 90° cut into three
    /// triangles of about 30° at the corner (the corner may not move, and merging one free
    /// vertex into the other leaves 60° and 30°) becomes two of about 45° (the CAD sweep's
    /// last four runs below the angle, 29.4°–29.8°). Of the pairs, the one whose new
    /// triangles' worst sine is best is taken, and only if that is above the worst of the
    /// two fans before, every new triangle faces ∇f and folds no more than a flip may, every
    /// new edge has its midpoint within `tolerance`, and the link allows it (the two rings
    /// share only the corners of the two triangles at c–k). Returns the merged vertex (k).
    pub(super) fn merge_pair(
        &mut self,
        t: u32,
        surface: &mut dyn Surface,
        tolerance: f64,
        project: &mut Project<'_>,
    ) -> Option<u32> {
        debug_assert!(self.log.is_none());
        let tv = self.tri[t as usize];
        // Only for a smallest angle at a corner that may not move: elsewhere the moves and
        // the removal mend a triangle, and a merge taken first (on the gallery's
        // intersecting patches) left a triangle they could no longer lift.
        let [a, b, c] = self.corners(tv);
        let lens = [b.distance(c), c.distance(a), a.distance(b)];
        let smallest = (0..3).min_by(|&x, &y| lens[x].total_cmp(&lens[y]))?;
        if self.free(tv[smallest]) {
            return None;
        }
        // (worst new sine, c, c's star, index of k in c's ring, point, normal).
        let mut best: Option<(f64, u32, Vec<u32>, usize, DVec3, DVec3)> = None;
        let (mut star_c, mut star_k) = (Vec::new(), Vec::new());
        for &c in &tv {
            if !self.free(c) || !self.star(c, &mut star_c) {
                continue;
            }
            for i in 0..star_c.len() {
                let k = self.dst(star_c[i]);
                // A pair of two corners of t is looked at once, from the lower index.
                if (tv.contains(&k) && k < c) || !self.free(k) || !self.star(k, &mut star_k) {
                    continue;
                }
                let Some((worst, p, n)) =
                    self.pair_merge(&star_c, i, &star_k, surface, tolerance, project)
                else {
                    continue;
                };
                if best.as_ref().is_none_or(|b| worst > b.0) {
                    best = Some((worst, c, star_c.clone(), i, p, n));
                }
            }
        }
        let (_, c, star, i, p, n) = best?;
        let keep = self.merge_into(c, &star, i);
        self.place(keep, p, n);
        Some(keep)
    }

    /// For free vertices c and k = ring[i] of c's closed fan `star_c`, k's closed fan
    /// `star_k`: the merged vertex's worst new sine, point and normal, if the merge passes
    /// `merge_pair`'s tests.
    fn pair_merge(
        &self,
        star_c: &[u32],
        i: usize,
        star_k: &[u32],
        surface: &mut dyn Surface,
        tolerance: f64,
        project: &mut Project<'_>,
    ) -> Option<(f64, DVec3, DVec3)> {
        let ring_c: Vec<u32> = star_c.iter().map(|&e| self.dst(e)).collect();
        let ring_k: Vec<u32> = star_k.iter().map(|&e| self.dst(e)).collect();
        let (nc, nk) = (ring_c.len(), ring_k.len());
        let (c, k) = (self.org(star_c[0]), ring_c[i]);
        let j = ring_k.iter().position(|&r| r == c)?;
        // The link: the rings share the two corners at c–k and nothing else, and the merged
        // ring has at least three corners.
        let shared = ring_c.iter().filter(|r| ring_k.contains(r)).count();
        if shared != 2 || nc + nk < 7 {
            return None;
        }
        let (p, n) = project(surface, 0.5 * (self.p(c) + self.p(k)))?;
        if !self.in_box(p) {
            return None;
        }
        let old_worst = star_c
            .iter()
            .chain(star_k)
            .map(|&e| self.q(self.tri[(e / 3) as usize]))
            .fold(f64::INFINITY, f64::min);
        // The merged ring, counter-clockwise: c's ring from the corner after k round to the
        // corner before it, then k's ring likewise from the corner after c.
        let merged: Vec<u32> = (1..nc)
            .map(|x| ring_c[(i + x) % nc])
            .chain((2..nk - 1).map(|x| ring_k[(j + x) % nk]))
            .collect();
        let m = merged.len();
        let mut worst = f64::INFINITY;
        let mut normals = Vec::with_capacity(m);
        for x in 0..m {
            let (r1, r2) = (merged[x], merged[(x + 1) % m]);
            let corners = [p, self.p(r1), self.p(r2)];
            let normal = (corners[1] - p).cross(corners[2] - p);
            let faces = normal.length() > 0.0
                && normal.dot(n) > 0.0
                && [r1, r2]
                    .iter()
                    .all(|&r| normal.dot(self.normal[r as usize]) > 0.0);
            if !faces {
                return None;
            }
            normals.push(normal.normalize());
            worst = worst.min(min_sin(corners[0], corners[1], corners[2]));
        }
        let folds = (0..m).any(|x| normals[x].dot(normals[(x + 1) % m]) < FOLD_COS);
        if folds || worst <= old_worst {
            return None;
        }
        let chords = merged
            .iter()
            .all(|&r| midpoint_within(surface, p, self.p(r), tolerance));
        chords.then_some((worst, p, n))
    }

    /// Merges free vertex c, with closed fan `star`, into ring[i] (kept where it is): the
    /// two triangles at the edge c–keep go, the others of c's fan take the kept corner
    /// instead of c, and c is left unused. Returns the kept corner.
    fn merge_into(&mut self, c: u32, star: &[u32], i: usize) -> u32 {
        let ring: Vec<u32> = star.iter().map(|&e| self.dst(e)).collect();
        let n = ring.len();
        let keep = ring[i];
        // The triangles of c's fan: star[j] leaves c towards ring[j]; its triangle is
        // (c, ring[j], ring[j + 1]). The two at the edge c–keep are star[i] (c, keep,
        // ring[i + 1]) and star[i − 1] (c, ring[i − 1], keep).
        let gone = [star[i] / 3, star[(i + n - 1) % n] / 3];
        let kept: Vec<u32> = star
            .iter()
            .map(|&e| e / 3)
            .filter(|t| !gone.contains(t))
            .collect();
        // The triangles on the far side of the removed ones' outer edges.
        let mut around: Vec<u32> = Vec::new();
        for &g in &gone {
            for h in 0..3 {
                let tw = self.twin[(3 * g + h) as usize];
                if tw != NONE && !gone.contains(&(tw / 3)) {
                    around.push(tw / 3);
                }
            }
        }
        for &u in &kept {
            let v = self.tri[u as usize].map(|x| if x == c { keep } else { x });
            self.tri[u as usize] = v;
        }
        // Relink the half-edges of the changed triangles and their far neighbours among
        // themselves; an edge with no partner among them keeps its twin if that still runs
        // the other way, else it is open.
        let mut local: Vec<u32> = kept.iter().chain(&around).copied().collect();
        local.sort_unstable();
        local.dedup();
        let half: Vec<u32> = local
            .iter()
            .flat_map(|&u| (0..3).map(move |h| 3 * u + h))
            .collect();
        for &e in &half {
            let (o, d) = (self.org(e), self.dst(e));
            let partner = half
                .iter()
                .copied()
                .find(|&f| self.org(f) == d && self.dst(f) == o);
            let tw = self.twin[e as usize];
            let twin = match partner {
                Some(f) => f,
                None if tw != NONE
                    && !gone.contains(&(tw / 3))
                    && self.org(tw) == d
                    && self.dst(tw) == o =>
                {
                    tw
                }
                None => NONE,
            };
            self.twin[e as usize] = twin;
            if twin != NONE {
                self.twin[twin as usize] = e;
            }
        }
        self.out[c as usize] = NONE;
        for &u in &local {
            for (h, &v) in self.tri[u as usize].iter().enumerate() {
                self.out[v as usize] = 3 * u + h as u32;
            }
        }
        // Remove the two triangles, the higher index first (each swap moves the last
        // triangle into the freed slot).
        let mut gone = gone;
        gone.sort_unstable_by(|x, y| y.cmp(x));
        for g in gone {
            self.remove_triangle(g);
        }
        keep
    }

    /// For free vertex c with closed fan `star`: the best of merging c into either vertex
    /// of `keeps` (both in c's ring), as (the new triangles' worst sine, index in the ring
    /// of the kept corner), if it passes `remove_corner`'s tests.
    fn best_merge(
        &self,
        star: &[u32],
        keeps: [u32; 2],
        surface: &mut dyn Surface,
        tolerance: f64,
    ) -> Option<(f64, usize)> {
        let ring: Vec<u32> = star.iter().map(|&e| self.dst(e)).collect();
        let old_worst = star
            .iter()
            .map(|&e| self.q(self.tri[(e / 3) as usize]))
            .fold(f64::INFINITY, f64::min);
        let n = ring.len();
        let mut best: Option<(f64, usize)> = None;
        for (i, &keep) in ring.iter().enumerate() {
            // A corner at a non-manifold edge has more than one fan: the manifold test
            // below could not see all its edges.
            if !keeps.contains(&keep) || self.frozen[keep as usize] {
                continue;
            }
            // The new edges keep–r, r the ring's other corners, must not exist yet.
            let others: Vec<u32> = (2..n - 1).map(|j| ring[(i + j) % n]).collect();
            if others
                .iter()
                .any(|&r| r == keep || self.edge_exists(keep, r))
            {
                continue;
            }
            let pk = self.p(keep);
            let mut worst = f64::INFINITY;
            let mut ok = true;
            let mut prev_normal: Option<DVec3> = None;
            // The new triangles (keep, ring[i+j], ring[i+j+1]) for j = 1 .. n−2.
            for j in 1..n - 1 {
                let (r1, r2) = (ring[(i + j) % n], ring[(i + j + 1) % n]);
                let tri = [keep, r1, r2];
                let corners = [pk, self.p(r1), self.p(r2)];
                if !self.facing(tri, corners) {
                    ok = false;
                    break;
                }
                let normal = (corners[1] - pk).cross(corners[2] - pk).normalize_or_zero();
                if prev_normal.is_some_and(|m| m.dot(normal) < FOLD_COS) {
                    ok = false;
                    break;
                }
                prev_normal = Some(normal);
                worst = worst.min(min_sin(corners[0], corners[1], corners[2]));
            }
            if !ok || worst <= old_worst {
                continue;
            }
            let chords = others
                .iter()
                .all(|&r| midpoint_within(surface, pk, self.p(r), tolerance));
            if chords && best.is_none_or(|(w, _)| worst > w) {
                best = Some((worst, i));
            }
        }
        best
    }

    /// Removes triangle g, whose half-edges no twin points to any more, by moving the last
    /// triangle into its slot.
    fn remove_triangle(&mut self, g: u32) {
        let last = self.tri.len() as u32 - 1;
        if g != last {
            let moved = self.tri[last as usize];
            self.tri[g as usize] = moved;
            for h in 0..3 {
                let tw = self.twin[(3 * last + h) as usize];
                self.twin[(3 * g + h) as usize] = tw;
                if tw != NONE {
                    self.twin[tw as usize] = 3 * g + h;
                }
                let v = moved[h as usize] as usize;
                if self.out[v] / 3 == last {
                    self.out[v] = 3 * g + self.out[v] % 3;
                }
            }
        }
        self.tri.pop();
        self.twin.truncate(3 * last as usize);
    }

    /// Inserts a vertex for bad triangle t: the off-centre of its shortest edge (the apex of
    /// the equilateral triangle over it, or the circumcentre where that is nearer), placed
    /// in t or split onto the edge it lies across, projected onto the surface. Returns the
    /// new vertex.
    fn insert(
        &mut self,
        t: u32,
        surface: &mut dyn Surface,
        project: &mut Project<'_>,
    ) -> Option<u32> {
        let tv = self.tri[t as usize];
        if tv.iter().any(|&v| self.frozen[v as usize]) {
            return None;
        }
        let [a, b, c] = self.corners(tv);
        let lens = [a.distance(b), b.distance(c), c.distance(a)];
        // A cap on the box: its longest edge runs along a face; split it on the face.
        let long = (0..3)
            .max_by(|&i, &j| lens[i].total_cmp(&lens[j]))
            .unwrap_or(0);
        let e = 3 * t + long as u32;
        if self.twin[e as usize] == NONE {
            if let Some(p) = self.split_on_face(e, surface) {
                return Some(p);
            }
        }
        let mut proj = |q: DVec3| project(surface, q);
        let project = &mut proj;
        // k: the shortest edge tv[k]→tv[k+1]; r the corner opposite.
        let k = (0..3)
            .min_by(|&i, &j| lens[i].total_cmp(&lens[j]))
            .unwrap_or(0);
        let (p, q, r) = (
            self.p(tv[k]),
            self.p(tv[(k + 1) % 3]),
            self.p(tv[(k + 2) % 3]),
        );
        let m = 0.5 * (p + q);
        let normal = (q - p).cross(r - p);
        let dir = normal.cross(q - p).normalize_or_zero(); // in the plane, towards r
        if dir == DVec3::ZERO {
            return None;
        }
        let circ = circumcentre(p, q, r)?;
        let off = lens[k] * 3f64.sqrt() / 2.0;
        let o = m + dir * off.min((circ - m).dot(dir).max(0.0));
        // Barycentric coordinates of o in t's plane.
        let bary = barycentric(a, b, c, o)?;
        let min_i = (0..3)
            .min_by(|&i, &j| bary[i].total_cmp(&bary[j]))
            .unwrap_or(0);
        if bary[min_i] > 0.05 {
            self.split_triangle(t, o, project)
        } else {
            // Across (or at) the edge opposite the corner with the smallest coordinate:
            // split that edge at the point nearest o.
            let e = 3 * t + ((min_i + 1) % 3) as u32;
            let (x, y) = (self.p(self.org(e)), self.p(self.dst(e)));
            let s = ((o - x).dot(y - x) / (y - x).length_squared()).clamp(0.25, 0.75);
            self.split_edge(e, x + s * (y - x), project)
        }
    }

    /// Splits the boundary edge of half-edge e, between two border points on one face of
    /// the box, at the point of the surface on that face nearest its midpoint; the new
    /// vertex is a border point.
    fn split_on_face(&mut self, e: u32, surface: &mut dyn Surface) -> Option<u32> {
        let (a, b, c) = (self.org(e), self.dst(e), self.org(prev(e)));
        let (lo, hi) = self.bbox?;
        let (pa, pb) = (self.p(a), self.p(b));
        if !(self.border[a as usize] && self.border[b as usize]) || self.constrained(a, b) {
            return None;
        }
        let (axis, value) = (0..3).find_map(|k| {
            [lo[k], hi[k]]
                .into_iter()
                .find(|&v| pa[k] == v && pb[k] == v)
                .map(|v| (k, v))
        })?;
        let scale = self.h_of(&[a, b]);
        let (sp, sn) = face_point(surface, 0.5 * (pa + pb), axis, value, scale)?;
        if !self.in_box(sp) {
            return None;
        }
        let pc = self.p(c);
        for (x, y) in [(pa, sp), (sp, pb)] {
            let n = (y - x).cross(pc - x);
            if !(n.dot(sn) > 0.0 && n.dot(self.normal[c as usize]) > 0.0) {
                return None;
            }
        }
        let h = self.h_of(&[a, b, c]);
        let p = self.new_vertex(sp, sn, h);
        self.border[p as usize] = true;
        let (o_bc, o_ca) = (self.twin[next(e) as usize], self.twin[prev(e) as usize]);
        let t = e / 3;
        let n1 = self.tri.len() as u32;
        self.tri.push([0; 3]);
        self.twin.extend([NONE; 3]);
        // t = [a, p, c]: a→p (open), p→c, c→a; n1 = [p, b, c]: p→b (open), b→c, c→p.
        self.set(t, [a, p, c]);
        self.set(n1, [p, b, c]);
        self.link(3 * t, NONE);
        self.link(3 * t + 1, 3 * n1 + 2);
        self.link(3 * t + 2, o_ca);
        self.link(3 * n1, NONE);
        self.link(3 * n1 + 1, o_bc);
        Some(p)
    }

    fn new_vertex(&mut self, p: DVec3, n: DVec3, h: f64) -> u32 {
        self.pos.push(p);
        self.normal.push(n);
        self.border.push(false);
        self.h.push(h);
        self.out.push(NONE);
        self.frozen.push(false);
        (self.pos.len() - 1) as u32
    }

    fn split_triangle(
        &mut self,
        t: u32,
        o: DVec3,
        project: &mut dyn FnMut(DVec3) -> Option<(DVec3, DVec3)>,
    ) -> Option<u32> {
        let [a, b, c] = self.tri[t as usize];
        let (sp, sn) = project(o)?;
        if !self.in_box(sp) {
            return None;
        }
        let news = [[a, b], [b, c], [c, a]];
        for [x, y] in news {
            let pts = [self.p(x), self.p(y), sp];
            let n = (pts[1] - pts[0]).cross(pts[2] - pts[0]);
            if !([x, y].iter().all(|&v| n.dot(self.normal[v as usize]) > 0.0) && n.dot(sn) > 0.0) {
                return None;
            }
        }
        let h = self.h_of(&[a, b, c]);
        let p = self.new_vertex(sp, sn, h);
        let (o_ab, o_bc, o_ca) = (
            self.twin[3 * t as usize],
            self.twin[3 * t as usize + 1],
            self.twin[3 * t as usize + 2],
        );
        let n1 = self.tri.len() as u32;
        let n2 = n1 + 1;
        self.tri.push([0; 3]);
        self.tri.push([0; 3]);
        self.twin.extend([NONE; 6]);
        self.set(t, [a, b, p]);
        self.set(n1, [b, c, p]);
        self.set(n2, [c, a, p]);
        self.link(3 * t, o_ab);
        self.link(3 * t + 1, 3 * n1 + 2);
        self.link(3 * t + 2, 3 * n2 + 1);
        self.link(3 * n1, o_bc);
        self.link(3 * n1 + 1, 3 * n2 + 2);
        self.link(3 * n2, o_ca);
        Some(p)
    }

    fn split_edge(
        &mut self,
        e: u32,
        o: DVec3,
        project: &mut dyn FnMut(DVec3) -> Option<(DVec3, DVec3)>,
    ) -> Option<u32> {
        let f = self.twin[e as usize];
        let (a, b) = (self.org(e), self.dst(e));
        if f == NONE || self.constrained(a, b) {
            return None;
        }
        let (c, d) = (self.org(prev(e)), self.org(prev(f)));
        let (sp, sn) = project(o)?;
        if !self.in_box(sp) {
            return None;
        }
        // t = [a, p, c], n1 = [p, b, c], u = [b, p, d], n2 = [p, a, d].
        let check = |x: u32, y: u32, first: bool| {
            // Triangle (x, p, y) or (p, x, y): corners in order.
            let (p0, p1, p2) = if first {
                (self.p(x), sp, self.p(y))
            } else {
                (sp, self.p(x), self.p(y))
            };
            let n = (p1 - p0).cross(p2 - p0);
            n.dot(self.normal[x as usize]) > 0.0
                && n.dot(self.normal[y as usize]) > 0.0
                && n.dot(sn) > 0.0
        };
        if !(check(a, c, true) && check(b, c, false) && check(b, d, true) && check(a, d, false)) {
            return None;
        }
        let h = self.h_of(&[a, b, c, d]);
        let p = self.new_vertex(sp, sn, h);
        let [o_ad, o_db, o_bc, o_ca] = self.outer(e, f);
        let (t, u) = (e / 3, f / 3);
        let n1 = self.tri.len() as u32;
        let n2 = n1 + 1;
        self.tri.push([0; 3]);
        self.tri.push([0; 3]);
        self.twin.extend([NONE; 6]);
        self.set(t, [a, p, c]);
        self.set(n1, [p, b, c]);
        self.set(u, [b, p, d]);
        self.set(n2, [p, a, d]);
        // t: a→p, p→c, c→a; n1: p→b, b→c, c→p; u: b→p, p→d, d→b; n2: p→a, a→d, d→p.
        self.link(3 * t, 3 * n2);
        self.link(3 * t + 1, 3 * n1 + 2);
        self.link(3 * t + 2, o_ca);
        self.link(3 * n1, 3 * u);
        self.link(3 * n1 + 1, o_bc);
        self.link(3 * u + 1, 3 * n2 + 2);
        self.link(3 * u + 2, o_db);
        self.link(3 * n2 + 1, o_ad);
        Some(p)
    }
}
