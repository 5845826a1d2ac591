//! Numerical solvers on top of the surface oracle: Hartmann's surfacepoint projection (paper
//! Sect. 2.2), foot points on smooth surfaces, patches and surfaces with creases (`solid`),
//! and curve tracing. Tolerances are named in `tolerance`.

pub mod curve;
pub mod foot;
pub mod solid;
pub mod surfacepoint;
pub mod tolerance;

pub use foot::{
    Curvature, Foot, FootError, PatchFoot, PatchFootError, PatchGrid, foot_point,
    foot_point_hinted, patch_foot,
};
pub use surfacepoint::{
    StartError, SurfacePoint, SurfacePointError, surface_point, surface_point_and_normal,
    surface_point_near, tangent_frame,
};
