//! Every tolerance of the numerical solvers, named once. Lengths are relative to a length
//! scale the caller passes (the mesh step), so the solvers behave alike at every scale.

/// Settings of the surfacepoint projection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePointTolerance {
    /// Stop when a Newton step is shorter than `relative_step * scale`. Default 1e-12: one
    /// more (quadratically convergent) step then leaves |f|/|∇f| far below 1e-9·step.
    pub relative_step: f64,
    /// Give up after this many Newton steps. Default 64.
    pub max_iterations: u32,
    /// |∇f| below `zero_gradient * |f|/scale`, or exactly zero, counts as a vanishing
    /// gradient. Default 1e-14.
    pub zero_gradient: f64,
}

impl Default for SurfacePointTolerance {
    fn default() -> Self {
        SurfacePointTolerance {
            relative_step: 1e-12,
            max_iterations: 64,
            zero_gradient: 1e-14,
        }
    }
}
