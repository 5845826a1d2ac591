//! Compile-time evaluation: constants and the numbers that meshes, curves and patch ranges
//! need. Only coordinate-free expressions get here (sema has checked that); function calls
//! are evaluated by substituting the arguments, to a bounded nesting depth.

use glam::DVec3;

use crate::diag::messages;
use crate::span::Span;
use crate::syntax::ast;

use super::Checker;
use super::expr::{Ctx, Place};
use super::program::*;

/// Function calls nested deeper than this are not evaluated at compile time (each call's body
/// is itself at most `MAX_EXPR_DEPTH` deep, so this bounds the evaluator's stack).
const MAX_CALL_DEPTH: usize = 32;

/// Why a value could not be computed: a dependency is broken (already reported), or the
/// evaluation would nest too deeply.
#[derive(Debug, PartialEq)]
enum NoValue {
    Broken,
    TooDeep,
}

impl Checker<'_> {
    fn eval(&self, e: &Expr, args: &[f64], depth: usize) -> Result<f64, NoValue> {
        Ok(match &e.kind {
            ExprKind::Number(v) => *v,
            ExprKind::Param(i) => *args.get(*i as usize).ok_or(NoValue::Broken)?,
            ExprKind::Const(id) => {
                let d = self
                    .by_kind
                    .get(&(super::Kind::Const as u8, id.0))
                    .ok_or(NoValue::Broken)?;
                if self.decls[*d].broken {
                    return Err(NoValue::Broken);
                }
                self.constants[id.index()]
                    .as_ref()
                    .ok_or(NoValue::Broken)?
                    .value
            }
            ExprKind::Unary(UnaryOp::Neg, a) => -self.eval(a, args, depth)?,
            ExprKind::Binary(op, a, b) => {
                let (a, b) = (self.eval(a, args, depth)?, self.eval(b, args, depth)?);
                match op {
                    BinaryOp::Add => a + b,
                    BinaryOp::Sub => a - b,
                    BinaryOp::Mul => a * b,
                    BinaryOp::Div => a / b,
                    BinaryOp::Pow => a.powf(b),
                }
            }
            ExprKind::Builtin(b, xs) => {
                let mut v = [0.0; 2];
                for (k, x) in xs.iter().take(2).enumerate() {
                    v[k] = self.eval(x, args, depth)?;
                }
                let [a, c] = v;
                match b {
                    Builtin::Sqrt => a.sqrt(),
                    Builtin::Abs => a.abs(),
                    Builtin::Exp => a.exp(),
                    Builtin::Ln => a.ln(),
                    Builtin::Sin => a.sin(),
                    Builtin::Cos => a.cos(),
                    Builtin::Tan => a.tan(),
                    Builtin::Asin => a.asin(),
                    Builtin::Acos => a.acos(),
                    Builtin::Atan => a.atan(),
                    Builtin::Atan2 => a.atan2(c),
                    Builtin::Sinh => a.sinh(),
                    Builtin::Cosh => a.cosh(),
                    Builtin::Tanh => a.tanh(),
                    Builtin::Min => a.min(c),
                    Builtin::Max => a.max(c),
                    Builtin::Pow => a.powf(c),
                    Builtin::Hypot => crate::values::hypot(a, c),
                }
            }
            ExprKind::Call(id, xs) => {
                if depth >= MAX_CALL_DEPTH {
                    return Err(NoValue::TooDeep);
                }
                let f = self.functions[id.index()].as_ref().ok_or(NoValue::Broken)?;
                let mut values = Vec::with_capacity(xs.len());
                for x in xs {
                    values.push(self.eval(x, args, depth)?);
                }
                self.eval(&f.body, &values, depth + 1)?
            }
            // Sema never evaluates these (no coordinates where values are computed).
            ExprKind::Coord(_) | ExprKind::Surface(_) | ExprKind::Dist(_) | ExprKind::At(..) => {
                return Err(NoValue::Broken);
            }
        })
    }

    /// The value of an already lowered expression if it is a compile-time constant (no
    /// coordinates, parameters or broken dependencies), without reporting anything.
    pub(crate) fn known(&self, e: &Expr) -> Option<f64> {
        self.eval(e, &[], 0).ok().filter(|v| v.is_finite())
    }

    /// Lowers and evaluates a coordinate-free expression; reports a value that is infinite or
    /// NaN (`what` names it). None if it cannot be computed (the error is already reported).
    pub(crate) fn number_in(
        &mut self,
        e: &ast::Expr,
        place: Place,
        owner: Option<usize>,
        what: &str,
    ) -> Option<f64> {
        let mut cx = Ctx::new(place, &[], owner);
        let lowered = self.lower(e, &mut cx);
        if cx.failed {
            return None;
        }
        match self.eval(&lowered, &[], 0) {
            Ok(v) if v.is_finite() => Some(v),
            Ok(v) => {
                self.diags.push(messages::not_finite(e.span, what, v));
                None
            }
            Err(NoValue::TooDeep) => {
                self.diags.push(crate::syntax::nesting_too_deep(e.span));
                None
            }
            Err(NoValue::Broken) => None,
        }
    }

    /// A number of a mesh option, a curve or a patch range.
    pub(crate) fn number(&mut self, e: &ast::Expr, what: &str) -> Option<f64> {
        self.number_in(e, Place::Number, None, what)
    }

    /// The value of the constant declared as `d`.
    pub(crate) fn const_value(&mut self, e: &ast::Expr, d: usize) -> Option<f64> {
        let what = format!("constant `{}`", self.decls[d].name.name);
        self.number_in(e, Place::Const, Some(d), &what)
    }

    /// A point `(x, y, z)` of constant expressions.
    pub(crate) fn point(&mut self, e: &ast::Expr, what: &str) -> Option<DVec3> {
        match &e.kind {
            ast::ExprKind::Tuple(parts) if parts.len() == 3 => {
                let mut v = [0.0; 3];
                let mut ok = true;
                for (k, p) in parts.iter().enumerate() {
                    match self.number(p, what) {
                        Some(x) => v[k] = x,
                        None => ok = false,
                    }
                }
                ok.then(|| DVec3::from_array(v))
            }
            ast::ExprKind::Tuple(parts) => {
                self.diags
                    .push(messages::wrong_point_arity(e.span, parts.len()));
                None
            }
            _ => {
                // A single number where a point belongs: check it anyway (its own errors
                // first), then say that a point is needed.
                let before = self.diags.len();
                let _ = self.number(e, what);
                if self.diags.len() == before {
                    self.diags.push(messages::wrong_point_arity(e.span, 1));
                }
                None
            }
        }
    }
}

/// A span covering a list of spans (for labels over several values).
pub(crate) fn cover(spans: impl IntoIterator<Item = Span>) -> Option<Span> {
    spans.into_iter().reduce(Span::join)
}
