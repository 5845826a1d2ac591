//! Expressions: AST → program `Expr` with names resolved by kind, calls checked against their
//! signatures, and the combinators rewritten (docs/language.md):
//! `offset(S, d)` = dist(S) − d; `product(S1, …, Sn)` = S1·…·Sn (the surfaces' values);
//! `blend(S1, S2, c1, c2, mu)` = (1−mu)(d1/c1)(d2/c2) − mu(1 − d1/c1 − d2/c2)^3, d_i = dist(S_i).
//! Recursion follows the AST, whose depth the parser bounds.

use crate::diag::{messages, suggest};
use crate::span::Span;
use crate::syntax::ast;

use super::program::*;
use super::{COMBINATORS, COORDINATES, CURVE_CONSTRUCTORS, Checker, Kind};

/// Where an expression stands: decides whether coordinates exist and how messages name it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Place {
    Const,
    Fn,
    Surface,
    PatchBody,
    /// A number a mesh option, a curve or a patch range needs.
    Number,
}

impl Place {
    pub fn has_coordinates(self) -> bool {
        matches!(self, Place::Fn | Place::Surface)
    }

    /// How messages name the place ("… cannot be used in a constant").
    pub fn words(self) -> &'static str {
        match self {
            Place::Const => "a constant",
            Place::Fn => "a function",
            Place::Surface => "a surface",
            Place::PatchBody => "a patch body",
            Place::Number => "a constant expression",
        }
    }
}

pub(crate) struct Ctx<'p> {
    pub place: Place,
    pub params: &'p [&'p str],
    /// The declaration being lowered (its own name is not a use of itself).
    pub owner: Option<usize>,
    /// Set when the expression reads x, y, z (directly, through a surface, `dist` or a
    /// function that does).
    pub used_coordinates: bool,
    /// Set when lowering reported an error (the value is then not evaluated).
    pub failed: bool,
}

impl<'p> Ctx<'p> {
    pub fn new(place: Place, params: &'p [&'p str], owner: Option<usize>) -> Ctx<'p> {
        Ctx {
            place,
            params,
            owner,
            used_coordinates: false,
            failed: false,
        }
    }
}

fn number(v: f64, span: Span) -> Expr {
    Expr {
        kind: ExprKind::Number(v),
        span,
    }
}

fn binary(op: BinaryOp, l: Expr, r: Expr, span: Span) -> Expr {
    Expr {
        kind: ExprKind::Binary(op, Box::new(l), Box::new(r)),
        span,
    }
}

/// `name(params…)` for messages.
fn signature(name: &str, params: &[&str]) -> String {
    format!("{name}({})", params.join(", "))
}

pub(crate) fn builtin_signature(b: Builtin) -> String {
    let params: &[&str] = match b {
        Builtin::Atan2 => &["y", "x"],
        Builtin::Hypot => &["a", "b"],
        Builtin::Min | Builtin::Max => &["a", "b", "…"],
        Builtin::Pow => &["base", "exponent"],
        _ => &["t"],
    };
    signature(b.name(), params)
}

fn combinator_signature(name: &str) -> &'static str {
    match name {
        "dist" => "dist(S)",
        "offset" => "offset(S, d)",
        "product" => "product(S1, S2, …)",
        _ => "blend(S1, S2, c1, c2, mu)",
    }
}

pub(crate) fn count_words(n: usize) -> String {
    format!("{n} argument{}", if n == 1 { "" } else { "s" })
}

impl<'f> Checker<'f> {
    pub(crate) fn fail(&mut self, cx: &mut Ctx<'_>, d: crate::diag::Diagnostic) -> Expr {
        self.diags.push(d);
        cx.failed = true;
        number(0.0, Span::default())
    }

    /// Marks a declaration as used (unless it is the one being defined).
    pub(crate) fn mark_used(&mut self, d: usize, cx: &Ctx<'_>) {
        if cx.owner != Some(d) {
            self.decls[d].used = true;
        }
    }

    /// Every name visible in `cx`, for suggestions.
    fn visible_names(&self, cx: &Ctx<'_>) -> Vec<String> {
        let mut names: Vec<String> = cx.params.iter().map(|p| p.to_string()).collect();
        if cx.place.has_coordinates() {
            names.extend(COORDINATES.map(String::from));
        }
        names.extend(["pi", "tau"].map(String::from));
        names.extend(self.globals.keys().map(|k| k.to_string()));
        names
    }

