//! Interval gradients: forward-mode differentiation over intervals. For each opcode, an
//! interval value (the rule of [`interval`]) with three interval partials that contain every
//! derivative the opcode's output takes by x, y and z when its operands range over their
//! intervals. The component search (`pipeline::components`) uses them to keep only the cells
//! where a component can have an extreme point (docs/components.md).
//!
//! What "every derivative" means where f is not differentiable: the partials enclose the
//! Clarke generalized gradient — the convex hull of the limits of nearby gradients — which
//! is what the extreme-point argument of the search needs (at a crease of `min`/`max` the
//! hull of both sides' gradients, under `abs` at 0 the factor [−1, 1]). Where an opcode is
//! not Lipschitz inside the cell (`sqrt`, `ln`, `recip` near 0; `asin` near ±1; a pole of
//! `tan`), no such hull exists, so its factor becomes the whole line: every partial that
//! depends on it contains 0 and nothing is concluded there. A partial of an operand that does
//! not depend on an input stays exactly [0, 0] (as in `ops::term`).
//!
//! A partial with no defined value (NaN ends) is the whole line too: an unknown derivative
//! never prunes a cell.

use crate::compile::tape::Op;
use crate::values::interval::{Interval, mul};
use crate::values::interval_grad::{IntervalGrad, ONE, UNIT, ZERO, finite, known, sum};

use super::interval::interval;

fn op1(op: Op, a: Interval) -> Interval {
    interval(op, a, ZERO)
}

fn op2(op: Op, a: Interval, b: Interval) -> Interval {
    interval(op, a, b)
}

/// Partial by partial: the derivatives of a ± b.
fn sum_each(a: [Interval; 3], b: [Interval; 3], negate_b: bool) -> [Interval; 3] {
    let mut d = a;
    for (slot, db) in d.iter_mut().zip(b) {
        let db = if negate_b { op1(Op::Neg, db) } else { db };
        *slot = sum(*slot, db);
    }
    d
}

/// The part of `a` inside [lo, hi] (EMPTY if none).
fn within(a: Interval, lo: f64, hi: f64) -> Interval {
    if a.is_empty() || a.hi < lo || a.lo > hi {
        Interval::EMPTY
    } else {
        Interval::new(a.lo.max(lo), a.hi.min(hi))
    }
}

