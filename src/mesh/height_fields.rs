//! A certificate that no two triangles of a patch cross, so that the crossing search
//! (`check::intersecting_pairs`) tests only the triangles it cannot vouch for: on a marched
//! mesh a few linear passes instead of a box test of every pair of neighbours.
//!
//! The mesh is cut into *patches*: triangles joined across edges (run once each way) whose
//! normals have the same largest component, axis and sign. Seen along that axis every
//! triangle of a patch turns the same way (its shadow's orientation is that component), so
//! the number of triangles whose shadow holds a point is the winding number about it of the
//! patch's boundary — the interior edges, run once each way, cancel. Where that boundary is
//! simple closed curves that meet nowhere (checked with orientation signs that floating
//! point is sure of) and the winding number of the other curves at a vertex of each curve
//! is 0 for a counter-clockwise curve and 1 for a clockwise one, the winding number is 0
//! just right of every curve and 1 just left: at most 1 anywhere. The shadows then do not
//! overlap, and two triangles whose shadows do not overlap do not cross — where an edge of
//! one passed through the other, the other's open shadow would hold a point of the first's
//! shadow's rim, and so points inside both. Such a patch is *certified*.
//!
//! Triangles of two patches can cross only where both touch one cell of a coarse grid; the
//! triangles that touch a cell of two patches, or of a patch not certified, are left for the
//! exact search, which skips pairs of one certified patch.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::edges::Edges;
use super::topology::{find, union};

/// The triangles the certificate leaves to the exact search, ascending, each with its
/// certified patch's number (below `patches`), or `NOT_CERTIFIED`.
pub(super) struct Left {
    pub triangles: Vec<u32>,
    pub patch: Vec<u32>,
    pub patches: u32,
}

/// `Left::patch` of a triangle whose patch is not certified.
pub(super) const NOT_CERTIFIED: u32 = u32::MAX;

/// A triangle's class: 2·axis + 1 where that component of its normal is negative; `NONE`
/// for a triangle with no normal (all its components 0).
const NONE: u8 = u8::MAX;

/// Cells of the cross-patch grid at most (4 bytes each).
const MAX_CELLS: usize = 1 << 22;

/// The triangles of `tris` over `vs` that the certificate cannot vouch for, or `None` where
/// it does not apply (a corner not finite, an edge in more than two triangles or run twice
/// the same way): then every triangle is left to the exact search. `edges`, where given,
/// are `Edges::new(vs.len(), tris)`.
pub(super) fn uncertified(vs: &[DVec3], tris: &[[u32; 3]], edges: Option<&Edges>) -> Option<Left> {
    if !vs.par_iter().all(|p| p.is_finite()) {
        return None;
    }
    // Each triangle's class, and whether it surely turns counter-clockwise seen along it.
    let (classes, turned): (Vec<u8>, Vec<bool>) = tris
        .par_iter()
        .map(|&t| {
            let c = class_of(vs, t);
            (c, c != NONE && orient_of(vs, c, t) == 1)
        })
        .unzip();
    let built;
    let edges = match edges {
        Some(edges) => edges,
        None => {
            built = Edges::new(vs.len(), tris);
            &built
        }
    };
    let (patch, patch_class) = patches(edges, &classes)?;
    drop(classes);
    // A patch is certified if each of its triangles turns counter-clockwise, surely, seen
    // along its axis, and its boundary passes `boundary_certified`.
    let mut certified = vec![true; patch_class.len()];
    for (&p, &ok) in patch.iter().zip(&turned) {
        certified[p as usize] &= ok;
    }
    drop(turned);
    // The boundary of each patch, its segments run with the patch on their left (an edge
    // is in one or two triangles, `patches` saw).
    let mut boundary: Vec<(u32, [u32; 2])> = Vec::new();
    for (lo, hi, uses) in edges.runs() {
        let of = |k: usize| patch[uses[k].triangle() as usize];
        if uses.len() == 2 && of(0) == of(1) {
            continue;
        }
        for (k, u) in uses.iter().enumerate() {
            if certified[of(k) as usize] {
                boundary.push((of(k), if u.forward() { [lo, hi] } else { [hi, lo] }));
            }
        }
    }
    boundary.par_sort_unstable();
    let runs: Vec<&[(u32, [u32; 2])]> = boundary.chunk_by(|x, y| x.0 == y.0).collect();
    let refused: Vec<u32> = runs
        .par_iter()
        .filter_map(|run| {
            let p = run[0].0;
            let segs: Vec<[u32; 2]> = run.iter().map(|s| s.1).collect();
            (!boundary_certified(patch_class[p as usize], &segs, vs)).then_some(p)
        })
        .collect();
    for p in refused {
        certified[p as usize] = false;
    }
    // A patch with no boundary (closed) cannot turn one way all round; it is not certified.
    let mut bounded = vec![false; patch_class.len()];
    for run in &runs {
        bounded[run[0].0 as usize] = true;
    }
    for (c, b) in certified.iter_mut().zip(bounded) {
        *c &= b;
    }
    Some(across_patches(vs, tris, &patch, &certified))
}

