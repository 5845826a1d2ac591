//! Solids as CSG users write them (docs/language.md) → program expressions. The booleans become
//! `min`/`max` (creases the mesher finds, docs/creases.md), the smooth booleans the polynomial
//! smooth minimum (no crease), the primitives their distance formulas, and a transform an `At`
//! node: the surface evaluated at the inverse-transformed point. A transform of a patch (where a
//! patch is expected: `dist`, `offset`, `blend`) becomes a new patch whose points are
//! transformed. docs/language.md lists the formulas.

use std::collections::HashSet;

use glam::{DMat3, DVec3};

use crate::diag::messages;
use crate::span::Span;
use crate::syntax::ast;

use super::expr::{Ctx, Place, count_words};
use super::program::*;
use super::{Checker, Kind};

const TRANSFORMS: [&str; 3] = ["translate", "rotate", "scale"];

/// Rotation-matrix entries closer to 0 than this are 0, so that a quarter turn maps the axes
/// onto each other exactly (cos(π/2) is 6e-17 in f64, not 0).
const ROTATION_ZERO: f64 = 1e-15;

pub(crate) fn signature(name: &str) -> &'static str {
    match name {
        "union" => "union(S1, S2, …)",
        "intersection" => "intersection(S1, S2, …)",
        "difference" => "difference(S1, S2, …)",
        "smooth_union" => "smooth_union(S1, S2, r)",
        "smooth_intersection" => "smooth_intersection(S1, S2, r)",
        "smooth_difference" => "smooth_difference(S1, S2, r)",
        "translate" => "translate(S, (dx, dy, dz))",
        "rotate" => "rotate(S, axis: (ax, ay, az), angle: a)",
        "scale" => "scale(S, s) or scale(S, (sx, sy, sz))",
        "sphere" => "sphere(r)",
        "box" => "box((x0, y0, z0), (x1, y1, z1))",
        "cylinder" => "cylinder(r, h)",
        "torus" => "torus(R, r)",
        _ => "plane((nx, ny, nz), offset)",
    }
}

/// Builds expressions at one span, folding numbers as it goes (so that a transform with
/// constant arguments gives a small tape: zero coefficients vanish).
struct Build {
    span: Span,
}

fn as_number(e: &Expr) -> Option<f64> {
    match e.kind {
        ExprKind::Number(v) => Some(v),
        _ => None,
    }
}

impl Build {
    fn expr(&self, kind: ExprKind) -> Expr {
        Expr {
            kind,
            span: self.span,
        }
    }

    fn num(&self, v: f64) -> Expr {
        self.expr(ExprKind::Number(v))
    }

    fn coords(&self) -> [Expr; 3] {
        [Axis::X, Axis::Y, Axis::Z].map(|a| self.expr(ExprKind::Coord(a)))
    }

    fn bin(&self, op: BinaryOp, a: Expr, b: Expr) -> Expr {
        self.expr(ExprKind::Binary(op, Box::new(a), Box::new(b)))
    }

    fn add(&self, a: Expr, b: Expr) -> Expr {
        match (as_number(&a), as_number(&b)) {
            (Some(x), Some(y)) => self.num(x + y),
            (Some(0.0), None) => b,
            (None, Some(0.0)) => a,
            _ => self.bin(BinaryOp::Add, a, b),
        }
    }

    fn sub(&self, a: Expr, b: Expr) -> Expr {
        match (as_number(&a), as_number(&b)) {
            (Some(x), Some(y)) => self.num(x - y),
            (None, Some(0.0)) => a,
            (Some(0.0), None) => self.neg(b),
            _ => self.bin(BinaryOp::Sub, a, b),
        }
    }

    /// A product; a zero coefficient drops the term (sema only multiplies coordinates and
    /// values by numbers it made, where 0·inf does not arise).
    fn mul(&self, a: Expr, b: Expr) -> Expr {
        match (as_number(&a), as_number(&b)) {
            (Some(x), Some(y)) => self.num(x * y),
            (Some(x), _) | (_, Some(x)) if x == 0.0 => self.num(0.0),
            (Some(1.0), None) => b,
            (None, Some(1.0)) => a,
            (Some(-1.0), None) => self.neg(b),
            (None, Some(-1.0)) => self.neg(a),
            _ => self.bin(BinaryOp::Mul, a, b),
        }
    }