    fn callable_names(&self) -> Vec<&str> {
        let mut names: Vec<&str> = Builtin::ALL.iter().map(|b| b.name()).collect();
        names.extend(COMBINATORS);
        names.extend(super::SOLIDS);
        names.extend(
            self.globals
                .iter()
                .filter(|(_, d)| self.decls[**d].kind == Kind::Fn)
                .map(|(n, _)| *n),
        );
        names
    }

    /// Lowers an expression standing for a number.
    pub(crate) fn lower(&mut self, e: &ast::Expr, cx: &mut Ctx<'_>) -> Expr {
        let span = e.span;
        match &e.kind {
            ast::ExprKind::Number { value, .. } => {
                if !value.is_finite() {
                    return self.fail(cx, messages::literal_too_large(span));
                }
                number(*value, span)
            }
            ast::ExprKind::Name(n) => self.lower_name(n, span, cx),
            ast::ExprKind::Neg(inner) => {
                let inner = self.lower(inner, cx);
                Expr {
                    kind: ExprKind::Unary(UnaryOp::Neg, Box::new(inner)),
                    span,
                }
            }
            ast::ExprKind::Binary(op, l, r) => {
                let op = match op {
                    ast::BinOp::Add => BinaryOp::Add,
                    ast::BinOp::Sub => BinaryOp::Sub,
                    ast::BinOp::Mul => BinaryOp::Mul,
                    ast::BinOp::Div => BinaryOp::Div,
                    ast::BinOp::Pow => BinaryOp::Pow,
                };
                let l = self.lower(l, cx);
                let r = self.lower(r, cx);
                binary(op, l, r, span)
            }
            ast::ExprKind::Tuple(_) => self.fail(cx, messages::tuple_as_number(span)),
            ast::ExprKind::Call { callee, args } => self.lower_call(callee, args, span, cx),
        }
    }

    fn lower_name(&mut self, n: &str, span: Span, cx: &mut Ctx<'_>) -> Expr {
        if let Some(i) = cx.params.iter().position(|p| *p == n) {
            return Expr {
                kind: ExprKind::Param(i as u32),
                span,
            };
        }
        if let Some(axis) = match n {
            "x" => Some(Axis::X),
            "y" => Some(Axis::Y),
            "z" => Some(Axis::Z),
            _ => None,
        } {
            if !cx.place.has_coordinates() {
                return self.fail(
                    cx,
                    messages::coordinate_without_coordinates(span, n, cx.place.words()),
                );
            }
            cx.used_coordinates = true;
            return Expr {
                kind: ExprKind::Coord(axis),
                span,
            };
        }
        match n {
            "pi" => return number(std::f64::consts::PI, span),
            "tau" => return number(std::f64::consts::TAU, span),
            _ => {}
        }
        if let Some(&d) = self.globals.get(n) {
            self.mark_used(d, cx);
            let decl = &self.decls[d];
            let id = decl.id;
            return match decl.kind {
                Kind::Const => Expr {
                    kind: ExprKind::Const(ConstId(id)),
                    span,
                },
                Kind::Surface => {
                    if !cx.place.has_coordinates() {
                        return self.fail(
                            cx,
                            messages::surface_without_coordinates(span, n, cx.place.words()),
                        );
                    }
                    cx.used_coordinates = true;
                    Expr {
                        kind: ExprKind::Surface(SurfaceId(id)),
                        span,
                    }
                }
                Kind::Patch => self.fail(cx, messages::patch_as_value(span, n)),
                Kind::Curve => self.fail(cx, messages::curve_as_value(span, &format!("`{n}`"))),
                Kind::Fn => {
                    let sig = self.fn_signature(d);
                    self.fail(cx, messages::fn_without_call(span, n, &sig))
                }
            };
        }
        if let Some(b) = Builtin::from_name(n) {
            return self.fail(
                cx,
                messages::fn_without_call(span, n, &builtin_signature(b)),
            );
        }
        if COMBINATORS.contains(&n) {
            return self.fail(
                cx,
                messages::fn_without_call(span, n, combinator_signature(n)),
            );
        }
        if CURVE_CONSTRUCTORS.contains(&n) {
            return self.fail(cx, messages::curve_as_value(span, &format!("`{n}`")));
        }
        let suggestion = if self.suggestions_wanted() {
            let names = self.visible_names(cx);
            suggest::nearest(n, names.iter().map(String::as_str)).map(str::to_string)
        } else {
            None
        };
        let d = messages::unknown_name(span, n, suggestion.as_deref());
        self.fail(cx, d)
    }

    pub(crate) fn fn_signature(&self, d: usize) -> String {
        let decl = &self.decls[d];
        match &decl.item.kind {
            ast::ItemKind::Fn { params, .. } => {
                let ps: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
                signature(&decl.name.name, &ps)
            }
            _ => decl.name.name.clone(),
        }
    }