/// The triangles that touch a cell of a coarse grid touched by two patches or by a patch
/// not certified: two triangles that cross both touch the cell of a point they share (a
/// point in both boxes lies in a cell both boxes' cell ranges hold, the cells being taken
/// from coordinates by monotone operations).
fn across_patches(vs: &[DVec3], tris: &[[u32; 3]], patch: &[u32], certified: &[bool]) -> Left {
    const EMPTY: u32 = u32::MAX;
    const SHARED: u32 = u32::MAX - 1;
    let bounds = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|k| vs[k as usize]);
        (a.min(b).min(c), a.max(b).max(c))
    };
    // The mesh's box and its triangles' mean box side, in chunks of a fixed size (the same
    // bits for any number of threads).
    let (lo, hi, sides) = tris
        .par_chunks(1 << 14)
        .map(|chunk| {
            chunk.iter().fold(
                (DVec3::INFINITY, DVec3::NEG_INFINITY, 0.0f64),
                |(lo, hi, s), t| {
                    let b = bounds(t);
                    (lo.min(b.0), hi.max(b.1), s + (b.1 - b.0).max_element())
                },
            )
        })
        .collect::<Vec<_>>()
        .into_iter()
        .fold(
            (DVec3::INFINITY, DVec3::NEG_INFINITY, 0.0f64),
            |(lo, hi, s), c| (lo.min(c.0), hi.max(c.1), s + c.2),
        );
    let extent = hi - lo;
    // Cells three mean triangles wide (each triangle touches a few), fewer where that
    // makes too many.
    let mut width = (3.0 * sides / tris.len().max(1) as f64).max(extent.max_element() / 256.0);
    let mut shape = [1usize; 3];
    let fits = width > 0.0 && width.is_finite() && {
        loop {
            shape = (extent / width).to_array().map(|n| n as usize + 1);
            if shape.iter().product::<usize>() <= MAX_CELLS {
                break true;
            }
            width *= 1.25;
        }
    };
    let left = |triangles: Vec<u32>| Left {
        patch: triangles
            .iter()
            .map(|&t| {
                let p = patch[t as usize];
                if certified[p as usize] {
                    p
                } else {
                    NOT_CERTIFIED
                }
            })
            .collect(),
        triangles,
        patches: certified.len() as u32,
    };
    if !fits {
        return left((0..tris.len() as u32).collect());
    }
    let grid = CellGrid {
        lo,
        per_width: 1.0 / width,
        shape,
    };
    let mut cells = vec![EMPTY; shape.iter().product()];
    // Triangles far larger than the mean (a soup, not a march) could make the marking
    // quadratic: past a budget of cells, every triangle is left to the search (still
    // skipping pairs of one certified patch, which is sound whatever the grid).
    let mut budget = 64 * tris.len() + MAX_CELLS;
    for (t, &p) in tris.iter().zip(patch) {
        let own = if certified[p as usize] { p } else { SHARED };
        let within = grid.cells_of(bounds(t), |c| {
            let at = &mut cells[c];
            *at = if *at == EMPTY || *at == own {
                own
            } else {
                SHARED
            };
            budget = budget.saturating_sub(1);
            budget > 0
        });
        if !within {
            return left((0..tris.len() as u32).collect());
        }
    }
    let triangles: Vec<u32> = (0..tris.len() as u32)
        .into_par_iter()
        .filter(|&t| !grid.cells_of(bounds(&tris[t as usize]), |c| cells[c] != SHARED))
        .collect();
    left(triangles)
}

/// The coarse grid of `across_patches`: cells 1/`per_width` wide from `lo`, `shape` of
/// them. A coordinate's cell is taken by a multiplication, not a division (six a triangle,
/// twice: a tenth of the certificate's time): monotone all the same.
struct CellGrid {
    lo: DVec3,
    per_width: f64,
    shape: [usize; 3],
}

