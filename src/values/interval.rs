//! Closed intervals of reals with outward rounding: the value type of interval arithmetic
//! (the component search's bounds). The rule of each opcode over intervals is
//! `eval::interval`; this module has the arithmetic it is made of and imports nothing of the
//! crate.
//!
//! Conventions (`docs/components.md` has the reasoning):
//! - An interval bounds the *defined* values: points where the function is NaN (sqrt or ln of
//!   a negative, asin beyond ±1) hold no surface, so `sqrt([−1, 4]) = [0, 2]`, and an operand
//!   with no defined value at all gives [`Interval::EMPTY`] (both ends NaN), which every
//!   opcode passes on (except where IEEE gives a number from a NaN: `pow(NaN, 0) = 1`).
//! - Ends may be infinite. A lower end 0 stands for +0 and an upper end 0 for −0, as IEEE
//!   division reads them: `1/[0, 2] = [0.5, +∞]`, `1/[−1, 1]` is the whole line.
//! - Outward rounding: every end computed by rounded arithmetic or a libm function is moved
//!   outward by two ulps (libm's sin, exp, … are within one ulp; +, −, ×, ÷ within half an
//!   ulp), so the true range is inside despite rounding.
//! - `dist` has no rule here: the evaluator asks the child surface for its bound (a distance
//!   is 1-Lipschitz: its centre value ± the cell's half-diagonal).

use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// A closed interval [lo, hi] of reals, possibly with infinite ends, or empty (NaN ends).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    pub lo: f64,
    pub hi: f64,
}

impl Interval {
    /// The whole line: nothing is known.
    pub const ENTIRE: Interval = Interval {
        lo: f64::NEG_INFINITY,
        hi: f64::INFINITY,
    };

    /// No defined value.
    pub const EMPTY: Interval = Interval {
        lo: f64::NAN,
        hi: f64::NAN,
    };

    /// [lo, hi]; a NaN end (from ∞ − ∞ or 0·∞ in a rule) widens to the infinite end on its
    /// side, so a rule never turns a non-empty interval empty.
    pub fn new(lo: f64, hi: f64) -> Interval {
        Interval {
            lo: if lo.is_nan() { f64::NEG_INFINITY } else { lo },
            hi: if hi.is_nan() { f64::INFINITY } else { hi },
        }
    }

    /// The single value v.
    pub fn point(v: f64) -> Interval {
        if v.is_nan() {
            Interval::EMPTY
        } else {
            Interval { lo: v, hi: v }
        }
    }

    pub fn is_empty(self) -> bool {
        self.lo.is_nan() || self.hi.is_nan()
    }

    /// Whether v lies in the interval (never for an empty one).
    pub fn contains(self, v: f64) -> bool {
        self.lo <= v && v <= self.hi
    }

    /// The smallest interval holding both.
    pub fn hull(self, other: Interval) -> Interval {
        match (self.is_empty(), other.is_empty()) {
            (true, _) => other,
            (_, true) => self,
            _ => Interval {
                lo: self.lo.min(other.lo),
                hi: self.hi.max(other.hi),
            },
        }
    }

    /// The hull of the given values (NaN values skipped; EMPTY if all are NaN).
    pub fn of(values: &[f64]) -> Interval {
        values
            .iter()
            .fold(Interval::EMPTY, |acc, &v| acc.hull(Interval::point(v)))
    }

    /// The hull of f at the four corners of a × b (NaN values skipped).
    pub fn corners(a: Interval, b: Interval, f: impl Fn(f64, f64) -> f64) -> Interval {
        Interval::of(&[f(a.lo, b.lo), f(a.lo, b.hi), f(a.hi, b.lo), f(a.hi, b.hi)])
    }

    /// Both ends moved outward by two ulps: covers the rounding of the rule that made them.
    pub fn widen(self) -> Interval {
        if self.is_empty() {
            return self;
        }
        Interval {
            lo: -up2(-self.lo),
            hi: up2(self.hi),
        }
    }

    /// The image under a non-decreasing function.
    pub fn increasing(self, f: impl Fn(f64) -> f64) -> Interval {
        if self.is_empty() {
            return self;
        }
        Interval::new(f(self.lo), f(self.hi)).widen()
    }

    /// The image under a non-increasing function.
    pub fn decreasing(self, f: impl Fn(f64) -> f64) -> Interval {
        if self.is_empty() {
            return self;
        }
        Interval::new(f(self.hi), f(self.lo)).widen()
    }

