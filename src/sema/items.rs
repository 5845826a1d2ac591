//! Patches, curves and mesh blocks: their shapes, named arguments and options, the numbers
//! they need (evaluated here), and the cross-mesh check that meshes sharing a curve use the
//! same step.

use std::collections::BTreeMap;

use glam::DVec3;

use crate::diag::messages::{self, FoundInsteadOfCurve};
use crate::diag::{Diagnostic, suggest};
use crate::span::Span;
use crate::syntax::ast;

use super::expr::{Ctx, Place};
use super::program::*;
use super::{CURVE_CONSTRUCTORS, Checker, Kind};

/// 2^64: the first whole number a `u64` cannot hold.
const TWO_TO_64: f64 = 18_446_744_073_709_551_616.0;

/// A box must be at least this fraction of the step wide along every axis.
pub(crate) const MIN_BOX_WIDTH: f64 = 1e-6;

/// What is wrong with a box from `l` to `h` for a mesh of `step` (if it is known): an empty or
/// inverted axis, or one thinner than `MIN_BOX_WIDTH` steps (a box one ulp wide included).
fn box_error(span: Span, l: DVec3, h: DVec3, step: Option<f64>) -> Option<Diagnostic> {
    let axis = |k: usize| ["x", "y", "z"][k];
    if let Some(k) = (0..3).find(|&k| l[k] >= h[k]) {
        return Some(messages::bad_box(span, axis(k), l[k], h[k]));
    }
    let min = MIN_BOX_WIDTH * step?;
    (0..3)
        .find(|&k| h[k] - l[k] < min)
        .map(|k| messages::thin_box(span, axis(k), h[k] - l[k], min))
}

const MESH_OPTIONS: [&str; 9] = [
    "step",
    "start",
    "box",
    "front",
    "bounds",
    "max_triangles",
    "tolerance",
    "uniform",
    "radius_ratio",
];

const INTERSECTION_SIG: &str = "intersection(S1, S2, near: (x, y, z))";
const CIRCLE_SIG: &str = "circle(center: (x, y, z), normal: (x, y, z), radius: r[, segments: n])";

/// The most segments a circle's `segments:` may ask for.
const MAX_CIRCLE_SEGMENTS: f64 = 1_000_000.0;

/// A curve constructor's arguments: positional ones, required named ones (in the order
/// asked for), optional named ones (`None` where not given).
type CurveArgs<'a> = (
    Vec<&'a ast::Expr>,
    Vec<&'a ast::Expr>,
    Vec<Option<&'a ast::Expr>>,
);
const BOUNDARY_SIG: &str = "boundary(P)";
const REVERSE_SIG: &str = "reverse(C)";

impl<'f> Checker<'f> {
    pub(crate) fn lower_patch(
        &mut self,
        name: &ast::Ident,
        item_span: Span,
        params: &[ast::PatchParam],
        body: &ast::Expr,
        d: usize,
    ) -> PatchDef {
        self.check_params(params.iter().map(|p| &p.name).collect());
        if params.len() != 2 {
            let span = super::eval::cover(params.iter().map(|p| p.span)).unwrap_or(item_span);
            self.diags
                .push(messages::patch_param_count(span, params.len()));
        }
        let mut ranges = [(0.0, 1.0); 2];
        for (k, p) in params.iter().enumerate().take(2) {
            let what = format!("the range of `{}`", p.name.name);
            let lo = self.number(&p.lo, &what);
            let hi = self.number(&p.hi, &what);
            if let (Some(lo), Some(hi)) = (lo, hi) {
                if lo >= hi {
                    self.diags.push(messages::inverted_range(
                        p.lo.span.join(p.hi.span),
                        &p.name.name,
                        lo,
                        hi,
                    ));
                } else {
                    ranges[k] = (lo, hi);
                }
            }
        }
        let names: Vec<&str> = params.iter().map(|p| p.name.name.as_str()).collect();
        let placeholder = || Expr {
            kind: ExprKind::Number(0.0),
            span: body.span,
        };
        let mut out = [placeholder(), placeholder(), placeholder()];
        match &body.kind {
            ast::ExprKind::Tuple(parts) if parts.len() == 3 => {
                let mut cx = Ctx::new(Place::PatchBody, &names, Some(d));
                for (k, p) in parts.iter().enumerate() {
                    out[k] = self.lower(p, &mut cx);
                }
            }
            ast::ExprKind::Tuple(parts) => {
                self.diags.push(messages::patch_body_not_triple(
                    body.span,
                    Some(parts.len()),
                ));
            }
            _ => {
                self.diags
                    .push(messages::patch_body_not_triple(body.span, None));
            }
        }
        let param = |k: usize| names.get(k).map_or(String::new(), |n| n.to_string());
        PatchDef {
            name: name.name.clone(),
            span: name.span,
            params: [param(0), param(1)],
            u_range: ranges[0],
            v_range: ranges[1],
            body: out,
        }
    }

