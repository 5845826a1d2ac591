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
            let normal = g / g2.sqrt();
            let (t1, t2) = tangent_frame(normal);
            return Ok(SurfacePoint {
                point: u - delta,
                normal,
                t1,
                t2,
            });
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
