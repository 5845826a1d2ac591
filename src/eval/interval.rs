//! Interval arithmetic over the tape: for each opcode, an interval that contains every value
//! the opcode takes when its operands range over their intervals. The component search
//! (`pipeline::components`) runs a surface's tape on the box of an octree cell and drops the
//! cell when the result excludes 0.
//!
//!
//! The interval type and its arithmetic are `values::interval`; the conventions are there.

use crate::compile::tape::Op;
use crate::values::hypot;
use crate::values::interval::{Interval, abs, add, atan2, cos, mul, pow, recip, sin, square, tan};

/// `op a, b` on intervals: contains `ops::value(op, x, y)` for every x in a and y in b where
/// that value is not NaN. `Dist` has no rule here (the evaluator bounds the child): the
/// whole line.
pub fn interval(op: Op, a: Interval, b: Interval) -> Interval {
    let binary = op.arity() == crate::compile::tape::Arity::Binary;
    if op != Op::Pow && (a.is_empty() || (binary && b.is_empty())) {
        return match op {
            // hypot(±∞, NaN) = +∞.
            Op::Hypot if a.lo.is_infinite() || a.hi.is_infinite() => Interval::point(f64::INFINITY),
            Op::Hypot if b.lo.is_infinite() || b.hi.is_infinite() => Interval::point(f64::INFINITY),
            _ => Interval::EMPTY,
        };
    }
    match op {
        Op::Neg => Interval::new(-a.hi, -a.lo),
        Op::Square => square(a),
        Op::Recip => recip(a),
        Op::Sqrt => a.clamp_below(0.0).increasing(f64::sqrt).clamp_below(0.0),
        Op::Abs => abs(a),
        Op::Exp => a.increasing(f64::exp).clamp_below(0.0),
        Op::Ln => a.clamp_below(0.0).increasing(f64::ln),
        Op::Sin => sin(a),
        Op::Cos => cos(a),
        Op::Tan => tan(a),
        Op::Asin => {
            let a = a.clamp_below(-1.0);
            if a.is_empty() || a.lo > 1.0 {
                return Interval::EMPTY;
            }
            Interval::new(a.lo, a.hi.min(1.0)).increasing(f64::asin)
        }
        Op::Acos => {
            let a = a.clamp_below(-1.0);
            if a.is_empty() || a.lo > 1.0 {
                return Interval::EMPTY;
            }
            Interval::new(a.lo, a.hi.min(1.0))
                .decreasing(f64::acos)
                .clamp_below(0.0)
        }
        Op::Atan => a.increasing(f64::atan),
        Op::Sinh => a.increasing(f64::sinh),
        Op::Cosh => {
            let m = abs(a);
            Interval::new(m.lo.cosh(), m.hi.cosh())
                .widen()
                .clamp_below(1.0)
        }
        Op::Tanh => a.increasing(f64::tanh),
        Op::Add => add(a, b),
        Op::Sub => Interval::new(a.lo - b.hi, a.hi - b.lo).widen(),
        Op::Mul => mul(a, b),
        Op::Div => {
            if b.lo == 0.0 && b.hi == 0.0 {
                return Interval::ENTIRE;
            }
            mul(a, recip(b))
        }
        Op::Pow => pow(a, b),
        Op::Atan2 => atan2(a, b),
        Op::Min => Interval::new(a.lo.min(b.lo), a.hi.min(b.hi)),
        Op::Max => Interval::new(a.lo.max(b.lo), a.hi.max(b.hi)),
        Op::Hypot => {
            let (a, b) = (abs(a), abs(b));
            Interval::new(hypot(a.lo, b.lo), hypot(a.hi, b.hi)).widen()
        }
        Op::Dist => Interval::ENTIRE,
    }
}
