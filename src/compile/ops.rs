//! What every opcode computes: its value, and its value with first derivatives as a dual
//! number ([`Grad`]). The one definition the VM (single point and batch), the compiler's
//! constant folding and the conformance tests share.
//!
//! Domain errors give NaN or ±inf as IEEE arithmetic does (sqrt and ln of a negative, division
//! by zero); nothing panics. Derivatives at points where the function is not differentiable
//! are chosen, documented in `docs/compiler.md`, and tested:
//! - `abs` at 0, `sqrt` at 0, `hypot` at (0, 0), `atan2` at (0, 0): derivative 0 (for `abs`
//!   the middle of its subdifferential; for the others a vanishing gradient, which
//!   surfacepoint reports as a singular point instead of stepping to infinity);
//! - `min`/`max` on a tie: the mean of the two operands' derivatives;
//! - `min`/`max` with a NaN operand: NaN (unlike `f64::min`, so domain errors are not hidden).

use crate::compile::tape::Op;

/// A value with its partial derivatives by the three inputs (x, y, z; for a patch u, v and
/// an unused third).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Grad {
    pub v: f64,
    pub dx: f64,
    pub dy: f64,
    pub dz: f64,
}

impl Grad {
    pub const fn new(v: f64, dx: f64, dy: f64, dz: f64) -> Grad {
        Grad { v, dx, dy, dz }
    }

    /// A constant: all partials 0.
    pub const fn constant(v: f64) -> Grad {
        Grad::new(v, 0.0, 0.0, 0.0)
    }

    /// Input `axis` (0, 1 or 2) with value v: its own partial 1.
    pub fn input(v: f64, axis: usize) -> Grad {
        Grad::new(
            v,
            f64::from(axis == 0),
            f64::from(axis == 1),
            f64::from(axis == 2),
        )
    }

    /// The chain rule: f(self) with value `v` and f'(self) = `k`.
    #[inline(always)]
    fn chain(self, v: f64, k: f64) -> Grad {
        Grad::new(v, term(k, self.dx), term(k, self.dy), term(k, self.dz))
    }

    /// k·self' + m·other' with value `v`.
    #[inline(always)]
    fn chain2(self, other: Grad, v: f64, k: f64, m: f64) -> Grad {
        Grad::new(
            v,
            term(k, self.dx) + term(m, other.dx),
            term(k, self.dy) + term(m, other.dy),
            term(k, self.dz) + term(m, other.dz),
        )
    }
}

/// k·d, where a zero derivative stays zero whatever k is: a partial that does not depend
/// on an input must not turn NaN because a coefficient is infinite (x·y at x = ∞ has ∂/∂x =
/// y, not NaN). It also makes the dense dual numbers agree with the batch evaluator, which
/// skips partials that are structurally zero.
#[inline(always)]
pub fn term(k: f64, d: f64) -> f64 {
    if d == 0.0 { 0.0 } else { k * d }
}

/// f64::min/max ignore NaN; ours propagate it.
#[inline(always)]
fn min_value(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else if b < a {
        b
    } else {
        a
    }
}

#[inline(always)]
fn max_value(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else if b > a {
        b
    } else {
        a
    }
}

/// The value of `op a, b` (b unread by unary ops). `Dist` has no value here (it needs its
/// child): NaN.
#[inline(always)]
pub fn value(op: Op, a: f64, b: f64) -> f64 {
    match op {
        Op::Neg => -a,
        Op::Square => a * a,
        Op::Recip => 1.0 / a,
        Op::Sqrt => a.sqrt(),
        Op::Abs => a.abs(),
        Op::Exp => a.exp(),
        Op::Ln => a.ln(),
        Op::Sin => a.sin(),
        Op::Cos => a.cos(),
        Op::Tan => a.tan(),
        Op::Asin => a.asin(),
        Op::Acos => a.acos(),
        Op::Atan => a.atan(),
        Op::Sinh => a.sinh(),
        Op::Cosh => a.cosh(),
        Op::Tanh => a.tanh(),
        Op::Add => a + b,
        Op::Sub => a - b,
        Op::Mul => a * b,
        Op::Div => a / b,
        Op::Pow => a.powf(b),
        Op::Atan2 => a.atan2(b),
        Op::Min => min_value(a, b),
        Op::Max => max_value(a, b),
        Op::Hypot => crate::values::hypot(a, b),
        Op::Dist => f64::NAN,
    }
}

