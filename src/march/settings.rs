//! Every threshold of the marching method, named once. Lengths are multiples of the step δ,
//! angles are in radians, so the marcher behaves alike at every scale. docs/marcher.md says
//! why each default was chosen.

use crate::solve::tolerance::SurfacePointTolerance;
use crate::survey::sizing::SizingSettings;

/// The quality stage's default aim for the mean radius ratio: docs/quality.md's bar of 0.97
/// with a margin. Also the least aim the cut into slabs holds the joined slabs to (less a
/// margin, `pipeline::pieces`) and where a higher aim's centroid rounds start.
pub const DEFAULT_QUALITY_RATIO: f64 = 0.975;

/// Settings of `march::march`. `Default` gives the values the tests were run with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarchSettings {
    /// Step 2: two front points are "near" when closer than `near_distance · δ`.
    /// Default 1.0, the paper's δ. (The 0.7 of public re-implementations let fronts come
    /// within 0.1–0.2 δ before joining on the torus and genus 3 tests, leaving triangles of
    /// 5–12°; at 1.0 every test keeps its smallest angle above 15°.)
    pub near_distance: f64,
    /// Step 2: near points must see each other across the surface: the midpoint of their
    /// chord within `near_midpoint`·|a − b| of the surface (|f|/|∇f|). On one sheet that
    /// distance is the chord's sagitta, d/8 · d/ρ (≤ 0.07 d where the local step follows the
    /// curvature); across a gap between two sheets it is half the gap (≥ d/2 for pairs
    /// straight across). Default 0.3.
    pub near_midpoint: f64,
    /// Step 2: near points must have normals with n_a · n_b above this (cosine). Default 0.3:
    /// two sheets of a surface that pass close to each other with opposed normals are never
    /// joined.
    pub near_normal_cos: f64,
    /// Remark 2: points whose front angle is below this are completed before any distance
    /// check. Default 1.05 rad (≈ 60°, the paper's "about 60°").
    pub small_angle: f64,
    /// Step 3: if Δω < `min_delta_angle` and n_t > 1, one triangle fewer. Default 0.8 rad
    /// (paper).
    pub min_delta_angle: f64,
    /// Step 3: a single triangle whose opposite edge would exceed `split_gap · δ` is split
    /// into two. Default 1.2 (paper).
    pub split_gap: f64,
    /// Step 3: a front angle below `close_angle` with a neighbour within
    /// `close_neighbour · δ` always gets one triangle. Default 3.0 rad (paper).
    pub close_angle: f64,
    /// Step 3: see `close_angle`. Default 0.5 (paper).
    pub close_neighbour: f64,
    /// Step 3: a point whose front angle is below this, with neighbours closer than
    /// `close_neighbour`·δ to each other, is not completed with a sliver; the newer
    /// neighbour is merged into the older instead. Default 0.35 rad (20°).
    pub collapse_angle: f64,
    /// Box: a new point closer than `box_snap · δ` to a face of the box is moved onto the
    /// face (a border point), so that no edge between it and the border shrinks to a sliver.
    /// Default 0.3.
    pub box_snap: f64,
    /// The quality stage after the march (`improve/`): the smallest angle it aims at;
    /// triangles below it after flips and smoothing get a new vertex. Default 0.524 rad
    /// (30.02°, CGAL's bound, docs/quality.md, with a margin for rounding). 0 turns the stage
    /// off.
    pub quality_angle: f64,
    /// Rounds of the quality stage (flips, smoothing, insertion; the last round does not
    /// insert). Default 6.
    pub quality_rounds: u32,
    /// The mean radius ratio the quality stage raises a mesh to once its angles are mended:
    /// rounds of smoothing towards the rings' centroids where they can reach it, and the
    /// costlier ratios' phase only for a mesh still below it (or with a triangle still below
    /// the angle). Default `DEFAULT_QUALITY_RATIO`. At 1 every mesh gets every phase (a mesh
    /// block's `radius_ratio:`).
    pub quality_ratio: f64,
    /// The quality stage inserts at most this fraction of the triangle count (plus 64) as
    /// new vertices. Default 0.05.
    pub quality_insert: f64,
    /// Largest number of triangles before the marcher gives up without a box
    /// (`MarchInput::max_triangles` overrides it; with a box the default is what the box can
    /// hold, `guard::default_limit`, at most this). Default 10 000 000 (a sphere at step
    /// radius/500; ~10 s).
    pub max_triangles: u64,
    /// A front or bound polygon's edges must be between `polygon_edge_min · δ` and
    /// `polygon_edge_max · δ` long. Defaults 0.25 and 2.5.
    pub polygon_edge_min: f64,
    /// See `polygon_edge_min`.
    pub polygon_edge_max: f64,
    /// Polygon vertices must lie on the surface: |f|/|∇f| ≤ `polygon_on_surface · δ`.
    /// Default 1e-6.
    pub polygon_on_surface: f64,
    /// The surfacepoint tolerances (relative to δ).
    pub surface_point: SurfacePointTolerance,
    /// The local step (`survey::sizing`), unless `MarchInput::uniform`.
    pub sizing: SizingSettings,
    /// The default `tolerance` (largest chord error) relative to the step. Default 0.1
    /// (CGAL's distance criterion in the comparison; the paper's sphere and torus
    /// meet it at their steps).
    pub tolerance: f64,
    /// A mesh that fails its verification is re-marched with the local step capped near the
    /// failures, at most this many times, then refused. Default 4. Triangles the quality
    /// stage leaves below `quality_angle` with only free corners are refined the same way
    /// (while that lowers their number; then the right mesh is returned with a warning).
    pub refine_rounds: u32,
    /// A failure caps the local step near it at this fraction of the step its triangle was
    /// made with. Default 0.5.
    pub refine_factor: f64,
    /// Parallel pieces (`pipeline::pieces`): a component marched from a start point whose
    /// estimated triangle count (its area over √3/4·δ², from a coarse survey) is above this is
    /// cut along planes into slabs marched on separate threads. Default 50 000 (the three
    /// cylinders in their box at step 0.1, 120 k triangles, are cut in two; no gallery example
    /// is). `u64::MAX` never cuts.
    pub pieces_above: u64,
    /// The triangles a slab is cut for: a component is cut into ⌈estimate / this⌉ slabs
    /// rounded up to a power of two (so that 2, 4, 8 threads share them evenly), at least 2
    /// and at most `pieces_max`. Default 200 000.
    pub piece_triangles: u64,
    /// The most slabs a component is cut into. Default 16: on a mesh of a few million
    /// triangles, a slab for each core of a machine of 8–16 (docs/pieces.md). Below 2 nothing
    /// is cut.
    pub pieces_max: u32,
}