impl CellGrid {
    /// Calls `f` with each cell of the box `b` while it returns true (inlined into each
    /// caller, not a call through a pointer a cell).
    #[inline(always)]
    fn cells_of(&self, b: (DVec3, DVec3), mut f: impl FnMut(usize) -> bool) -> bool {
        // Through i64, a single conversion where usize takes several, and clamped: monotone
        // all the same (NaN and below zero to the first cell, as `as usize` gives them).
        let cell = |x: f64, axis: usize| {
            (((x - self.lo[axis]) * self.per_width) as i64).clamp(0, self.shape[axis] as i64 - 1)
                as usize
        };
        let (l, h) = (b.0.to_array(), b.1.to_array());
        let l = [cell(l[0], 0), cell(l[1], 1), cell(l[2], 2)];
        let h = [cell(h[0], 0), cell(h[1], 1), cell(h[2], 2)];
        for x in l[0]..=h[0] {
            for y in l[1]..=h[1] {
                let row = (x * self.shape[1] + y) * self.shape[2];
                for z in l[2]..=h[2] {
                    if !f(row + z) {
                        return false;
                    }
                }
            }
        }
        true
    }
}

/// Whether the boundary `segs` of a patch of class `class` (each run with the patch on its
/// left, sorted by its start) is simple closed curves, none touching another or itself,
/// each counter-clockwise with the others' winding number 0 at its vertices, or clockwise
/// with it 1: the winding number of the whole is then 1 just left of each curve and 0 just
/// right, so at most 1 everywhere (each region of the plane the curves cut is right of one,
/// or left of every one it borders). A vertex that starts two segments (two corners of the
/// patch meeting at one point) is refused.
fn boundary_certified(class: u8, segs: &[[u32; 2]], vs: &[DVec3]) -> bool {
    if segs.windows(2).any(|w| w[0][0] == w[1][0]) {
        return false;
    }
    let at = |k: u32| project(class, vs[k as usize]);
    let ends: Vec<[DVec2; 2]> = segs.iter().map(|s| [at(s[0]), at(s[1])]).collect();
    // The curves: each segment's successor starts where it ends.
    let mut curve_of = vec![u32::MAX; segs.len()];
    let mut curves: Vec<Vec<u32>> = Vec::new();
    for first in 0..segs.len() {
        if curve_of[first] != u32::MAX {
            continue;
        }
        let number = curves.len() as u32;
        let mut curve = Vec::new();
        let mut s = first;
        while curve_of[s] == u32::MAX {
            curve_of[s] = number;
            curve.push(s as u32);
            match segs.binary_search_by_key(&segs[s][1], |t| t[0]) {
                Ok(next) => s = next,
                Err(_) => return false,
            }
        }
        if s != first {
            return false;
        }
        curves.push(curve);
    }
    if !segments_apart(segs, &ends) {
        return false;
    }
    let Some(strips) = Strips::new(&ends) else {
        return false;
    };
    curves.iter().enumerate().all(|(number, curve)| {
        // The turn at the lowest-leftmost vertex is the curve's (the inner angle there is
        // below π; a straight or folded-back turn there is a touch, refused above).
        let lowest = (0..curve.len())
            .min_by(|&i, &j| {
                let (p, q) = (ends[curve[i] as usize][0], ends[curve[j] as usize][0]);
                p.x.total_cmp(&q.x).then(p.y.total_cmp(&q.y))
            })
            .expect("a curve has segments");
        let before = curve[(lowest + curve.len() - 1) % curve.len()] as usize;
        let [v, after] = ends[curve[lowest] as usize];
        let turn = orient(ends[before][0], v, after);
        let others = strips.winding(&ends, v, |s| curve_of[s] != number as u32);
        matches!((turn, others), (1, Some(0)) | (-1, Some(1)))
    })
}