    /// The curve a `curve` definition (declaration `d`) describes. A broken curve becomes a
    /// placeholder circle (the program is refused anyway).
    pub(crate) fn lower_curve(&mut self, e: &ast::Expr, d: usize) -> CurveKind {
        self.curve_kind(e, Some(d), "curve")
            .unwrap_or(CurveKind::Circle {
                center: DVec3::ZERO,
                normal: DVec3::Z,
                radius: 1.0,
                segments: None,
            })
    }

    fn not_a_curve(&mut self, e: &ast::Expr) {
        match &e.kind {
            ast::ExprKind::Call { callee, .. }
                if super::SOLIDS.contains(&callee.name.as_str())
                    && !self.globals.contains_key(callee.name.as_str()) =>
            {
                self.diags
                    .push(messages::solid_in_curve(e.span, &callee.name));
            }
            ast::ExprKind::Name(n)
            | ast::ExprKind::Call {
                callee: ast::Ident { name: n, .. },
                ..
            } if self.globals.contains_key(n.as_str()) => {
                let d = self.globals[n.as_str()];
                let kind = self.decls[d].kind;
                self.decls[d].used = true;
                let what = match kind {
                    Kind::Surface => FoundInsteadOfCurve::Surface,
                    Kind::Patch => FoundInsteadOfCurve::Patch,
                    _ => FoundInsteadOfCurve::Other,
                };
                self.diags.push(messages::expected_curve(
                    e.span,
                    Some(n),
                    kind.article(),
                    what,
                ));
            }
            _ => self.diags.push(messages::expected_curve(
                e.span,
                None,
                "",
                FoundInsteadOfCurve::Other,
            )),
        }
    }

