//! The compiled tapes against the reference interpreter (values) and central differences
//! (gradients), at 1000 seeded random points per surface; every opcode against a reference
//! closure, edge inputs included; batch against single-point evaluation; patches; dist().

use crate::common::rng::Rng;
use crate::common::sources as common;

use std::cell::Cell;
use std::rc::Rc;

use common::{BLEND, GENUS3, Reference, SPHERE, TORUS, program, surface_id};
use glam::DVec3;
use surfc::compile::tape::{Instr, Op, Reg, Tape};
use surfc::eval::native::NativeError;
use surfc::eval::{Engine, Grad, Vm};
use surfc::sema::program::{PatchId, Program, SurfaceRef};
use surfc::surface::compiled::CompiledSurface;
use surfc::surface::compiled::{compile_patch, compile_surface};
use surfc::surface::{NativeSurface, Patch, Surface, ValueGrad};

const POINTS: usize = 1000;
/// Values agree with the reference to this, relative to the magnitude.
const VALUE_TOL: f64 = 1e-12;
/// Gradients agree with central differences to this, relative (with an absolute floor
/// scaled by |f| over the box size, where rounding in the differences lives).
const GRAD_TOL: f64 = 1e-6;
/// Forward and backward difference quotients this far apart (relative to the gradient):
/// a crease within the difference step.
const KINK: f64 = 1e-2;

fn no_dist(_: &SurfaceRef) -> Result<Box<dyn Surface>, std::convert::Infallible> {
    panic!("this surface has no dist()")
}

fn compile_named(p: &Program, name: &str) -> CompiledSurface {
    compile_surface(p, &SurfaceRef::Surface(surface_id(p, name)), &mut no_dist).unwrap()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs()).max(1.0)
}

/// Central differences of `f` at p with step h.
fn central(f: &mut dyn FnMut(DVec3) -> f64, p: DVec3, h: f64) -> DVec3 {
    let d = |f: &mut dyn FnMut(DVec3) -> f64, e: DVec3| (f(p + e * h) - f(p - e * h)) / (2.0 * h);
    DVec3::new(d(f, DVec3::X), d(f, DVec3::Y), d(f, DVec3::Z))
}

/// Checks `surface` against `reference` at POINTS points of the box, single and batch.
fn check_surface(
    name: &str,
    surface: &mut CompiledSurface,
    reference: &dyn Fn(DVec3) -> f64,
    lo: DVec3,
    hi: DVec3,
) {
    let size = (hi - lo).max_element();
    let h = 1e-5 * size;
    // Seeded by the name alone (a file's name, not its path), so that every checkout samples
    // the same points.
    let seed = name.bytes().fold(0x5eed_u64, |h, b| {
        h.rotate_left(5) ^ u64::from(b).wrapping_mul(0x9e37_79b9_7f4a_7c15)
    });
    let mut rng = Rng::new(seed);
    let points: Vec<DVec3> = (0..POINTS).map(|_| rng.point(lo, hi)).collect();
    let mut batch_v = vec![0.0; POINTS];
    let mut batch_g = vec![
        ValueGrad {
            value: 0.0,
            gradient: DVec3::ZERO
        };
        POINTS
    ];
    // Both engines: the interpreter (its single points are the reference) and the native
    // code (the default), each at single points and in a batch.
    let mut block_v = batch_v.clone();
    let mut block_g = batch_g.clone();
    surface.set_engine(Engine::Interpreter);
    let interpreted: Vec<(f64, ValueGrad)> = points
        .iter()
        .map(|&p| (surface.value(p), surface.value_gradient(p)))
        .collect();
    surface.value_batch(&points, &mut block_v);
    surface.value_gradient_batch(&points, &mut block_g);
    surface.set_engine(Engine::Native);
    surface.value_batch(&points, &mut batch_v);
    surface.value_gradient_batch(&points, &mut batch_g);
    assert_native_unless_children(name, surface);
    let mut kinks = 0;
    for (i, &p) in points.iter().enumerate() {
        let want = reference(p);
        let (v, vg) = interpreted[i];
        assert!(
            close(v, want, VALUE_TOL),
            "{name} at {p}: {v} vs reference {want}"
        );
        assert_eq!(
            vg.value.to_bits(),
            v.to_bits(),
            "{name} at {p}: value modes differ"
        );
        let native = (surface.value(p), surface.value_gradient(p));
        let found = [
            ("native", native.0, native.1),
            ("native batch", batch_v[i], batch_g[i]),
            ("block", block_v[i], block_g[i]),
        ];
        for (what, value, grad) in found {
            assert_eq!(value.to_bits(), v.to_bits(), "{name} at {p}: {what} value");
            assert_eq!(grad, vg, "{name} at {p}: {what} gradient");
        }
        let fd = central(&mut |q| reference(q), p, h);
        let floor = GRAD_TOL * (want.abs() / size + 1.0);
        // Within h of a crease (a `min`, `max` or `abs` switching: CSG surfaces) no difference
        // quotient is a derivative: there the forward and backward quotients differ by the
        // jump of the gradient, where elsewhere they differ by about h·f''. Such points are
        // skipped, and must stay rare.
        let at = want;
        let jump = [DVec3::X, DVec3::Y, DVec3::Z]
            .map(|e| ((reference(p + e * h) - at) - (at - reference(p - e * h))).abs() / h);
        if jump.into_iter().fold(0.0, f64::max) > KINK * (fd.abs().max_element() + 1.0) {
            kinks += 1;
            continue;
        }
        let err = (vg.gradient - fd).abs().max_element();
        assert!(
            err <= GRAD_TOL * vg.gradient.abs().max_element() + floor,
            "{name} at {p}: gradient {} vs central differences {fd}",
            vg.gradient
        );
    }
    assert!(
        kinks <= POINTS / 50,
        "{name}: {kinks} of {POINTS} points within a difference step of a crease"
    );
}