/// Whether no two segments (by vertex, with their ends seen in the plane) touch, but two
/// that share a vertex there, and those only there (not folded back along each other).
fn segments_apart(segs: &[[u32; 2]], ends: &[[DVec2; 2]]) -> bool {
    let (lo, hi, length) = ends.iter().fold(
        (DVec2::INFINITY, DVec2::NEG_INFINITY, 0.0f64),
        |(lo, hi, l), [a, b]| (lo.min(a.min(*b)), hi.max(a.max(*b)), l + a.distance(*b)),
    );
    let extent = hi - lo;
    let width = (length / segs.len() as f64).max(extent.max_element() / 1024.0);
    if !(width > 0.0 && width.is_finite()) {
        return false;
    }
    let shape = (extent / width).to_array().map(|n| n as u64 + 1);
    let cell = |x: f64, axis: usize| (((x - lo[axis]) / width) as u64).min(shape[axis] - 1);
    // A few cells a segment; far more (segments far longer than the mean) is not a
    // march's boundary, and is not certified rather than searched at length.
    let budget = 16 * segs.len() + 4096;
    let mut entries: Vec<(u64, u32)> = Vec::new();
    for (i, [a, b]) in ends.iter().enumerate() {
        let (l, h) = (a.min(*b), a.max(*b));
        for x in cell(l.x, 0)..=cell(h.x, 0) {
            for y in cell(l.y, 1)..=cell(h.y, 1) {
                entries.push((x * shape[1] + y, i as u32));
            }
        }
        if entries.len() > budget {
            return false;
        }
    }
    entries.sort_unstable();
    entries.chunk_by(|x, y| x.0 == y.0).all(|run| {
        run.iter().enumerate().all(|(k, &(_, i))| {
            run[k + 1..].iter().all(|&(_, j)| {
                apart(
                    segs[i as usize],
                    segs[j as usize],
                    ends[i as usize],
                    ends[j as usize],
                )
            })
        })
    })
}

/// Whether two segments meet at most in a vertex they share, and there without folding back
/// along each other, as far as floating point is sure.
fn apart(s: [u32; 2], t: [u32; 2], [a, b]: [DVec2; 2], [c, d]: [DVec2; 2]) -> bool {
    let shared = |k: u32| t.contains(&k);
    match (shared(s[0]), shared(s[1])) {
        (true, true) => false,
        (true, false) | (false, true) => {
            let (v, x) = if shared(s[0]) { (a, b) } else { (b, a) };
            let y = if t[0] == s[0] || t[0] == s[1] { d } else { c };
            // Not on one line, or on one line going opposite ways from v.
            orient(v, x, y) != 0 || {
                let (p, q) = (x - v, y - v);
                let dot = p.x * q.x + p.y * q.y;
                dot < -1e-15 * ((p.x * q.x).abs() + (p.y * q.y).abs())
            }
        }
        (false, false) => {
            let side = |p, q, r, s| {
                let (o, u) = (orient(p, q, r), orient(p, q, s));
                o != 0 && o == u
            };
            side(a, b, c, d)
                || side(c, d, a, b)
                || a.max(b).cmplt(c.min(d)).any()
                || c.max(d).cmplt(a.min(b)).any()
        }
    }
}

/// Segments bucketed by the horizontal strips their heights span, for winding numbers.
struct Strips {
    lo: f64,
    inv: f64,
    last: usize,
    start: Vec<u32>,
    members: Vec<u32>,
}

impl Strips {
    fn new(ends: &[[DVec2; 2]]) -> Option<Strips> {
        let (lo, hi) = ends
            .iter()
            .flatten()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
                (l.min(p.y), h.max(p.y))
            });
        let count = ends.len().clamp(1, 4096);
        let inv = if hi > lo {
            count as f64 / (hi - lo)
        } else {
            0.0
        };
        let mut strips = Strips {
            lo,
            inv,
            last: count - 1,
            start: vec![0; count + 1],
            members: Vec::new(),
        };
        let span = |s: &Strips, [a, b]: &[DVec2; 2]| s.strip(a.y.min(b.y))..=s.strip(a.y.max(b.y));
        for e in ends {
            for k in span(&strips, e) {
                strips.start[k + 1] += 1;
            }
        }
        for k in 0..count {
            strips.start[k + 1] += strips.start[k];
        }
        // Strips a segment: a few, or the boundary is not a march's (and is not certified).
        if strips.start[count] as usize > 64 * ends.len() + 4096 {
            return None;
        }
        let mut fill = strips.start.clone();
        strips.members = vec![0; strips.start[count] as usize];
        for (i, e) in ends.iter().enumerate() {
            for k in span(&strips, e) {
                strips.members[fill[k] as usize] = i as u32;
                fill[k] += 1;
            }
        }
        Some(strips)
    }

    fn strip(&self, y: f64) -> usize {
        (((y - self.lo) * self.inv) as usize).min(self.last)
    }

    /// The winding number about `q` of the segments `counted` (Sunday's crossings of the
    /// ray to the right, each segment's lower end in, its upper end out); `None` where
    /// floating point cannot tell on which side of a segment crossing the ray `q` is.
    fn winding(
        &self,
        ends: &[[DVec2; 2]],
        q: DVec2,
        counted: impl Fn(usize) -> bool,
    ) -> Option<i64> {
        let k = self.strip(q.y);
        let mut w = 0;
        for &s in &self.members[self.start[k] as usize..self.start[k + 1] as usize] {
            let s = s as usize;
            if !counted(s) {
                continue;
            }
            let [a, b] = ends[s];
            if a.y <= q.y && b.y > q.y {
                match orient(a, b, q) {
                    1 => w += 1,
                    0 => return None,
                    _ => {}
                }
            } else if a.y > q.y && b.y <= q.y {
                match orient(a, b, q) {
                    -1 => w -= 1,
                    0 => return None,
                    _ => {}
                }
            }
        }
        Some(w)
    }
}

