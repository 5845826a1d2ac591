//! surfacepoint (paper Sect. 2.2): from a point q near the surface, Newton steps along the
//! gradient, u ← u − f(u)/|∇f(u)|² ∇f(u), to a surface point p, with the unit normal and two
//! tangents there. A start that does not converge is an error that says why and where.

use glam::DVec3;

use super::tolerance::SurfacePointTolerance;
use crate::surface::Surface;

/// A point on the surface with its orthonormal frame (normal, t1, t2), t2 = n × t1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub point: DVec3,
    pub normal: DVec3,
    pub t1: DVec3,
    pub t2: DVec3,
}

/// Why surfacepoint failed; each variant says where.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum SurfacePointError {
    #[error(
        "no convergence after {iterations} Newton steps from {start}: last point {last}, last step {last_step:e}"
    )]
    NoConvergence {
        start: DVec3,
        last: DVec3,
        iterations: u32,
        last_step: f64,
    },
    #[error("the gradient vanishes at {at} (a singular point of the surface?)")]
    ZeroGradient { at: DVec3 },
    #[error("the surface function is not finite at {at} (value {value}, outside its domain?)")]
    NotFinite { at: DVec3, value: f64 },
}

impl SurfacePointError {
    /// The point where it happened.
    pub fn location(&self) -> DVec3 {
        match *self {
            SurfacePointError::NoConvergence { last, .. } => last,
            SurfacePointError::ZeroGradient { at } | SurfacePointError::NotFinite { at, .. } => at,
        }
    }
}

/// The paper's surfacepoint. `scale` is the length the tolerances are relative to (the step).
pub fn surface_point(
    surface: &mut dyn Surface,
    q: DVec3,
    scale: f64,
    tolerance: &SurfacePointTolerance,
) -> Result<SurfacePoint, SurfacePointError> {
    let (point, normal) = surface_point_and_normal(surface, q, scale, tolerance)?;
    let (t1, t2) = tangent_frame(normal);
    Ok(SurfacePoint {
        point,
        normal,
        t1,
        t2,
    })
}

/// [`surface_point`]'s point and unit normal, without the tangents (for callers that move
/// many points and need no frame: the quality stage's smoothing).
pub fn surface_point_and_normal(
    surface: &mut dyn Surface,
    q: DVec3,
    scale: f64,
    tolerance: &SurfacePointTolerance,
) -> Result<(DVec3, DVec3), SurfacePointError> {
    let mut u = q;
    let mut last_step = f64::INFINITY;
    for _ in 0..tolerance.max_iterations {
        let vg = surface.value_gradient(u);
        let (f, g) = (vg.value, vg.gradient);
        if !f.is_finite() || !g.is_finite() {
            return Err(SurfacePointError::NotFinite { at: u, value: f });
        }
        let g2 = g.length_squared();
        if g2 == 0.0 || g2.sqrt() * scale < tolerance.zero_gradient * f.abs() {
            return Err(SurfacePointError::ZeroGradient { at: u });
        }
        let delta = g * (f / g2);
        last_step = delta.length();
        // Rounding bounds how small a step can get: a few ulps of the point's coordinates.
        let floor = 8.0 * f64::EPSILON * u.abs().max_element();
        if last_step <= (tolerance.relative_step * scale).max(floor) {
            return Ok((u - delta, g / g2.sqrt()));
        }
        u -= delta;
    }
    Err(SurfacePointError::NoConvergence {
        start: q,
        last: u,
        iterations: tolerance.max_iterations,
        last_step,
    })
}

/// Why no surface point was found near a start point, after [`surface_point_near`] retried
/// from the points around it.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("no surface point found from {start} ({}) nor from {retries} points around it: {first}", describe_distance(*.value, *.gradient))]
pub struct StartError {
    pub start: DVec3,
    /// f and |∇f| at the start (how far from the surface it is: about |f|/|∇f|).
    pub value: f64,
    pub gradient: f64,
    /// Points tried around the start.
    pub retries: usize,
    /// Why surfacepoint failed from the start itself.
    pub first: SurfacePointError,
}

fn describe_distance(value: f64, gradient: f64) -> String {
    if !value.is_finite() {
        format!("where f is {value}")
    } else if gradient > 0.0 && gradient.is_finite() {
        format!(
            "about {:.3} from the surface: f = {value:.3}, |∇f| = {gradient:.3}",
            value.abs() / gradient
        )
    } else {
        format!("where f = {value:.3} and the gradient vanishes")
    }
}

/// How far the retries of [`surface_point_near`] move from the start, in steps: half a step
/// first (off a centre of symmetry, where the gradient vanishes), then two (past a local
/// feature that sends Newton astray).
const RETRY_DISTANCES: [f64; 2] = [0.5, 2.0];

/// surfacepoint from `q`, and if that fails, from the points `RETRY_DISTANCES` steps away
/// along ±x, ±y, ±z (in that order; the first that converges wins). A start at the centre of
/// a sphere, where the gradient vanishes, thus still finds the sphere.
pub fn surface_point_near(
    surface: &mut dyn Surface,
    q: DVec3,
    scale: f64,
    tolerance: &SurfacePointTolerance,
) -> Result<SurfacePoint, StartError> {
    let first = match surface_point(surface, q, scale, tolerance) {
        Ok(sp) => return Ok(sp),
        Err(e) => e,
    };
    let axes = [
        DVec3::X,
        -DVec3::X,
        DVec3::Y,
        -DVec3::Y,
        DVec3::Z,
        -DVec3::Z,
    ];
    let mut retries = 0;
    for r in RETRY_DISTANCES {
        for d in axes {
            retries += 1;
            if let Ok(sp) = surface_point(surface, q + d * (r * scale), scale, tolerance) {
                return Ok(sp);
            }
        }
    }
    let vg = surface.value_gradient(q);
    Err(StartError {
        start: q,
        value: vg.value,
        gradient: vg.gradient.length(),
        retries,
        first,
    })
}

/// The paper's tangents for a unit normal n, with the absolute values its text lacks (without
/// them t1 degenerates for n ≈ (0, −1, 0)): t1 ⊥ n, t2 = n × t1, both unit.
pub fn tangent_frame(n: DVec3) -> (DVec3, DVec3) {
    let t1 = if n.x.abs() > 0.5 || n.y.abs() > 0.5 {
        DVec3::new(n.y, -n.x, 0.0)
    } else {
        DVec3::new(-n.z, 0.0, n.x)
    }
    .normalize();
    (t1, n.cross(t1))
}
