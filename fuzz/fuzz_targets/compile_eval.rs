//! Arbitrary bytes → a checked program → every surface without `dist` compiled and evaluated
//! by both engines (the bytecode interpreter and the native code) at fixed and fuzzed points:
//! never a panic; values equal bit for bit (any NaN equals any NaN), gradients equal up to
//! the sign of zero.
#![no_main]

use glam::DVec3;
use libfuzzer_sys::fuzz_target;
use surfc::surface::compiled::compile_surface;
use surfc::eval::Engine;
use surfc::sema::program::{SurfaceId, SurfaceRef};
use surfc::surface::Surface;
use surfc::{diag, sema, syntax};

/// At most this many surfaces of one input are compiled (each native compile costs time).
const MAX_SURFACES: usize = 4;

fn same_value(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// Equal, or both NaN; +0 and −0 are equal (the engines may differ in a zero's sign).
fn same_partial(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = syntax::source_text(data) else {
        return;
    };
    let (Some(file), diags) = syntax::parse(text) else {
        return;
    };
    let (program, more) = sema::check(&file);
    if diag::has_errors(&diags) || diag::has_errors(&more) {
        return;
    }
    let seed = data.iter().fold(0xcbf2_9ce4_8422_2325_u64, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    });
    let fuzzed = DVec3::new(
        f64::from_bits(seed),
        f64::from_bits(seed.rotate_left(21)),
        f64::from_bits(seed.rotate_left(42)),
    );
    let points = [
        DVec3::ZERO,
        DVec3::new(-0.0, 0.0, -0.0),
        DVec3::new(1.0, 2.0, 3.0),
        DVec3::new(-0.5, 0.25, 1e-3),
        DVec3::new(1e10, -1e10, 3.0),
        DVec3::new(1e-310, -1e300, 7.5),
        DVec3::new(f64::INFINITY, 0.0, 1.0),
        DVec3::new(f64::NAN, 1.0, 1.0),
        fuzzed,
        DVec3::new(
            (seed % 2001) as f64 / 100.0 - 10.0,
            (seed / 2001 % 2001) as f64 / 100.0 - 10.0,
            (seed / 4_004_001 % 2001) as f64 / 100.0 - 10.0,
        ),
    ];
    for k in 0..program.surfaces.len().min(MAX_SURFACES) {
        let r = SurfaceRef::Surface(SurfaceId(k as u32));
        // Surfaces with dist() children are left out: their foot points are the meshing
        // target's concern, and both engines share the child's code.
        let Ok(mut s) = compile_surface(&program, &r, &mut |_: &SurfaceRef| {
            Err::<Box<dyn Surface>, _>("no dist() here")
        }) else {
            continue;
        };
        let mut results = Vec::new();
        for engine in [Engine::Interpreter, Engine::Native] {
            s.set_engine(engine);
            let single: Vec<_> = points
                .iter()
                .map(|&p| (s.value(p), s.value_gradient(p)))
                .collect();
            let mut values = vec![0.0; points.len()];
            s.value_batch(&points, &mut values);
            for (i, (v, _)) in single.iter().enumerate() {
                assert!(
                    same_value(*v, values[i]),
                    "{engine:?}: batch value {} vs {v}",
                    values[i]
                );
            }
            results.push(single);
        }
        for (i, ((v1, g1), (v2, g2))) in results[0].iter().zip(&results[1]).enumerate() {
            let p = points[i];
            assert!(
                same_value(*v1, *v2),
                "values at {p}: interpreter {v1}, native {v2}\n{text}"
            );
            assert!(
                same_value(g1.value, g2.value),
                "value of value_gradient at {p}\n{text}"
            );
            for a in 0..3 {
                assert!(
                    same_partial(g1.gradient[a], g2.gradient[a]),
                    "gradient at {p}: interpreter {}, native {}\n{text}",
                    g1.gradient,
                    g2.gradient
                );
            }
        }
    }
});
