//! A local repair pass over the finished triangulation: triangles whose smallest angle is
//! below `MarchSettings::improve_angle` are improved by edge flips and by moving free
//! vertices towards the middle of their neighbours (then back onto the surface).
//!
//! Input: the marcher's points (positions, unit normals ∇f/|∇f|), its triangles, which points
//! may move, and a projection onto the surface. Output: the same arrays changed in place.
//!
//! Invariants kept: the vertex set and the topology (a flip replaces two triangles sharing an
//! edge by two over the other diagonal; a move keeps every incidence), so watertightness,
//! boundary loops and the Euler characteristic stay; every change must raise the smallest
//! angle of the triangles it touches and keep each touched triangle facing the side ∇f
//! points to at all three corners; edges between two fixed points (polygon edges) are never
//! flipped and fixed or border points never move. The processing order is index order, so
//! the result is deterministic.

use glam::DVec3;

/// sin of the smallest angle of triangle (a, b, c): the smallest angle is opposite the
/// shortest edge, so sin = |(b−a)×(c−a)| / (product of the two longer edges). 0 if
/// degenerate.
pub(super) fn min_sin(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (ab, bc, ca) = (
        a.distance_squared(b),
        b.distance_squared(c),
        c.distance_squared(a),
    );
    let shortest = ab.min(bc).min(ca);
    let longer = (ab * bc * ca / shortest).sqrt();
    let area2 = (b - a).cross(c - a).length();
    if longer > 0.0 && shortest > 0.0 {
        area2 / longer
    } else {
        0.0
    }
}

/// The points and triangles being repaired.
pub(super) struct Repair<'a> {
    pub pos: &'a mut [DVec3],
    pub normal: &'a mut [DVec3],
    pub triangles: &'a mut [[u32; 3]],
    /// Per point: may be moved (not a polygon vertex, not a border point).
    pub movable: &'a [bool],
    /// Per point: a polygon vertex (edges between two of them are never flipped).
    pub fixed: &'a [bool],
}

/// How much cleaning up to do.
pub(super) struct Limits {
    /// sin of the angle below which a triangle is repaired.
    pub sin_bad: f64,
    /// Rounds of (flips, moves).
    pub rounds: u32,
}