/// The sign of `orient` of triangle `t` seen along `class`'s axis.
fn orient_of(vs: &[DVec3], class: u8, t: [u32; 3]) -> i8 {
    let [a, b, c] = t.map(|k| project(class, vs[k as usize]));
    orient(a, b, c)
}

/// `2·axis + (component < 0)` of the largest component of `t`'s normal.
fn class_of(vs: &[DVec3], t: [u32; 3]) -> u8 {
    let [a, b, c] = t.map(|k| vs[k as usize]);
    let n = (b - a).cross(c - a);
    let m = n.abs();
    let axis = if m.x >= m.y && m.x >= m.z {
        0
    } else if m.y >= m.z {
        1
    } else {
        2
    };
    if n[axis] == 0.0 || !n[axis].is_finite() {
        return NONE;
    }
    2 * axis as u8 + u8::from(n[axis] < 0.0)
}

/// Each triangle's patch, numbered in the order of their first triangles, and each patch's
/// class; `None` where an edge is in more than two triangles or run twice the same way.
fn patches(edges: &Edges, classes: &[u8]) -> Option<(Vec<u32>, Vec<u8>)> {
    let mut parent: Vec<u32> = (0..classes.len() as u32).collect();
    for (_, _, uses) in edges.runs() {
        match uses {
            [_] => {}
            [u, w] => {
                if u.forward() == w.forward() {
                    return None;
                }
                let (a, b) = (u.triangle(), w.triangle());
                if classes[a as usize] == classes[b as usize] && classes[a as usize] != NONE {
                    union(&mut parent, a, b);
                }
            }
            _ => return None,
        }
    }
    let mut number = vec![u32::MAX; classes.len()];
    let mut class = Vec::new();
    let mut patch = Vec::with_capacity(classes.len());
    for t in 0..classes.len() as u32 {
        let r = find(&mut parent, t) as usize;
        if number[r] == u32::MAX {
            number[r] = class.len() as u32;
            class.push(classes[t as usize]);
        }
        patch.push(number[r]);
    }
    Some((patch, class))
}

/// `p` seen along a class's axis, so that a triangle of that class turns counter-clockwise.
fn project(class: u8, p: DVec3) -> DVec2 {
    let k = usize::from(class >> 1);
    let (u, v) = (p[(k + 1) % 3], p[(k + 2) % 3]);
    if class & 1 == 0 {
        DVec2::new(u, v)
    } else {
        DVec2::new(v, u)
    }
}

