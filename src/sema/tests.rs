//! What sema puts into the `Program`: ids, evaluated constants, the combinator rewrites of
//! docs/language.md, curves and meshes; and that the deepest expressions the parser accepts go
//! through every recursive walk on a test thread's small stack.

use glam::DVec3;

use super::program::*;
use crate::diag::has_errors;
use crate::syntax;

fn program(source: &str) -> Program {
    let (file, diags) = syntax::parse(source);
    let file = file.unwrap_or_else(|| panic!("parse: {diags:?}"));
    let (program, diags) = super::check(&file);
    assert!(!has_errors(&diags), "{diags:?}");
    program
}

/// A span-free rendering of a program expression, to compare rewrites.
fn show(e: &Expr) -> String {
    match &e.kind {
        ExprKind::Number(v) => format!("{v}"),
        ExprKind::Coord(a) => format!("{a:?}").to_lowercase(),
        ExprKind::Param(i) => format!("p{i}"),
        ExprKind::Const(c) => format!("c{}", c.0),
        ExprKind::Unary(_, a) => format!("(neg {})", show(a)),
        ExprKind::Binary(op, a, b) => {
            let op = match op {
                BinaryOp::Add => "+",
                BinaryOp::Sub => "-",
                BinaryOp::Mul => "*",
                BinaryOp::Div => "/",
                BinaryOp::Pow => "^",
            };
            format!("({op} {} {})", show(a), show(b))
        }
        ExprKind::Builtin(b, xs) => {
            let xs: Vec<String> = xs.iter().map(show).collect();
            format!("({} {})", b.name(), xs.join(" "))
        }
        ExprKind::Call(f, xs) => {
            let xs: Vec<String> = xs.iter().map(show).collect();
            format!("(f{} {})", f.0, xs.join(" "))
        }
        ExprKind::Surface(s) => format!("s{}", s.0),
        ExprKind::Dist(r) => format!("(dist {})", show_ref(r)),
        ExprKind::At(e, p) => format!(
            "(at {} {} {} {})",
            show(e),
            show(&p[0]),
            show(&p[1]),
            show(&p[2])
        ),
    }
}

fn show_ref(r: &SurfaceRef) -> String {
    match r {
        SurfaceRef::Surface(s) => format!("s{}", s.0),
        SurfaceRef::Patch(p) => format!("patch{}", p.0),
        SurfaceRef::Anonymous(e) => show(e),
    }
}

#[test]
fn design_example_lowers() {
    let p = program(include_str!("../../examples/g2_set.surf"));
    assert_eq!(p.constants.len(), 6);
    assert_eq!(p.constants[0].name, "r1");
    assert_eq!(p.constants[0].value, 1.3);
    assert_eq!(p.surfaces.len(), 3);
    assert_eq!(p.patches.len(), 1);
    // The roof declares its parameters as (v, u), so that Pv × Pu faces up: `u_range` and
    // `params[0]` are those of the first declared parameter, v.
    assert_eq!(p.patches[0].u_range, (0.0, 0.8));
    assert_eq!(p.patches[0].v_range, (0.0, 1.0));
    assert_eq!(p.patches[0].params, ["v".to_string(), "u".to_string()]);
    assert_eq!(show(&p.patches[0].body[0]), "(- (* 10 p0) 5)");
    // fillet = blend(cylinder, roof, c1, c2, mu) with c1, c2, mu constants 1..3 (ids 1, 2, 3).
    assert_eq!(
        show(&p.surfaces[1].body),
        "(- (* (* (- 1 c3) (/ (dist s0) c1)) (/ (dist patch0) c2)) \
         (* c3 (^ (- (- 1 (/ (dist s0) c1)) (/ (dist patch0) c2)) 3)))"
    );
    assert_eq!(p.meshes.len(), 4);
    let roof = &p.meshes[1];
    assert_eq!(roof.name, "roof");
    assert!(matches!(&roof.surface, SurfaceRef::Anonymous(e) if show(e) == "(dist patch0)"));
    assert_eq!(roof.step, 0.2);
    assert!(matches!(p.curves[3].kind, CurveKind::Boundary(PatchId(0))));
    match &p.curves[0].kind {
        CurveKind::Intersection {
            first,
            second,
            near,
        } => {
            assert_eq!(show_ref(first), "s0");
            assert_eq!(show_ref(second), "(- (dist patch0) c2)");
            assert_eq!(*near, DVec3::new(0.1, -1.0, 3.9));
        }
        k => panic!("{k:?}"),
    }
}