/// The batch paths of a surface without `dist` children ran as native code (on the hosts
/// Cranelift supports); one with children fell back to the block interpreter, saying why.
fn assert_native_unless_children(name: &str, surface: &CompiledSurface) {
    let error = surface.native_error();
    if surface.tape().children() > 0 {
        assert!(
            matches!(error, Some(NativeError::UnsupportedTape)),
            "{name}: {error:?}"
        );
    } else if cfg!(any(target_arch = "x86_64", target_arch = "aarch64")) {
        assert!(error.is_none(), "{name}: no native code: {error:?}");
    }
}

fn check_source(source: &str, name: &str, lo: DVec3, hi: DVec3) {
    let p = program(source);
    let id = surface_id(&p, name);
    let no = |_: &SurfaceRef, _: DVec3| f64::NAN;
    let reference = Reference {
        program: &p,
        dist: &no,
    };
    let mut s = compile_named(&p, name);
    check_surface(name, &mut s, &|q| reference.surface(id, q), lo, hi);
}

#[test]
fn gallery_formulas_match_reference_and_finite_differences() {
    let b = |r: f64| (DVec3::splat(-r), DVec3::splat(r));
    let (lo, hi) = b(3.0);
    check_source(SPHERE, "sphere", lo, hi);
    let (lo, hi) = b(1.5);
    check_source(TORUS, "torus", lo, hi);
    check_source(
        GENUS3,
        "genus3",
        DVec3::new(-6.5, -4.0, -2.0),
        DVec3::new(6.5, 4.0, 2.0),
    );
    let (lo, hi) = b(3.0);
    check_source(BLEND, "cylinder_blend", lo, hi);
    let six_peak = "surface six_peak = (3 * x^2 - y^2)^2 * y^2 - (x^2 + y^2)^4 - z^3 - 0.001 * z;";
    check_source(
        six_peak,
        "six_peak",
        DVec3::new(-1.2, -1.2, -0.3),
        DVec3::new(1.2, 1.2, 1.0),
    );
}

/// Functions (nested, called repeatedly), named surfaces, constants and every smooth builtin,
/// each used inside its domain.
#[test]
fn functions_surfaces_and_builtins_match_reference() {
    let source = "
const k = 2 * pi / 3;
fn sq(t) = t * t;
fn quad(t) = sq(sq(t));
fn mix(a, b) = sq(a) + quad(b) - a * b;
fn radial(t) = sqrt(sq(x) + sq(y) + t);
surface ball = sq(x) + sq(y) + sq(z) - 1;
surface waves = sin(k * x) * cos(y) + tan(0.3 * z) + exp(-sq(x)) + ln(2 + sq(y))
    + asin(0.5 * tanh(z)) + acos(0.4 * sin(x)) + atan(y) + atan2(y + 3, 2 + sq(x))
    + sinh(0.5 * x) + cosh(0.3 * y) + hypot(x + 3, y) + pow(2 + sq(z), 0.7)
    + (1 + sq(x))^-2 + (2 + z)^1.5 + 1 / (1 + sq(y));
surface all = mix(x, y) + mix(x, y) * quad(z) + ball * waves + radial(1) + radial(ball + 3)
    - mix(mix(x, z), mix(y, z)) / 100 + abs(x + 5) + min(x, 7) + max(y, -7);
";
    check_source(source, "waves", DVec3::splat(-1.0), DVec3::splat(1.0));
    check_source(source, "all", DVec3::splat(-1.0), DVec3::splat(1.0));
}