    /// The part at or above `min` (EMPTY if none).
    pub fn clamp_below(self, min: f64) -> Interval {
        if self.is_empty() || self.hi < min {
            Interval::EMPTY
        } else {
            Interval {
                lo: self.lo.max(min),
                hi: self.hi,
            }
        }
    }

    /// Whether some x + k·period (k whole) lies in the interval; may say yes when the
    /// answer is within rounding of the ends (that only widens a result).
    pub fn reaches(self, x: f64, period: f64) -> bool {
        let slack = 1e-9;
        let k0 = ((self.lo - x) / period - slack).ceil();
        let k1 = ((self.hi - x) / period + slack).floor();
        k0 <= k1
    }
}

/// The next float towards +∞ (`f64::next_up` needs Rust 1.86; the crate supports 1.85).
pub fn up(x: f64) -> f64 {
    if x.is_nan() || x == f64::INFINITY {
        x
    } else if x == 0.0 {
        f64::from_bits(1)
    } else if x > 0.0 {
        f64::from_bits(x.to_bits() + 1)
    } else {
        f64::from_bits(x.to_bits() - 1)
    }
}

/// Two floats towards +∞: on the bits directly for the normal numbers of ordinary size (the
/// octree's hot path), else by [`up`] twice.
pub fn up2(x: f64) -> f64 {
    let a = x.abs();
    if (1e-300..1e300).contains(&a) {
        // Adjacent floats of one sign have adjacent bit patterns; far from 0 and from the
        // largest float, two steps stay normal and finite.
        let bits = x.to_bits();
        f64::from_bits(if x > 0.0 { bits + 2 } else { bits - 2 })
    } else {
        up(up(x))
    }
}

/// The next float towards −∞.
pub fn down(x: f64) -> f64 {
    -up(-x)
}

/// 0·∞ = 0 in a product of ends: an end ±∞ is approached, not taken, by finite values, and a
/// factor 0 keeps the product 0.
pub fn mul_ends(a: f64, b: f64) -> f64 {
    if a == 0.0 || b == 0.0 { 0.0 } else { a * b }
}

/// The product rule (`Op::Mul`).
pub fn mul(a: Interval, b: Interval) -> Interval {
    if a.lo.is_finite() && a.hi.is_finite() && b.lo.is_finite() && b.hi.is_finite() {
        // The common case, without the NaN and 0·∞ care of the general rule (finite ends
        // give finite or infinite products, never NaN): the hot path of the octree.
        let (p, q, r, t) = (a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi);
        let min = |x: f64, y: f64| if y < x { y } else { x };
        let max = |x: f64, y: f64| if y > x { y } else { x };
        return Interval {
            lo: min(min(p, q), min(r, t)),
            hi: max(max(p, q), max(r, t)),
        }
        .widen();
    }
    Interval::corners(a, b, mul_ends).widen()
}

/// The sum rule (`Op::Add`).
pub fn add(a: Interval, b: Interval) -> Interval {
    if a.is_empty() || b.is_empty() {
        return Interval::EMPTY;
    }
    Interval::new(a.lo + b.lo, a.hi + b.hi).widen()
}

pub fn recip(a: Interval) -> Interval {
    if a.lo > 0.0 || a.hi < 0.0 {
        a.decreasing(|v| 1.0 / v)
    } else if a.lo == 0.0 && a.hi > 0.0 {
        // The right half-line: 1/+0 = +∞.
        Interval::new(down(down(1.0 / a.hi)), f64::INFINITY)
    } else if a.hi == 0.0 && a.lo < 0.0 {
        Interval::new(f64::NEG_INFINITY, up(up(1.0 / a.lo)))
    } else {
        Interval::ENTIRE
    }
}

pub fn square(a: Interval) -> Interval {
    if a.lo >= 0.0 {
        a.increasing(|v| v * v)
    } else if a.hi <= 0.0 {
        a.decreasing(|v| v * v)
    } else {
        Interval::new(0.0, (a.lo * a.lo).max(a.hi * a.hi)).widen()
    }
}

/// sin over the interval: the ends, and ±1 where a crest or trough lies inside.
pub fn sin(a: Interval) -> Interval {
    periodic(a, f64::sin, FRAC_PI_2, -FRAC_PI_2)
}

pub fn cos(a: Interval) -> Interval {
    periodic(a, f64::cos, 0.0, PI)
}

