//! Compiled tapes against native Rust: value, and value + gradient, over a batch of points in
//! the model's box, for the genus-3 surface (paper Sect. 3.5) and the G2 blend of three
//! cylinders (Sect. 3.10). `rust` is the same formula written in Rust with hand-derived
//! gradients; `jit` the tape as native code (the default engine), `interpreter` the bytecode
//! interpreter. Also the single-point path the marcher uses (one `value_gradient` call a
//! point), and the time to translate a tape to native code (`compile_jit`).
//!
//! `cargo bench --bench eval -- --warm-up-time 1 --measurement-time 3`

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use surfc::eval::Engine;
use surfc::eval::native::NativeTape;
use surfc::sema::program::{SurfaceId, SurfaceRef};
use surfc::surface::compiled::CompiledSurface;
use surfc::surface::compiled::compile_surface;
use surfc::surface::{Surface, ValueGrad};

/// Points a batch: 1 M.
const POINTS: usize = 1 << 20;

const GENUS3: &str = include_str!("../examples/genus3.surf");
const BLEND: &str = include_str!("../examples/blend_three_cylinders.surf");

fn compiled(source: &str, name: &str) -> CompiledSurface {
    let (file, diags) = surfc::syntax::parse(source);
    let file = file.unwrap_or_else(|| panic!("{diags:?}"));
    let (program, _) = surfc::sema::check(&file);
    let mut no_dist =
        |_: &SurfaceRef| -> Result<Box<dyn Surface>, std::convert::Infallible> { unreachable!() };
    let id = program
        .surfaces
        .iter()
        .position(|s| s.name == name)
        .unwrap();
    let r = SurfaceRef::Surface(SurfaceId(id as u32));
    compile_surface(&program, &r, &mut no_dist).unwrap()
}

const RX: f64 = 6.0;
const RY: f64 = 3.5;
const RZ4: f64 = 256.0;
const R1SQ: f64 = 1.2 * 1.2;
const X1: f64 = 3.9;

#[inline]
fn genus3_value(p: DVec3) -> f64 {
    let (x, y, z) = (p.x, p.y, p.z);
    let y2 = y * y;
    let a = 1.0 - (x / RX) * (x / RX) - (y / RY) * (y / RY);
    let b = (x - X1) * (x - X1) + y2 - R1SQ;
    let c = x * x + y2 - R1SQ;
    let d = (x + X1) * (x + X1) + y2 - R1SQ;
    RZ4 * z * z - a * b * c * d
}

#[inline]
fn genus3_grad(p: DVec3) -> ValueGrad {
    let (x, y, z) = (p.x, p.y, p.z);
    let y2 = y * y;
    let a = 1.0 - (x / RX) * (x / RX) - (y / RY) * (y / RY);
    let b = (x - X1) * (x - X1) + y2 - R1SQ;
    let c = x * x + y2 - R1SQ;
    let d = (x + X1) * (x + X1) + y2 - R1SQ;
    let (ax, ay) = (-2.0 * x / (RX * RX), -2.0 * y / (RY * RY));
    let (bx, cx, dx) = (2.0 * (x - X1), 2.0 * x, 2.0 * (x + X1));
    let yy = 2.0 * y;
    let (ab, cd) = (a * b, c * d);
    let px = ax * b * cd + a * bx * cd + ab * cx * d + ab * c * dx;
    let py = ay * b * cd + (a * cd + ab * d + ab * c) * yy;
    ValueGrad {
        value: RZ4 * z * z - ab * cd,
        gradient: DVec3::new(-px, -py, 2.0 * RZ4 * z),
    }
}

const MU: f64 = 0.0003;

#[inline]
fn blend_value(p: DVec3) -> f64 {
    let (x2, y2, z2) = (p.x * p.x, p.y * p.y, p.z * p.z);
    let s = 9.0 - x2 - y2 - z2;
    (1.0 - MU) * (x2 + y2 - 1.0) * (x2 + z2 - 1.0) * (y2 + z2 - 1.0) - MU * s * s * s
}