    fn div(&self, a: Expr, b: Expr) -> Expr {
        match (as_number(&a), as_number(&b)) {
            (Some(x), Some(y)) => self.num(x / y),
            (None, Some(1.0)) => a,
            _ => self.bin(BinaryOp::Div, a, b),
        }
    }

    fn neg(&self, a: Expr) -> Expr {
        match a.kind {
            ExprKind::Number(v) => self.num(-v),
            ExprKind::Unary(UnaryOp::Neg, inner) => *inner,
            kind => self.expr(ExprKind::Unary(
                UnaryOp::Neg,
                Box::new(Expr { kind, span: a.span }),
            )),
        }
    }

    fn call(&self, b: Builtin, args: Vec<Expr>) -> Expr {
        self.expr(ExprKind::Builtin(b, args))
    }

    fn min(&self, a: Expr, b: Expr) -> Expr {
        self.call(Builtin::Min, vec![a, b])
    }

    fn max(&self, a: Expr, b: Expr) -> Expr {
        self.call(Builtin::Max, vec![a, b])
    }

    /// m·p + t, row by row.
    fn affine(&self, m: &[[Expr; 3]; 3], p: &[Expr; 3], t: Option<&[Expr; 3]>) -> [Expr; 3] {
        std::array::from_fn(|i| {
            let row = (0..3).fold(self.num(0.0), |acc, j| {
                self.add(acc, self.mul(m[i][j].clone(), p[j].clone()))
            });
            match t {
                Some(t) => self.add(row, t[i].clone()),
                None => row,
            }
        })
    }

    /// The polynomial smooth minimum agreed with the crease finder (which must not take it
    /// for a sharp edge): h = clamp(0.5 + 0.5·(b − a)/r, 0, 1),
    /// smin = mix(b, a, h) − r·h·(1 − h) with mix(b, a, h) = b + (a − b)·h.
    fn smin(&self, a: Expr, b: Expr, r: Expr) -> Expr {
        let t = self.add(
            self.num(0.5),
            self.mul(
                self.num(0.5),
                self.div(self.sub(b.clone(), a.clone()), r.clone()),
            ),
        );
        let h = self.max(self.min(t, self.num(1.0)), self.num(0.0));
        let mix = self.add(b.clone(), self.mul(self.sub(a, b), h.clone()));
        let round = self.mul(self.mul(r, h.clone()), self.sub(self.num(1.0), h));
        self.sub(mix, round)
    }
}

/// Whether `def` is the smooth minimum the smooth booleans call: made by sema (no span of
/// its own), unlike a user's `fn smooth_union`, which has one. The compiler lifts the sharp
/// parts out of it (`compile::spine`).
pub fn is_smooth_min(def: &FnDef) -> bool {
    def.name == "smooth_union" && def.span == Span::default() && def.params.len() == 3
}

/// A transform with its arguments lowered (constants folded to numbers).
enum Transform {
    Translate([Expr; 3]),
    /// A unit axis and the angle (radians, right-handed).
    Rotate {
        axis: DVec3,
        angle: Expr,
    },
    Scale {
        factors: [Expr; 3],
        uniform: bool,
    },
}

