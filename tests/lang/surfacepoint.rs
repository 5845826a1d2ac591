//! surfacepoint on compiled surfaces: from points up to one step away from the sphere, the
//! torus and the genus-3 surface it converges in a few Newton steps to |f|/|∇f| ≤ 1e-12 of the
//! model size; where the gradient vanishes it reports an error instead of looping.

use crate::common::rng::Rng;
use crate::common::sources as common;

use common::{GENUS3, SPHERE, TORUS, program, surface_id};
use glam::DVec3;
use surfc::eval::Engine;
use surfc::sema::program::SurfaceRef;
use surfc::solve::tolerance::SurfacePointTolerance;
use surfc::solve::{SurfacePointError, surface_point};
use surfc::surface::compiled::CompiledSurface;
use surfc::surface::compiled::compile_surface;
use surfc::surface::{Surface, ValueGrad};

/// Most Newton steps (gradient evaluations) a start within one step may take.
const MAX_STEPS: u32 = 8;
/// |f|/|∇f| at the result, relative to the model size.
const RESIDUAL: f64 = 1e-12;

fn compiled(source: &str, name: &str) -> CompiledSurface {
    let p = program(source);
    let mut no_dist =
        |_: &SurfaceRef| -> Result<Box<dyn Surface>, std::convert::Infallible> { unreachable!() };
    compile_surface(&p, &SurfaceRef::Surface(surface_id(&p, name)), &mut no_dist).unwrap()
}

/// Counts the value+gradient evaluations (one per Newton step).
struct Counting<'s> {
    inner: &'s mut CompiledSurface,
    calls: u32,
}

impl Surface for Counting<'_> {
    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        self.calls += 1;
        self.inner.value_gradient(p)
    }
}

/// Projects starts p + s·step·(random direction), s ≤ 1, for each surface point p, with
/// each engine.
fn converges_from_one_step_away(
    surface: &mut CompiledSurface,
    on_surface: &[DVec3],
    step: f64,
    size: f64,
) {
    for engine in [Engine::Native, Engine::Interpreter] {
        surface.set_engine(engine);
        converges_on_engine(surface, on_surface, step, size);
    }
}

fn converges_on_engine(surface: &mut CompiledSurface, on_surface: &[DVec3], step: f64, size: f64) {
    let tol = SurfacePointTolerance::default();
    let mut rng = Rng::new(42);
    let mut worst = 0;
    for &p in on_surface {
        let q = p + rng.direction() * step * rng.range(0.0, 1.0);
        let mut counting = Counting {
            inner: surface,
            calls: 0,
        };
        let sp = surface_point(&mut counting, q, step, &tol)
            .unwrap_or_else(|e| panic!("from {q} (near {p}): {e}"));
        worst = worst.max(counting.calls);
        assert!(
            counting.calls <= MAX_STEPS,
            "{} steps from {q}",
            counting.calls
        );
        let vg = surface.value_gradient(sp.point);
        let residual = vg.value.abs() / vg.gradient.length();
        assert!(
            residual <= RESIDUAL * size,
            "residual {residual} at {}",
            sp.point
        );
        assert!((sp.normal - vg.gradient.normalize()).length() < 1e-9);
        assert!(sp.t1.dot(sp.normal).abs() < 1e-12 && sp.t2.dot(sp.normal).abs() < 1e-12);
        assert!((sp.point - q).length() <= 2.0 * step);
    }
    assert!(worst >= 2, "the starts were not off the surface");
    eprintln!("most Newton steps: {worst}");
}

#[test]
fn sphere() {
    let mut s = compiled(SPHERE, "sphere");
    let mut rng = Rng::new(1);
    let points: Vec<DVec3> = (0..300).map(|_| rng.direction() * 2.0).collect();
    converges_from_one_step_away(&mut s, &points, 0.3, 4.0);
}

#[test]
fn torus() {
    let mut s = compiled(TORUS, "torus");
    let mut rng = Rng::new(2);
    let (r, a) = (1.0, 0.35);
    let points: Vec<DVec3> = (0..300)
        .map(|_| {
            let (t, f) = (rng.range(0.0, 6.3), rng.range(0.0, 6.3));
            DVec3::new(
                (r + a * f.cos()) * t.cos(),
                (r + a * f.cos()) * t.sin(),
                a * f.sin(),
            )
        })
        .collect();
    // Step 0.1 as in the gallery: one step is well inside the tube of radius 0.35.
    converges_from_one_step_away(&mut s, &points, 0.1, 2.7);
}

#[test]
fn genus3() {
    let mut s = compiled(GENUS3, "genus3");
    let mut rng = Rng::new(3);
    // Points over (x, y) where the product is positive: z = ±sqrt(product)/rz².
    let mut points = Vec::new();
    while points.len() < 300 {
        let (x, y) = (rng.range(-6.0, 6.0), rng.range(-3.5, 3.5));
        let a = 1.0 - (x / 6.0f64).powi(2) - (y / 3.5f64).powi(2);
        let c = |x0: f64| (x - x0).powi(2) + y * y - 1.44;
        let prod = a * c(3.9) * c(0.0) * c(-3.9);
        if prod > 1.0 {
            let z = prod.sqrt() / 16.0;
            points.push(DVec3::new(x, y, if rng.unit() < 0.5 { z } else { -z }));
        }
    }
    // The gallery's step 0.3; the surface is about 12 long.
    converges_from_one_step_away(&mut s, &points, 0.3, 12.0);
}

#[test]
fn vanishing_gradient_is_reported() {
    for engine in [Engine::Native, Engine::Interpreter] {
        vanishing_gradient_is_reported_on(engine);
    }
}

fn vanishing_gradient_is_reported_on(engine: Engine) {
    let compiled = |source: &str, name: &str| {
        let mut s = compiled(source, name);
        s.set_engine(engine);
        s
    };
    let tol = SurfacePointTolerance::default();
    let mut sphere = compiled(SPHERE, "sphere");
    let e = surface_point(&mut sphere, DVec3::ZERO, 0.3, &tol).unwrap_err();
    assert_eq!(e, SurfacePointError::ZeroGradient { at: DVec3::ZERO });
    let mut cone = compiled("surface cone = x^2 + y^2 - z^2;", "cone");
    let e = surface_point(&mut cone, DVec3::ZERO, 0.3, &tol).unwrap_err();
    assert_eq!(e.location(), DVec3::ZERO);
    assert!(matches!(e, SurfacePointError::ZeroGradient { .. }));
    // No real surface at all: Newton wanders, and stops at the iteration cap at the latest.
    let mut empty = compiled("surface none = x^2 + 1;", "none");
    let e = surface_point(&mut empty, DVec3::new(0.3, 0.0, 0.0), 0.3, &tol).unwrap_err();
    assert!(
        matches!(
            e,
            SurfacePointError::NoConvergence { iterations: 64, .. }
                | SurfacePointError::ZeroGradient { .. }
        ),
        "{e}"
    );
    // Outside the function's domain: NaN is reported, not followed.
    let mut root = compiled("surface root = sqrt(x) - 1;", "root");
    let e = surface_point(&mut root, DVec3::new(-1.0, 0.0, 0.0), 0.3, &tol).unwrap_err();
    assert!(matches!(e, SurfacePointError::NotFinite { .. }), "{e}");
}
