//! Interval gradients: a value interval with three interval partials (by x, y, z), the
//! value type of forward-mode differentiation over intervals. The rule of each opcode is
//! `eval::interval_grad`, whose module comment says what the partials enclose; this module
//! has the type and the arithmetic of partials, and imports nothing of the crate.
use glam::DVec3;

use super::interval::{Interval, add, mul};

/// A value interval with its three partial-derivative intervals (by x, y, z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntervalGrad {
    pub v: Interval,
    pub d: [Interval; 3],
    /// Whether f is known to be defined and finite at every point of the box (no operand
    /// beyond its opcode's domain, no infinite or NaN value on the way): where it is not, the
    /// partials say nothing about how f changes from point to point, and
    /// [`IntervalGrad::mean_value`] does not apply.
    pub defined: bool,
}

pub const ZERO: Interval = Interval { lo: 0.0, hi: 0.0 };
pub const ONE: Interval = Interval { lo: 1.0, hi: 1.0 };
/// [−1, 1]: the Clarke factor of `abs` at 0, and the bound of hypot's partials.
pub const UNIT: Interval = Interval { lo: -1.0, hi: 1.0 };

impl IntervalGrad {
    /// A constant: every partial [0, 0].
    pub fn constant(v: Interval) -> IntervalGrad {
        IntervalGrad {
            v,
            d: [ZERO; 3],
            defined: finite(v),
        }
    }

    /// Input `axis` (0, 1, 2) over `v`: its own partial 1. Other axes give a constant.
    pub fn input(v: Interval, axis: usize) -> IntervalGrad {
        let mut g = IntervalGrad::constant(v);
        if let Some(d) = g.d.get_mut(axis) {
            *d = ONE;
        }
        g
    }

    /// A value whose derivatives are unknown (a `dist` child): every partial the whole line.
    pub fn unknown_slope(v: Interval) -> IntervalGrad {
        IntervalGrad {
            v,
            d: [Interval::ENTIRE; 3],
            defined: false,
        }
    }

    /// The mean-value form of f over the box `lo .. hi`: f(c) + Σ ∂f/∂k · [lo_k − c_k,
    /// hi_k − c_k] for the axes `axes` asks for (the box must be flat along the others),
    /// given `at_centre`, an interval holding f at the centre c. Valid (Lebourg's mean-value
    /// theorem for the generalized gradient) where f is defined and finite on the whole box;
    /// elsewhere the whole line. Much tighter than the natural bound on small boxes, as its
    /// excess shrinks with the square of the box's size.
    pub fn mean_value(
        &self,
        at_centre: Interval,
        lo: DVec3,
        hi: DVec3,
        axes: [bool; 3],
    ) -> Interval {
        if !self.defined || at_centre.is_empty() {
            return Interval::ENTIRE;
        }
        let c = (lo + hi) * 0.5;
        let mut r = at_centre;
        for k in (0..3).filter(|&k| axes[k]) {
            // The offsets from the centre, rounded outward by `add`.
            let offset = add(Interval::new(lo[k], hi[k]), Interval::point(-c[k]));
            r = add(r, mul(self.d[k], offset));
        }
        if r.is_empty() { Interval::ENTIRE } else { r }
    }

    /// Whether partial `axis` may be 0 somewhere in the cell.
    pub fn partial_may_vanish(&self, axis: usize) -> bool {
        self.d
            .get(axis)
            .is_none_or(|d| d.is_empty() || d.contains(0.0))
    }

    /// Whether the derivative along `dir` (Σ dir_k · ∂f/∂k) may be 0 somewhere in the cell;
    /// along an axis exactly as [`IntervalGrad::partial_may_vanish`].
    pub fn derivative_may_vanish(&self, dir: DVec3) -> bool {
        let along = dir.cmpne(DVec3::ZERO).bitmask();
        if along.count_ones() == 1 {
            return self.partial_may_vanish(along.trailing_zeros() as usize);
        }
        let d = self.derivative_along(dir);
        d.is_empty() || d.contains(0.0)
    }

    /// An interval holding the derivative along `dir` (Σ dir_k · ∂f/∂k over the axes where
    /// dir_k ≠ 0); empty where one of those partials is.
    pub fn derivative_along(&self, dir: DVec3) -> Interval {
        (0..3)
            .filter(|&k| dir[k] != 0.0)
            .fold(Interval::point(0.0), |sum, k| {
                add(sum, mul(Interval::point(dir[k]), self.d[k]))
            })
    }

    /// f(self) with value `v` and f' in `k`.
    pub fn chain(self, v: Interval, k: Interval) -> IntervalGrad {
        IntervalGrad {
            v,
            d: self.d.map(|d| scale(k, d)),
            defined: self.defined && finite(v),
        }
    }

    /// k·self' + m·other' with value `v`.
    pub fn chain2(
        self,
        other: IntervalGrad,
        v: Interval,
        k: Interval,
        m: Interval,
    ) -> IntervalGrad {
        let mut d = [ZERO; 3];
        for (i, slot) in d.iter_mut().enumerate() {
            *slot = sum(scale(k, self.d[i]), scale(m, other.d[i]));
        }
        IntervalGrad {
            v,
            d,
            defined: self.defined && other.defined && finite(v),
        }
    }
}

/// Both ends finite (not empty, not infinite).
pub fn finite(v: Interval) -> bool {
    v.lo.is_finite() && v.hi.is_finite()
}

/// An empty partial (no defined value) is unknown: the whole line.
pub fn known(d: Interval) -> Interval {
    if d.is_empty() { Interval::ENTIRE } else { d }
}

/// a + b for partials, exact where one is [0, 0].
pub fn sum(a: Interval, b: Interval) -> Interval {
    if a == ZERO {
        b
    } else if b == ZERO {
        a
    } else {
        known(add(a, b))
    }
}

/// k·d for a partial d: exactly 0 where d is (the operand does not depend on that input),
/// and the whole line where k is unbounded or undefined (the opcode is not Lipschitz in the
/// cell, so no derivative bound holds there).
pub fn scale(k: Interval, d: Interval) -> Interval {
    if d == ZERO {
        return ZERO;
    }
    // An input's own partial: k itself (exact, and the most common case).
    if d == ONE && !k.is_empty() && k.lo.is_finite() && k.hi.is_finite() {
        return k;
    }
    let lipschitz = !k.is_empty() && k.lo.is_finite() && k.hi.is_finite();
    let k = if lipschitz { k } else { Interval::ENTIRE };
    known(mul(k, d))
}