impl MarchSettings {
    /// Whether rounder triangles than the default's are asked for (a `radius_ratio:` above
    /// `DEFAULT_QUALITY_RATIO`): the quality stage's second pass (`improve`), and finer
    /// slabs with polished seams (`pipeline::pieces`).
    pub fn above_default_aim(&self) -> bool {
        self.quality_ratio > DEFAULT_QUALITY_RATIO
    }
}

impl Default for MarchSettings {
    fn default() -> Self {
        MarchSettings {
            near_distance: 1.0,
            near_normal_cos: 0.3,
            small_angle: 1.05,
            min_delta_angle: 0.8,
            split_gap: 1.2,
            close_angle: 3.0,
            close_neighbour: 0.5,
            collapse_angle: 0.35,
            box_snap: 0.3,
            quality_angle: 0.524,
            quality_rounds: 6,
            quality_ratio: DEFAULT_QUALITY_RATIO,
            quality_insert: 0.05,
            max_triangles: 10_000_000,
            polygon_edge_min: 0.25,
            polygon_edge_max: 2.5,
            polygon_on_surface: 1e-6,
            surface_point: SurfacePointTolerance::default(),
            near_midpoint: 0.3,
            sizing: SizingSettings::default(),
            tolerance: 0.1,
            refine_rounds: 4,
            refine_factor: 0.5,
            pieces_above: 50_000,
            piece_triangles: 200_000,
            pieces_max: 16,
        }
    }
}
