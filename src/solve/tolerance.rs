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

/// Settings of the foot-point search on an implicit surface (`solve::foot`) and of the
/// distance surfaces built on it (`surface::dist`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FootTolerance {
    /// The length every other length here is relative to: the mesh step when one is known.
    /// Default 1.0 (object-space units).
    pub scale: f64,
    /// Converged when the tangential part of x − q (the component of x − q perpendicular to
    /// the normal at q) is shorter than `relative_residual * scale`, or than the rounding floor
    /// of the coordinates. Default 1e-12: the foot point is then exact to ~1e-12·scale, the
    /// distance (second order in that error) to rounding, the normal to ~1e-12·scale·κ.
    pub relative_residual: f64,
    /// Give up after this many outer (tangent-plane Newton) iterations. Default 50.
    pub max_iterations: u32,
    /// Step of the central differences of the gradient that estimate the curvature of the
    /// surface at q, relative to `scale`. Default 1e-5: truncation error ~1e-10 relative,
    /// rounding error ~1e-11; the estimate only sets the convergence rate, never the result.
    pub hessian_step: f64,
    /// A curvature estimate is reused (not re-measured, saving four gradient evaluations)
    /// while the iterate stays within `curvature_reuse * scale` of where it was measured,
    /// also across warm-started queries. Default 1e-3: the outdated estimate then slows the
    /// quadratic convergence to a linear rate of ~1e-3·|d|·|∇κ|, still a few iterations.
    pub curvature_reuse: f64,
    /// Smallest eigenvalue the tangential Newton matrix I + d·W (W the Weingarten map, d the
    /// signed distance) is allowed before it is shifted up to it, dimensionless. Near a focal
    /// point it tends to 0 and a raw Newton step would be huge; steps are also capped at
    /// 2|x − q| and backtracked. Default 1e-3: near the medial axis (x close to the axis of
    /// a torus) the true eigenvalue is that small, and a larger floor shrinks the steps into
    /// a crawl (0.25 left 12 % of such points unconverged after 50 iterations).
    pub min_newton_eigenvalue: f64,
    /// A converged point where I + d·W has an eigenvalue below `-saddle_eigenvalue` is a
    /// saddle or maximum of the distance (a critical point on the far side), not a foot point:
    /// the search steps off it along that eigenvector. Dimensionless. Default 1e-6.
    pub saddle_eigenvalue: f64,
    /// Halvings of a step that would increase the distance before giving up. Default 30.
    pub max_backtracks: u32,
    /// A query within `warm_radius * scale` of the previous query starts from the previous
    /// foot point instead of surfacepoint(x). Default 1.0.
    pub warm_radius: f64,
    /// Warm starts are used only when the previous foot point was regular: the smallest
    /// eigenvalue of I + d·W there at least this (dimensionless; 1 on a plane, 0 at a focal
    /// point). Default 0.5: x lies well inside the tubular neighbourhood of radius 1/κ where
    /// the nearest point is locally unique, so the warm and the cold search find the same
    /// foot point.
    pub warm_min_eigenvalue: f64,
    /// The global phase (`solve::foot`): after the local search found a foot at distance |d|,
    /// f is sampled along 26 fixed rays from x at radius `global_margin * |d|`, and a sign
    /// change starts another local search there (a nearer sheet crosses that ray).
    /// Dimensionless; 0 disables the phase. Default 1.25: a flat sheet nearer than the found
    /// one is crossed by a ray within 37° of its normal, and every direction is within ≈ 28°
    /// of one of the rays.
    pub global_margin: f64,
    /// Rays within this cosine of the direction from x to the found foot point are not sampled:
    /// their crossing is that foot's own sheet. Default 0.7 (≈ 45°).
    pub global_skip_cos: f64,
    /// The surfacepoint projection used inside the search (its `scale` is `scale` above).
    pub surface_point: SurfacePointTolerance,
}

impl Default for FootTolerance {
    fn default() -> Self {
        FootTolerance {
            scale: 1.0,
            relative_residual: 1e-12,
            max_iterations: 50,
            hessian_step: 1e-5,
            curvature_reuse: 1e-3,
            min_newton_eigenvalue: 1e-3,
            saddle_eigenvalue: 1e-6,
            max_backtracks: 30,
            warm_radius: 1.0,
            warm_min_eigenvalue: 0.5,
            global_margin: 1.25,
            global_skip_cos: 0.7,
            surface_point: SurfacePointTolerance::default(),
        }
    }
}

/// Settings of the foot-point search on a parametric patch (`solve::foot::patch_foot`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchFootTolerance {
    /// Convergence, iteration cap, curvature step (here relative to the side lengths of the
    /// declared domain, in parameter units), clamping, backtracking and warm-start radius,
    /// with the meanings (and defaults) of `FootTolerance`; its `surface_point` and
    /// `warm_min_eigenvalue` are unused (a patch's warm start is only the first of several
    /// seeds, see `solve::foot::patch_foot`).
    pub foot: FootTolerance,
    /// Cells per side of the pre-search grid over the extended domain. Default 32
    /// ((32+1)² = 1089 patch evaluations per cold query).
    pub grid: u32,
    /// The pre-search covers the declared domain extended on every side by this fraction of
    /// that side's length. Default 0.25 (a 1.5 × 1.5 times larger rectangle).
    pub extension: f64,
    /// Newton runs from this many of the grid's best discrete local minima; the nearest result
    /// wins. Default 4.
    pub candidates: u32,
    /// |Pu × Pv| below `singular * |Pu| |Pv|` (the sine of the angle between the partials)
    /// is a singular parametrisation. Default 1e-12.
    pub singular: f64,
}