#[inline]
fn blend_grad(p: DVec3) -> ValueGrad {
    let (x2, y2, z2) = (p.x * p.x, p.y * p.y, p.z * p.z);
    let (f1, f2, f3) = (x2 + y2 - 1.0, x2 + z2 - 1.0, y2 + z2 - 1.0);
    let s = 9.0 - x2 - y2 - z2;
    let k = 1.0 - MU;
    let m = 6.0 * MU * s * s;
    ValueGrad {
        value: k * f1 * f2 * f3 - MU * s * s * s,
        gradient: DVec3::new(
            (k * 2.0 * (f2 * f3 + f1 * f3) + m) * p.x,
            (k * 2.0 * (f2 * f3 + f1 * f2) + m) * p.y,
            (k * 2.0 * (f1 * f3 + f1 * f2) + m) * p.z,
        ),
    }
}

/// Seeded points in the box lo..hi.
fn points(lo: DVec3, hi: DVec3) -> Vec<DVec3> {
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        (s.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..POINTS)
        .map(|_| lo + (hi - lo) * DVec3::new(next(), next(), next()))
        .collect()
}

/// Generic over the native functions, so they are inlined into their loops (a function
/// pointer would charge the native side a call per point).
fn bench_surface<V, G>(
    c: &mut Criterion,
    name: &str,
    (source, surface_name): (&str, &str),
    (lo, hi): (DVec3, DVec3),
    value: V,
    grad: G,
) where
    V: Fn(DVec3) -> f64 + Copy,
    G: Fn(DVec3) -> ValueGrad + Copy,
{
    let pts = points(lo, hi);
    let mut surface = compiled(source, surface_name);
    let mut values = vec![0.0; POINTS];
    let zero = ValueGrad {
        value: 0.0,
        gradient: DVec3::ZERO,
    };
    let mut grads = vec![zero; POINTS];
    // They agree before they race.
    for engine in [Engine::Native, Engine::Interpreter] {
        surface.set_engine(engine);
        surface.value_gradient_batch(&pts[..1000], &mut grads[..1000]);
        for (p, g) in pts.iter().zip(&grads[..1000]) {
            let n = grad(*p);
            let tol = 1e-9 * (1.0 + n.value.abs() + n.gradient.abs().max_element());
            assert!(
                (n.value - g.value).abs() <= tol
                    && (n.gradient - g.gradient).abs().max_element() <= tol
            );
            assert!((value(*p) - n.value).abs() <= tol);
        }
    }

    let mut group = c.benchmark_group(name);
    group.throughput(Throughput::Elements(POINTS as u64));
    group.sample_size(10);
    group.bench_function("value/rust", |b| {
        b.iter(|| {
            for (o, p) in values.iter_mut().zip(black_box(&pts)) {
                *o = value(*p);
            }
        })
    });
    group.bench_function("value_gradient/rust", |b| {
        b.iter(|| {
            for (o, p) in grads.iter_mut().zip(black_box(&pts)) {
                *o = grad(*p);
            }
        })
    });
    for (engine, label) in [
        (Engine::Native, "jit"),
        (Engine::Interpreter, "interpreter"),
    ] {
        surface.set_engine(engine);
        group.bench_function(format!("value/{label}"), |b| {
            b.iter(|| surface.value_batch(black_box(&pts), &mut values))
        });
        group.bench_function(format!("value_gradient/{label}"), |b| {
            b.iter(|| surface.value_gradient_batch(black_box(&pts), &mut grads))
        });
        group.bench_function(format!("value_gradient_single/{label}"), |b| {
            b.iter(|| {
                for (o, p) in grads.iter_mut().zip(black_box(&pts)) {
                    *o = surface.value_gradient(*p);
                }
            })
        });
    }
    group.bench_function("compile_jit", |b| {
        b.iter(|| NativeTape::new(black_box(surface.tape())).unwrap())
    });
    group.finish();
}

fn benches(c: &mut Criterion) {
    bench_surface(
        c,
        "genus3",
        (GENUS3, "genus3"),
        (DVec3::new(-6.5, -4.0, -2.0), DVec3::new(6.5, 4.0, 2.0)),
        genus3_value,
        genus3_grad,
    );
    bench_surface(
        c,
        "blend",
        (BLEND, "cylinder_blend"),
        (DVec3::splat(-3.0), DVec3::splat(3.0)),
        blend_value,
        blend_grad,
    );
}

criterion_group!(eval, benches);
criterion_main!(eval);
