//! Cells where the sizing's thickness rays need not be walked (docs/marcher.md, *The local
//! step*): a proof, from one interval evaluation of ∇f over a box, that no other sheet lies
//! within the rays' reach of a point.
//!
//! Space is cut into cubic cells as wide as the reach. For a cell, ∇f is bounded over the
//! cell grown by the reach on every side (the box every ray of a point in the cell stays in),
//! once, when a point first falls in it. For a point p of the cell with unit normal n, if
//! every generalized gradient g in those bounds has g·n > 0 — checked as Σₖ min(gₖ·nₖ) over
//! the partials' intervals — then f is strictly increasing along every line parallel to n
//! in the box (Lebourg's mean-value theorem), so the rays from p along ±n meet no zero of f
//! but p: the walk of `Sizing::thickness` would find nothing and return the reach. Where
//! the surface cannot bound its partials, f may be undefined in the box, or the proof fails
//! (a sheet near, a bend across the box), the rays are walked as before. So the local step
//! is the same number either way, bit for bit; only evaluations are spared.
//!
//! The answer for a cell depends on the cell and the surface only, not on the order of the
//! queries: the same mesh for any order of the points and any thread count.

use std::collections::HashMap;

use glam::DVec3;

use crate::mesh::bits::BitsHash;
use crate::surface::Surface;
use crate::values::Interval;
use crate::values::floor;

/// The smallest share of the partials' largest norm over the box that g·n must keep, so that
/// f rises along n by more than a point's own residual before the first place the rays
/// sample: a polygon vertex may lie 1e-6·step off the surface (`polygon_on_surface`), the
/// rays sample no nearer than reach/64 = 0.078·step, so 1.3e-5 of |∇f| would do; this is
/// 78 times that. (With 0.1 the three cylinders took 13.75 point evaluations a vertex, with
/// this 12.85.)
const MIN_RISE: f64 = 1e-3;

/// The cells met so far, with the partials' bounds over each one's grown box and the rise
/// a normal must find in them (None where the surface gave none it can vouch for).
pub struct FreeCells {
    reach: f64,
    inv_side: f64,
    cells: HashMap<[i64; 3], Option<Partials>, BitsHash>,
}

/// A cell's partials' bounds, and `MIN_RISE` times their largest norm: what g·n must exceed.
#[derive(Clone, Copy)]
struct Partials {
    d: [Interval; 3],
    least_rise: f64,
}

impl FreeCells {
    /// Cells for rays that reach `reach` (model units) from their point.
    pub fn new(reach: f64) -> Self {
        FreeCells {
            reach,
            inv_side: 1.0 / reach,
            cells: HashMap::default(),
        }
    }

    /// The reach the cells were cut for.
    pub fn reach(&self) -> f64 {
        self.reach
    }

    /// Whether no zero of f but p lies on the segments p ± t·n, 0 < t ≤ the reach, proven
    /// over p's cell (bounding the cell's partials the first time it is asked).
    pub fn proves_free(&mut self, surface: &mut dyn Surface, p: DVec3, n: DVec3) -> bool {
        if !(self.reach.is_finite() && self.reach > 0.0 && p.is_finite()) {
            return false;
        }
        let key = (p * self.inv_side).to_array().map(floor);
        let reach = self.reach;
        let partials = self.cells.entry(key).or_insert_with(|| {
            let corner = DVec3::new(key[0] as f64, key[1] as f64, key[2] as f64) * reach;
            // Grown by the reach and a little more, so that rounding in the cell's corner
            // cannot leave a ray's end outside.
            let grow = DVec3::splat(1.001 * reach);
            let (lo, hi) = (corner - grow, corner + DVec3::splat(reach) + grow);
            partials_over(surface, lo, hi)
        });
        let Some(Partials { d, least_rise }) = *partials else {
            return false;
        };
        let rise: f64 = (0..3).map(|k| (d[k].lo * n[k]).min(d[k].hi * n[k])).sum();
        rise.is_finite() && rise > least_rise
    }
}

/// The partials' bounds over the box `lo .. hi`, or None where the surface has none it can
/// vouch for (f undefined somewhere in the box, or no bounds at all). One box, not parts of
/// it: bounding the grown box in 2³ parts (their partials' hull, tighter for a polynomial of
/// high degree) took genus 3 from 16.29 to 15.74 point evaluations a vertex and the three
/// cylinders from 13.75 to 13.63 (with a rise of 0.1 asked), for eight times the interval
/// evaluations.
fn partials_over(surface: &mut dyn Surface, lo: DVec3, hi: DVec3) -> Option<Partials> {
    let d = surface
        .bound_gradient(lo, hi, [true; 3])
        .filter(|g| g.defined)?
        .d;
    let largest = (0..3)
        .map(|k| d[k].lo.abs().max(d[k].hi.abs()).powi(2))
        .sum::<f64>()
        .sqrt();
    largest.is_finite().then_some(Partials {
        d,
        least_rise: MIN_RISE * largest,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::ValueGrad;
    use crate::values::interval_grad::IntervalGrad;

    /// Two parallel planes z = 0 and z = gap as f = z (z − gap), bounded exactly.
    struct Slab {
        gap: f64,
    }

    impl Surface for Slab {
        fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
            ValueGrad {
                value: p.z * (p.z - self.gap),
                gradient: DVec3::new(0.0, 0.0, 2.0 * p.z - self.gap),
            }
        }

        fn bound_gradient(
            &mut self,
            lo: DVec3,
            hi: DVec3,
            _axes: [bool; 3],
        ) -> Option<IntervalGrad> {
            let dz = Interval {
                lo: 2.0 * lo.z - self.gap,
                hi: 2.0 * hi.z - self.gap,
            };
            let zero = Interval { lo: 0.0, hi: 0.0 };
            Some(IntervalGrad {
                v: Interval::ENTIRE,
                d: [zero, zero, dz],
                defined: true,
            })
        }
    }

    #[test]
    fn a_far_sheet_is_proven_absent_and_a_near_one_is_not() {
        // The other plane 10 reaches away: every cell around z = 0 proves the rays free.
        let mut far = Slab { gap: 10.0 };
        let mut cells = FreeCells::new(1.0);
        for x in [-3.3, 0.2, 7.9] {
            let p = DVec3::new(x, 0.4, 0.0);
            assert!(cells.proves_free(&mut far, p, -DVec3::Z), "{p}");
        }
        // The other plane within the reach (and within the grown box): no proof.
        let mut near = Slab { gap: 0.8 };
        let mut cells = FreeCells::new(1.0);
        assert!(!cells.proves_free(&mut near, DVec3::new(0.5, 0.5, 0.0), -DVec3::Z));
    }

    #[test]
    fn a_surface_without_bounds_proves_nothing() {
        struct Plane;
        impl Surface for Plane {
            fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
                ValueGrad {
                    value: p.z,
                    gradient: DVec3::Z,
                }
            }
        }
        let mut cells = FreeCells::new(1.0);
        assert!(!cells.proves_free(&mut Plane, DVec3::ZERO, DVec3::Z));
    }
}