/// dist(S) written several times is one instruction and one child call per evaluation; the
/// child's value and gradient enter the chain rule.
#[test]
fn dist_children_are_shared_and_differentiated() {
    let source = "
surface ball = x^2 + y^2 + z^2 - 1;
surface d = dist(ball) * dist(ball) + 3 * dist(ball) - 0.5 * dist(x - 1) + offset(ball, 0.2);
";
    let p = program(source);
    let calls = Rc::new(Cell::new(0u32));
    // Child surfaces: the exact distance to the unit sphere, and the plane x = 1.
    let exact = |r: &SurfaceRef, q: DVec3| match r {
        SurfaceRef::Surface(_) => q.length() - 1.0,
        _ => q.x - 1.0,
    };
    let mut factory = {
        let calls = calls.clone();
        move |r: &SurfaceRef| -> Result<Box<dyn Surface>, std::convert::Infallible> {
            let plane = !matches!(r, SurfaceRef::Surface(_));
            let calls = calls.clone();
            Ok(Box::new(NativeSurface(move |q: DVec3| {
                calls.set(calls.get() + 1);
                if plane {
                    ValueGrad {
                        value: q.x - 1.0,
                        gradient: DVec3::X,
                    }
                } else {
                    ValueGrad {
                        value: q.length() - 1.0,
                        gradient: q.normalize(),
                    }
                }
            })))
        }
    };
    let id = surface_id(&p, "d");
    let mut s = compile_surface(&p, &SurfaceRef::Surface(id), &mut factory).unwrap();
    let dists = s
        .tape()
        .instrs()
        .iter()
        .filter(|i| i.op == Op::Dist)
        .count();
    assert_eq!(dists, 2, "{}", s.tape());
    assert_eq!(s.tape().children(), 2);
    calls.set(0);
    s.value_gradient(DVec3::new(0.3, 0.2, 0.9));
    assert_eq!(calls.get(), 2, "one call per distinct dist()");
    let reference = Reference {
        program: &p,
        dist: &exact,
    };
    check_surface(
        "d",
        &mut s,
        &|q| reference.surface(id, q),
        DVec3::splat(0.5),
        DVec3::splat(2.0),
    );
}

#[test]
fn patch_jacobian_matches_reference_and_finite_differences() {
    let source = "
fn bump(t) = t - t^2;
patch roof(u: 0..1, v: 0..0.8) = (10 * v - 5, 10 * u - 5, 6 * (bump(u) + bump(v)));
patch twist(s: -1..1, t: 0..tau) = (cos(t) * (2 + s), sin(t) * (2 + s), s * t + sqrt(1 + s^2));
";
    let p = program(source);
    let no = |_: &SurfaceRef, _: DVec3| f64::NAN;
    let reference = Reference {
        program: &p,
        dist: &no,
    };
    for (k, def) in p.patches.iter().enumerate() {
        let mut patch = compile_patch(&p, PatchId(k as u32)).unwrap();
        assert_eq!(patch.domain(), (def.u_range, def.v_range));
        let point = |u: f64, v: f64| {
            let c = |i: usize| reference.eval(&def.body[i], DVec3::ZERO, &[u, v]);
            DVec3::new(c(0), c(1), c(2))
        };
        let mut rng = Rng::new(7 + k as u64);
        for _ in 0..POINTS {
            let (u, v) = (
                rng.range(def.u_range.0, def.u_range.1),
                rng.range(def.v_range.0, def.v_range.1),
            );
            let jet = patch.point_jacobian(u, v);
            let want = point(u, v);
            assert!(
                (jet.point - want).abs().max_element()
                    <= VALUE_TOL * want.abs().max_element().max(1.0)
            );
            let h = 1e-6;
            let du = (point(u + h, v) - point(u - h, v)) / (2.0 * h);
            let dv = (point(u, v + h) - point(u, v - h)) / (2.0 * h);
            for (ad, fd) in [(jet.du, du), (jet.dv, dv)] {
                assert!(
                    (ad - fd).abs().max_element() <= GRAD_TOL * ad.abs().max_element().max(1.0),
                    "{} at ({u}, {v}): {ad} vs {fd}",
                    def.name
                );
            }
        }
    }
}

