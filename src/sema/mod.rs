//! Semantic analysis: AST → checked `Program`. Declares every name (duplicates and built-in
//! names are reported), orders the definitions by their dependencies (cycles are reported
//! with the whole cycle), then lowers each definition in dependency order: names become typed
//! ids, `offset`/`product`/`blend` become arithmetic over `Dist`, constants and every number
//! a mesh or curve needs are evaluated, and each check of the language runs. Every diagnostic
//! of the file is collected; a `Program` is returned even when there are errors (with
//! placeholders where a definition was broken), and callers refuse it if any is an error.

mod eval;
mod expr;
mod graph;
mod items;
pub mod program;
pub(crate) mod solids;
#[cfg(test)]
mod tests;

use std::collections::BTreeMap;

use crate::diag::{Diagnostic, messages};
use crate::span::Span;
use crate::syntax::ast;

use program::*;

/// Checks a parsed file; see the module doc.
pub fn check(file: &ast::File) -> (Program, Vec<Diagnostic>) {
    check_with(file, &Options::default())
}

/// What the command line adds to a file: `-D NAME=VALUE` overrides and the extent of the
/// root file among imported ones.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// Constants set from the command line (each name once), replacing their definitions.
    pub defines: Vec<(String, f64)>,
    /// Items whose span starts at or past this offset come from imported files: they are a
    /// library, and are not reported as unused. `None`: every item is the file's own.
    pub imported_from: Option<u32>,
}

/// [`check`] with command-line overrides and imported items.
pub fn check_with(file: &ast::File, options: &Options) -> (Program, Vec<Diagnostic>) {
    let mut c = Checker::new(file);
    c.declare();
    c.apply_defines(options);
    let order = c.order();
    for d in order {
        c.lower_decl(d);
    }
    c.check_meshes();
    c.warn_unused(options.imported_from);
    c.finish()
}

/// The kinds of global names (meshes have a namespace of their own).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    Const,
    Fn,
    Surface,
    Patch,
    Curve,
}

impl Kind {
    /// "a constant", "a function", … for messages.
    pub(crate) fn article(self) -> &'static str {
        match self {
            Kind::Const => "a constant",
            Kind::Fn => "a function",
            Kind::Surface => "a surface",
            Kind::Patch => "a patch",
            Kind::Curve => "a curve",
        }
    }

    fn word(self) -> &'static str {
        match self {
            Kind::Const => "constant",
            Kind::Fn => "function",
            Kind::Surface => "surface",
            Kind::Patch => "patch",
            Kind::Curve => "curve",
        }
    }
}

/// One declared global name.
pub(crate) struct Decl<'f> {
    pub kind: Kind,
    /// Index among the declarations of its kind (the typed id).
    pub id: u32,
    pub name: &'f ast::Ident,
    pub item: &'f ast::Item,
    /// Part of a cycle, or depends on one: lowered without the facts its dependencies give.
    pub broken: bool,
    pub used: bool,
}

/// Coordinates and combinator names that are not definitions but are taken by the language.
pub(crate) const COORDINATES: [&str; 3] = ["x", "y", "z"];
pub(crate) const COMBINATORS: [&str; 4] = ["dist", "offset", "product", "blend"];
pub(crate) const CURVE_CONSTRUCTORS: [&str; 4] = ["intersection", "circle", "boundary", "reverse"];
/// The solid constructors, in the order docs/language.md lists them.
pub(crate) const SOLIDS: [&str; 14] = [
    "union",
    "intersection",
    "difference",
    "smooth_union",
    "smooth_intersection",
    "smooth_difference",
    "translate",
    "rotate",
    "scale",
    "sphere",
    "box",
    "cylinder",
    "torus",
    "plane",
];

fn reserved(name: &str) -> Option<&'static str> {
    if COORDINATES.contains(&name) {
        Some("a coordinate")
    } else if name == "pi" || name == "tau" {
        Some("a built-in constant")
    } else if Builtin::from_name(name).is_some() {
        Some("a built-in function")
    } else if COMBINATORS.contains(&name) {
        Some("a built-in combinator")
    } else if CURVE_CONSTRUCTORS.contains(&name) {
        Some("a built-in curve constructor")
    } else {
        None
    }
}

pub(crate) struct Checker<'f> {
    pub file: &'f ast::File,
    pub decls: Vec<Decl<'f>>,
    pub globals: BTreeMap<&'f str, usize>,
    pub diags: Vec<Diagnostic>,
    pub constants: Vec<Option<ConstDef>>,
    pub functions: Vec<Option<FnDef>>,
    pub surfaces: Vec<Option<SurfaceDef>>,
    pub patches: Vec<Option<PatchDef>>,
    pub curves: Vec<Option<CurveDef>>,
    pub meshes: Vec<MeshDef>,
    /// Per declaration: the decl index for each kind's id, to find a decl from an id.
    pub by_kind: BTreeMap<(u8, u32), usize>,
    /// Constant values set with `-D`, by declaration index.
    pub defines: BTreeMap<usize, f64>,
    /// The built-in function the smooth booleans call (made at the first one).
    pub smin: Option<FnId>,
}