/// A 2π-periodic function with its maximum 1 at `crest` and minimum −1 at `trough`.
pub fn periodic(a: Interval, f: fn(f64) -> f64, crest: f64, trough: f64) -> Interval {
    let narrow = a.hi - a.lo < TAU;
    if !narrow || !within_period_range(a) {
        return Interval::new(-1.0, 1.0);
    }
    let mut r = Interval::of(&[f(a.lo), f(a.hi)]).widen();
    if a.reaches(crest, TAU) {
        r.hi = 1.0;
    }
    if a.reaches(trough, TAU) {
        r.lo = -1.0;
    }
    Interval::new(r.lo.max(-1.0), r.hi.min(1.0))
}

/// Whether the ends are small enough that k·π is known to far better than the slack of
/// [`Interval::reaches`] (beyond, the periodic rules give their whole range).
pub fn within_period_range(a: Interval) -> bool {
    a.lo.abs() <= 1e6 && a.hi.abs() <= 1e6
}

/// tan: increasing between its poles at π/2 + kπ; the whole line over a pole.
pub fn tan(a: Interval) -> Interval {
    let narrow = a.hi - a.lo < PI;
    if !narrow || !within_period_range(a) || a.reaches(FRAC_PI_2, PI) {
        return Interval::ENTIRE;
    }
    a.increasing(f64::tan)
}

/// a^b as `powf` computes it. For a ≥ 0 the function is monotone in each argument with the
/// other fixed, so its extremes over a rectangle are at the corners. A negative base has a
/// value only at whole exponents.
pub fn pow(a: Interval, b: Interval) -> Interval {
    if a.is_empty() || b.is_empty() {
        // powf(NaN, 0) = 1 and powf(1, NaN) = 1.
        let one = (a.is_empty() && b.contains(0.0)) || (b.is_empty() && a.contains(1.0));
        return if one {
            Interval::point(1.0)
        } else {
            Interval::EMPTY
        };
    }
    let whole = b.lo == b.hi && b.lo.fract() == 0.0 && b.lo.is_finite();
    if a.lo < 0.0 && whole {
        let n = b.lo;
        if n < 0.0 && a.hi >= 0.0 {
            return Interval::ENTIRE;
        }
        // Monotone on each side of 0: the ends, and 0^n where 0 is inside.
        let mut r = Interval::of(&[a.lo.powf(n), a.hi.powf(n)]);
        if a.contains(0.0) {
            r = r.hull(Interval::point(0.0f64.powf(n)));
        }
        return r.widen();
    }
    if a.lo < 0.0 && b.lo != b.hi {
        // Whole exponents inside b give values for the negative bases: no bound kept.
        return Interval::ENTIRE;
    }
    if a.lo < 0.0 && b.lo.is_infinite() {
        // IEEE: a negative base to ±∞ is 0, 1 or ∞.
        return Interval::new(0.0, f64::INFINITY);
    }
    // IEEE gives −∞ to a fractional power a value (0 or ∞), unlike finite negative bases.
    let minus_infinity = if a.lo == f64::NEG_INFINITY {
        Interval::point(f64::NEG_INFINITY.powf(b.lo))
    } else {
        Interval::EMPTY
    };
    let a = a.clamp_below(0.0);
    if a.is_empty() {
        return minus_infinity;
    }
    // An infinite corner is approached, not taken: bound its limit by the largest finite
    // values near it instead of trusting powf's conventions (0^−∞ = ∞, 1^∞ = 1, …).
    let mut r = Interval::corners(a, b, f64::powf);
    if a.contains(1.0) {
        r = r.hull(Interval::point(1.0));
    }
    if !a.lo.is_finite() || !a.hi.is_finite() || !b.lo.is_finite() || !b.hi.is_finite() {
        // Limits at infinite ends may be 0, 1 or ∞ whatever powf says there.
        r = r.hull(Interval::point(0.0));
        if a.hi > 0.0 {
            r = r.hull(Interval::point(f64::INFINITY));
        }
    }
    r.hull(minus_infinity).widen()
}

/// atan2(a, b), the angle of the point (b, a) in [−π, π]. Away from the cut along the
/// negative b-axis it is monotone in each argument (the other fixed), so the corners bound
/// it; over the cut or the origin it takes the whole range.
pub fn atan2(a: Interval, b: Interval) -> Interval {
    let pi = Interval::new(-PI, PI).widen();
    if a.contains(0.0) && b.lo <= 0.0 {
        return pi;
    }
    let r = Interval::corners(a, b, f64::atan2).widen();
    Interval::new(r.lo.max(pi.lo), r.hi.min(pi.hi))
}

pub fn abs(a: Interval) -> Interval {
    if a.lo >= 0.0 {
        a
    } else if a.hi <= 0.0 {
        Interval::new(-a.hi, -a.lo)
    } else {
        Interval::new(0.0, (-a.lo).max(a.hi))
    }
}
