//! The marching method of E. Hartmann (paper Sect. 2): an advancing front of near-equilateral
//! triangles over a surface it sees only through the `Surface` oracle and surfacepoint.
//!
//! Input: a step δ, a start (a point near the surface, or a first front polygon), optional
//! bounding polygons and a box. Output: a `Mesh` whose triangles are oriented so that their
//! normals agree with ∇f, or a `MarchError` that says why and where it stopped.
//!
//! Orientation rule for polygons (front and bounds): walking along the polygon, seen from the
//! side ∇f points to, the area to be meshed lies on the LEFT — the polygon runs the way the
//! boundary edges of the resulting triangles run. Polygon vertices become mesh vertices with
//! bit-identical coordinates, first the front's, then each bound's in the order given;
//! vertices with bit-identical coordinates in several polygons are one mesh vertex.
//!
//! After the march a repair pass (`improve`) flips edges of and moves free corners of
//! triangles below `MarchSettings::improve_angle`, keeping the topology and polygon vertices.
//!
//! `SURFC_TRACE=1` in the environment prints a step-by-step trace to stderr.

pub mod angle;
pub mod guard;
pub mod hash;
mod improve;
mod marcher;
pub mod ring;
pub mod settings;

use glam::DVec3;

pub use ring::{FrontId, NodeId, PointId};
pub use settings::MarchSettings;

use crate::mesh::Mesh;
use crate::solve::SurfacePointError;
use crate::surface::Surface;

/// Where the triangulation starts.
#[derive(Clone, Debug, PartialEq)]
pub enum Start {
    /// A point near the surface: the paper's Step 0 puts a hexagon around its surface point.
    Point(DVec3),
    /// A closed polygon on the surface (last vertex not repeated) as the first actual front;
    /// the area to its left (seen from where ∇f points) is meshed.
    Front(Vec<DVec3>),
}

/// What to triangulate.
#[derive(Clone, Debug, PartialEq)]
pub struct MarchInput {
    /// The step δ, ≈ the edge length of the triangles.
    pub step: f64,
    pub start: Start,
    /// Bounding front polygons (each closed, on the surface, area to mesh on its left).
    pub bounds: Vec<Vec<DVec3>>,
    /// A global bounding box (lo, hi): the mesh stops at its faces.
    pub bbox: Option<(DVec3, DVec3)>,
    /// Overrides the default limit: `MarchSettings::max_triangles`, or with a box what the
    /// box can hold (`guard::default_limit`).
    pub max_triangles: Option<u64>,
}

impl MarchInput {
    /// A closed-surface run from a start point.
    pub fn from_point(step: f64, start: DVec3) -> Self {
        MarchInput {
            step,
            start: Start::Point(start),
            bounds: Vec::new(),
            bbox: None,
            max_triangles: None,
        }
    }
}

/// Which input polygon an error refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PolygonRole {
    Front,
    /// Index into `MarchInput::bounds`.
    Bound(usize),
}

impl std::fmt::Display for PolygonRole {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PolygonRole::Front => write!(f, "the front polygon"),
            PolygonRole::Bound(i) => write!(f, "bound polygon {i}"),
        }
    }
}

/// Why a triangulation could not be completed. Input errors name the input; numerical ones
/// say where on the surface they happened.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MarchError {
    #[error("the step {step} is not a positive finite number")]
    InvalidStep { step: f64 },
    #[error("the box {lo} .. {hi} is empty or not finite")]
    InvalidBox { lo: DVec3, hi: DVec3 },
    #[error("no surface point found from the start {start}: {source}")]
    Start {
        start: DVec3,
        source: SurfacePointError,
    },
    #[error("the surface point {at} of the start lies outside the box")]
    StartOutsideBox { at: DVec3 },
    #[error("{polygon} has {len} vertices; a closed polygon needs at least 3")]
    PolygonTooShort { polygon: PolygonRole, len: usize },
    #[error(
        "{polygon}: the edge from vertex {index} at {at} is {length} long, far from the step {step} (allowed {min} .. {max})"
    )]
    PolygonSpacing {
        polygon: PolygonRole,
        index: usize,
        at: DVec3,
        length: f64,
        step: f64,
        min: f64,
        max: f64,
    },
    #[error("{polygon}: vertex {index} at {at} is {distance:e} off the surface")]
    PolygonOffSurface {
        polygon: PolygonRole,
        index: usize,
        at: DVec3,
        distance: f64,
    },
    #[error("{polygon}: the gradient at vertex {index} ({at}) is zero or not finite")]
    PolygonGradient {
        polygon: PolygonRole,
        index: usize,
        at: DVec3,
    },
    #[error("a new front point near {near} could not be put on the surface: {source}")]
    NewPoint {
        near: DVec3,
        source: SurfacePointError,
    },
    #[error("more than {limit} triangles (the front was last advanced at {at})")]
    TooManyTriangles { limit: u64, at: DVec3 },
    #[error(
        "the surface is unbounded here, add a box: after {triangles} triangles the mesh is {extent:.3e} across and still growing (the front was last advanced at {at})"
    )]
    Unbounded {
        at: DVec3,
        triangles: u64,
        /// The diagonal of the mesh's bounding box.
        extent: f64,
    },
    #[error(
        "the front keeps overlapping itself near {at}: the step is too coarse for the surface there ({triangles} triangles in {lo} .. {hi}, more than that region holds at this step)"
    )]
    Overlapping {
        at: DVec3,
        triangles: u64,
        lo: DVec3,
        hi: DVec3,
    },
    #[error(
        "the front stopped making progress near {at} after {iterations} steps without a triangle"
    )]
    Stalled { at: DVec3, iterations: u64 },
}

/// Triangulates `surface` as `input` says (paper Sect. 2).
pub fn march(
    surface: &mut dyn Surface,
    input: &MarchInput,
    settings: &MarchSettings,
) -> Result<Mesh, MarchError> {
    marcher::run(surface, input, settings)
}