impl Repair<'_> {
    fn q(&self, t: [u32; 3]) -> f64 {
        let [a, b, c] = t.map(|v| self.pos[v as usize]);
        min_sin(a, b, c)
    }

    /// Triangle t with corner positions `p` faces the side ∇f points to at every corner.
    fn facing(&self, t: [u32; 3], p: [DVec3; 3]) -> bool {
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        t.iter().all(|&v| n.dot(self.normal[v as usize]) > 0.0)
    }

    /// Runs the repair; `project` puts a point near the surface onto it, returning the
    /// surface point and its unit normal, or None (off the box, no convergence). Returns
    /// (triangles below the limit at the start, flips, moves).
    pub fn run(
        &mut self,
        limits: &Limits,
        project: &mut dyn FnMut(DVec3) -> Option<(DVec3, DVec3)>,
    ) -> (usize, usize, usize) {
        let bad: Vec<u32> = (0..self.triangles.len() as u32)
            .filter(|&t| self.q(self.triangles[t as usize]) < limits.sin_bad)
            .collect();
        if bad.is_empty() {
            return (0, 0, 0);
        }
        let (found, mut flips, mut moves) = (bad.len(), 0, 0);
        let mut around = Around::new(self.triangles, self.pos.len(), &bad);
        let mut work = bad;
        for _ in 0..limits.rounds {
            let mut changed = false;
            // Flips until none helps (bounded: each raises the sorted vector of smallest
            // angles; the cap guards against rounding cycles).
            let mut queue = std::collections::VecDeque::from(work.clone());
            let mut budget = 16 * queue.len() + 64;
            while let Some(t) = queue.pop_front() {
                if budget == 0 {
                    break;
                }
                budget -= 1;
                if self.q(self.triangles[t as usize]) >= limits.sin_bad {
                    continue;
                }
                if let Some(u) = self.flip_best(t, &mut around) {
                    changed = true;
                    flips += 1;
                    queue.push_back(t);
                    queue.push_back(u);
                }
            }
            // Moves of the free corners of triangles still bad.
            let still: Vec<u32> = work
                .iter()
                .copied()
                .filter(|&t| self.q(self.triangles[t as usize]) < limits.sin_bad)
                .collect();
            for &t in &still {
                for v in self.triangles[t as usize] {
                    if self.movable[v as usize]
                        && self.q(self.triangles[t as usize]) < limits.sin_bad
                        && around
                            .get(v)
                            .is_some_and(|tris| self.relax(v, tris, project))
                    {
                        changed = true;
                        moves += 1;
                    }
                }
            }
            if !changed {
                break;
            }
            // The next round looks at the triangles around what is still bad.
            let mut next: Vec<u32> = Vec::new();
            for &t in &still {
                if self.q(self.triangles[t as usize]) < limits.sin_bad {
                    for v in self.triangles[t as usize] {
                        next.extend_from_slice(around.get(v).unwrap_or(&[]));
                    }
                }
            }
            next.sort_unstable();
            next.dedup();
            next.retain(|&t| self.q(self.triangles[t as usize]) < limits.sin_bad);
            if next.is_empty() {
                break;
            }
            work = next;
        }
        (found, flips, moves)
    }

    /// Flips the first edge of triangle t (longest first) whose flip raises the smaller of
    /// the two triangles' smallest angles; returns the other triangle changed.
    fn flip_best(&mut self, t: u32, around: &mut Around) -> Option<u32> {
        let tri = self.triangles[t as usize];
        let mut edges: Vec<(f64, usize)> = (0..3)
            .map(|i| {
                let (a, b) = (tri[i], tri[(i + 1) % 3]);
                (
                    self.pos[a as usize].distance_squared(self.pos[b as usize]),
                    i,
                )
            })
            .collect();
        edges.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
        for (_, i) in edges {
            let (a, b, c) = (tri[i], tri[(i + 1) % 3], tri[(i + 2) % 3]);
            if self.fixed[a as usize] && self.fixed[b as usize] {
                continue;
            }
            // The neighbour across a→b runs b→a.
            let (Some(ta), Some(tc)) = (around.get(a), around.get(c)) else {
                continue;
            };
            let mut across = ta.iter().copied().filter(|&u| {
                u != t && {
                    let s = self.triangles[u as usize];
                    (0..3).any(|k| s[k] == b && s[(k + 1) % 3] == a)
                }
            });
            let Some(u) = across.next() else { continue };
            if across.next().is_some() {
                continue;
            }
            let s = self.triangles[u as usize];
            let Some(&d) = s.iter().find(|&&v| v != a && v != b) else {
                continue;
            };
            if d == c
                || around.get(b).is_none()
                || around.get(d).is_none()
                || tc.iter().any(|&w| self.triangles[w as usize].contains(&d))
            {
                continue;
            }
            let (nt, nu) = ([a, d, c], [d, b, c]);
            let old = self.q(tri).min(self.q(s));
            let new = self.q(nt).min(self.q(nu));
            if new <= old * (1.0 + 1e-9) {
                continue;
            }
            let pt = nt.map(|v| self.pos[v as usize]);
            let pu = nu.map(|v| self.pos[v as usize]);
            if !self.facing(nt, pt) || !self.facing(nu, pu) {
                continue;
            }
            // No fold: the two new triangles (and the old pair) must be nearly coplanar.
            let n1 = (pt[1] - pt[0]).cross(pt[2] - pt[0]).normalize_or_zero();
            let n2 = (pu[1] - pu[0]).cross(pu[2] - pu[0]).normalize_or_zero();
            if n1.dot(n2) < FOLD_COS {
                continue;
            }
            self.triangles[t as usize] = nt;
            self.triangles[u as usize] = nu;
            around.edit(a, |l| l.retain(|&w| w != u));
            around.edit(b, |l| l.retain(|&w| w != t));
            around.edit(c, |l| l.push(u));
            around.edit(d, |l| l.push(t));
            return Some(u);
        }
        None
    }

    /// Moves free point v to the surface point nearest the mean of its neighbours if that
    /// raises the smallest angle around it and keeps every triangle facing ∇f.
    fn relax(
        &mut self,
        v: u32,
        tris: &[u32],
        project: &mut dyn FnMut(DVec3) -> Option<(DVec3, DVec3)>,
    ) -> bool {
        let mut sum = DVec3::ZERO;
        let mut count = 0.0;
        for &t in tris {
            for w in self.triangles[t as usize] {
                if w != v {
                    sum += self.pos[w as usize];
                    count += 1.0;
                }
            }
        }
        if count == 0.0 {
            return false;
        }
        let Some((p, n)) = project(sum / count) else {
            return false;
        };
        let old_worst = tris
            .iter()
            .map(|&t| self.q(self.triangles[t as usize]))
            .fold(f64::INFINITY, f64::min);
        let (old_p, old_n) = (self.pos[v as usize], self.normal[v as usize]);
        self.pos[v as usize] = p;
        self.normal[v as usize] = n;
        let ok = tris.iter().all(|&t| {
            let tri = self.triangles[t as usize];
            self.facing(tri, tri.map(|w| self.pos[w as usize]))
        }) && tris
            .iter()
            .map(|&t| self.q(self.triangles[t as usize]))
            .fold(f64::INFINITY, f64::min)
            > old_worst * (1.0 + 1e-9);
        if !ok {
            self.pos[v as usize] = old_p;
            self.normal[v as usize] = old_n;
        }
        ok
    }
}

/// The triangles around each point near the bad triangles: the corners of the bad triangles
/// and every point of a triangle touching one (two rings). Points farther out have no entry,
/// and a flip or move that would need one is not done, so the map costs memory and time in
/// proportion to the bad triangles (plus one scan), not to the mesh.
struct Around {
    /// Per point: index into `lists`, or u32::MAX.
    slot: Vec<u32>,
    lists: Vec<Vec<u32>>,
}