#[test]
fn product_and_offset_rewrite() {
    let p = program(
        "surface a = x;\nsurface b = dist(a) - y;\nsurface s = product(a, b, z - 1) - 0.5;\n\
         surface o = offset(a, 0.25);\nsurface d = dist(x + y);",
    );
    assert_eq!(show(&p.surfaces[2].body), "(- (* (* s0 s1) (- z 1)) 0.5)");
    assert_eq!(show(&p.surfaces[3].body), "(- (dist s0) 0.25)");
    assert_eq!(show(&p.surfaces[4].body), "(dist (+ x y))");
}

#[test]
fn constants_and_functions() {
    let p = program(
        "fn sq(t) = t * t;\nfn lift(t) = t + z;\nconst r = sq(3) + pi - tau / 2;\n\
         surface s = lift(sq(x)) - r;\nmesh m = s { step: r / 30; start: (r, 0, 0); max_triangles: 1e6; }",
    );
    assert_eq!(p.constants[0].value, 9.0);
    assert!(!p.functions[0].uses_coordinates);
    assert!(p.functions[1].uses_coordinates);
    assert_eq!(show(&p.surfaces[0].body), "(- (f1 (f0 x)) c0)");
    assert_eq!(p.meshes[0].step, 9.0 / 30.0);
    assert_eq!(p.meshes[0].start, Some(DVec3::new(9.0, 0.0, 0.0)));
    assert_eq!(p.meshes[0].max_triangles, Some(1_000_000));
}

#[test]
fn curves_and_anonymous_curves() {
    let p = program(
        "surface s = x^2 + y^2 + z^2 - 4;\ncurve c = circle(center: (0, 0, 1), normal: (0, 0, 2), radius: sqrt(3));\n\
         mesh m = s { step: 0.1; front: reverse(c); bounds: c, intersection(s, z + 1, near: (1.7, 0, -1)); }",
    );
    assert_eq!(p.curves.len(), 3);
    assert_eq!(p.curves[1].name, "m.front");
    assert!(matches!(p.curves[1].kind, CurveKind::Reverse(CurveId(0))));
    assert_eq!(p.curves[2].name, "m.bounds[1]");
    assert_eq!(p.meshes[0].front, Some(CurveId(1)));
    assert_eq!(p.meshes[0].bounds, vec![CurveId(0), CurveId(2)]);
    match p.curves[0].kind {
        CurveKind::Circle { radius, normal, .. } => {
            assert_eq!(radius, 3f64.sqrt());
            assert_eq!(normal, DVec3::new(0.0, 0.0, 2.0));
        }
        ref k => panic!("{k:?}"),
    }
}

#[test]
fn every_example_checks() {
    for text in [
        include_str!("../../examples/sphere.surf"),
        include_str!("../../examples/cylinder.surf"),
        include_str!("../../examples/torus.surf"),
        include_str!("../../examples/six_peak.surf"),
        include_str!("../../examples/genus3.surf"),
        include_str!("../../examples/three_cylinders.surf"),
        include_str!("../../examples/intersecting_patches.surf"),
        include_str!("../../examples/sphere_six_holes.surf"),
        include_str!("../../examples/two_surfaces.surf"),
        include_str!("../../examples/blend_three_cylinders.surf"),
    ] {
        let p = program(text);
        assert!(!p.meshes.is_empty());
    }
    let p = program(include_str!("../../examples/sphere_six_holes.surf"));
    assert_eq!(p.meshes[0].step, 1.6 * std::f64::consts::PI / 30.0);
    assert_eq!(p.meshes[0].bounds.len(), 5);
}

/// The deepest expressions the parser accepts pass every recursive walk (parse, sema,
/// evaluation, format, dump) on a test thread's default 2 MiB stack.
#[test]
fn deepest_accepted_expressions_fit_the_stack() {
    let depth = crate::syntax::limits::MAX_PAREN_DEPTH;
    let chain = crate::syntax::limits::MAX_EXPR_DEPTH - 10;
    let sources = [
        format!("const c = {}1{};", "(1 + ".repeat(depth), ")".repeat(depth)),
        format!("const c = {}1;", "-".repeat(chain)),
        format!("const c = 1{};", "^1".repeat(chain)),
        format!("const c = 1{};", " + 1".repeat(chain)),
        format!(
            "fn f(t) = {}t{};\nconst c = f(1);",
            "sqrt(".repeat(depth),
            ")".repeat(depth)
        ),
    ];
    for s in sources {
        let text = format!("{s}\nsurface q = x - c;\nmesh m = q {{ step: 1; start: (0, 0, 0); }}");
        let p = program(&text);
        assert!(p.constants[0].value.is_finite());
        let (file, _) = syntax::parse(&text);
        let file = file.expect("parses");
        let formatted = syntax::format(&file);
        let (again, _) = syntax::parse(&formatted);
        assert_eq!(
            syntax::sexpr(&file),
            syntax::sexpr(&again.expect("reparses"))
        );
    }
}
