//! Helpers shared by the compiler's integration tests: programs from source text, a
//! tree-walking reference interpreter of the checked `Program`, and the gallery's formulas as text.

#![allow(dead_code)]

use glam::DVec3;
use surfc::sema::program::{
    Axis, BinaryOp, Builtin, Expr, ExprKind, Program, SurfaceId, SurfaceRef, UnaryOp,
};

/// Parses and checks `source`; panics with the diagnostics if it has errors.
pub fn program(source: &str) -> Program {
    let (file, diags) = surfc::syntax::parse(source);
    let file = file.unwrap_or_else(|| panic!("parse errors: {diags:#?}"));
    let (program, more) = surfc::sema::check(&file);
    assert!(
        !surfc::diag::has_errors(&diags) && !surfc::diag::has_errors(&more),
        "{diags:#?} {more:#?}"
    );
    program
}

pub fn surface_id(program: &Program, name: &str) -> SurfaceId {
    let i = program
        .surfaces
        .iter()
        .position(|s| s.name == name)
        .unwrap_or_else(|| panic!("no surface {name}"));
    SurfaceId(i as u32)
}

/// The reference semantics, written independently of the compiler and VM: a direct walk of
/// the expression tree with Rust's f64 functions. `dist(S)` is whatever `dist` returns.
pub struct Reference<'p> {
    pub program: &'p Program,
    pub dist: &'p dyn Fn(&SurfaceRef, DVec3) -> f64,
}

impl Reference<'_> {
    pub fn surface(&self, id: SurfaceId, p: DVec3) -> f64 {
        self.eval(&self.program.surfaces[id.index()].body, p, &[])
    }

    pub fn eval(&self, e: &Expr, p: DVec3, params: &[f64]) -> f64 {
        match &e.kind {
            ExprKind::Number(c) => *c,
            ExprKind::Coord(Axis::X) => p.x,
            ExprKind::Coord(Axis::Y) => p.y,
            ExprKind::Coord(Axis::Z) => p.z,
            ExprKind::Param(i) => params[*i as usize],
            ExprKind::Const(id) => self.program.constants[id.index()].value,
            ExprKind::Unary(UnaryOp::Neg, a) => -self.eval(a, p, params),
            ExprKind::Binary(op, a, b) => {
                let a = self.eval(a, p, params);
                let b = self.eval(b, p, params);
                match op {
                    BinaryOp::Add => a + b,
                    BinaryOp::Sub => a - b,
                    BinaryOp::Mul => a * b,
                    BinaryOp::Div => a / b,
                    BinaryOp::Pow => pow(a, b),
                }
            }
            ExprKind::Builtin(b, args) => {
                let v: Vec<f64> = args.iter().map(|a| self.eval(a, p, params)).collect();
                match b {
                    Builtin::Sqrt => v[0].sqrt(),
                    Builtin::Abs => v[0].abs(),
                    Builtin::Exp => v[0].exp(),
                    Builtin::Ln => v[0].ln(),
                    Builtin::Sin => v[0].sin(),
                    Builtin::Cos => v[0].cos(),
                    Builtin::Tan => v[0].tan(),
                    Builtin::Asin => v[0].asin(),
                    Builtin::Acos => v[0].acos(),
                    Builtin::Atan => v[0].atan(),
                    Builtin::Atan2 => v[0].atan2(v[1]),
                    Builtin::Sinh => v[0].sinh(),
                    Builtin::Cosh => v[0].cosh(),
                    Builtin::Tanh => v[0].tanh(),
                    Builtin::Min => {
                        if v[0].is_nan() || v[1].is_nan() {
                            f64::NAN
                        } else {
                            v[0].min(v[1])
                        }
                    }
                    Builtin::Max => {
                        if v[0].is_nan() || v[1].is_nan() {
                            f64::NAN
                        } else {
                            v[0].max(v[1])
                        }
                    }
                    Builtin::Pow => pow(v[0], v[1]),
                    Builtin::Hypot => v[0].hypot(v[1]),
                }
            }
            ExprKind::Call(f, args) => {
                let v: Vec<f64> = args.iter().map(|a| self.eval(a, p, params)).collect();
                self.eval(&self.program.functions[f.index()].body, p, &v)
            }
            ExprKind::Surface(id) => self.surface(*id, p),
            ExprKind::Dist(r) => (self.dist)(r, p),
            ExprKind::At(inner, at) => {
                let q = DVec3::new(
                    self.eval(&at[0], p, params),
                    self.eval(&at[1], p, params),
                    self.eval(&at[2], p, params),
                );
                self.eval(inner, q, params)
            }
        }
    }
}

/// The language's `^`: integer exponents are repeated multiplication (here the naive
/// product, not the compiler's squaring), others `powf`.
fn pow(a: f64, b: f64) -> f64 {
    if b.fract() == 0.0 && b.abs() <= 64.0 {
        let mut r = 1.0;
        for _ in 0..(b.abs() as u32) {
            r *= a;
        }
        if b < 0.0 { 1.0 / r } else { r }
    } else {
        a.powf(b)
    }
}

/// A large program: `surfaces` surfaces `s0, s1, …` of 50 terms each, `term(k)` the k-th term
/// overall, and `name` = their sum − 1.
pub fn large_source(name: &str, surfaces: usize, term: impl Fn(usize) -> String) -> String {
    let mut source = String::new();
    for s in 0..surfaces {
        let terms: Vec<String> = (0..50).map(|i| term(s * 50 + i)).collect();
        source.push_str(&format!("surface s{s} = {};\n", terms.join(" + ")));
    }
    let all: Vec<String> = (0..surfaces).map(|s| format!("s{s}")).collect();
    source.push_str(&format!("surface {name} = {} - 1;\n", all.join(" + ")));
    source
}

pub const SPHERE: &str = "surface sphere = x^2 + y^2 + z^2 - 4;\n";

pub const TORUS: &str = "const r = 1;\nconst a = 0.35;\n\
surface torus = (x^2 + y^2 + z^2 + r^2 - a^2)^2 - 4 * r^2 * (x^2 + y^2);\n";

pub const GENUS3: &str = "const rx = 6;
const ry = 3.5;
const rz = 4;
const r1 = 1.2;
const x1 = 3.9;

surface genus3 = rz^4 * z^2
    - (1 - (x / rx)^2 - (y / ry)^2) * ((x - x1)^2 + y^2 - r1^2) * (x^2 + y^2 - r1^2)
        * ((x + x1)^2 + y^2 - r1^2);
";

pub const BLEND: &str = "const mu = 0.0003;

surface cylinder_blend = (1 - mu) * (x^2 + y^2 - 1) * (x^2 + z^2 - 1) * (y^2 + z^2 - 1)
    - mu * (9 - x^2 - y^2 - z^2)^3;
";