// ---- Opcode conformance -------------------------------------------------------------------

/// A tape computing `op x, y` (or `op x`), inputs x, y, z.
fn op_tape(op: Op) -> Tape {
    let names = vec!["x".to_string(), "y".to_string(), "z".to_string()];
    let b = if op.arity() == surfc::compile::tape::Arity::Binary {
        Reg(1)
    } else {
        Reg(0)
    };
    let ins = vec![Instr {
        op,
        out: Reg(3),
        // For dist: child #0.
        a: Reg(0),
        b,
    }];
    Tape::new(
        names,
        vec![],
        ins,
        vec![Reg(3)],
        4,
        usize::from(op == Op::Dist),
    )
    .unwrap()
}

/// The reference of each opcode, straight from std.
fn reference_op(op: Op) -> fn(f64, f64) -> f64 {
    match op {
        Op::Neg => |a, _| -a,
        Op::Square => |a, _| a * a,
        Op::Recip => |a, _| 1.0 / a,
        Op::Sqrt => |a, _| a.sqrt(),
        Op::Abs => |a, _| a.abs(),
        Op::Exp => |a, _| a.exp(),
        Op::Ln => |a, _| a.ln(),
        Op::Sin => |a, _| a.sin(),
        Op::Cos => |a, _| a.cos(),
        Op::Tan => |a, _| a.tan(),
        Op::Asin => |a, _| a.asin(),
        Op::Acos => |a, _| a.acos(),
        Op::Atan => |a, _| a.atan(),
        Op::Sinh => |a, _| a.sinh(),
        Op::Cosh => |a, _| a.cosh(),
        Op::Tanh => |a, _| a.tanh(),
        Op::Add => |a, b| a + b,
        Op::Sub => |a, b| a - b,
        Op::Mul => |a, b| a * b,
        Op::Div => |a, b| a / b,
        Op::Pow => |a, b| a.powf(b),
        Op::Atan2 => |a, b| a.atan2(b),
        Op::Min => |a, b| {
            if a.is_nan() || b.is_nan() {
                f64::NAN
            } else {
                a.min(b)
            }
        },
        Op::Max => |a, b| {
            if a.is_nan() || b.is_nan() {
                f64::NAN
            } else {
                a.max(b)
            }
        },
        // The language's hypot (`values::hypot`): √(a·a + b·b) where a·a + b·b is normal
        // and finite, else std's scaled form.
        Op::Hypot => |a, b| {
            let s = a * a + b * b;
            if (f64::MIN_POSITIVE..f64::INFINITY).contains(&s) {
                s.sqrt()
            } else {
                a.hypot(b)
            }
        },
        // The child of the dist tape below: the sphere of radius 2.
        Op::Dist => |a, b| (a * a + b * b).sqrt() - 2.0,
    }
}

/// A VM of `op_tape(op)`, with the `dist` child when `op` is `dist`.
fn op_vm(op: Op) -> Vm {
    let children = if op == Op::Dist {
        vec![dist_child()]
    } else {
        vec![]
    };
    Vm::new(op_tape(op), children).unwrap()
}

fn dist_child() -> Box<dyn Surface> {
    Box::new(NativeSurface(|p: DVec3| ValueGrad {
        value: p.length() - 2.0,
        gradient: p / p.length(),
    }))
}

fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// Equal, NaN included, up to the sign of zero: the batch evaluator skips partials that are
/// structurally zero, so it may return −0 for a partial where a dense `+ 0` gives +0.
fn same_partial(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

// Batches take the points two at a time: pairs of one lane in a range and the other out of
// it (1e10 with 1e-300 or with 1e200 for `hypot`'s a² + b²) run in both.
const EDGE: [f64; 15] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    -0.7,
    2.5,
    -3.25,
    1e10,
    -1e10,
    1e-300,
    1e200,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::NAN,
];