    /// Checks named and positional arguments against a curve constructor's signature.
    /// Returns the positional values and the named ones (in signature order), or None.
    pub(crate) fn curve_args<'a>(
        &mut self,
        callee: &str,
        sig: &str,
        args: &'a [ast::Arg],
        call_span: Span,
        positional: usize,
        names: &[&str],
    ) -> Option<CurveArgs<'a>> {
        let mut ok = true;
        let mut pos = Vec::new();
        // Optional names end in `?` and come after the required ones.
        let named: Vec<&str> = names
            .iter()
            .copied()
            .filter(|n| !n.ends_with('?'))
            .collect();
        let all: Vec<&str> = names.iter().map(|n| n.trim_end_matches('?')).collect();
        let mut found: Vec<Option<(&ast::Ident, &ast::Expr)>> = vec![None; all.len()];
        for a in args {
            match &a.name {
                None => {
                    if all.is_empty() || pos.len() < positional {
                        pos.push(&a.value);
                    } else {
                        self.diags.push(messages::positional_where_named(
                            a.value.span,
                            callee,
                            positional,
                            sig,
                        ));
                        ok = false;
                    }
                }
                Some(n) => match all.iter().position(|k| *k == n.name) {
                    Some(k) => {
                        if let Some((first, _)) = found[k] {
                            self.diags.push(messages::duplicate_named_argument(
                                &n.name, first.span, n.span,
                            ));
                            ok = false;
                        } else {
                            found[k] = Some((n, &a.value));
                        }
                    }
                    None => {
                        self.diags.push(messages::unexpected_named_argument(
                            n.span, callee, &n.name, sig,
                        ));
                        ok = false;
                    }
                },
            }
        }
        if pos.len() != positional {
            let expected = format!(
                "{positional} positional argument{}",
                if positional == 1 { "" } else { "s" }
            );
            self.diags.push(messages::wrong_arity(
                call_span,
                callee,
                sig,
                &expected,
                pos.len(),
            ));
            ok = false;
        }
        let mut values = Vec::new();
        let optional_values = found[named.len()..]
            .iter()
            .map(|f| f.map(|(_, v)| v))
            .collect();
        for (k, f) in found[..named.len()].iter().enumerate() {
            match f {
                Some((_, v)) => values.push(*v),
                None => {
                    self.diags.push(messages::missing_named_argument(
                        call_span, callee, named[k], sig,
                    ));
                    ok = false;
                }
            }
        }
        ok.then_some((pos, values, optional_values))
    }

    /// A curve constructor call → its kind. `owner` is the curve declaration, if any.
    fn curve_kind(
        &mut self,
        e: &ast::Expr,
        owner: Option<usize>,
        label: &str,
    ) -> Option<CurveKind> {
        let ast::ExprKind::Call { callee, args } = &e.kind else {
            self.not_a_curve(e);
            return None;
        };
        if !CURVE_CONSTRUCTORS.contains(&callee.name.as_str()) {
            self.not_a_curve(e);
            return None;
        }
        let span = e.span;
        match callee.name.as_str() {
            "intersection" => {
                let (pos, named, _) =
                    self.curve_args("intersection", INTERSECTION_SIG, args, span, 2, &["near"])?;
                let mut cx = Ctx::new(Place::Surface, &[], owner);
                let first = self.lower_surface_ref(pos[0], &mut cx);
                let second = self.lower_surface_ref(pos[1], &mut cx);
                let near = self.point(named[0], "the point `near`");
                if cx.failed {
                    return None;
                }
                Some(CurveKind::Intersection {
                    first,
                    second,
                    near: near?,
                })
            }
            "circle" => {
                let (_, named, optional) = self.curve_args(
                    "circle",
                    CIRCLE_SIG,
                    args,
                    span,
                    0,
                    &["center", "normal", "radius", "segments?"],
                )?;
                let center = self.point(named[0], "the circle's center");
                let normal = self.point(named[1], "the circle's normal");
                let radius = self.number(named[2], "the circle's radius");
                if let Some(n) = normal {
                    if n.length_squared() == 0.0 {
                        self.diags.push(messages::bad_circle(
                            named[1].span,
                            "the normal is the zero vector",
                        ));
                        return None;
                    }
                }
                if let Some(r) = radius {
                    if r <= 0.0 {
                        self.diags.push(messages::bad_circle(
                            named[2].span,
                            &format!("the radius must be positive, it is {r}"),
                        ));
                        return None;
                    }
                }
                let segments = match optional[0] {
                    None => None,
                    Some(e) => {
                        let n = self.number(e, "the circle's number of segments")?;
                        if !((3.0..=MAX_CIRCLE_SEGMENTS).contains(&n) && n.fract() == 0.0) {
                            self.diags.push(messages::bad_circle(
                                e.span,
                                &format!(
                                    "`segments` must be a whole number from 3 to {MAX_CIRCLE_SEGMENTS}, it is {n}"
                                ),
                            ));
                            return None;
                        }
                        Some(n as u32)
                    }
                };
                Some(CurveKind::Circle {
                    center: center?,
                    normal: normal?,
                    radius: radius?,
                    segments,
                })
            }
            "boundary" => {
                let (pos, _, _) = self.curve_args("boundary", BOUNDARY_SIG, args, span, 1, &[])?;
                let p = pos[0];
                if let ast::ExprKind::Name(n) = &p.kind {
                    if let Some(&d) = self.globals.get(n.as_str()) {
                        if owner != Some(d) {
                            self.decls[d].used = true;
                        }
                        if self.decls[d].kind == Kind::Patch {
                            return Some(CurveKind::Boundary(PatchId(self.decls[d].id)));
                        }
                        let kind = self.decls[d].kind;
                        self.diags
                            .push(messages::expected_patch(p.span, Some((n, kind.article()))));
                        return None;
                    }
                    let names: Vec<&str> = self
                        .globals
                        .iter()
                        .filter(|(_, d)| self.decls[**d].kind == Kind::Patch)
                        .map(|(k, _)| *k)
                        .collect();
                    let s = suggest::nearest(n, names).map(str::to_string);
                    self.diags
                        .push(messages::unknown_name(p.span, n, s.as_deref()));
                    return None;
                }
                // A moved, turned or scaled patch: the boundary of the transformed patch.
                let mut cx = Ctx::new(Place::Number, &[], owner);
                if let Some(id) = self.transformed_patch(p, &mut cx) {
                    return (!cx.failed).then_some(CurveKind::Boundary(id));
                }
                self.diags.push(messages::expected_patch(p.span, None));
                None
            }
            _ => {
                let (pos, _, _) = self.curve_args("reverse", REVERSE_SIG, args, span, 1, &[])?;
                let c = self.curve_ref(pos[0], owner, &format!("{label}.reversed"))?;
                Some(CurveKind::Reverse(c))
            }
        }
    }

    /// Where a curve is expected: a curve's name, or a constructor call (which becomes an
    /// anonymous curve named `label`).
    fn curve_ref(&mut self, e: &ast::Expr, owner: Option<usize>, label: &str) -> Option<CurveId> {
        if let ast::ExprKind::Name(n) = &e.kind {
            match self.globals.get(n.as_str()) {
                Some(&d) if self.decls[d].kind == Kind::Curve => {
                    if owner != Some(d) {
                        self.decls[d].used = true;
                    }
                    return Some(CurveId(self.decls[d].id));
                }
                Some(_) => {
                    self.not_a_curve(e);
                    return None;
                }
                None => {
                    let names: Vec<&str> = self
                        .globals
                        .iter()
                        .filter(|(_, d)| self.decls[**d].kind == Kind::Curve)
                        .map(|(k, _)| *k)
                        .collect();
                    let s = suggest::nearest(n, names).map(str::to_string);
                    self.diags
                        .push(messages::unknown_name(e.span, n, s.as_deref()));
                    return None;
                }
            }
        }
        let kind = self.curve_kind(e, owner, label)?;
        self.curves.push(Some(CurveDef {
            name: label.to_string(),
            span: e.span,
            kind,
        }));
        Some(CurveId((self.curves.len() - 1) as u32))
    }

    pub(crate) fn check_meshes(&mut self) {
        let mut names: BTreeMap<&str, Span> = BTreeMap::new();
        // Base curve → (mesh, step, span of the use) of its first user.
        let mut curve_users: BTreeMap<u32, (String, f64, Span)> = BTreeMap::new();
        let items = self.file.items.iter();
        for item in items {
            let ast::ItemKind::Mesh {
                name,
                surface,
                options,
                ..
            } = &item.kind
            else {
                continue;
            };
            if let Some(&first) = names.get(name.name.as_str()) {
                self.diags.push(messages::duplicate_definition(
                    "mesh", &name.name, first, name.span,
                ));
            } else {
                names.insert(&name.name, name.span);
            }
            let Some(mesh) = self.lower_mesh(name, surface, options) else {
                continue;
            };
            let mut uses: Vec<(CurveId, Span)> = Vec::new();
            let option_span = |key: &str| {
                options
                    .iter()
                    .find(|o| o.name.name == key)
                    .map_or(name.span, |o| o.span)
            };
            if let Some(f) = mesh.front {
                uses.push((f, option_span("front")));
            }
            for &b in &mesh.bounds {
                uses.push((b, option_span("bounds")));
            }
            for (c, span) in uses {
                let base = self.base_curve(c);
                match curve_users.get(&base.0) {
                    Some((other, step, first_span)) => {
                        if *step != mesh.step && *other != mesh.name {
                            let curve = self.curves[base.index()]
                                .as_ref()
                                .map_or(String::new(), |c| c.name.clone());
                            self.diags.push(messages::shared_curve_steps(
                                &curve,
                                (other, *step, *first_span),
                                (&mesh.name, mesh.step, span),
                            ));
                        }
                    }
                    None => {
                        curve_users.insert(base.0, (mesh.name.clone(), mesh.step, span));
                    }
                }
            }
            self.meshes.push(mesh);
        }
    }

    /// The curve whose polygon `c` uses (through `reverse`).
    fn base_curve(&self, mut c: CurveId) -> CurveId {
        // Bounded: a chain of reverses is at most as long as the curve list (no cycles).
        for _ in 0..=self.curves.len() {
            match self.curves.get(c.index()).and_then(Option::as_ref) {
                Some(CurveDef {
                    kind: CurveKind::Reverse(inner),
                    ..
                }) => c = *inner,
                _ => break,
            }
        }
        c
    }

    fn single_value<'o>(
        &mut self,
        o: &'o ast::MeshOption,
        expected: &str,
    ) -> Option<&'o ast::Expr> {
        match o.values.as_slice() {
            [ast::OptionValue::Expr(e)] => Some(e),
            _ => {
                let span = super::eval::cover(o.values.iter().map(ast::OptionValue::span))
                    .unwrap_or(o.span);
                self.diags
                    .push(messages::option_shape(span, &o.name.name, expected));
                None
            }
        }
    }

    fn lower_mesh(
        &mut self,
        name: &ast::Ident,
        surface: &ast::Expr,
        options: &[ast::MeshOption],
    ) -> Option<MeshDef> {
        let mut ok = true;
        let mut cx = Ctx::new(Place::Surface, &[], None);
        let surface_ref = self.lower_surface_ref(surface, &mut cx);
        if let SurfaceRef::Patch(p) = &surface_ref {
            let pname = self.patches[p.index()]
                .as_ref()
                .map_or_else(|| "P".to_string(), |p| p.name.clone());
            let pname = if pname.is_empty() {
                "P".to_string()
            } else {
                pname
            };
            self.diags
                .push(messages::patch_meshed(surface.span, &pname));
            ok = false;
        }
        ok &= !cx.failed;
        let mut seen: BTreeMap<&str, &ast::MeshOption> = BTreeMap::new();
        let mut unknown_options = false;
        for o in options {
            let key = o.name.name.as_str();
            if !MESH_OPTIONS.contains(&key) {
                unknown_options = true;
                let s = suggest::nearest(key, MESH_OPTIONS).map(str::to_string);
                self.diags.push(messages::unknown_mesh_option(
                    o.name.span,
                    key,
                    s.as_deref(),
                ));
                ok = false;
                continue;
            }
            if let Some(first) = seen.get(key) {
                self.diags.push(messages::duplicate_mesh_option(
                    key,
                    first.name.span,
                    o.name.span,
                ));
                ok = false;
                continue;
            }
            seen.insert(key, o);
        }
        let mut step = None;
        match seen.get("step") {
            None => {
                self.diags
                    .push(messages::missing_step(name.span, &name.name));
                ok = false;
            }
            Some(o) => {
                if let Some(e) = self.single_value(o, "a positive number") {
                    match self.number(e, "the step") {
                        Some(v) if v > 0.0 => step = Some(v),
                        Some(v) => {
                            self.diags.push(messages::non_positive_step(e.span, v));
                            ok = false;
                        }
                        None => ok = false,
                    }
                } else {
                    ok = false;
                }
            }
        }
        let mut start = None;
        if let Some(o) = seen.get("start") {
            match self.single_value(o, "a point `(x, y, z)`") {
                Some(e) => {
                    start = self.point(e, "the start point");
                    ok &= start.is_some();
                }
                None => ok = false,
            }
        }
        let mut bbox = None;
        if let Some(o) = seen.get("box") {
            match o.values.as_slice() {
                [ast::OptionValue::Range(lo, hi, span)] => {
                    let l = self.point(lo, "the box's corner");
                    let h = self.point(hi, "the box's corner");
                    match (l, h) {
                        (Some(l), Some(h)) => match box_error(*span, l, h, step) {
                            Some(d) => {
                                self.diags.push(d);
                                ok = false;
                            }
                            None => bbox = Some((l, h)),
                        },
                        _ => ok = false,
                    }
                }
                _ => {
                    let span = super::eval::cover(o.values.iter().map(ast::OptionValue::span))
                        .unwrap_or(o.span);
                    self.diags.push(messages::option_shape(
                        span,
                        "box",
                        "two corners `(xmin, ymin, zmin) .. (xmax, ymax, zmax)`",
                    ));
                    ok = false;
                }
            }
        }
        let mut front = None;
        if let Some(o) = seen.get("front") {
            match self.single_value(o, "one curve") {
                Some(e) => {
                    front = self.curve_ref(e, None, &format!("{}.front", name.name));
                    ok &= front.is_some();
                }
                None => ok = false,
            }
        }
        let mut bounds = Vec::new();
        if let Some(o) = seen.get("bounds") {
            for (k, v) in o.values.iter().enumerate() {
                match v {
                    ast::OptionValue::Expr(e) => {
                        match self.curve_ref(e, None, &format!("{}.bounds[{k}]", name.name)) {
                            Some(c) => bounds.push(c),
                            None => ok = false,
                        }
                    }
                    ast::OptionValue::Range(_, _, span) => {
                        self.diags.push(messages::option_shape(
                            *span,
                            "bounds",
                            "curves separated by `,`",
                        ));
                        ok = false;
                    }
                }
            }
        }
        let mut max_triangles = None;
        if let Some(o) = seen.get("max_triangles") {
            match self.single_value(o, "a positive whole number") {
                Some(e) => match self.number(e, "`max_triangles`") {
                    // 2^64 itself is `u64::MAX as f64`: the bound is strict.
                    Some(v) if v >= 1.0 && v.fract() == 0.0 && v < TWO_TO_64 => {
                        max_triangles = Some(v as u64);
                    }
                    Some(v) => {
                        self.diags.push(messages::bad_max_triangles(e.span, v));
                        ok = false;
                    }
                    None => ok = false,
                },
                None => ok = false,
            }
        }
        let mut tolerance = None;
        if let Some(o) = seen.get("tolerance") {
            match self.single_value(o, "a positive number") {
                Some(e) => match self.number(e, "the tolerance") {
                    Some(v) if v > 0.0 && v.is_finite() => tolerance = Some(v),
                    Some(v) => {
                        self.diags.push(messages::bad_tolerance(e.span, v));
                        ok = false;
                    }
                    None => ok = false,
                },
                None => ok = false,
            }
        }
        let mut radius_ratio = None;
        if let Some(o) = seen.get("radius_ratio") {
            match self.single_value(o, "a number in (0, 1]") {
                Some(e) => match self.number(e, "the radius ratio") {
                    Some(v) if v > 0.0 && v <= 1.0 => radius_ratio = Some(v),
                    Some(v) => {
                        self.diags.push(messages::bad_radius_ratio(e.span, v));
                        ok = false;
                    }
                    None => ok = false,
                },
                None => ok = false,
            }
        }
        let mut uniform = false;
        if let Some(o) = seen.get("uniform") {
            match self.single_value(o, "`true` or `false`") {
                Some(e) => match &e.kind {
                    ast::ExprKind::Name(n) if n == "true" || n == "false" => uniform = n == "true",
                    _ => {
                        self.diags.push(messages::bad_uniform(e.span));
                        ok = false;
                    }
                },
                None => ok = false,
            }
        }
        // With a box alone every component inside is meshed (docs/language.md). A misspelt
        // `start`, `front` or `box` is already reported as an unknown option.
        let begins = ["start", "front", "box"]
            .iter()
            .any(|k| seen.contains_key(k));
        if !begins && !unknown_options {
            self.diags.push(messages::no_start(name.span, &name.name));
        }
        ok &= begins;
        if let (Some(s), Some(f)) = (seen.get("start"), seen.get("front")) {
            self.diags.push(messages::start_ignored(s.span, f.span));
        }
        let step = step?;
        ok.then(|| MeshDef {
            name: name.name.clone(),
            span: name.span,
            surface: surface_ref,
            step,
            start,
            bbox,
            front,
            bounds,
            max_triangles,
            tolerance,
            uniform,
            radius_ratio,
        })
    }
}