impl Transform {
    /// The rotation matrix by `angle` (negated if `inverse`) about `axis` (Rodrigues):
    /// c·I + (1 − c)·k kᵀ + s·[k]×.
    fn rotation(b: &Build, axis: DVec3, angle: &Expr, inverse: bool) -> [[Expr; 3]; 3] {
        let k = axis.to_array();
        let cross = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
        let sign = if inverse { -1.0 } else { 1.0 };
        if let Some(a) = as_number(angle) {
            let (s, c) = (sign * a).sin_cos();
            return std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    let id = if i == j { c } else { 0.0 };
                    let v = id + (1.0 - c) * k[i] * k[j] + s * cross[i][j];
                    b.num(if v.abs() < ROTATION_ZERO { 0.0 } else { v })
                })
            });
        }
        let c = b.call(Builtin::Cos, vec![angle.clone()]);
        let s = b.mul(b.num(sign), b.call(Builtin::Sin, vec![angle.clone()]));
        std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let id = b.mul(b.num(if i == j { 1.0 } else { 0.0 }), c.clone());
                let outer = b.mul(b.sub(b.num(1.0), c.clone()), b.num(k[i] * k[j]));
                b.add(b.add(id, outer), b.mul(b.num(cross[i][j]), s.clone()))
            })
        })
    }

    /// Where the original is evaluated for the point p of the result (for a surface).
    fn inverse(&self, b: &Build, p: [Expr; 3]) -> [Expr; 3] {
        let each = |d: &[Expr; 3], op: fn(&Build, Expr, Expr) -> Expr| {
            std::array::from_fn(|i| op(b, p[i].clone(), d[i].clone()))
        };
        match self {
            Transform::Translate(d) => each(d, Build::sub),
            Transform::Rotate { axis, angle } => {
                b.affine(&Transform::rotation(b, *axis, angle, true), &p, None)
            }
            Transform::Scale { factors, .. } => each(factors, Build::div),
        }
    }

    /// The forward map p ↦ m·p + t when every argument is a number.
    fn numbers(&self) -> Option<(DMat3, DVec3)> {
        let vector = |v: &[Expr; 3]| -> Option<DVec3> {
            Some(DVec3::new(
                as_number(&v[0])?,
                as_number(&v[1])?,
                as_number(&v[2])?,
            ))
        };
        match self {
            Transform::Translate(d) => Some((DMat3::IDENTITY, vector(d)?)),
            Transform::Rotate { axis, angle } => Some((
                DMat3::from_axis_angle(*axis, as_number(angle)?),
                DVec3::ZERO,
            )),
            Transform::Scale { factors, .. } => {
                Some((DMat3::from_diagonal(vector(factors)?), DVec3::ZERO))
            }
        }
    }

    /// What a surface's value is multiplied by: a uniform scale s keeps a distance a distance
    /// (s·S(p/s)); a per-axis scale multiplies by the smallest factor, which keeps a
    /// 1-Lipschitz S 1-Lipschitz (a lower bound of the distance).
    fn value_factor(&self, b: &Build) -> Option<Expr> {
        match self {
            Transform::Scale { factors, uniform } => Some(if *uniform {
                factors[0].clone()
            } else {
                let [a, c, d] = factors.clone();
                match (as_number(&a), as_number(&c), as_number(&d)) {
                    (Some(a), Some(c), Some(d)) => b.num(a.min(c).min(d)),
                    _ => b.min(b.min(a, c), d),
                }
            }),
            _ => None,
        }
    }
}

