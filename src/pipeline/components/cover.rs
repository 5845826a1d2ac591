//! The cover of the component search: which places the meshes made so far already cover
//! (a seed there starts no new component) and which cells they touch, from the triangles
//! hashed by centroid in one grid per size level.

use std::collections::HashMap;

use glam::DVec3;

use crate::mesh::Mesh;
use crate::mesh::bits::BitsHash;
use crate::mesh::check::closest_on_triangle;
use crate::survey::cells::Cell;

/// The triangles meshed so far, hashed by the centroid in grids by size: a triangle whose
/// longest edge is at most `step · 2^l` (and above half that) is in the grid of cells of that
/// side. A query then looks at a few cells of each grid, each holding a few triangles, also
/// where the local step made triangles far below the step (a thin shell at step/50 put
/// thousands of triangles into one cell of side `step`, and the search spent minutes here).
/// A cell's triangles are a chain through `next` from the cell's last one: one hash entry a
/// cell and no list of its own (the pieces of a creased surface, hundreds of thousands of
/// triangles, are hashed at once).
pub(super) struct Cover {
    step: f64,
    /// Per size level l (from `COVER_LEVELS.0` on): the cells (of side `step · 2^l`) and
    /// their last triangle.
    levels: Vec<HashMap<[i64; 3], u32, BitsHash>>,
    /// Each triangle's predecessor in its cell, or `END`.
    next: Vec<u32>,
}

/// The end of a cell's chain.
const END: u32 = u32::MAX;

/// Size levels are clamped to this range (2⁻⁴⁰ to 2⁸ steps): a degenerate or huge triangle
/// goes to an end level, where it is still found (the cells searched cover its reach).
const COVER_LEVELS: (i32, i32) = (-40, 8);

/// ⌈log₂ x⌉ as `x.log2().ceil()` gives it, read from x's exponent where its mantissa is
/// zero (log₂ is exact there) or clear of the powers of two by 2⁻⁴⁰ (log₂ x then lies
/// 10⁻¹² inside the exponent's interval, where libm's error of under an ulp cannot move it
/// onto an integer); libm's log₂ elsewhere. Most triangles are hashed without a libm call.
fn ceil_log2(x: f64) -> i32 {
    const MANTISSA: u64 = (1 << 52) - 1;
    const CLEAR: u64 = 1 << 12;
    if x.is_normal() && x > 0.0 {
        let bits = x.to_bits();
        let exponent = (bits >> 52) as i32 - 1023;
        match bits & MANTISSA {
            0 => return exponent,
            m if m > CLEAR && m < MANTISSA - CLEAR => return exponent + 1,
            _ => {}
        }
    }
    x.log2().ceil() as i32
}

impl Cover {
    pub(super) fn new(step: f64) -> Cover {
        Cover {
            step,
            levels: (COVER_LEVELS.0..=COVER_LEVELS.1)
                .map(|_| HashMap::default())
                .collect(),
            next: Vec::new(),
        }
    }

    fn side(&self, level: i32) -> f64 {
        self.step * 2f64.powi(level)
    }

    fn key(side: f64, p: DVec3) -> [i64; 3] {
        // Saturating float-to-int casts: a point far out stays in an edge cell.
        (p / side).to_array().map(crate::values::floor)
    }

    /// Appends `part` to `mesh` and hashes its triangles.
    pub(super) fn add(&mut self, mesh: &mut Mesh, part: &Mesh) {
        let offset = mesh.vertices.len() as u32;
        let first = mesh.triangles.len();
        mesh.vertices.extend_from_slice(&part.vertices);
        mesh.normals.extend_from_slice(&part.normals);
        mesh.sides
            .extend(part.sides.iter().map(|s| crate::mesh::Side {
                vertex: s.vertex + offset,
                ..*s
            }));
        mesh.triangles
            .extend(part.triangles.iter().map(|t| t.map(|v| v + offset)));
        self.hash_from(mesh, first);
    }

    /// Hashes the triangles of `mesh` from `first` on (all of a mesh the search starts from:
    /// the pieces of a creased surface, taken rather than copied by `add`).
    pub(super) fn hash_from(&mut self, mesh: &Mesh, first: usize) {
        // Triangles of `mesh` from before `first` that were never hashed are in no chain.
        self.next.resize(first, END);
        self.next.reserve(mesh.triangles.len() - first);
        for (t, tri) in mesh.triangles.iter().enumerate().skip(first) {
            let [a, b, c] = tri.map(|v| mesh.vertices[v as usize]);
            // One root of the largest square: the square root is monotonic and correctly
            // rounded, so this is the largest of the three distances, bit for bit.
            let edge = a
                .distance_squared(b)
                .max(b.distance_squared(c))
                .max(c.distance_squared(a))
                .sqrt();
            let level = ceil_log2(edge / self.step).clamp(COVER_LEVELS.0, COVER_LEVELS.1);
            let side = self.side(level);
            let last = self.levels[(level - COVER_LEVELS.0) as usize]
                .entry(Cover::key(side, (a + b + c) / 3.0))
                .or_insert(END);
            self.next.push(*last);
            *last = t as u32;
        }
    }