/// The sign of (a − c) × (b − c), twice the signed area of a, b, c (positive
/// counter-clockwise), where floating point is sure of it; 0 where it is not (Shewchuk's
/// first error bound, `(3 + 16ε)ε` of the terms' magnitudes, with room).
fn orient(a: DVec2, b: DVec2, c: DVec2) -> i8 {
    let l = (a.x - c.x) * (b.y - c.y);
    let r = (a.y - c.y) * (b.x - c.x);
    let det = l - r;
    let bound = 1e-15 * (l.abs() + r.abs());
    if det > bound {
        1
    } else if det < -bound {
        -1
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::check::{ANY_GROUP, crossing_pairs, grid_pairs};
    use crate::testing::uniform;
    use std::f64::consts::TAU;

    /// A grid of `nu` × `nv` quads over `f` on [0, 1]², two triangles a quad, wrapped round
    /// in u and v where asked.
    fn grid(
        nu: usize,
        nv: usize,
        wrap: [bool; 2],
        f: impl Fn(f64, f64) -> DVec3,
    ) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let (cu, cv) = (nu + usize::from(!wrap[0]), nv + usize::from(!wrap[1]));
        let vs = (0..cu)
            .flat_map(|i| (0..cv).map(move |j| (i, j)))
            .map(|(i, j)| f(i as f64 / nu as f64, j as f64 / nv as f64))
            .collect();
        let at = |i: usize, j: usize| ((i % cu) * cv + j % cv) as u32;
        let tris = (0..nu)
            .flat_map(|i| (0..nv).map(move |j| (i, j)))
            .flat_map(|(i, j)| {
                let [a, b, c, d] = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                [[a, b, c], [a, c, d]]
            })
            .collect();
        (vs, tris)
    }

    fn torus(nu: usize, nv: usize) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        grid(nu, nv, [true, true], |u, v| {
            let (r, a) = (2.0 + 0.7 * (TAU * v).cos(), TAU * u);
            DVec3::new(r * a.cos(), r * a.sin(), 0.7 * (TAU * v).sin())
        })
    }

    /// The triangles left, with their patches.
    fn left(vs: &[DVec3], tris: &[[u32; 3]]) -> Vec<(u32, u32)> {
        let left = uncertified(vs, tris, None).expect("the certificate applies");
        left.triangles.into_iter().zip(left.patch).collect()
    }

    /// A right torus: every patch certified, and only triangles near where patches meet
    /// left to the search; it finds nothing, as the whole search does not.
    #[test]
    fn a_torus_is_certified_but_where_its_patches_meet() {
        let (vs, tris) = torus(240, 90);
        let left = left(&vs, &tris);
        assert!(left.iter().all(|&(_, p)| p != NOT_CERTIFIED));
        assert!(
            left.len() * 3 < tris.len(),
            "{} of {} left",
            left.len(),
            tris.len()
        );
        assert!(grid_pairs(&vs, &tris, None).is_empty());
        assert!(crossing_pairs(&vs, &tris, None).is_empty());
    }

    /// Mutations that make crossings (corners moved by up to four edge lengths, a few or
    /// many, in one place or all over): the pairs found are always the whole search's, with
    /// groups and without.
    #[test]
    #[ignore = "long run: `.ci/run` runs it (cargo test -- --include-ignored)"]
    fn moved_corners_give_the_whole_searchs_pairs() {
        let mut r = uniform(0x5eed_cafe);
        let (base, tris) = torus(120, 45);
        let edge = base[0].distance(base[1]);
        let (mut crossed, mut refused) = (0, 0);
        for round in 0..60 {
            let mut vs = base.clone();
            let moves = [3, 40, 400, 2000][round % 4];
            let reach = [0.5, 1.0, 2.0, 4.0][round / 4 % 4] * edge;
            let centre = vs[(r() * vs.len() as f64) as usize];
            let near: Vec<usize> = (0..vs.len())
                .filter(|&k| round % 2 == 0 || vs[k].distance(centre) < 10.0 * edge)
                .collect();
            for _ in 0..moves {
                let k = near[(r() * near.len() as f64) as usize];
                vs[k] += reach * DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * 2.0;
            }
            let whole = grid_pairs(&vs, &tris, None);
            crossed += usize::from(!whole.is_empty());
            refused += usize::from(left(&vs, &tris).iter().any(|&(_, p)| p == NOT_CERTIFIED));
            assert_eq!(crossing_pairs(&vs, &tris, None), whole, "round {round}");
            let groups: Vec<u32> = (0..tris.len())
                .map(|t| {
                    if t % 97 == 0 {
                        ANY_GROUP
                    } else {
                        (t / 1500) as u32
                    }
                })
                .collect();
            assert_eq!(
                crossing_pairs(&vs, &tris, Some(&groups)),
                grid_pairs(&vs, &tris, Some(&groups)),
                "round {round}, grouped"
            );
        }
        // Most rounds cross, and in most a patch is refused (a fold within it).
        assert!(crossed >= 35, "{crossed} of 60 rounds made crossings");
        assert!(refused >= 50, "{refused} of 60 rounds with a patch refused");
    }

    /// Large triangles across a fine torus (a soup, not a march: each spans most of the
    /// coarse grid, so every cell is shared): every triangle is left to the search, which
    /// finds the whole search's pairs.
    #[test]
    fn large_triangles_over_a_fine_mesh_give_the_whole_searchs_pairs() {
        let (mut vs, mut tris) = torus(200, 80);
        let mut r = uniform(0xb16_5ca1e);
        for _ in 0..400 {
            let k = vs.len() as u32;
            for _ in 0..3 {
                vs.push(DVec3::new(
                    6.0 * r() - 3.0,
                    6.0 * r() - 3.0,
                    2.0 * r() - 1.0,
                ));
            }
            tris.push([k, k + 1, k + 2]);
        }
        let whole = grid_pairs(&vs, &tris, None);
        assert!(!whole.is_empty());
        assert_eq!(left(&vs, &tris).len(), tris.len());
        assert_eq!(crossing_pairs(&vs, &tris, None), whole);
    }

    /// Random ramps (a strip wound up to two and a half turns about the z axis, rising or
    /// falling, tilted across by an amount that turns with the angle, jittered): one
    /// patch seen from above in most, overlapping itself from a turn on, crossing itself
    /// where the tilt outgrows the rise. The pairs are always the whole search's; both
    /// ramps that cross and ramps the certificate spares triangles of come up.
    #[test]
    fn random_ramps_give_the_whole_searchs_pairs() {
        let mut r = uniform(0x7a3b_51c9);
        let (mut crossing, mut certified) = (0, 0);
        for round in 0..40 {
            let turns = 0.3 + 2.2 * r();
            let rise = 0.2 * r() - 0.1;
            let tilt = 1.5 * r();
            let (inner, width) = (0.3 + r(), 0.2 + 1.2 * r());
            let jitter = 0.1 * r() * r();
            let (nu, nv) = (100 + (r() * 300.0) as usize, 4 + (r() * 20.0) as usize);
            let (mut vs, tris) = grid(nu, nv, [false, false], |u, v| {
                let (a, rr) = (turns * TAU * u, inner + width * v);
                let z = rise * a + tilt * (rr - inner - width / 2.0) * (a / 2.0).cos();
                DVec3::new(rr * a.cos(), rr * a.sin(), z)
            });
            let edge = vs[0].distance(vs[1]);
            for p in &mut vs {
                *p += jitter * edge * DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5);
            }
            let whole = grid_pairs(&vs, &tris, None);
            crossing += usize::from(!whole.is_empty());
            if let Some(l) = uncertified(&vs, &tris, None) {
                certified += usize::from(l.triangles.len() < tris.len());
            }
            assert_eq!(crossing_pairs(&vs, &tris, None), whole, "round {round}");
        }
        assert!(
            crossing >= 12 && certified >= 12,
            "{crossing} crossing, {certified} with triangles spared"
        );
    }

    /// A ramp of one and a half turns whose upper turn dips through the lower: every
    /// triangle faces up (one patch), and its triangles cross. Its boundary is not simple
    /// seen from above, so it is not certified, and the crossings are found.
    #[test]
    fn a_ramp_through_itself_is_not_certified() {
        // (301 steps: the turns' corners do not lie over each other.)
        let (vs, tris) = grid(301, 20, [false, false], |u, v| {
            let (a, r) = (1.5 * TAU * u, 1.0 + v);
            let z = 0.05 * a + 0.8 * (r - 1.5) * (a / 2.0).cos();
            DVec3::new(r * a.cos(), r * a.sin(), z)
        });
        let classes: Vec<u8> = tris.iter().map(|&t| class_of(&vs, t)).collect();
        assert!(classes.iter().all(|&c| c == classes[0]), "one class");
        let whole = grid_pairs(&vs, &tris, None);
        assert!(!whole.is_empty());
        let left = left(&vs, &tris);
        assert_eq!(left.len(), tris.len());
        assert!(left.iter().all(|&(_, p)| p == NOT_CERTIFIED));
        assert_eq!(crossing_pairs(&vs, &tris, None), whole);
    }

    /// A flat plate with square holes, and islands in some holes a little above it: the
    /// plate's patch (one outer curve, a clockwise curve a hole) is certified; a spiral
    /// strip lying over itself without crossing (its boundary not simple from above) is
    /// not, and neither is a plate whose hole holds a second layer of the same patch.
    #[test]
    fn holes_are_certified_and_layers_are_not() {
        // A 60 × 60 grid of unit squares with every fifth square of every fifth row cut.
        let n = 60;
        let at = |i: usize, j: usize| (i * (n + 1) + j) as u32;
        let vs: Vec<DVec3> = (0..=n)
            .flat_map(|i| (0..=n).map(move |j| DVec3::new(i as f64, j as f64, 0.0)))
            .collect();
        let hole = |i: usize, j: usize| i % 5 == 2 && j % 5 == 2;
        let tris: Vec<[u32; 3]> = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .filter(|&(i, j)| !hole(i, j))
            .flat_map(|(i, j)| {
                let [a, b, c, d] = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                [[a, b, c], [a, c, d]]
            })
            .collect();
        let left = left(&vs, &tris);
        assert!(left.is_empty(), "one certified patch, nothing to search");
        // The same plate twice, the second 0.1 above and shifted by half a square: two
        // patches; every triangle of both is left (they share every cell), certified.
        let mut two = vs.clone();
        two.extend(vs.iter().map(|p| *p + DVec3::new(0.5, 0.5, 0.1)));
        let m = vs.len() as u32;
        let mut tris2 = tris.clone();
        tris2.extend(tris.iter().map(|t| t.map(|k| k + m)));
        let left2 = self::left(&two, &tris2);
        assert!(left2.iter().all(|&(_, p)| p != NOT_CERTIFIED));
        assert!(left2.len() > tris2.len() * 9 / 10);
        assert!(crossing_pairs(&two, &tris2, None).is_empty());
        // A flat strip coiled twice round, each turn 0.01 above the last: no crossing, but
        // its boundary is not simple from above, so it is not certified.
        let (coil, ctris) = grid(400, 8, [false, false], |u, v| {
            let a = 2.0 * TAU * u;
            let r = 1.0 + 0.5 * v;
            DVec3::new(r * a.cos(), r * a.sin(), 0.01 * a / TAU)
        });
        let left3 = self::left(&coil, &ctris);
        assert!(left3.iter().all(|&(_, p)| p == NOT_CERTIFIED));
        assert_eq!(left3.len(), ctris.len());
        assert!(crossing_pairs(&coil, &ctris, None).is_empty());
    }

    #[test]
    fn segments_touch_only_at_shared_ends() {
        let p = |x: f64, y: f64| DVec2::new(x, y);
        let (a, b, c, d) = (p(0.0, 0.0), p(1.0, 0.0), p(2.0, 0.0), p(0.5, 0.0));
        // On one line: end to end (shared vertex) apart; folded back along it, not.
        assert!(apart([0, 1], [1, 2], [a, b], [b, c]));
        assert!(!apart([0, 1], [0, 3], [a, b], [a, d]));
        // On one line, not sharing a vertex: apart only with room between.
        assert!(apart([0, 1], [2, 4], [a, d], [b, c]));
        assert!(!apart([0, 1], [3, 4], [a, b], [d, c]));
        // Crossing, touching at an end, and clear of each other.
        let (e, f) = (p(0.5, -1.0), p(0.5, 1.0));
        assert!(!apart([0, 1], [5, 6], [a, b], [e, f]));
        assert!(!apart([0, 1], [5, 6], [a, b], [d, f]));
        assert!(apart([0, 1], [5, 6], [a, b], [p(0.5, 0.1), f]));
        // Two vertices at one point, sharing nothing by number: touching.
        assert!(!apart([0, 1], [7, 6], [a, b], [a, f]));
    }

    #[test]
    fn winding_numbers_about_a_square_and_its_hole() {
        let p = |x: f64, y: f64| DVec2::new(x, y);
        let square = [p(0.0, 0.0), p(4.0, 0.0), p(4.0, 4.0), p(0.0, 4.0)];
        let hole = [p(1.0, 1.0), p(1.0, 3.0), p(3.0, 3.0), p(3.0, 1.0)];
        let ring = |c: &[DVec2]| (0..4).map(|k| [c[k], c[(k + 1) % 4]]).collect::<Vec<_>>();
        let ends: Vec<[DVec2; 2]> = ring(&square).into_iter().chain(ring(&hole)).collect();
        let strips = Strips::new(&ends).expect("a few strips a segment");
        let all = |_| true;
        assert_eq!(strips.winding(&ends, p(0.5, 0.5), all), Some(1));
        assert_eq!(strips.winding(&ends, p(2.0, 2.0), all), Some(0));
        assert_eq!(strips.winding(&ends, p(5.0, 2.0), all), Some(0));
        // At a vertex of the hole, the square alone: 1 (the hole is clockwise, so certified).
        assert_eq!(strips.winding(&ends, hole[0], |s| s < 4), Some(1));
        // On a segment of the square: floating point cannot tell.
        assert_eq!(strips.winding(&ends, p(4.0, 2.0), all), None);
    }
}