/// `op a, b` on dual numbers: the same value as [`value`], with the derivatives of the
/// module documentation. `Dist` has no value here: NaN.
#[inline(always)]
pub fn grad(op: Op, a: Grad, b: Grad) -> Grad {
    match op {
        Op::Neg => Grad::new(-a.v, -a.dx, -a.dy, -a.dz),
        Op::Square => a.chain(a.v * a.v, 2.0 * a.v),
        Op::Recip => {
            let v = 1.0 / a.v;
            a.chain(v, -v * v)
        }
        Op::Sqrt => {
            let v = a.v.sqrt();
            a.chain(v, if v == 0.0 { 0.0 } else { 0.5 / v })
        }
        Op::Abs => {
            let s = if a.v > 0.0 {
                1.0
            } else if a.v < 0.0 {
                -1.0
            } else if a.v == 0.0 {
                0.0
            } else {
                f64::NAN
            };
            a.chain(a.v.abs(), s)
        }
        Op::Exp => {
            let v = a.v.exp();
            a.chain(v, v)
        }
        Op::Ln => a.chain(a.v.ln(), 1.0 / a.v),
        Op::Sin => {
            let (s, c) = a.v.sin_cos();
            a.chain(s, c)
        }
        Op::Cos => {
            let (s, c) = a.v.sin_cos();
            a.chain(c, -s)
        }
        Op::Tan => {
            let v = a.v.tan();
            a.chain(v, 1.0 + v * v)
        }
        Op::Asin => a.chain(a.v.asin(), 1.0 / (1.0 - a.v * a.v).sqrt()),
        Op::Acos => a.chain(a.v.acos(), -1.0 / (1.0 - a.v * a.v).sqrt()),
        Op::Atan => a.chain(a.v.atan(), 1.0 / (1.0 + a.v * a.v)),
        Op::Sinh => a.chain(a.v.sinh(), a.v.cosh()),
        Op::Cosh => a.chain(a.v.cosh(), a.v.sinh()),
        Op::Tanh => {
            let v = a.v.tanh();
            a.chain(v, 1.0 - v * v)
        }
        Op::Add => Grad::new(a.v + b.v, a.dx + b.dx, a.dy + b.dy, a.dz + b.dz),
        Op::Sub => Grad::new(a.v - b.v, a.dx - b.dx, a.dy - b.dy, a.dz - b.dz),
        Op::Mul => a.chain2(b, a.v * b.v, b.v, a.v),
        Op::Div => {
            // (a'b − ab')/b² = (a' − (a/b)·b')/b
            let v = a.v / b.v;
            let r = 1.0 / b.v;
            a.chain2(b, v, r, -v * r)
        }
        Op::Pow => {
            let v = a.v.powf(b.v);
            let k = b.v * a.v.powf(b.v - 1.0);
            // The ln(a) term only where the exponent varies: a constant exponent must not
            // turn the derivative of, say, (−2)^3 into NaN through ln(−2).
            let l = v * a.v.ln();
            let ln_term = |db: f64| term(l, db);
            Grad::new(
                v,
                term(k, a.dx) + ln_term(b.dx),
                term(k, a.dy) + ln_term(b.dy),
                term(k, a.dz) + ln_term(b.dz),
            )
        }
        Op::Atan2 => {
            // d atan2(a, b) = (b·a' − a·b') / (a² + b²)
            let r = a.v * a.v + b.v * b.v;
            let inv = if r == 0.0 { 0.0 } else { 1.0 / r };
            a.chain2(b, a.v.atan2(b.v), b.v * inv, -a.v * inv)
        }
        Op::Min | Op::Max => {
            let v = if op == Op::Min {
                min_value(a.v, b.v)
            } else {
                max_value(a.v, b.v)
            };
            let (k, m) = if v.is_nan() {
                (f64::NAN, f64::NAN)
            } else if a.v == b.v {
                (0.5, 0.5)
            } else if v == a.v {
                (1.0, 0.0)
            } else {
                (0.0, 1.0)
            };
            a.chain2(b, v, k, m)
        }
        Op::Hypot => {
            let v = crate::values::hypot(a.v, b.v);
            let inv = if v == 0.0 { 0.0 } else { 1.0 / v };
            a.chain2(b, v, a.v * inv, b.v * inv)
        }
        Op::Dist => Grad::constant(f64::NAN),
    }
}