impl Around {
    fn new(triangles: &[[u32; 3]], points: usize, bad: &[u32]) -> Self {
        let mut seed = vec![false; points];
        for &t in bad {
            for v in triangles[t as usize] {
                seed[v as usize] = true;
            }
        }
        let mut slot = vec![u32::MAX; points];
        let mut lists: Vec<Vec<u32>> = Vec::new();
        for t in triangles {
            if t.iter().any(|&v| seed[v as usize]) {
                for &v in t {
                    if slot[v as usize] == u32::MAX {
                        slot[v as usize] = lists.len() as u32;
                        lists.push(Vec::new());
                    }
                }
            }
        }
        for (i, t) in triangles.iter().enumerate() {
            for &v in t {
                if let Some(l) = lists.get_mut(slot[v as usize] as usize) {
                    l.push(i as u32);
                }
            }
        }
        Around { slot, lists }
    }

    fn get(&self, v: u32) -> Option<&[u32]> {
        self.lists
            .get(self.slot[v as usize] as usize)
            .map(|l| &l[..])
    }

    fn edit(&mut self, v: u32, f: impl FnOnce(&mut Vec<u32>)) {
        if let Some(l) = self.lists.get_mut(self.slot[v as usize] as usize) {
            f(l);
        }
    }
}

/// Cosine of the largest angle between the two triangles of a flip: beyond it (≈ 37°) the
/// quad is folded, not a flat sliver pair.
const FOLD_COS: f64 = 0.8;

#[cfg(test)]
mod tests {
    use super::*;

    const UP: DVec3 = DVec3::Z;

    /// Two triangles in the plane z = 0 over the quad a(0,0) b(2,0) c(1,0.2) d(1,−1.5): the
    /// shared edge a–b makes (a, b, c) a 11° sliver; the other diagonal c–d does not.
    fn sliver_pair() -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let pos = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(1.0, 0.2, 0.0),
            DVec3::new(1.0, -1.5, 0.0),
        ];
        (pos, vec![[0, 1, 2], [1, 0, 3]])
    }

    fn repair(pos: &mut [DVec3], tris: &mut [[u32; 3]], fixed: &[bool], movable: &[bool]) {
        let mut normal = vec![UP; pos.len()];
        let mut plane = |q: DVec3| Some((DVec3::new(q.x, q.y, 0.0), UP));
        Repair {
            pos,
            normal: &mut normal,
            triangles: tris,
            movable,
            fixed,
        }
        .run(
            &Limits {
                sin_bad: 0.44f64.sin(),
                rounds: 3,
            },
            &mut plane,
        );
    }

    fn worst(pos: &[DVec3], tris: &[[u32; 3]]) -> f64 {
        tris.iter()
            .map(|t| min_sin(pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]))
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn min_sin_is_the_sine_of_the_smallest_angle() {
        let s = min_sin(
            DVec3::ZERO,
            DVec3::X,
            DVec3::new(0.5, 3f64.sqrt() / 2.0, 0.0),
        );
        assert!((s - 3f64.sqrt() / 2.0).abs() < 1e-12);
        let s = min_sin(
            DVec3::ZERO,
            DVec3::new(4.0, 0.0, 0.0),
            DVec3::new(4.0, 3.0, 0.0),
        );
        assert!((s - 0.6).abs() < 1e-12, "{s}");
        assert_eq!(min_sin(DVec3::ZERO, DVec3::ZERO, DVec3::X), 0.0);
    }

    #[test]
    fn a_sliver_is_flipped_to_the_other_diagonal() {
        let (mut pos, mut tris) = sliver_pair();
        let before = worst(&pos, &tris);
        repair(&mut pos, &mut tris, &[false; 4], &[false; 4]);
        assert!(worst(&pos, &tris) > before);
        // Same corners, edge c–d now, still counter-clockwise seen from +z.
        for t in &tris {
            assert!(t.contains(&2) && t.contains(&3), "{tris:?}");
            let [a, b, c] = t.map(|v| pos[v as usize]);
            assert!((b - a).cross(c - a).z > 0.0);
        }
    }

    #[test]
    fn an_edge_between_polygon_vertices_is_kept() {
        let (mut pos, mut tris) = sliver_pair();
        let orig = tris.clone();
        repair(
            &mut pos,
            &mut tris,
            &[true, true, false, false],
            &[false; 4],
        );
        assert_eq!(tris, orig);
    }

    #[test]
    fn a_free_corner_moves_and_fixed_ones_stay() {
        // A fan around point 0 (free) that sits almost on the edge 1–2.
        let mut pos = vec![
            DVec3::new(0.95, 0.0, 0.0),
            DVec3::new(1.0, -1.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(-1.0, 1.0, 0.0),
            DVec3::new(-1.0, -1.0, 0.0),
        ];
        let mut tris = vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]];
        let orig = pos.clone();
        let movable = [true, false, false, false, false];
        let before = worst(&pos, &tris);
        repair(
            &mut pos,
            &mut tris,
            &[false, true, true, true, true],
            &movable,
        );
        assert!(worst(&pos, &tris) > before);
        assert_ne!(pos[0], orig[0]);
        assert_eq!(pos[0].z, 0.0);
        assert_eq!(&pos[1..], &orig[1..]);
    }
}