    /// Reports named arguments; returns false if there were any.
    pub(crate) fn positional_only(
        &mut self,
        callee: &str,
        sig: &str,
        args: &[ast::Arg],
        cx: &mut Ctx<'_>,
    ) -> bool {
        let mut ok = true;
        for a in args {
            if let Some(n) = &a.name {
                self.diags.push(messages::unexpected_named_argument(
                    n.span, callee, &n.name, sig,
                ));
                cx.failed = true;
                ok = false;
            }
        }
        ok
    }

    fn lower_call(
        &mut self,
        callee: &ast::Ident,
        args: &[ast::Arg],
        span: Span,
        cx: &mut Ctx<'_>,
    ) -> Expr {
        let name = callee.name.as_str();
        if cx.params.contains(&name) {
            return self.fail(cx, messages::not_callable(callee.span, name, "a parameter"));
        }
        if let Some(&d) = self.globals.get(name) {
            self.mark_used(d, cx);
            let kind = self.decls[d].kind;
            if kind != Kind::Fn {
                return self.fail(
                    cx,
                    messages::not_callable(callee.span, name, kind.article()),
                );
            }
            let sig = self.fn_signature(d);
            let id = FnId(self.decls[d].id);
            let arity = match &self.decls[d].item.kind {
                ast::ItemKind::Fn { params, .. } => params.len(),
                _ => 0,
            };
            if !self.positional_only(name, &sig, args, cx) {
                return number(0.0, span);
            }
            if args.len() != arity {
                return self.fail(
                    cx,
                    messages::wrong_arity(span, name, &sig, &count_words(arity), args.len()),
                );
            }
            let uses_coordinates = self.functions[id.index()]
                .as_ref()
                .is_some_and(|f| f.uses_coordinates);
            if uses_coordinates {
                if !cx.place.has_coordinates() {
                    let def = self.decls[d].name.span;
                    return self.fail(
                        cx,
                        messages::coordinate_fn_without_coordinates(
                            span,
                            name,
                            cx.place.words(),
                            def,
                        ),
                    );
                }
                cx.used_coordinates = true;
            }
            let lowered = args.iter().map(|a| self.lower(&a.value, cx)).collect();
            return Expr {
                kind: ExprKind::Call(id, lowered),
                span,
            };
        }
        if let Some(b) = Builtin::from_name(name) {
            let sig = builtin_signature(b);
            if !self.positional_only(name, &sig, args, cx) {
                return number(0.0, span);
            }
            // `min` and `max` take two or more operands (like `union` and `intersection`),
            // folded from the left into the two-operand builtins the compiler knows.
            let variadic = matches!(b, Builtin::Min | Builtin::Max);
            if args.len() != b.arity() && !(variadic && args.len() > b.arity()) {
                let expected = if variadic {
                    format!("at least {}", count_words(b.arity()))
                } else {
                    count_words(b.arity())
                };
                return self.fail(
                    cx,
                    messages::wrong_arity(span, name, &sig, &expected, args.len()),
                );
            }
            let mut lowered: Vec<Expr> = args.iter().map(|a| self.lower(&a.value, cx)).collect();
            let rest = lowered.split_off(b.arity());
            let first = Expr {
                kind: ExprKind::Builtin(b, lowered),
                span,
            };
            return rest.into_iter().fold(first, |acc, e| Expr {
                kind: ExprKind::Builtin(b, vec![acc, e]),
                span,
            });
        }
        if COMBINATORS.contains(&name) {
            return self.lower_combinator(name, args, span, cx);
        }
        // Before the curve constructors: in an expression, `intersection` is the boolean.
        if super::SOLIDS.contains(&name) {
            return self.lower_solid(name, args, span, cx);
        }
        if CURVE_CONSTRUCTORS.contains(&name) {
            return self.fail(cx, messages::curve_as_value(span, &format!("`{name}(…)`")));
        }
        let suggestion = if self.suggestions_wanted() {
            suggest::nearest(name, self.callable_names()).map(str::to_string)
        } else {
            None
        };
        let d = messages::unknown_function(callee.span, name, suggestion.as_deref());
        self.fail(cx, d)
    }