impl Default for PatchFootTolerance {
    fn default() -> Self {
        PatchFootTolerance {
            foot: FootTolerance::default(),
            grid: 32,
            extension: 0.25,
            candidates: 4,
            singular: 1e-12,
        }
    }
}

/// Settings of curve tracing and sampling (`solve::curve`). Lengths relative to the step δ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurveTolerance {
    /// A correction onto both surfaces stops when its Newton step is shorter than
    /// `relative_step * δ` (or the rounding floor); one more quadratic step follows implicitly.
    /// Default 1e-12.
    pub relative_step: f64,
    /// Newton iterations of one correction onto both surfaces. Default 32.
    pub max_corrector_iterations: u32,
    /// Newton iterations of the first search for a point on both surfaces from `near`.
    /// Default 200.
    pub max_seek_iterations: u32,
    /// Where that search stalls, the point counts as on both surfaces only if its first-order
    /// distance max |f_i|/|∇f_i| is below `meet_residual * δ`. Default 1e-6.
    pub meet_residual: f64,
    /// The sine of the angle between the two normals below which the tangent ∇f1 × ∇f2
    /// counts as vanishing (surfaces touching, or a singular point). Default 1e-6.
    pub tangent_sine: f64,
    /// Tracing steps per δ: the curve is traced at δ / `substeps` and then resampled
    /// uniformly by arc length. Default 4.
    pub substeps: u32,
    /// A tracing step is halved at most this many times before giving up. Default 20.
    pub max_halvings: u32,
    /// Largest angle between the tangents at the ends of one tracing step, radians.
    /// Default 0.3.
    pub max_turn: f64,
    /// Tracing gives up (no closure, no exit from the box) after this arc length, in units of
    /// δ. Default 1e5.
    pub max_length: f64,
    /// The curve has closed when a tracing step passes within `closure_radius` times its own
    /// length of the start point, after at least two tracing steps. Default 0.5.
    pub closure_radius: f64,
    /// Sliding along the curve towards `near`: iterations, and the stop when the tangential
    /// distance to `near` is below `relative_step * δ`. Default 100.
    pub max_slide_iterations: u32,
    /// Refuse to build polygons with more vertices than this (a tiny step on a huge curve).
    /// Default 10 000 000.
    pub max_vertices: usize,
}

impl Default for CurveTolerance {
    fn default() -> Self {
        CurveTolerance {
            relative_step: 1e-12,
            max_corrector_iterations: 32,
            max_seek_iterations: 200,
            meet_residual: 1e-6,
            tangent_sine: 1e-6,
            substeps: 4,
            max_halvings: 20,
            max_turn: 0.3,
            max_length: 1e5,
            closure_radius: 0.5,
            max_slide_iterations: 100,
            max_vertices: 10_000_000,
        }
    }
}

/// Settings of the foot-point search on a surface with creases (`solve::solid`): a solid's
/// faces, creases and corners.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolidFootTolerance {
    /// The face searches (`solve::foot`, on one form each), and the scale, convergence,
    /// iteration cap, Newton floor and backtracking of the crease searches (same meanings).
    pub foot: FootTolerance,
    /// A candidate lies on the surface when |f| ≤ `on_surface · scale · |∇f|` there; also
    /// the distance below which a crease's gradient is taken from f at x. Default 1e-10: the
    /// candidates are solved to ~1e-12·scale, and a point this close to the surface changes
    /// the distance by no more.
    pub on_surface: f64,
    /// At a candidate off the surface, the forms whose value is within
    /// `tie · scale · |∇|` of f's are the chosen ones (whose crease or corner is tried next).
    /// Default 1e-9: exact ties of the forms f picks from, with room for the rounding of
    /// their sums; a form counted that f does not pick only costs a solve.
    pub tie: f64,
    /// The first search radius without a warm hint, in units of |f(x)|/|∇f(x)| (the distance
    /// to the chosen form's zero to first order). Default 2: beyond a box's corner the foot is
    /// √3 times that away, on the cube of half-width 1 · that.
    pub first_radius: f64,
    /// While no candidate lies on the surface, the radius grows by this factor. Default 4.
    pub radius_growth: f64,
    /// Rounds of the radius before the search gives up. Default 40 (a radius 4⁴⁰ times the
    /// first one: past any surface in floating point).
    pub max_rounds: u32,
    /// Gauss–Newton steps onto two forms (a crease) or three (a corner). Default 32: each
    /// converges quadratically from within a fraction of a curvature radius.
    pub projection_iterations: u32,
    /// The step, relative to `foot.scale`, of the second difference along a crease that gives
    /// its curvature vector. Default 1e-4: rounding of the projections (~1e-16·|p|) over h²
    /// leaves ~1e-8 relative, and the estimate only sets the speed of convergence.
    pub curve_step: f64,
    /// Two normals whose sine is below this (three whose determinant is below it, relative to
    /// their lengths) define no crease (no corner). Default 1e-6, as for traced curves.
    pub tangent_sine: f64,
    /// The global phase does not search a face again from a ray's crossing whose unit normal
    /// is within this of the normal at the face's foot found from x, on that foot's tangent
    /// plane (within this times the scale): the same plane, where the search would end in
    /// the same foot. Default 1e-9.
    pub same_plane: f64,
}

impl Default for SolidFootTolerance {
    fn default() -> Self {
        SolidFootTolerance {
            foot: FootTolerance::default(),
            on_surface: 1e-10,
            tie: 1e-9,
            first_radius: 2.0,
            radius_growth: 4.0,
            max_rounds: 40,
            projection_iterations: 32,
            curve_step: 1e-4,
            tangent_sine: 1e-6,
            same_plane: 1e-9,
        }
    }
}