impl<'f> Checker<'f> {
    fn new(file: &'f ast::File) -> Checker<'f> {
        Checker {
            file,
            decls: Vec::new(),
            globals: BTreeMap::new(),
            diags: Vec::new(),
            constants: Vec::new(),
            functions: Vec::new(),
            surfaces: Vec::new(),
            patches: Vec::new(),
            curves: Vec::new(),
            meshes: Vec::new(),
            by_kind: BTreeMap::new(),
            defines: BTreeMap::new(),
            smin: None,
        }
    }

    /// Registers every global name; reports duplicates and built-in names.
    fn declare(&mut self) {
        for item in &self.file.items {
            let kind = match &item.kind {
                ast::ItemKind::Const { .. } => Kind::Const,
                ast::ItemKind::Fn { .. } => Kind::Fn,
                ast::ItemKind::Surface { .. } => Kind::Surface,
                ast::ItemKind::Patch { .. } => Kind::Patch,
                ast::ItemKind::Curve { .. } => Kind::Curve,
                ast::ItemKind::Mesh { .. } | ast::ItemKind::Import { .. } => continue,
            };
            let name = item.kind.name();
            if let Some(what) = reserved(&name.name) {
                self.diags
                    .push(messages::reserved_name(name.span, &name.name, what));
                continue;
            }
            if let Some(&first) = self.globals.get(name.name.as_str()) {
                let first = self.decls[first].name.span;
                self.diags.push(messages::duplicate_definition(
                    kind.word(),
                    &name.name,
                    first,
                    name.span,
                ));
                continue;
            }
            let id = match kind {
                Kind::Const => push_slot(&mut self.constants),
                Kind::Fn => push_slot(&mut self.functions),
                Kind::Surface => push_slot(&mut self.surfaces),
                Kind::Patch => push_slot(&mut self.patches),
                Kind::Curve => push_slot(&mut self.curves),
            };
            self.by_kind.insert((kind as u8, id), self.decls.len());
            self.globals.insert(&name.name, self.decls.len());
            self.decls.push(Decl {
                kind,
                id,
                name,
                item,
                broken: false,
                used: false,
            });
        }
    }

    /// The declaration order in which every definition comes after what it uses; reports
    /// cycles and marks the declarations in or behind them as broken.
    fn order(&mut self) -> Vec<usize> {
        let deps: Vec<Vec<(usize, Span)>> = (0..self.decls.len())
            .map(|d| graph::dependencies(self, d))
            .collect();
        let (order, cycles, broken) = graph::order(&deps);
        for cycle in cycles {
            let described: Vec<(String, Span, Span)> = cycle
                .iter()
                .map(|&(d, use_span)| {
                    (
                        self.decls[d].name.name.clone(),
                        self.decls[d].name.span,
                        use_span,
                    )
                })
                .collect();
            self.diags.push(messages::recursive_definition(&described));
        }
        for d in broken {
            self.decls[d].broken = true;
        }
        order
    }

    /// Binds each `-D NAME=VALUE` to its constant; a name that is no constant is an error
    /// that lists the constants there are.
    fn apply_defines(&mut self, options: &Options) {
        for (name, value) in &options.defines {
            match self.globals.get(name.as_str()) {
                Some(&d) if self.decls[d].kind == Kind::Const => {
                    self.defines.insert(d, *value);
                }
                found => {
                    let constants: Vec<&str> = self
                        .decls
                        .iter()
                        .filter(|d| d.kind == Kind::Const)
                        .map(|d| d.name.name.as_str())
                        .collect();
                    let kind = found.map(|&d| self.decls[d].kind.article());
                    self.diags
                        .push(messages::unknown_define(name, kind, &constants));
                }
            }
        }
    }

    fn lower_decl(&mut self, d: usize) {
        let item = self.decls[d].item;
        let id = self.decls[d].id;
        let name = self.decls[d].name;
        match &item.kind {
            ast::ItemKind::Const { value, .. } => {
                // A `-D` value replaces the definition, which is still checked.
                let v = self.const_value(value, d);
                let v = match self.defines.get(&d) {
                    Some(&defined) => Some(defined),
                    None => v,
                };
                // Without a value, its users stay silent rather than see a placeholder.
                if v.is_none() {
                    self.decls[d].broken = true;
                }
                let v = v.unwrap_or(0.0);
                self.constants[id as usize] = Some(ConstDef {
                    name: name.name.clone(),
                    span: name.span,
                    value: v,
                });
            }
            ast::ItemKind::Fn { params, body, .. } => {
                self.check_params(params.iter().collect());
                let names: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
                let mut cx = expr::Ctx::new(expr::Place::Fn, &names, Some(d));
                let body = self.lower(body, &mut cx);
                self.functions[id as usize] = Some(FnDef {
                    name: name.name.clone(),
                    span: name.span,
                    params: params.iter().map(|p| p.name.clone()).collect(),
                    body,
                    uses_coordinates: cx.used_coordinates,
                });
            }
            ast::ItemKind::Surface { body, .. } => {
                let mut cx = expr::Ctx::new(expr::Place::Surface, &[], Some(d));
                let body = self.lower(body, &mut cx);
                self.surfaces[id as usize] = Some(SurfaceDef {
                    name: name.name.clone(),
                    span: name.span,
                    body,
                });
            }
            ast::ItemKind::Patch { params, body, .. } => {
                let def = self.lower_patch(name, item.span, params, body, d);
                self.patches[id as usize] = Some(def);
            }
            ast::ItemKind::Curve { value, .. } => {
                let kind = self.lower_curve(value, d);
                self.curves[id as usize] = Some(CurveDef {
                    name: name.name.clone(),
                    span: name.span,
                    kind,
                });
            }
            ast::ItemKind::Mesh { .. } | ast::ItemKind::Import { .. } => {}
        }
    }

    /// Reports parameters declared twice.
    pub(crate) fn check_params(&mut self, params: Vec<&ast::Ident>) {
        let mut first: BTreeMap<&str, Span> = BTreeMap::new();
        for p in params {
            match first.get(p.name.as_str()) {
                Some(&f) => self
                    .diags
                    .push(messages::duplicate_parameter(&p.name, f, p.span)),
                None => {
                    first.insert(&p.name, p.span);
                }
            }
        }
    }

    /// Whether a "did you mean" is still worth computing: past a screenful of diagnostics
    /// nobody reads them, and each costs a pass over every name.
    pub(crate) fn suggestions_wanted(&self) -> bool {
        self.diags.len() < MAX_DIAGNOSTICS
    }

    fn warn_unused(&mut self, imported_from: Option<u32>) {
        for d in &self.decls {
            if imported_from.is_some_and(|from| d.item.span.start >= from) {
                continue;
            }
            let what = match d.kind {
                // Surfaces are entry points (`surfc eval FILE SURFACE`), never unused.
                Kind::Surface => continue,
                k => k.word(),
            };
            if !d.used && !d.name.name.starts_with('_') {
                self.diags
                    .push(messages::unused(d.name.span, what, &d.name.name));
            }
        }
    }

    fn finish(self) -> (Program, Vec<Diagnostic>) {
        let placeholder_expr = || Expr {
            kind: ExprKind::Number(0.0),
            span: Span::default(),
        };
        let program = Program {
            constants: self
                .constants
                .into_iter()
                .map(|c| {
                    c.unwrap_or(ConstDef {
                        name: String::new(),
                        span: Span::default(),
                        value: 0.0,
                    })
                })
                .collect(),
            functions: self
                .functions
                .into_iter()
                .map(|f| {
                    f.unwrap_or_else(|| FnDef {
                        name: String::new(),
                        span: Span::default(),
                        params: Vec::new(),
                        body: placeholder_expr(),
                        uses_coordinates: false,
                    })
                })
                .collect(),
            surfaces: self
                .surfaces
                .into_iter()
                .map(|s| {
                    s.unwrap_or_else(|| SurfaceDef {
                        name: String::new(),
                        span: Span::default(),
                        body: placeholder_expr(),
                    })
                })
                .collect(),
            patches: self
                .patches
                .into_iter()
                .map(|p| {
                    p.unwrap_or_else(|| PatchDef {
                        name: String::new(),
                        span: Span::default(),
                        params: [String::new(), String::new()],
                        u_range: (0.0, 1.0),
                        v_range: (0.0, 1.0),
                        body: [placeholder_expr(), placeholder_expr(), placeholder_expr()],
                    })
                })
                .collect(),
            curves: self
                .curves
                .into_iter()
                .map(|c| {
                    c.unwrap_or(CurveDef {
                        name: String::new(),
                        span: Span::default(),
                        kind: CurveKind::Circle {
                            center: glam::DVec3::ZERO,
                            normal: glam::DVec3::Z,
                            radius: 1.0,
                            segments: None,
                        },
                    })
                })
                .collect(),
            meshes: self.meshes,
        };
        let mut diags = self.diags;
        // Report in source order, errors and warnings interleaved as they occur in the file.
        diags.sort_by_key(|d| (d.primary_span().map_or(u32::MAX, |s| s.start), d.severity));
        if diags.len() > MAX_DIAGNOSTICS {
            let rest = diags.len() - MAX_DIAGNOSTICS;
            diags.truncate(MAX_DIAGNOSTICS);
            diags.push(messages::suppressed(rest));
        }
        (program, diags)
    }
}

/// At most this many diagnostics of one file are shown.
const MAX_DIAGNOSTICS: usize = 100;

fn push_slot<T>(v: &mut Vec<Option<T>>) -> u32 {
    v.push(None);
    (v.len() - 1) as u32
}
