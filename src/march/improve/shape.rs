//! A triangle's shape: the sine of its smallest angle, its radius ratio (`Shape`), the
//! scans that measure them over the mesh, and the triangle geometry the phases share
//! (circumcentre, barycentric coordinates).

use glam::DVec3;
use rayon::prelude::*;

use super::{SCAN_BLOCK, Stage, min_sin};

/// The sum of the shapes' radius ratios, in order.
pub(super) fn ratio_sum_of(shapes: &[Shape]) -> f64 {
    shapes.iter().map(|shape| shape.ratio).sum()
}

/// The mean radius ratio of the shapes (1 for none), summed in blocks of `SCAN_BLOCK` on
/// rayon's pool and the blocks' sums added in order, as the scan at the end of an angle round
/// sums them: the same bits for any thread count.
pub(super) fn mean_ratio(shapes: &[Shape]) -> f64 {
    if shapes.is_empty() {
        return 1.0;
    }
    let blocks: Vec<f64> = shapes.par_chunks(SCAN_BLOCK).map(ratio_sum_of).collect();
    blocks.iter().sum::<f64>() / shapes.len() as f64
}

/// The radius ratio 2·r_in/r_circ = 16·A² / (abc·(a+b+c)): 1 for an equilateral triangle,
/// 0 for a degenerate one.
pub(super) fn radius_ratio(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let area2 = (b - a).cross(c - a).length_squared(); // (2A)²
    ratio_of_sides(a.distance(b), b.distance(c), c.distance(a), area2)
}

/// (`min_sin`, `radius_ratio`) of a triangle, from one set of side lengths.
fn shape([a, b, c]: [DVec3; 3]) -> (f64, f64) {
    let (ab, bc, ca) = (
        a.distance_squared(b),
        b.distance_squared(c),
        c.distance_squared(a),
    );
    let area2 = (b - a).cross(c - a).length_squared();
    let sin = sin2_of(area2, ab, bc, ca).sqrt();
    (sin, ratio_of_sides(ab.sqrt(), bc.sqrt(), ca.sqrt(), area2))
}

/// sin² of the smallest angle of a triangle from |cross|² of two of its sides (`area2`) and
/// its squared sides: |c|²·m²/(x²y²z²), m the shortest side, with no square root. 0 if
/// degenerate.
pub(super) fn sin2_of(area2: f64, x2: f64, y2: f64, z2: f64) -> f64 {
    let product = x2 * y2 * z2;
    if product > 0.0 {
        area2 * x2.min(y2).min(z2) / product
    } else {
        0.0
    }
}

/// 2·r_in/r_circ of a triangle with sides x, y, z and (2A)² = `area2`; 0 if degenerate.
pub(super) fn ratio_of_sides(x: f64, y: f64, z: f64, area2: f64) -> f64 {
    let den = x * y * z * (x + y + z);
    if den > 0.0 { 4.0 * area2 / den } else { 0.0 }
}

/// A triangle's smallest angle's sine (`min_sin`) and radius ratio (`radius_ratio`).
#[derive(Clone, Copy)]
pub(super) struct Shape {
    pub(super) sin: f64,
    pub(super) ratio: f64,
}

impl Stage<'_> {
    /// Triangle t's `Shape`.
    pub(super) fn shape_of(&self, t: [u32; 3]) -> Shape {
        let [a, b, c] = self.corners(t);
        Shape {
            sin: min_sin(a, b, c),
            ratio: radius_ratio(a, b, c),
        }
    }

    /// Per triangle: its `Shape`, for the scans of a round to share; and per vertex, whether
    /// it is a corner of a triangle whose smallest angle's sine is below `sin`.
    /// `known`: the shapes of the triangles as they were before the triangles listed with
    /// them changed (nothing else changed since), brought up to date instead of computed
    /// anew.
    pub(super) fn shapes_and_corners_below(
        &self,
        sin: f64,
        known: Option<(Vec<Shape>, &[u32])>,
    ) -> (Vec<Shape>, Vec<bool>) {
        let shapes = match known {
            Some((mut shapes, changed)) => {
                for &t in changed {
                    shapes[t as usize] = self.shape_of(self.tri[t as usize]);
                }
                // The tests' builds check the claim: every shape as computed anew, bit for bit.
                debug_assert!(
                    shapes.len() == self.tri.len()
                        && shapes.iter().zip(self.tri.iter()).all(|(s, &t)| {
                            let fresh = self.shape_of(t);
                            (s.sin.to_bits(), s.ratio.to_bits())
                                == (fresh.sin.to_bits(), fresh.ratio.to_bits())
                        }),
                    "a triangle changed that the carried shapes do not know of"
                );
                shapes
            }
            None => self.tri.par_iter().map(|&t| self.shape_of(t)).collect(),
        };
        let mut below = Vec::new();
        below.par_extend(
            (0..shapes.len())
                .into_par_iter()
                .filter(|&t| shapes[t].sin < sin),
        );
        let mut marked = vec![false; self.pos.len()];
        for t in below {
            for v in self.tri[t] {
                marked[v as usize] = true;
            }
        }
        (shapes, marked)
    }

    /// The mean radius ratio of the triangles (1 for none), and the triangles whose
    /// smallest angle has a sine below `sin_bad`, in one scan.
    pub(super) fn survey(&self, sin_bad: f64) -> (f64, Vec<u32>) {
        // In blocks on the pool, summed in block order (`SCAN_BLOCK`).
        let blocks: Vec<(f64, Vec<u32>)> = self
            .tri
            .par_chunks(SCAN_BLOCK)
            .enumerate()
            .map(|(block, tri)| {
                let mut below = Vec::new();
                let mut sum = 0.0;
                for (i, &t) in tri.iter().enumerate() {
                    let (sin, ratio) = shape(self.corners(t));
                    sum += ratio;
                    if sin < sin_bad {
                        below.push((block * SCAN_BLOCK + i) as u32);
                    }
                }
                (sum, below)
            })
            .collect();
        let mut below = Vec::new();
        let mut sum = 0.0;
        for (block_sum, block_below) in blocks {
            sum += block_sum;
            below.extend(block_below);
        }
        let mean = if self.tri.is_empty() {
            1.0
        } else {
            sum / self.tri.len() as f64
        };
        (mean, below)
    }
}

/// The circumcentre of triangle (a, b, c), or None if degenerate.
pub(super) fn circumcentre(a: DVec3, b: DVec3, c: DVec3) -> Option<DVec3> {
    circumcentre_and_normal(a, b, c).map(|(centre, _)| centre)
}

/// The circumcentre of triangle (a, b, c) and the normal (b − a) × (c − a) it is computed
/// from (twice the area as its length), or None if degenerate.
pub(super) fn circumcentre_and_normal(a: DVec3, b: DVec3, c: DVec3) -> Option<(DVec3, DVec3)> {
    let (u, v) = (b - a, c - a);
    let n = u.cross(v);
    let d = 2.0 * n.length_squared();
    if d <= 0.0 {
        return None;
    }
    let centre = a + (u.length_squared() * v.cross(n) + v.length_squared() * n.cross(u)) / d;
    Some((centre, n))
}

/// Barycentric coordinates of o (projected into the plane of a, b, c).
pub(super) fn barycentric(a: DVec3, b: DVec3, c: DVec3, o: DVec3) -> Option<[f64; 3]> {
    let n = (b - a).cross(c - a);
    let area = n.length_squared();
    if area <= 0.0 {
        return None;
    }
    let wa = (c - b).cross(o - b).dot(n) / area;
    let wb = (a - c).cross(o - c).dot(n) / area;
    Some([wa, wb, 1.0 - wa - wb])
}