impl Checker<'_> {
    /// A call of one of `SOLIDS` in an expression.
    pub(crate) fn lower_solid(
        &mut self,
        name: &str,
        args: &[ast::Arg],
        span: Span,
        cx: &mut Ctx<'_>,
    ) -> Expr {
        let placeholder = Build { span }.num(0.0);
        if !cx.place.has_coordinates() {
            let d = messages::surface_without_coordinates(
                span,
                &format!("{name}(…)"),
                cx.place.words(),
            );
            return self.fail(cx, d);
        }
        cx.used_coordinates = true;
        if name == "intersection" {
            if let Some(near) = args
                .iter()
                .filter_map(|a| a.name.as_ref())
                .find(|n| n.name == "near")
            {
                return self.fail(cx, messages::near_in_boolean(near.span));
            }
        }
        let lowered = match name {
            "union" | "intersection" | "difference" => self.boolean(name, args, span, cx),
            "smooth_union" | "smooth_intersection" | "smooth_difference" => {
                self.smooth_boolean(name, args, span, cx)
            }
            "translate" | "rotate" | "scale" => self.transformed(name, args, span, cx),
            _ => self.primitive(name, args, span, cx),
        };
        lowered.unwrap_or_else(|| {
            cx.failed = true;
            placeholder
        })
    }

    /// Checks that every argument is positional and that there are `expected` of them (or at
    /// least `-expected` if negative); reports otherwise.
    fn solid_arity(
        &mut self,
        name: &str,
        args: &[ast::Arg],
        span: Span,
        expected: i32,
        cx: &mut Ctx<'_>,
    ) -> Option<()> {
        let sig = signature(name);
        if !self.positional_only(name, sig, args, cx) {
            return None;
        }
        let ok = if expected < 0 {
            args.len() >= expected.unsigned_abs() as usize
        } else {
            args.len() == expected as usize
        };
        if !ok {
            let words = if expected < 0 {
                format!("at least {}", count_words(expected.unsigned_abs() as usize))
            } else {
                count_words(expected as usize)
            };
            self.diags
                .push(messages::wrong_arity(span, name, sig, &words, args.len()));
            return None;
        }
        Some(())
    }

    /// A lowered expression with a compile-time value replaced by that value.
    fn folded(&self, e: Expr) -> Expr {
        match self.known(&e) {
            Some(v) => Expr {
                kind: ExprKind::Number(v),
                span: e.span,
            },
            None => e,
        }
    }

    /// An expression lowered with its compile-time value folded in; None if lowering reported
    /// an error (`cx.failed` then stays set).
    fn lower_folded(&mut self, e: &ast::Expr, cx: &mut Ctx<'_>) -> Option<Expr> {
        let failed = std::mem::replace(&mut cx.failed, false);
        let v = self.lower(e, cx);
        let bad = cx.failed;
        cx.failed |= failed;
        (!bad).then(|| self.folded(v))
    }

    /// A constant vector made unit length; a zero one is reported (E0408).
    fn unit_vector(&mut self, e: &ast::Expr, name: &str, what: &str, noun: &str) -> Option<DVec3> {
        let v = self.point(e, what)?;
        let unit = v.try_normalize();
        if unit.is_none() {
            self.diags.push(messages::bad_solid_parameter(
                e.span,
                name,
                &format!("{noun} is zero"),
                signature(name),
            ));
        }
        unit
    }

    /// A size that must be positive where it is known at compile time.
    fn positive(
        &mut self,
        e: &ast::Expr,
        name: &str,
        what: &str,
        cx: &mut Ctx<'_>,
    ) -> Option<Expr> {
        let v = self.lower_folded(e, cx)?;
        if as_number(&v).is_some_and(|v| v <= 0.0) {
            self.diags.push(messages::bad_solid_parameter(
                e.span,
                name,
                &format!("{what} must be positive"),
                signature(name),
            ));
            return None;
        }
        Some(v)
    }

    /// A vector `(a, b, c)` of numbers (expressions of constants and parameters).
    fn vector(&mut self, e: &ast::Expr, cx: &mut Ctx<'_>) -> Option<[Expr; 3]> {
        match &e.kind {
            ast::ExprKind::Tuple(parts) if parts.len() == 3 => {
                let v: Vec<Option<Expr>> = parts.iter().map(|p| self.lower_folded(p, cx)).collect();
                let [a, b, c] = <[Option<Expr>; 3]>::try_from(v).ok()?;
                Some([a?, b?, c?])
            }
            ast::ExprKind::Tuple(parts) => {
                self.diags
                    .push(messages::wrong_point_arity(e.span, parts.len()));
                None
            }
            _ => {
                self.diags.push(messages::wrong_point_arity(e.span, 1));
                None
            }
        }
    }

    fn boolean(
        &mut self,
        name: &str,
        args: &[ast::Arg],
        span: Span,
        cx: &mut Ctx<'_>,
    ) -> Option<Expr> {
        self.solid_arity(name, args, span, -2, cx)?;
        let b = Build { span };
        let mut parts = args
            .iter()
            .map(|a| self.lower(&a.value, cx))
            .collect::<Vec<_>>();
        let first = parts.remove(0);
        Some(parts.into_iter().fold(first, |acc, e| match name {
            "union" => b.min(acc, e),
            "intersection" => b.max(acc, e),
            _ => b.max(acc, b.neg(e)),
        }))
    }

    fn smooth_boolean(
        &mut self,
        name: &str,
        args: &[ast::Arg],
        span: Span,
        cx: &mut Ctx<'_>,
    ) -> Option<Expr> {
        self.solid_arity(name, args, span, 3, cx)?;
        let s1 = self.lower(&args[0].value, cx);
        let s2 = self.lower(&args[1].value, cx);
        let r = self.positive(&args[2].value, name, "the rounding radius", cx)?;
        let b = Build { span };
        // A call, not the formula: the formula uses each operand several times, and nested
        // smooth booleans written out would grow exponentially; the compiler inlines the call
        // with each operand lowered once.
        let smin = self.smin_fn();
        let call = |a: Expr, c: Expr| b.expr(ExprKind::Call(smin, vec![a, c, r.clone()]));
        Some(match name {
            "smooth_union" => call(s1, s2),
            // smooth_intersection(a, b) = −smin(−a, −b)
            "smooth_intersection" => b.neg(call(b.neg(s1), b.neg(s2))),
            // smooth_difference(a, b) = smooth_intersection(a, −b) = −smin(−a, b)
            _ => b.neg(call(b.neg(s1), s2)),
        })
    }

    /// The function `smin(a, b, r)` of the smooth booleans, added to the program once
    /// (`is_smooth_min` tells it from a user's function of the same name).
    fn smin_fn(&mut self) -> FnId {
        if let Some(id) = self.smin {
            return id;
        }
        let b = Build {
            span: Span::default(),
        };
        let param = |k: u32| b.expr(ExprKind::Param(k));
        self.functions.push(Some(FnDef {
            name: "smooth_union".to_string(),
            span: Span::default(),
            params: ["a", "b", "r"].map(String::from).to_vec(),
            body: b.smin(param(0), param(1), param(2)),
            uses_coordinates: false,
        }));
        let id = FnId((self.functions.len() - 1) as u32);
        self.smin = Some(id);
        id
    }

    /// The target and the transform of a `translate`, `rotate` or `scale` call.
    fn transform_args<'a>(
        &mut self,
        name: &str,
        args: &'a [ast::Arg],
        span: Span,
        cx: &mut Ctx<'_>,
    ) -> Option<(&'a ast::Expr, Transform)> {
        let sig = signature(name);
        if name == "rotate" {
            let (pos, named, _) = self.curve_args(name, sig, args, span, 1, &["axis", "angle"])?;
            let axis = self.unit_vector(named[0], name, "the rotation axis", "the axis");
            let angle = self.lower_folded(named[1], cx)?;
            return Some((pos[0], Transform::Rotate { axis: axis?, angle }));
        }
        self.solid_arity(name, args, span, 2, cx)?;
        let arg = &args[1].value;
        let t = if name == "translate" {
            Transform::Translate(self.vector(arg, cx)?)
        } else if let ast::ExprKind::Tuple(_) = arg.kind {
            let factors = self.vector(arg, cx)?;
            if factors
                .iter()
                .any(|f| as_number(f).is_some_and(|v| v <= 0.0))
            {
                self.diags.push(messages::bad_solid_parameter(
                    arg.span,
                    name,
                    "scale factors must be positive",
                    sig,
                ));
                return None;
            }
            Transform::Scale {
                factors,
                uniform: false,
            }
        } else {
            let s = self.positive(arg, name, "the scale factor", cx)?;
            Transform::Scale {
                factors: [s.clone(), s.clone(), s],
                uniform: true,
            }
        };
        Some((&args[0].value, t))
    }

    /// A transformed surface: the target evaluated at the inverse-transformed point.
    fn transformed(
        &mut self,
        name: &str,
        args: &[ast::Arg],
        span: Span,
        cx: &mut Ctx<'_>,
    ) -> Option<Expr> {
        let (target, t) = self.transform_args(name, args, span, cx)?;
        let inner = self.lower(target, cx);
        if self.uses_dist(&inner, &mut HashSet::new(), 0) {
            self.diags
                .push(messages::dist_in_transform(target.span, name));
            return None;
        }
        let b = Build { span };
        let point = t.inverse(&b, b.coords());
        let at = b.expr(ExprKind::At(Box::new(inner), Box::new(point)));
        Some(match t.value_factor(&b) {
            Some(f) => b.mul(at, f),
            None => at,
        })
    }

    /// Whether an expression uses `dist`, directly or through a surface or function. Each
    /// surface and function is looked into once; past `MAX_WALK` levels the answer is no (the
    /// compiler refuses a `dist` inside a transform anyway, with its own error).
    fn uses_dist(&self, e: &Expr, seen: &mut HashSet<(bool, u32)>, depth: usize) -> bool {
        const MAX_WALK: usize = 1000;
        if depth > MAX_WALK {
            return false;
        }
        let rec = |x: &Expr, seen: &mut HashSet<(bool, u32)>| self.uses_dist(x, seen, depth + 1);
        match &e.kind {
            ExprKind::Dist(_) => true,
            ExprKind::Number(_) | ExprKind::Coord(_) | ExprKind::Param(_) | ExprKind::Const(_) => {
                false
            }
            ExprKind::Unary(_, a) => rec(a, seen),
            ExprKind::Binary(_, a, c) => rec(a, seen) || rec(c, seen),
            ExprKind::Builtin(_, xs) => xs.iter().any(|x| rec(x, seen)),
            ExprKind::Call(id, xs) => {
                xs.iter().any(|x| rec(x, seen))
                    || (seen.insert((false, id.0))
                        && self
                            .functions
                            .get(id.index())
                            .and_then(Option::as_ref)
                            .is_some_and(|f| rec(&f.body, seen)))
            }
            ExprKind::Surface(id) => {
                seen.insert((true, id.0))
                    && self
                        .surfaces
                        .get(id.index())
                        .and_then(Option::as_ref)
                        .is_some_and(|s| rec(&s.body, seen))
            }
            ExprKind::At(inner, p) => rec(inner, seen) || p.iter().any(|x| rec(x, seen)),
        }
    }

    /// `translate`, `rotate` or `scale` of a patch (possibly nested) where a patch may stand:
    /// a new patch whose points are transformed. None if `e` is not a transform of a patch.
    /// The transform's arguments are then constants (a patch body has no coordinates and
    /// no function parameters).
    pub(crate) fn transformed_patch(&mut self, e: &ast::Expr, cx: &mut Ctx<'_>) -> Option<PatchId> {
        let (base, m, t) = self.patch_chain(e, cx)?;
        let Some(def) = self.patches.get(base.index()).cloned().flatten() else {
            return Some(base);
        };
        if cx.failed {
            return Some(base);
        }
        // The transforms composed into one affine map, applied once: applied one by one,
        // each turn would copy the body three times.
        let b = Build { span: e.span };
        let num = |v: f64| b.num(if v.abs() < ROTATION_ZERO { 0.0 } else { v });
        let rows: [[Expr; 3]; 3] =
            std::array::from_fn(|i| std::array::from_fn(|j| num(m.col(j)[i])));
        let shift = t.to_array().map(num);
        let body = b.affine(&rows, &def.body, Some(&shift));
        self.patches.push(Some(PatchDef {
            name: format!("{}(…)", def.name),
            span: e.span,
            body,
            ..def
        }));
        Some(PatchId((self.patches.len() - 1) as u32))
    }

    /// A chain of transforms around a declared patch: the patch and the composed map
    /// p ↦ m·p + t. None if `e` is no such chain; a chain with a wrong argument sets
    /// `cx.failed` (the error is reported).
    fn patch_chain(&mut self, e: &ast::Expr, cx: &mut Ctx<'_>) -> Option<(PatchId, DMat3, DVec3)> {
        let ast::ExprKind::Call { callee, args } = &e.kind else {
            return None;
        };
        let name = callee.name.as_str();
        if !TRANSFORMS.contains(&name) || self.globals.contains_key(name) {
            return None;
        }
        let target = &args.first().filter(|a| a.name.is_none())?.value;
        let (base, m, t) = match &target.kind {
            ast::ExprKind::Name(n) if !cx.params.contains(&n.as_str()) => {
                let d = *self.globals.get(n.as_str())?;
                if self.decls[d].kind != Kind::Patch {
                    return None;
                }
                self.mark_used(d, cx);
                (PatchId(self.decls[d].id), DMat3::IDENTITY, DVec3::ZERO)
            }
            ast::ExprKind::Call { .. } => self.patch_chain(target, cx)?,
            _ => return None,
        };
        let mut constant = Ctx::new(Place::Number, &[], cx.owner);
        let numbers = self
            .transform_args(name, args, e.span, &mut constant)
            .filter(|_| !constant.failed)
            .map(|(_, transform)| transform.numbers());
        match numbers {
            Some(Some((m2, t2))) => Some((base, m2 * m, m2 * t + t2)),
            Some(None) => {
                self.diags.push(messages::bad_solid_parameter(
                    e.span,
                    name,
                    "a transform of a patch needs finite constant arguments",
                    signature(name),
                ));
                cx.failed = true;
                Some((base, m, t))
            }
            None => {
                cx.failed = true;
                Some((base, m, t))
            }
        }
    }

    fn primitive(
        &mut self,
        name: &str,
        args: &[ast::Arg],
        span: Span,
        cx: &mut Ctx<'_>,
    ) -> Option<Expr> {
        let arity = if name == "sphere" { 1 } else { 2 };
        self.solid_arity(name, args, span, arity, cx)?;
        let b = Build { span };
        let [x, y, z] = b.coords();
        let sq = |e: &Expr| b.mul(e.clone(), e.clone());
        let hypot = |a: Expr, c: Expr| b.call(Builtin::Hypot, vec![a, c]);
        Some(match name {
            "sphere" => {
                let r = self.positive(&args[0].value, name, "the radius", cx)?;
                let r2 = b.add(b.add(sq(&x), sq(&y)), sq(&z));
                b.sub(b.call(Builtin::Sqrt, vec![r2]), r)
            }
            "box" => {
                let lo = self.vector(&args[0].value, cx);
                let hi = self.vector(&args[1].value, cx)?;
                let lo = lo?;
                let inverted = (0..3).any(|k| match (as_number(&lo[k]), as_number(&hi[k])) {
                    (Some(l), Some(h)) => l >= h,
                    _ => false,
                });
                if inverted {
                    self.diags.push(messages::bad_solid_parameter(
                        args[0].value.span.join(args[1].value.span),
                        name,
                        "the first corner must be below the second on every axis",
                        signature(name),
                    ));
                    return None;
                }
                // The six face planes under max: the exact distance inside and across each
                // face, a lower bound outside near edges and corners; every edge is a crease
                // of `max` that the crease finder sees.
                let p = [x, y, z];
                let mut faces = (0..3).flat_map(|k| {
                    [
                        b.sub(lo[k].clone(), p[k].clone()),
                        b.sub(p[k].clone(), hi[k].clone()),
                    ]
                });
                let first = faces.next()?;
                faces.fold(first, |acc, f| b.max(acc, f))
            }
            "cylinder" => {
                let r = self.positive(&args[0].value, name, "the radius", cx);
                let h = self.positive(&args[1].value, name, "the height", cx)?;
                let r = r?;
                b.max(
                    b.sub(hypot(x, y), r),
                    b.sub(b.call(Builtin::Abs, vec![z]), b.mul(b.num(0.5), h)),
                )
            }
            "torus" => {
                let big = self.positive(&args[0].value, name, "the radius R", cx);
                let small = self.positive(&args[1].value, name, "the tube radius r", cx)?;
                let big = big?;
                if let (Some(rr), Some(r)) = (as_number(&big), as_number(&small)) {
                    if rr <= r {
                        self.diags.push(messages::bad_solid_parameter(
                            args[0].value.span.join(args[1].value.span),
                            name,
                            "the radius R must be larger than the tube radius r",
                            signature(name),
                        ));
                        return None;
                    }
                }
                b.sub(hypot(b.sub(hypot(x, y), big), z), small)
            }
            _ => {
                let n = self.unit_vector(
                    &args[0].value,
                    name,
                    "the normal of the plane",
                    "the normal",
                );
                let offset = self.lower_folded(&args[1].value, cx)?;
                let n = n?;
                let dot = b.add(
                    b.add(b.mul(b.num(n.x), x), b.mul(b.num(n.y), y)),
                    b.mul(b.num(n.z), z),
                );
                b.sub(dot, offset)
            }
        })
    }
}