#[test]
fn every_opcode_matches_its_reference_on_edge_inputs() {
    for op in Op::ALL {
        let mut vm = op_vm(op);
        let reference = reference_op(op);
        let mut points = Vec::new();
        for &a in &EDGE {
            for &b in &EDGE {
                points.push(DVec3::new(a, b, 0.0));
            }
        }
        let mut batch_v = vec![0.0; points.len()];
        let mut batch_g = vec![
            ValueGrad {
                value: 0.0,
                gradient: DVec3::ZERO
            };
            points.len()
        ];
        // The reference of both engines: the interpreter's dense dual numbers.
        vm.set_engine(Engine::Interpreter);
        let dense: Vec<Grad> = points
            .iter()
            .map(|p| vm.value_grad(&[p.x, p.y, p.z]))
            .collect();
        for engine in [Engine::Native, Engine::Interpreter] {
            vm.set_engine(engine);
            vm.value_batch(&points, &mut batch_v);
            vm.value_grad_batch(&points, &mut batch_g);
            if engine == Engine::Native
                && op != Op::Dist
                && cfg!(any(target_arch = "x86_64", target_arch = "aarch64"))
            {
                assert!(
                    vm.native_error().is_none(),
                    "{}: {:?}",
                    op.name(),
                    vm.native_error()
                );
            }
            for (i, p) in points.iter().enumerate() {
                let want = reference(p.x, p.y);
                let v = vm.value(&[p.x, p.y, p.z]);
                let g = vm.value_grad(&[p.x, p.y, p.z]);
                let bg = batch_g[i];
                let bg = Grad::new(bg.value, bg.gradient.x, bg.gradient.y, bg.gradient.z);
                let name = op.name();
                assert!(same(v, want), "{name} {engine:?} {p}: {v} vs {want}");
                assert!(same(batch_v[i], want), "{name} {engine:?} {p}: batch value");
                for (what, found) in [("dual", g), ("batch dual", bg)] {
                    assert!(
                        same(found.v, want),
                        "{name} {engine:?} {p}: {what} value {} vs {want}",
                        found.v
                    );
                    let pairs = [
                        (found.dx, dense[i].dx),
                        (found.dy, dense[i].dy),
                        (found.dz, dense[i].dz),
                    ];
                    for (x, y) in pairs {
                        assert!(
                            same_partial(x, y),
                            "{name} {engine:?} {p}: {what} {found:?} vs dense {:?}",
                            dense[i]
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn every_opcode_derivative_matches_central_differences() {
    // Points inside every opcode's domain, away from its kinks.
    let samples: [(f64, f64); 4] = [(0.3, 0.7), (-0.45, 1.3), (0.8, -0.6), (0.1, 2.2)];
    for op in Op::ALL {
        let mut vm = op_vm(op);
        let reference = reference_op(op);
        for &(a, b) in &samples {
            let (a, b) = match op {
                // Logarithms and real powers of positive numbers only.
                Op::Ln | Op::Pow | Op::Sqrt => (a.abs(), b),
                _ => (a, b),
            };
            let g = vm.value_grad(&[a, b, 0.0]);
            let h = 1e-6;
            let da = (reference(a + h, b) - reference(a - h, b)) / (2.0 * h);
            let db = (reference(a, b + h) - reference(a, b - h)) / (2.0 * h);
            for (ad, fd) in [(g.dx, da), (g.dy, db)] {
                assert!(
                    (ad - fd).abs() <= 1e-7 * ad.abs().max(1.0),
                    "{} at ({a}, {b}): {ad} vs central {fd}",
                    op.name()
                );
            }
            assert_eq!(g.dz, 0.0);
        }
    }
}

#[test]
fn derivatives_at_kinks_are_the_documented_ones() {
    let d = |op: Op, a: f64, b: f64| {
        let mut vm = Vm::new(op_tape(op), vec![]).unwrap();
        let g = vm.value_grad(&[a, b, 0.0]);
        (g.dx, g.dy)
    };
    assert_eq!(d(Op::Abs, 0.0, 0.0), (0.0, 0.0));
    assert_eq!(d(Op::Abs, -2.0, 0.0), (-1.0, 0.0));
    assert_eq!(d(Op::Sqrt, 0.0, 0.0), (0.0, 0.0));
    assert_eq!(d(Op::Min, 1.0, 1.0), (0.5, 0.5));
    assert_eq!(d(Op::Max, 1.0, 1.0), (0.5, 0.5));
    assert_eq!(d(Op::Min, 1.0, 2.0), (1.0, 0.0));
    assert_eq!(d(Op::Max, 1.0, 2.0), (0.0, 1.0));
    assert_eq!(d(Op::Hypot, 0.0, 0.0), (0.0, 0.0));
    assert_eq!(d(Op::Atan2, 0.0, 0.0), (0.0, 0.0));
    // A constant integer-valued exponent of a negative base: no NaN from ln.
    let mut g = Grad::input(-2.0, 0);
    g = surfc::eval::ops::grad(Op::Pow, g, Grad::constant(3.0));
    assert_eq!((g.v, g.dx), (-8.0, 12.0));
    // sqrt of a negative: NaN value and derivative, no panic.
    let (da, _) = d(Op::Sqrt, -1.0, 0.0);
    assert!(da.is_nan());
}

// ---- Every surface of every gallery file -------------------------------------------------

/// The stand-in for `dist(target)` in the gallery test: the target's own function value for
/// a surface (compiled, or evaluated by the reference), |p|² for a patch. Any smooth surface
/// exercises the `dist` instruction; the foot-point distances are `surface::dist`'s business.
fn stand_in_factory(
    p: &Program,
) -> impl FnMut(&SurfaceRef) -> Result<Box<dyn Surface>, std::convert::Infallible> + '_ {
    move |r: &SurfaceRef| -> Result<Box<dyn Surface>, std::convert::Infallible> {
        Ok(match r {
            SurfaceRef::Patch(_) => Box::new(NativeSurface(|q: DVec3| ValueGrad {
                value: q.length_squared(),
                gradient: 2.0 * q,
            })),
            _ => Box::new(compile_surface(p, r, &mut stand_in_factory(p)).unwrap()),
        })
    }
}

fn stand_in_reference(p: &Program, r: &SurfaceRef, q: DVec3) -> f64 {
    let dist = |r: &SurfaceRef, q: DVec3| stand_in_reference(p, r, q);
    let reference = Reference {
        program: p,
        dist: &dist,
    };
    match r {
        SurfaceRef::Surface(id) => reference.surface(*id, q),
        SurfaceRef::Patch(_) => q.length_squared(),
        SurfaceRef::Anonymous(e) => reference.eval(e, q, &[]),
    }
}

#[test]
fn every_gallery_surface_matches_reference_and_finite_differences() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return; // The gallery has not landed in this tree.
    };
    let mut files: Vec<_> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "surf"))
        .collect();
    files.sort();
    let mut checked = 0;
    for file in &files {
        let source = std::fs::read_to_string(file).unwrap();
        let p = program(&source);
        for (k, def) in p.surfaces.iter().enumerate() {
            let r = SurfaceRef::Surface(surfc::sema::program::SurfaceId(k as u32));
            // The box of a mesh of this surface, else a box around the origin.
            let (lo, hi) = p
                .meshes
                .iter()
                .find(|m| m.surface == r)
                .and_then(|m| m.bbox)
                .unwrap_or((DVec3::splat(-3.0), DVec3::splat(3.0)));
            let mut s = compile_surface(&p, &r, &mut stand_in_factory(&p)).unwrap();
            let file_name = file.file_name().unwrap_or_default().to_string_lossy();
            let name = format!("{file_name}: {}", def.name);
            check_surface(&name, &mut s, &|q| stand_in_reference(&p, &r, q), lo, hi);
            checked += 1;
        }
    }
    eprintln!("{checked} surfaces in {} files", files.len());
    assert!(
        checked >= files.len(),
        "{checked} surfaces in {} files",
        files.len()
    );
}

/// Batches of every length up to a few pairs (the native code runs pairs of points and pads
/// an odd last one), with the output shorter or longer than the points: each result is the
/// single-point one, and nothing past the shorter length is written; the same through the
/// `Surface` oracle.
#[test]
fn batches_of_any_length_match_single_points() {
    let p = program(GENUS3);
    let mut s = compile_named(&p, "genus3");
    let mut rng = Rng::new(7);
    let (lo, hi) = (DVec3::new(-6.5, -4.0, -2.0), DVec3::new(6.5, 4.0, 2.0));
    let points: Vec<DVec3> = (0..9).map(|_| rng.point(lo, hi)).collect();
    let untouched = ValueGrad {
        value: 12345.0,
        gradient: DVec3::splat(-1.0),
    };
    for engine in [Engine::Native, Engine::Interpreter] {
        s.set_engine(engine);
        for n in 0..=points.len() {
            for m in [n.saturating_sub(1), n, n + 2] {
                let mut values = vec![untouched.value; m];
                let mut grads = vec![untouched; m];
                // The oracle's batch (what the verification's chord errors call) as well.
                let mut oracle = vec![untouched; m];
                s.value_batch(&points[..n], &mut values);
                s.value_gradient_batch(&points[..n], &mut grads);
                assert!(Surface::value_gradient_batch(
                    &mut s,
                    &points[..n],
                    &mut oracle
                ));
                assert_eq!(oracle, grads, "{engine:?} {n} {m}: the oracle's batch");
                for i in 0..m {
                    let (want_v, want_g) = if i < n {
                        (s.value(points[i]), s.value_gradient(points[i]))
                    } else {
                        (untouched.value, untouched)
                    };
                    assert_eq!(
                        values[i].to_bits(),
                        want_v.to_bits(),
                        "{engine:?} {n} {m} {i}"
                    );
                    assert_eq!(grads[i], want_g, "{engine:?} {n} {m} {i}");
                }
            }
        }
    }
    assert_native_unless_children("genus3", &s);
}

/// A tape past Cranelift's optimisation limit (1024 instructions; compiled without its e-graph
/// pass) agrees with the interpreter like any other, callbacks included.
#[test]
fn large_tapes_agree_with_the_interpreter() {
    let source = common::large_source("large", 8, |k| {
        format!("sin(x * {} - y) * (z - {}.25)^2", k + 1, k % 7)
    });
    let p = program(&source);
    let mut s = compile_named(&p, "large");
    assert!(
        s.tape().instrs().len() > 1024,
        "{}",
        s.tape().instrs().len()
    );
    let mut rng = Rng::new(11);
    let points: Vec<DVec3> = (0..64)
        .map(|_| rng.point(DVec3::splat(-1.0), DVec3::splat(1.0)))
        .collect();
    s.set_engine(Engine::Interpreter);
    let interpreted: Vec<ValueGrad> = points.iter().map(|&q| s.value_gradient(q)).collect();
    s.set_engine(Engine::Native);
    for (q, want) in points.iter().zip(&interpreted) {
        let found = s.value_gradient(*q);
        assert_eq!(found.value.to_bits(), want.value.to_bits(), "at {q}");
        assert_eq!(found, *want, "at {q}");
    }
    assert_native_unless_children("large", &s);
}

/// Products whose coefficient is infinite where a partial is zero (x·x·y at x = 0, y = ∞):
/// the native code runs such pairs again with `ops::term`'s guards, and agrees with the
/// interpreter on every edge input, single points and batches.
#[test]
fn infinite_coefficients_of_zero_partials_agree_with_the_interpreter() {
    let sources = [
        "surface s = x * x * y;",
        "surface s = (x - 1)^2 / y + z;",
        "surface s = x^2 * y^2 * z - x * z;",
        "surface s = sqrt(x * x + y) * z;",
    ];
    let mut points = Vec::new();
    for &a in &EDGE {
        for &b in &EDGE {
            for c in [0.0, 1.0, f64::INFINITY, f64::NAN] {
                points.push(DVec3::new(a, b, c));
            }
        }
    }
    for source in sources {
        let p = program(source);
        let mut s = compile_named(&p, "s");
        s.set_engine(Engine::Interpreter);
        let dense: Vec<ValueGrad> = points.iter().map(|&q| s.value_gradient(q)).collect();
        s.set_engine(Engine::Native);
        let zero = ValueGrad {
            value: 0.0,
            gradient: DVec3::ZERO,
        };
        let mut batch = vec![zero; points.len()];
        s.value_gradient_batch(&points, &mut batch);
        assert_native_unless_children(source, &s);
        for (i, &q) in points.iter().enumerate() {
            for (what, found) in [("single", s.value_gradient(q)), ("batch", batch[i])] {
                let want = dense[i];
                let agree = same(found.value, want.value)
                    && same_partial(found.gradient.x, want.gradient.x)
                    && same_partial(found.gradient.y, want.gradient.y)
                    && same_partial(found.gradient.z, want.gradient.z);
                assert!(agree, "{source} at {q}: {what} {found:?} vs {want:?}");
            }
        }
    }
}