/// `op a, b` on interval gradients: the value of [`interval`], with partials enclosing the
/// (generalized) derivatives of the module documentation. `Dist` has no rule here (the
/// evaluator asks the child for its value bound): its partials are the whole line.
pub fn interval_grad(op: Op, a: IntervalGrad, b: IntervalGrad) -> IntervalGrad {
    let v = interval(op, a.v, b.v);
    let (x, y) = (a.v, b.v);
    let r = match op {
        Op::Neg => IntervalGrad {
            v,
            d: a.d.map(|d| op1(Op::Neg, d)),
            defined: a.defined,
        },
        Op::Square => a.chain(v, mul(Interval::point(2.0), x)),
        Op::Recip => a.chain(v, op1(Op::Neg, op1(Op::Square, op1(Op::Recip, x)))),
        Op::Sqrt => {
            // 1/(2√a) over the defined part a ≥ 0; unbounded where a reaches 0.
            let s = op1(Op::Sqrt, x);
            a.chain(v, op2(Op::Mul, Interval::point(0.5), op1(Op::Recip, s)))
        }
        Op::Abs => {
            let k = if x.lo > 0.0 {
                ONE
            } else if x.hi < 0.0 {
                op1(Op::Neg, ONE)
            } else {
                UNIT
            };
            a.chain(v, k)
        }
        Op::Exp => a.chain(v, v),
        Op::Ln => a.chain(v, op1(Op::Recip, within(x, 0.0, f64::INFINITY))),
        Op::Sin => a.chain(v, op1(Op::Cos, x)),
        Op::Cos => a.chain(v, op1(Op::Neg, op1(Op::Sin, x))),
        Op::Tan => a.chain(v, op2(Op::Add, ONE, op1(Op::Square, v))),
        Op::Asin | Op::Acos => {
            // ±1/√(1 − a²) over the defined part |a| ≤ 1; unbounded where |a| reaches 1.
            let inside = within(x, -1.0, 1.0);
            let k = op1(
                Op::Recip,
                op1(Op::Sqrt, op2(Op::Sub, ONE, op1(Op::Square, inside))),
            );
            a.chain(v, if op == Op::Asin { k } else { op1(Op::Neg, k) })
        }
        Op::Atan => a.chain(v, op1(Op::Recip, op2(Op::Add, ONE, op1(Op::Square, x)))),
        Op::Sinh => a.chain(v, op1(Op::Cosh, x)),
        Op::Cosh => a.chain(v, op1(Op::Sinh, x)),
        Op::Tanh => a.chain(v, op2(Op::Sub, ONE, op1(Op::Square, v))),
        Op::Add | Op::Sub => IntervalGrad {
            v,
            d: sum_each(a.d, b.d, op == Op::Sub),
            defined: a.defined && b.defined && finite(v),
        },
        Op::Mul => a.chain2(b, v, y, x),
        Op::Div => {
            // (a'b − ab')/b² = (a' − (a/b)·b')/b
            let r = op1(Op::Recip, y);
            a.chain2(b, v, r, op1(Op::Neg, op2(Op::Mul, v, r)))
        }
        Op::Pow => {
            // b·a^(b−1)·a' + ln(a)·a^b·b' (the second term only where b varies).
            let b_minus_1 = if y.lo == y.hi && (y.lo - 1.0) + 1.0 == y.lo {
                // Exact (whole exponents): keeps pow's rule for negative bases.
                Interval::point(y.lo - 1.0)
            } else {
                op2(Op::Sub, y, ONE)
            };
            let k = op2(Op::Mul, y, op2(Op::Pow, x, b_minus_1));
            let m = op2(Op::Mul, v, op1(Op::Ln, within(x, 0.0, f64::INFINITY)));
            a.chain2(b, v, k, m)
        }
        Op::Atan2 => {
            // (b·a' − a·b') / (a² + b²); unbounded at the origin.
            let inv = op1(
                Op::Recip,
                op2(Op::Add, op1(Op::Square, x), op1(Op::Square, y)),
            );
            a.chain2(
                b,
                v,
                op2(Op::Mul, y, inv),
                op1(Op::Neg, op2(Op::Mul, x, inv)),
            )
        }
        Op::Min | Op::Max => {
            if x.is_empty() || y.is_empty() {
                IntervalGrad::unknown_slope(v)
            } else {
                // The operand that is the result throughout, else (a tie is possible) the
                // hull of both: the generalized gradient at a crease.
                let a_below = x.hi < y.lo;
                let b_below = y.hi < x.lo;
                let pick_a = if op == Op::Min { a_below } else { b_below };
                let pick_b = if op == Op::Min { b_below } else { a_below };
                let defined = a.defined && b.defined;
                if pick_a {
                    IntervalGrad { v, d: a.d, defined }
                } else if pick_b {
                    IntervalGrad { v, d: b.d, defined }
                } else {
                    let mut d = a.d;
                    for (slot, other) in d.iter_mut().zip(b.d) {
                        *slot = slot.hull(other);
                    }
                    IntervalGrad { v, d, defined }
                }
            }
        }
        Op::Hypot => {
            // (a·a' + b·b')/hypot; each factor lies in [−1, 1] (at the origin, the unit
            // disc is the generalized gradient), widened by the rounding of a point's
            // a/hypot, which may pass 1 by an ulp.
            let inv = op1(Op::Recip, v);
            let unit = Interval::new(-1.0 - 4.0 * f64::EPSILON, 1.0 + 4.0 * f64::EPSILON);
            let clamp = |k: Interval| {
                if k.is_empty() || !(k.lo.is_finite() && k.hi.is_finite()) {
                    unit
                } else {
                    Interval::new(k.lo.max(unit.lo), k.hi.min(unit.hi))
                }
            };
            a.chain2(
                b,
                v,
                clamp(op2(Op::Mul, x, inv)),
                clamp(op2(Op::Mul, y, inv)),
            )
        }
        Op::Dist => IntervalGrad::unknown_slope(v),
    };
    // The operand must lie in the opcode's domain throughout for f to be defined there.
    let in_domain = match op {
        Op::Sqrt | Op::Ln => x.lo >= 0.0,
        Op::Asin | Op::Acos => x.lo >= -1.0 && x.hi <= 1.0,
        // A negative base has values only at a constant whole exponent.
        Op::Pow => x.lo >= 0.0 || (y.lo == y.hi && y.lo.fract() == 0.0),
        _ => true,
    };
    IntervalGrad {
        v: r.v,
        d: r.d.map(known),
        defined: r.defined && in_domain && finite(r.v),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn iv(lo: f64, hi: f64) -> Interval {
        Interval::new(lo, hi)
    }

    #[test]
    fn product_rule_on_a_box() {
        // x·y over [1, 2] × [3, 4]: ∂x = y ∈ [3, 4], ∂y = x ∈ [1, 2], ∂z = 0.
        let x = IntervalGrad::input(iv(1.0, 2.0), 0);
        let y = IntervalGrad::input(iv(3.0, 4.0), 1);
        let p = interval_grad(Op::Mul, x, y);
        assert!(p.d[0].contains(3.0) && p.d[0].contains(4.0) && !p.d[0].contains(2.9));
        assert!(p.d[1].contains(1.0) && p.d[1].contains(2.0) && !p.d[1].contains(2.1));
        assert_eq!(p.d[2], ZERO);
    }

    #[test]
    fn non_lipschitz_factors_give_the_whole_line() {
        let x = IntervalGrad::input(iv(0.0, 1.0), 0);
        let s = interval_grad(Op::Sqrt, x, IntervalGrad::constant(ZERO));
        assert_eq!(s.d[0], Interval::ENTIRE);
        assert_eq!(s.d[1], ZERO, "sqrt(x) does not depend on y");
    }

    #[test]
    fn a_crease_gives_the_hull_of_both_sides() {
        // min(x, −x) over [−1, 1]: the two sides tie at 0, slopes 1 and −1.
        let x = IntervalGrad::input(iv(-1.0, 1.0), 0);
        let m = interval_grad(Op::Neg, x, x);
        let r = interval_grad(Op::Min, x, m);
        assert!(r.d[0].contains(-1.0) && r.d[0].contains(1.0));
        // Apart, the lower one alone: min(x, x + 3) over [−1, 1] has slope 1.
        let shifted = interval_grad(Op::Add, x, IntervalGrad::constant(Interval::point(3.0)));
        let r = interval_grad(Op::Min, x, shifted);
        assert_eq!(r.d[0], ONE);
    }
}