    fn lower_combinator(
        &mut self,
        name: &str,
        args: &[ast::Arg],
        span: Span,
        cx: &mut Ctx<'_>,
    ) -> Expr {
        let sig = combinator_signature(name);
        if !self.positional_only(name, sig, args, cx) {
            return number(0.0, span);
        }
        let (ok, expected) = match name {
            "dist" => (args.len() == 1, "1 argument"),
            "offset" => (args.len() == 2, "2 arguments"),
            "product" => (!args.is_empty(), "at least 1 argument"),
            _ => (args.len() == 5, "5 arguments"),
        };
        if !ok {
            return self.fail(
                cx,
                messages::wrong_arity(span, name, sig, expected, args.len()),
            );
        }
        if !cx.place.has_coordinates() {
            return self.fail(
                cx,
                messages::surface_without_coordinates(
                    span,
                    &format!("{name}(…)"),
                    cx.place.words(),
                ),
            );
        }
        cx.used_coordinates = true;
        match name {
            "dist" => {
                let s = self.lower_surface_ref(&args[0].value, cx);
                Expr {
                    kind: ExprKind::Dist(s),
                    span,
                }
            }
            "offset" => {
                let s = self.lower_surface_ref(&args[0].value, cx);
                let dist = Expr {
                    kind: ExprKind::Dist(s),
                    span: args[0].value.span,
                };
                let d = self.lower(&args[1].value, cx);
                binary(BinaryOp::Sub, dist, d, span)
            }
            "product" => {
                let mut factors = args.iter().map(|a| self.lower(&a.value, cx));
                let first = factors.next().unwrap_or_else(|| number(1.0, span));
                factors.fold(first, |acc, f| binary(BinaryOp::Mul, acc, f, span))
            }
            _ => {
                let s1 = self.lower_surface_ref(&args[0].value, cx);
                let s2 = self.lower_surface_ref(&args[1].value, cx);
                let c1 = self.lower(&args[2].value, cx);
                let c2 = self.lower(&args[3].value, cx);
                let mu = self.lower(&args[4].value, cx);
                blend(
                    s1,
                    s2,
                    c1,
                    c2,
                    mu,
                    span,
                    args[0].value.span,
                    args[1].value.span,
                )
            }
        }
    }

    /// Where a surface is expected: a named surface, a patch, or an anonymous expression.
    pub(crate) fn lower_surface_ref(&mut self, e: &ast::Expr, cx: &mut Ctx<'_>) -> SurfaceRef {
        if let Some(p) = self.transformed_patch(e, cx) {
            return SurfaceRef::Patch(p);
        }
        if let ast::ExprKind::Name(n) = &e.kind {
            if !cx.params.contains(&n.as_str()) {
                if let Some(&d) = self.globals.get(n.as_str()) {
                    let kind = self.decls[d].kind;
                    let id = self.decls[d].id;
                    match kind {
                        Kind::Surface => {
                            self.mark_used(d, cx);
                            cx.used_coordinates = true;
                            return SurfaceRef::Surface(SurfaceId(id));
                        }
                        Kind::Patch => {
                            self.mark_used(d, cx);
                            return SurfaceRef::Patch(PatchId(id));
                        }
                        Kind::Curve => {
                            self.mark_used(d, cx);
                            self.diags.push(messages::curve_as_surface(e.span, n));
                            cx.failed = true;
                            return SurfaceRef::Anonymous(Box::new(number(0.0, e.span)));
                        }
                        Kind::Const | Kind::Fn => {}
                    }
                }
            }
        }
        let body = self.lower(e, cx);
        SurfaceRef::Anonymous(Box::new(body))
    }
}

#[allow(clippy::too_many_arguments)]
fn blend(
    s1: SurfaceRef,
    s2: SurfaceRef,
    c1: Expr,
    c2: Expr,
    mu: Expr,
    span: Span,
    span1: Span,
    span2: Span,
) -> Expr {
    let d1 = Expr {
        kind: ExprKind::Dist(s1),
        span: span1,
    };
    let d2 = Expr {
        kind: ExprKind::Dist(s2),
        span: span2,
    };
    let r1 = binary(BinaryOp::Div, d1, c1, span);
    let r2 = binary(BinaryOp::Div, d2, c2, span);
    // (1 − mu)(d1/c1)(d2/c2)
    let one_minus_mu = binary(BinaryOp::Sub, number(1.0, span), mu.clone(), span);
    let first = binary(
        BinaryOp::Mul,
        binary(BinaryOp::Mul, one_minus_mu, r1.clone(), span),
        r2.clone(),
        span,
    );
    // mu (1 − d1/c1 − d2/c2)^3
    let inner = binary(
        BinaryOp::Sub,
        binary(BinaryOp::Sub, number(1.0, span), r1, span),
        r2,
        span,
    );
    let cube = binary(BinaryOp::Pow, inner, number(3.0, span), span);
    let second = binary(BinaryOp::Mul, mu, cube, span);
    binary(BinaryOp::Sub, first, second, span)
}