    /// Whether `found` holds for a triangle of the cell whose chain ends at `last`.
    fn any_in(&self, mut last: u32, found: &mut impl FnMut(u32) -> bool) -> bool {
        while last != END {
            if found(last) {
                return true;
            }
            last = self.next[last as usize];
        }
        false
    }

    /// Calls `found` with the triangles of every level whose centroid cell meets the box
    /// `lo .. hi` grown by `grow(side)` (in model units), until it returns true. A level's
    /// cells are looked up one by one, or its occupied cells scanned where that is fewer.
    pub(super) fn any_near(
        &self,
        lo: DVec3,
        hi: DVec3,
        grow: impl Fn(f64) -> f64,
        mut found: impl FnMut(u32) -> bool,
    ) -> bool {
        for (level, cells) in (COVER_LEVELS.0..).zip(&self.levels) {
            if cells.is_empty() {
                continue;
            }
            let side = self.side(level);
            let g = DVec3::splat(grow(side));
            let (a, b) = (Cover::key(side, lo - g), Cover::key(side, hi + g));
            let span = (0..3).fold(1.0, |n, i| n * ((b[i] - a[i]) as f64 + 1.0));
            let inside = |k: &[i64; 3]| (0..3).all(|i| a[i] <= k[i] && k[i] <= b[i]);
            if span > cells.len() as f64 {
                if cells
                    .iter()
                    .any(|(k, &last)| inside(k) && self.any_in(last, &mut found))
                {
                    return true;
                }
                continue;
            }
            for k in a[2]..=b[2] {
                for j in a[1]..=b[1] {
                    for i in a[0]..=b[0] {
                        if cells
                            .get(&[i, j, k])
                            .is_some_and(|&last| self.any_in(last, &mut found))
                        {
                            return true;
                        }
                    }
                }
            }
        }
        false
    }

    /// Whether a vertex of `mesh` lies in the cell.
    pub(super) fn touches(&self, mesh: &Mesh, cell: Cell) -> bool {
        let inside = |v: &u32| {
            let p = mesh.vertices[*v as usize];
            p.cmpge(cell.lo).all() && p.cmple(cell.hi).all()
        };
        // A vertex is at most the longest edge (at most the level's side) from the centroid.
        self.any_near(
            cell.lo,
            cell.hi,
            |side| side,
            |t| mesh.triangles[t as usize].iter().any(inside),
        )
    }

    /// Whether a triangle of `mesh` lies within `factor · max(h, its longest edge)` of `p`
    /// with a normal agreeing with `normal` (cosine above `cos`). The reach follows the
    /// mesh's own edges as well as the local step `h` at p: a seed on a crease (where the
    /// local step measures the edge's kink, not the surface) is still within reach of the
    /// pieces meshed up to it, and another sheet is farther from a triangle than its edges
    /// (the marcher's thickness bound keeps it 2.5 edges away).
    pub(super) fn covered(
        &self,
        mesh: &Mesh,
        p: DVec3,
        normal: DVec3,
        factor: f64,
        h: f64,
        cos: f64,
    ) -> bool {
        // A triangle of a level (longest edge at most its side) within reach has its
        // centroid within the reach + its longest edge of p.
        let grow = |side: f64| factor * h.max(side) + side;
        self.any_near(p, p, grow, |t| {
            let [a, b, c] = mesh.triangles[t as usize].map(|v| mesh.vertices[v as usize]);
            let n = (b - a).cross(c - a).normalize_or_zero();
            if n.dot(normal) <= cos {
                return false;
            }
            let edge = a.distance(b).max(b.distance(c)).max(c.distance(a));
            let reach = factor * h.max(edge);
            (closest_on_triangle(p, a, b, c) - p).length() < reach
        })
    }
}

#[cfg(test)]
mod tests {
    use super::ceil_log2;

    /// The exponent's shortcut gives libm's ⌈log₂ x⌉ bit for bit: at and beside every power
    /// of two (within 2¹⁴ ulps on both sides, across the 2¹² band where libm decides), over
    /// random mantissas and exponents, and at zero, subnormals, infinity and NaN.
    #[test]
    fn the_exponent_read_is_libms_ceil_log2() {
        let libm = |x: f64| x.log2().ceil() as i32;
        let mut xs = vec![0.0, f64::MIN_POSITIVE / 3.0, f64::INFINITY, f64::NAN, -1.0];
        for e in -60..60 {
            let p = 2f64.powi(e);
            for k in 0..(1u64 << 14) {
                xs.push(f64::from_bits(p.to_bits() + k));
                xs.push(f64::from_bits(p.to_bits() - k));
            }
        }
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..200_000 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let exponent = (state >> 53) % 200;
            let bits = ((exponent + 923) << 52) | (state & ((1 << 52) - 1));
            xs.push(f64::from_bits(bits));
        }
        for x in xs {
            assert_eq!(ceil_log2(x), libm(x), "x = {x:e} ({:#x})", x.to_bits());
        }
    }
}
