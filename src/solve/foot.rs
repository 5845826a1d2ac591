//! Foot points (numerical implicitization, paper Sect. 1): for a point x, the point q of a
//! surface nearest to x, with the unit normal there and the signed distance.
//!
//! - Implicit surface f = 0 ([`foot_point`]): start at q = surfacepoint(x) (or a warm start),
//!   then repeat "step in the tangent plane at q, then surfacepoint" until x − q is parallel to
//!   the normal at q. The tangential step is a Newton step of |x − q|² in tangent
//!   coordinates, (I + d·W) w = P_T(x − q), W the Weingarten map estimated by central
//!   differences of ∇f; the plain tangent-plane projection (w = P_T(x − q)) converges only
//!   for |d·κ| < 1 and oscillates beyond (outside a thin torus tube, say).
//!   A global phase follows ([`foot_point_hinted`]): f sampled along 26 fixed rays from x at
//!   1.25 times the distance found; a sign change starts another local search there, and the
//!   nearest foot wins, so the answer does not depend on which sheet the start fell towards.
//! - Parametric patch ([`patch_foot`]): Newton on (u, v) for ½|P(u, v) − x|², second
//!   derivatives by central differences, seeded by a coarse grid pre-search over the extended
//!   declared domain, a warm start running first (see [`patch_foot`]).
//!
//! Invariants of a returned foot: |P_T(x − q)| ≤ max(relative_residual·scale, rounding floor);
//! `normal` is a unit vector (∇f/|∇f|, or (Pu × Pv)/|Pu × Pv| for patches); `distance` is
//! ±|x − q| with the sign of (x − q)·normal. Every step decreases |x − q| (backtracking), so the
//! search cannot cycle; it ends in a foot point or a typed error saying why.

use std::cmp::Ordering;

use glam::DVec3;

use super::surfacepoint::{SurfacePointError, surface_point, tangent_frame};
use super::tolerance::{FootTolerance, PatchFootTolerance};
use crate::surface::{Patch, PatchJet, Surface};

/// Rounding floor of lengths, in units of the largest coordinate magnitude involved: a
/// residual this small is as converged as floating point allows.
const ROUNDING: f64 = 64.0 * f64::EPSILON;

/// Where the gradient vanishes at the start, the search restarts this far (relative to the
/// scale) in a fixed, deliberately unaxial unit direction.
const OFF_CENTRE: f64 = 1e-3;

/// Grid seeds within this many cells (in u and in v) of a warm-started patch foot point are
/// taken to lie in its basin and are not run again.
const WARM_BASIN_CELLS: f64 = 1.5;
const OFF_CENTRE_DIRECTION: DVec3 = DVec3::new(0.6, 0.48, 0.64);

/// A foot point on an implicit surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Foot {
    /// q: the surface point nearest to x (among the sheets the global phase sees; see the
    /// module docs).
    pub point: DVec3,
    /// ∇f/|∇f| at q.
    pub normal: DVec3,
    /// ±|x − q|, positive on the side ∇f points to (where f > 0).
    pub distance: f64,
    /// Outer iterations used.
    pub iterations: u32,
    /// |P_T(x − q)| at the end: the part of x − q not parallel to the normal.
    pub residual: f64,
    /// Smallest eigenvalue of I + d·W at q (1 on a plane, 0 when x is at a focal point, < 0
    /// beyond it); NaN when the curvature could not be estimated. Decides warm starts.
    pub min_eigenvalue: f64,
    /// The last curvature estimate (near q), for the next warm start.
    pub curvature: Option<Curvature>,
}

/// The Weingarten map W = H_T/|∇f| of an implicit surface at a point `at`, as the symmetric
/// matrix [w11, w12, w22] in the tangent frame (t1, t2) there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Curvature {
    pub at: DVec3,
    pub t1: DVec3,
    pub t2: DVec3,
    pub w: [f64; 3],
}

impl Curvature {
    /// W in another (nearby) orthonormal tangent frame: w'_ij = t'_i · W t'_j with W extended
    /// as Σ w_kl t_k t_lᵀ.
    fn in_frame(&self, s1: DVec3, s2: DVec3) -> [f64; 3] {
        let a = [
            [s1.dot(self.t1), s1.dot(self.t2)],
            [s2.dot(self.t1), s2.dot(self.t2)],
        ];
        let w = [[self.w[0], self.w[1]], [self.w[1], self.w[2]]];
        let entry = |i: usize, j: usize| {
            let mut sum = 0.0;
            for (k, wk) in w.iter().enumerate() {
                for (l, wkl) in wk.iter().enumerate() {
                    sum += a[i][k] * wkl * a[j][l];
                }
            }
            sum
        };
        [entry(0, 0), entry(0, 1), entry(1, 1)]
    }
}

/// Why a foot-point search on an implicit surface failed.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum FootError {
    /// The caller asked about a point with a NaN or infinite coordinate.
    #[error("the query point {x} is not finite")]
    NotFinite { x: DVec3 },
    /// Projecting onto the surface failed (the surface is not defined there, its gradient
    /// vanishes, or Newton did not converge).
    #[error(
        "surfacepoint failed in iteration {iteration} of the foot-point search for {x}: {source}"
    )]
    SurfacePoint {
        x: DVec3,
        iteration: u32,
        #[source]
        source: SurfacePointError,
    },
    /// The iteration cap was reached, or no step along the surface decreased the distance.
    #[error(
        "no foot point of {x} after {iterations} iterations: last point {last}, tangential residual {residual:e}"
    )]
    NoConvergence {
        x: DVec3,
        last: DVec3,
        iterations: u32,
        residual: f64,
    },
}

/// A foot point on a parametric patch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchFoot {
    /// Parameters of the foot point (possibly outside the declared domain).
    pub u: f64,
    pub v: f64,
    /// P(u, v).
    pub point: DVec3,
    /// (Pu × Pv)/|Pu × Pv| at (u, v).
    pub normal: DVec3,
    /// (x − P)·normal = ±|x − P|.
    pub distance: f64,
    /// Newton iterations of the winning run.
    pub iterations: u32,
    /// |P_T(x − P)| at the end.
    pub residual: f64,
    /// Smallest eigenvalue of G⁻¹H (G the first fundamental form, H the Hessian of
    /// ½|P − x|²): 1 − d·κ for the principal curvature that matters most; NaN if unknown.
    pub min_eigenvalue: f64,
}

/// Why a foot-point search on a patch failed.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum PatchFootError {
    /// The caller asked about a point with a NaN or infinite coordinate.
    #[error("the query point {x} is not finite")]
    NotFinite { x: DVec3 },
    /// The patch's declared domain is empty or not finite (the patch's author is at fault).
    #[error("the patch domain u in {u:?}, v in {v:?} is empty or not finite")]
    BadDomain { u: (f64, f64), v: (f64, f64) },
    /// The patch formula gave NaN or infinity.
    #[error("the patch is not finite at (u, v) = ({u}, {v})")]
    PatchNotFinite { u: f64, v: f64 },
    /// Pu × Pv vanishes: no normal, no sign.
    #[error("the patch parametrisation is singular at (u, v) = ({u}, {v}), point {at}")]
    Singular { u: f64, v: f64, at: DVec3 },
    /// The iteration cap was reached, or no step decreased the distance.
    #[error(
        "no foot point of {x} after {iterations} iterations: last (u, v) = ({u}, {v}), tangential residual {residual:e}"
    )]
    NoConvergence {
        x: DVec3,
        u: f64,
        v: f64,
        iterations: u32,
        residual: f64,
    },
}

/// The foot point of x on the implicit surface, starting from surfacepoint(`start`) (x itself
/// when `start` is None: the cold start). See the module docs for the iteration.
pub fn foot_point(
    surface: &mut dyn Surface,
    x: DVec3,
    start: Option<DVec3>,
    tol: &FootTolerance,
) -> Result<Foot, FootError> {
    foot_point_hinted(surface, x, start, None, tol)
}

/// `foot_point` with a curvature estimate from an earlier search (a warm start's), reused
/// while the iterate stays within `curvature_reuse · scale` of where it was measured. The
/// estimate only sets the speed of convergence, never the foot point.
///
/// The local search from `start` is followed by the global phase (see `global_foot`), which
/// makes the answer independent of the start wherever its rays resolve the sheets.
pub fn foot_point_hinted(
    surface: &mut dyn Surface,
    x: DVec3,
    start: Option<DVec3>,
    curvature: Option<Curvature>,
    tol: &FootTolerance,
) -> Result<Foot, FootError> {
    if !x.is_finite() {
        return Err(FootError::NotFinite { x });
    }
    let first = local_foot(surface, x, start, curvature, tol)?;
    Ok(global_foot(surface, x, first, tol))
}

/// The global phase: `first` is a local foot point at distance |d|. Along each of the
/// [`RAY_DIRECTIONS`] not within `global_skip_cos` of the direction to `first.point`, f is
/// sampled at x + `global_margin`·|d|·u; a sign opposite to f(x) proves that the surface
/// crosses that ray inside the sampled radius, so a local search starts there, and the nearest
/// foot wins (ties: the earlier, so the result is deterministic). The rays depend only on x
/// and the first distance, and every sheet crossing a ray within the margin is searched, so a
/// warm and a cold start end in the same foot point wherever the rays resolve the sheets.
fn global_foot(surface: &mut dyn Surface, x: DVec3, first: Foot, tol: &FootTolerance) -> Foot {
    let d = first.distance.abs();
    if tol.global_margin <= 0.0 || d == 0.0 {
        return first;
    }
    let fx = surface.value(x);
    if !fx.is_finite() || fx == 0.0 {
        return first;
    }
    let towards = (first.point - x) / d;
    let radius = tol.global_margin * d;
    let mut best = first;
    for &(i, j, k) in RAY_DIRECTIONS.iter() {
        let u = DVec3::new(i, j, k).normalize();
        if u.dot(towards) > tol.global_skip_cos {
            continue;
        }
        let y = x + radius * u;
        let fy = surface.value(y);
        if !fy.is_finite() || fy.signum() == fx.signum() {
            continue;
        }
        if let Ok(f) = local_foot(surface, x, Some(y), None, tol)
            && f.distance.abs() < best.distance.abs()
        {
            best = f;
        }
    }
    best
}

/// The 26 directions from the centre of a 3 × 3 × 3 cube to its other cells (unnormalised),
/// in a fixed order: no direction is more than ≈ 28° from one of them.
pub(super) const RAY_DIRECTIONS: [(f64, f64, f64); 26] = {
    let mut dirs = [(0.0, 0.0, 0.0); 26];
    let mut n = 0;
    let mut c = 0;
    while c < 27 {
        if c != 13 {
            dirs[n] = (
                (c / 9) as f64 - 1.0,
                ((c / 3) % 3) as f64 - 1.0,
                (c % 3) as f64 - 1.0,
            );
            n += 1;
        }
        c += 1;
    }
    dirs
};

/// One local foot-point search (the iteration of the module docs) from surfacepoint(`start`).
fn local_foot(
    surface: &mut dyn Surface,
    x: DVec3,
    start: Option<DVec3>,
    curvature: Option<Curvature>,
    tol: &FootTolerance,
) -> Result<Foot, FootError> {
    let mut shape = curvature;
    let scale = tol.scale;
    let project = |surface: &mut dyn Surface, p: DVec3, iteration: u32| {
        surface_point(surface, p, scale, &tol.surface_point)
            .map(|sp| sp.point)
            .map_err(|source| FootError::SurfacePoint {
                x,
                iteration,
                source,
            })
    };
    let q0 = start.unwrap_or(x);
    let mut q = match project(surface, q0, 0) {
        // ∇f = 0 at the start (the centre of a sphere, a point of the medial axis where f is
        // extremal): any nearest point will do, so start a little off it in a fixed direction.
        Err(FootError::SurfacePoint {
            source: SurfacePointError::ZeroGradient { .. },
            ..
        }) => project(surface, q0 + OFF_CENTRE * scale * OFF_CENTRE_DIRECTION, 0)?,
        other => other?,
    };
    let mut min_eigenvalue = f64::NAN;
    let mut residual = f64::INFINITY;
    for iteration in 0..tol.max_iterations {
        let vg = surface.value_gradient(q);
        let g = vg.gradient;
        let gl = g.length();
        if !vg.value.is_finite() || !g.is_finite() {
            let source = SurfacePointError::NotFinite {
                at: q,
                value: vg.value,
            };
            return Err(FootError::SurfacePoint {
                x,
                iteration,
                source,
            });
        }
        if gl == 0.0 {
            let source = SurfacePointError::ZeroGradient { at: q };
            return Err(FootError::SurfacePoint {
                x,
                iteration,
                source,
            });
        }
        let n = g / gl;
        let r = x - q;
        let rn = r.dot(n);
        let rt = r - rn * n;
        residual = rt.length();
        let floor = ROUNDING * (x.abs().max_element() + q.abs().max_element() + r.length());
        let converged = residual <= (tol.relative_residual * scale).max(floor);
        let (t1, t2) = tangent_frame(n);
        // The tangential Newton matrix M = I + (rn/|∇f|)·H_T (H_T: the Hessian of f restricted
        // to the tangent plane), symmetric, in the frame (t1, t2).
        let mut m = [1.0, 0.0, 1.0];
        // Needed for the step and, at convergence, for the saddle test and warm starts; so
        // it must be measured near this q (an estimate from the previous iterate may belong
        // to another part of the surface).
        if rn != 0.0 {
            let reusable = shape.filter(|c| (c.at - q).length() <= tol.curvature_reuse * scale);
            let here = match reusable {
                Some(c) => Some(c),
                None => {
                    let h = tol.hessian_step * scale;
                    let c1 = hessian_column(surface, q, t1, h);
                    let c2 = hessian_column(surface, q, t2, h);
                    match (c1, c2) {
                        (Some(c1), Some(c2)) => Some(Curvature {
                            at: q,
                            t1,
                            t2,
                            w: [
                                t1.dot(c1) / gl,
                                0.5 * (t2.dot(c1) + t1.dot(c2)) / gl,
                                t2.dot(c2) / gl,
                            ],
                        }),
                        _ => None,
                    }
                }
            };
            shape = here;
            match here {
                Some(c) => {
                    let w = c.in_frame(t1, t2);
                    m = [1.0 + rn * w[0], rn * w[1], 1.0 + rn * w[2]];
                    min_eigenvalue = sym_min_eigenvalue(m);
                }
                // No curvature where f is undefined nearby: plain tangent-plane steps, and no
                // warm start from here.
                None => min_eigenvalue = f64::NAN,
            }
        } else if rn == 0.0 {
            min_eigenvalue = 1.0;
        }
        if converged {
            // A critical point where I + d·W has a negative eigenvalue is a saddle (or a
            // maximum) of the distance — the far side of a torus for x in a symmetry plane —
            // not a foot point: step off along that eigenvector, downhill.
            if min_eigenvalue < -tol.saddle_eigenvalue
                && let Some(c) = shape
            {
                let w = c.in_frame(t1, t2);
                let mm = [1.0 + rn * w[0], rn * w[1], 1.0 + rn * w[2]];
                let e = min_eigenvector(mm, [1.0, 0.0, 1.0]);
                let mut step = 0.5 * r.length() * (e[0] * t1 + e[1] * t2);
                let d0 = r.length();
                let mut escaped = false;
                for _ in 0..=tol.max_backtracks {
                    if let Ok(p) = project(surface, q + step, iteration)
                        && (x - p).length() < d0
                    {
                        q = p;
                        escaped = true;
                        break;
                    }
                    step *= 0.5;
                }
                if escaped {
                    min_eigenvalue = f64::NAN;
                    continue;
                }
            }
            let len = r.length();
            let distance = if rn < 0.0 { -len } else { len };
            return Ok(Foot {
                point: q,
                normal: n,
                distance,
                iterations: iteration,
                residual,
                min_eigenvalue,
                curvature: shape,
            });
        }
        let w = shifted_solve(m, [1.0, 0.0, 1.0], [rt.dot(t1), rt.dot(t2)], tol);
        let mut step = w[0] * t1 + w[1] * t2;
        let d0 = r.length();
        // The nearest point is within 2|x − q| of q: longer steps only overshoot.
        if step.length() > 2.0 * d0 {
            step *= 2.0 * d0 / step.length();
        }
        let mut next = None;
        let mut last_error = None;
        for _ in 0..=tol.max_backtracks {
            match project(surface, q + step, iteration) {
                Ok(p) if (x - p).length() <= d0 + floor => {
                    next = Some(p);
                    break;
                }
                Ok(_) => {}
                Err(e) => last_error = Some(e),
            }
            step *= 0.5;
        }
        match (next, last_error) {
            (Some(p), _) => q = p,
            (None, Some(e)) => return Err(e),
            (None, None) => {
                return Err(FootError::NoConvergence {
                    x,
                    last: q,
                    iterations: iteration + 1,
                    residual,
                });
            }
        }
    }
    Err(FootError::NoConvergence {
        x,
        last: q,
        iterations: tol.max_iterations,
        residual,
    })
}

/// H·dir by central differences of the gradient; None where f is not finite.
fn hessian_column(surface: &mut dyn Surface, q: DVec3, dir: DVec3, h: f64) -> Option<DVec3> {
    let gp = surface.value_gradient(q + h * dir).gradient;
    let gm = surface.value_gradient(q - h * dir).gradient;
    let c = (gp - gm) / (2.0 * h);
    c.is_finite().then_some(c)
}

/// Smallest eigenvalue of the symmetric 2×2 matrix [[a, b], [b, c]] given as [a, b, c].
fn sym_min_eigenvalue([a, b, c]: [f64; 3]) -> f64 {
    0.5 * (a + c) - (0.5 * (a - c)).hypot(b)
}

/// Smallest generalized eigenvalue λ of H y = λ G y (G symmetric positive definite), both
/// given as [m11, m12, m22].
fn generalized_min_eigenvalue(h: [f64; 3], g: [f64; 3]) -> f64 {
    let det_g = g[0] * g[2] - g[1] * g[1];
    let det_h = h[0] * h[2] - h[1] * h[1];
    let s = g[0] * h[2] + g[2] * h[0] - 2.0 * g[1] * h[1];
    let disc = (s * s - 4.0 * det_g * det_h).max(0.0);
    (s - disc.sqrt()) / (2.0 * det_g)
}

/// A unit-length (in the Euclidean norm of the coefficients) eigenvector of the smallest
/// generalized eigenvalue of (H, G), both [m11, m12, m22]; its sign is fixed by the formula,
/// so the choice is deterministic.
fn min_eigenvector(h: [f64; 3], g: [f64; 3]) -> [f64; 2] {
    let lambda = generalized_min_eigenvalue(h, g);
    let a = [
        h[0] - lambda * g[0],
        h[1] - lambda * g[1],
        h[2] - lambda * g[2],
    ];
    // Rows of the singular matrix A = H − λG: each is orthogonal to the eigenvector.
    let from_row1 = [a[1], -a[0]];
    let from_row2 = [a[2], -a[1]];
    let norm = |v: [f64; 2]| v[0].hypot(v[1]);
    let v = if norm(from_row1) >= norm(from_row2) {
        from_row1
    } else {
        from_row2
    };
    let l = norm(v);
    if l > 0.0 && l.is_finite() {
        [v[0] / l, v[1] / l]
    } else {
        [1.0, 0.0]
    }
}

/// Solves (M + σG) w = rhs where σ ≥ 0 is the smallest shift that lifts the smallest
/// generalized eigenvalue of (M, G) to `min_newton_eigenvalue` (a Levenberg–Marquardt shift
/// in the metric G): a pure Newton step where M is safely positive definite, a damped,
/// still descending step near and beyond focal points. Zero if the system is singular.
fn shifted_solve(m: [f64; 3], g: [f64; 3], rhs: [f64; 2], tol: &FootTolerance) -> [f64; 2] {
    let lambda = generalized_min_eigenvalue(m, g);
    let sigma = if lambda.is_finite() {
        (tol.min_newton_eigenvalue - lambda).max(0.0)
    } else {
        0.0
    };
    let a = [
        m[0] + sigma * g[0],
        m[1] + sigma * g[1],
        m[2] + sigma * g[2],
    ];
    let det = a[0] * a[2] - a[1] * a[1];
    if det == 0.0 || !det.is_finite() {
        return [0.0, 0.0];
    }
    [
        (a[2] * rhs[0] - a[1] * rhs[1]) / det,
        (a[0] * rhs[1] - a[1] * rhs[0]) / det,
    ]
}

/// The pre-search grid of a patch: the (grid+1)² points of the declared domain extended by
/// `extension` on every side. It does not depend on the query, so a distance surface builds
/// it once.
#[derive(Clone, Debug, PartialEq)]
pub struct PatchGrid {
    side: usize,
    origin: (f64, f64),
    spacing: (f64, f64),
    points: Vec<DVec3>,
    /// The longest edge between neighbouring grid points: any patch point of the region is
    /// within about this of a grid point.
    cell: f64,
    /// Central-difference steps in (u, v).
    steps: (f64, f64),
    /// The grid in blocks of `BLOCK`² points, each with the box of its finite points: a
    /// query computes the distances of the blocks whose box may hold a point near enough to
    /// matter, not of all (side)² points (which was two thirds of `intersecting_patches`).
    blocks: Vec<Block>,
}

/// Grid points a block has along each side.
const BLOCK: usize = 4;

/// A block of grid points (rows `i`, columns `j`) and the box of its finite points (empty:
/// lo > hi, when none is).
#[derive(Clone, Debug, PartialEq)]
struct Block {
    i: std::ops::Range<usize>,
    j: std::ops::Range<usize>,
    lo: DVec3,
    hi: DVec3,
}

impl Block {
    /// A lower bound of |p − x|² over the block's finite points p as `GridDistances::get`
    /// computes it: each axis's gap to the box is at most that coordinate's |p − x| after
    /// rounding (rounding is monotone), and so are their squares and sums; ∞ for an empty box.
    fn bound2(&self, x: DVec3) -> f64 {
        let gap = (self.lo - x).max(x - self.hi).max(DVec3::ZERO);
        gap.length_squared()
    }
}

impl PatchGrid {
    /// Samples the patch over its extended domain. Grid points where the patch is not finite
    /// are kept as NaN and never seed a search.
    pub fn new(patch: &mut dyn Patch, tol: &PatchFootTolerance) -> Result<Self, PatchFootError> {
        let (ud, vd) = patch.domain();
        let valid = |(lo, hi): (f64, f64)| lo.is_finite() && hi.is_finite() && hi > lo;
        if !valid(ud) || !valid(vd) {
            return Err(PatchFootError::BadDomain { u: ud, v: vd });
        }
        let n = tol.grid.max(1) as usize;
        let side = n + 1;
        let (eu, ev) = (tol.extension * (ud.1 - ud.0), tol.extension * (vd.1 - vd.0));
        let origin = (ud.0 - eu, vd.0 - ev);
        let spacing = (
            (ud.1 - ud.0 + 2.0 * eu) / n as f64,
            (vd.1 - vd.0 + 2.0 * ev) / n as f64,
        );
        let mut points = Vec::with_capacity(side * side);
        for i in 0..side {
            for j in 0..side {
                let u = origin.0 + i as f64 * spacing.0;
                let v = origin.1 + j as f64 * spacing.1;
                let p = patch.point_jacobian(u, v).point;
                points.push(if p.is_finite() { p } else { DVec3::NAN });
            }
        }
        let mut cell: f64 = 0.0;
        for i in 0..side {
            for j in 0..side {
                let p = points[i * side + j];
                if i + 1 < side {
                    cell = cell.max((points[(i + 1) * side + j] - p).length());
                }
                if j + 1 < side {
                    cell = cell.max((points[i * side + j + 1] - p).length());
                }
            }
        }
        let mut blocks = Vec::new();
        for i0 in (0..side).step_by(BLOCK) {
            for j0 in (0..side).step_by(BLOCK) {
                let (i, j) = (i0..(i0 + BLOCK).min(side), j0..(j0 + BLOCK).min(side));
                let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
                for a in i.clone() {
                    for p in &points[a * side + j.start..a * side + j.end] {
                        if p.is_finite() {
                            lo = lo.min(*p);
                            hi = hi.max(*p);
                        }
                    }
                }
                blocks.push(Block { i, j, lo, hi });
            }
        }
        Ok(PatchGrid {
            side,
            origin,
            spacing,
            points,
            cell,
            blocks,
            steps: (
                tol.foot.hessian_step * (ud.1 - ud.0),
                tol.foot.hessian_step * (vd.1 - vd.0),
            ),
        })
    }

    fn param(&self, k: usize) -> (f64, f64) {
        let (i, j) = (k / self.side, k % self.side);
        (
            self.origin.0 + i as f64 * self.spacing.0,
            self.origin.1 + j as f64 * self.spacing.1,
        )
    }

    /// The grid's distances to x, computed as the searches ask for them.
    fn distances(&self, x: DVec3) -> GridDistances<'_> {
        GridDistances {
            grid: self,
            x,
            d2: vec![f64::NAN; self.points.len()],
            // A little below each block's bound, for the bound's own rounding.
            bounds: self
                .blocks
                .iter()
                .map(|b| b.bound2(x) * (1.0 - 1e-12))
                .collect(),
        }
    }
}

/// The squared distances of one query point to the grid's points, computed when first asked
/// (NaN: not yet).
struct GridDistances<'a> {
    grid: &'a PatchGrid,
    x: DVec3,
    d2: Vec<f64>,
    /// Each block's lower bound of the squared distances of its points.
    bounds: Vec<f64>,
}

impl GridDistances<'_> {
    /// |P − x|² at grid point k (infinite where the patch is not finite).
    fn get(&mut self, k: usize) -> f64 {
        let d = self.d2[k];
        if !d.is_nan() {
            return d;
        }
        let d = (self.grid.points[k] - self.x).length_squared();
        let d = if d.is_finite() { d } else { f64::INFINITY };
        self.d2[k] = d;
        d
    }

    /// Whether grid point k is a discrete local minimum of the distances in the strict order
    /// (d², index), so that a plateau yields one seed.
    fn is_seed(&mut self, k: usize) -> bool {
        let side = self.grid.side;
        let (i, j) = (k / side, k % side);
        let dk = self.get(k);
        if !dk.is_finite() {
            return false;
        }
        // Half-open ranges: an inclusive range's iterator is slower (this test runs some
        // fifty times a query).
        for a in i.saturating_sub(1)..(i + 2).min(side) {
            for b in j.saturating_sub(1)..(j + 2).min(side) {
                let o = a * side + b;
                // (dk, k) < (d, o); d is never NaN.
                let d = self.get(o);
                if o != k && !(dk < d || (dk == d && k < o)) {
                    return false;
                }
            }
        }
        true
    }

    /// Calls `each` with the grid points of the blocks whose bound is at most `limit`: every
    /// point whose squared distance is at most `limit`, among others, block after block.
    fn each_within(&mut self, limit: f64, mut each: impl FnMut(&mut Self, usize)) {
        let grid = self.grid;
        for (b, block) in grid.blocks.iter().enumerate() {
            if self.bounds[b] <= limit {
                self.each_in(block, &mut each);
            }
        }
    }

    /// Calls `each` with the grid points of `block`, row by row.
    fn each_in(&mut self, block: &Block, each: &mut impl FnMut(&mut Self, usize)) {
        let side = self.grid.side;
        for i in block.i.clone() {
            for j in block.j.clone() {
                each(self, i * side + j);
            }
        }
    }

    /// The seeds (discrete local minima), nearest first by (d, index), with their distances
    /// d; only those whose basin may hold a point nearer than `reach` (d − cell ≤ reach:
    /// `patch_foot` stops at the first seed beyond, so leaving them out changes nothing).
    /// Only the blocks within reach + cell are looked at, and the distance test comes before
    /// the neighbour test.
    fn seeds(&mut self, reach: f64) -> Vec<(f64, usize)> {
        let cell = self.grid.cell;
        // A superset of the squares within reach + cell, before the exact test on √d².
        let near2 = ((reach + cell) * (1.0 + 1e-9)).powi(2);
        let mut seeds = Vec::new();
        self.each_within(near2, |g, k| {
            let d2 = g.get(k);
            if d2 <= near2 && d2.sqrt() - cell <= reach && g.is_seed(k) {
                seeds.push((d2.sqrt(), k));
            }
        });
        // (d, index) orders them totally (no two share an index): the order in which the
        // blocks were visited does not show.
        seeds.sort_by(|a, b| a.partial_cmp(b).unwrap_or(Ordering::Equal));
        seeds
    }

    /// `nearest`, or the nearest finite point of `block` under (d², index) where it is nearer.
    fn nearer_in(&mut self, block: &Block, nearest: &mut Option<(f64, usize)>) {
        self.each_in(block, &mut |g: &mut Self, k| {
            let d2 = g.get(k);
            if d2.is_finite()
                && nearest.is_none_or(|n| (d2, k).partial_cmp(&n) == Some(Ordering::Less))
            {
                *nearest = Some((d2, k));
            }
        });
    }

    /// The first of `seeds` whatever the reach, without the neighbour test over the grid:
    /// the nearest point under (d², index) is a seed, and sorts first unless a seed of the
    /// same rounded distance d has a lower index. The block of the least bound is looked at
    /// first, then every block whose bound does not exceed the nearest distance found so far
    /// (a nearer point's block always qualifies: its bound is below the point's distance).
    fn first_seed(&mut self) -> Option<usize> {
        let grid = self.grid;
        let first = (0..grid.blocks.len()).min_by(|&a, &b| {
            self.bounds[a]
                .partial_cmp(&self.bounds[b])
                .unwrap_or(Ordering::Equal)
        })?;
        let mut nearest: Option<(f64, usize)> = None;
        self.nearer_in(&grid.blocks[first], &mut nearest);
        for (b, block) in grid.blocks.iter().enumerate() {
            if b != first && nearest.is_none_or(|(d2, _)| self.bounds[b] <= d2) {
                self.nearer_in(block, &mut nearest);
            }
        }
        let (d2, nearest) = nearest?;
        let d = d2.sqrt();
        let limit = d2 * (1.0 + 4.0 * f64::EPSILON);
        let mut tied: Option<usize> = None;
        self.each_within(limit, |g, o| {
            if o < nearest && tied.is_none_or(|t| o < t) {
                let od2 = g.get(o);
                if od2 <= limit && od2.sqrt() == d && g.is_seed(o) {
                    tied = Some(o);
                }
            }
        });
        Some(tied.unwrap_or(nearest))
    }
}

/// The foot point of x on the patch: Newton from the `candidates` best discrete local minima
/// of the distance to the grid points (nearest first), the nearest result winning (ties: the
/// earlier run). `warm`, a previous foot's (u, v), runs first; it sharpens the bound that lets a
/// seed be skipped when its grid distance minus the grid's cell size already exceeds the best
/// distance found (its basin cannot hold a nearer point), and seeds within 1.5 grid cells of
/// the warm foot point (its own basin) are not run again. Every other basin is still searched,
/// so warm and cold searches return the same foot point.
pub fn patch_foot(
    patch: &mut dyn Patch,
    x: DVec3,
    warm: Option<(f64, f64)>,
    grid: &PatchGrid,
    tol: &PatchFootTolerance,
) -> Result<PatchFoot, PatchFootError> {
    if !x.is_finite() {
        return Err(PatchFootError::NotFinite { x });
    }
    let mut best: Option<PatchFoot> = None;
    let mut first_error = None;
    let mut consider =
        |result: Result<PatchFoot, PatchFootError>, best: &mut Option<PatchFoot>| match result {
            Ok(f) => {
                if best.is_none_or(|b| f.distance.abs() < b.distance.abs()) {
                    *best = Some(f);
                }
            }
            Err(e) => {
                first_error.get_or_insert(e);
            }
        };
    let mut warm_foot = None;
    if let Some(uv) = warm {
        consider(patch_newton(patch, x, uv, grid.steps, tol), &mut best);
        warm_foot = best.map(|f| (f.u, f.v));
    }
    let mut dist2 = grid.distances(x);
    // Without a warm foot point the nearest seed runs first, as it would in the loop below,
    // so that its distance bounds which seeds the grid has to find.
    let mut first = None;
    if best.is_none() {
        first = dist2.first_seed();
        if let Some(k) = first {
            consider(
                patch_newton(patch, x, grid.param(k), grid.steps, tol),
                &mut best,
            );
        }
    }
    let reach = best.map_or(f64::INFINITY, |b| b.distance.abs());
    let budget = tol.candidates.max(1) as usize - usize::from(first.is_some());
    for (d, k) in dist2
        .seeds(reach)
        .into_iter()
        .filter(|&(_, k)| Some(k) != first)
        .take(budget)
    {
        if best.is_some_and(|b| d - grid.cell > b.distance.abs()) {
            break;
        }
        let seed = grid.param(k);
        // A seed in the grid cells around the warm foot point lies in its basin (as far as
        // the grid resolves basins at all): Newton from it would only find it again.
        if warm_foot.is_some_and(|(u, v)| {
            (seed.0 - u).abs() <= WARM_BASIN_CELLS * grid.spacing.0
                && (seed.1 - v).abs() <= WARM_BASIN_CELLS * grid.spacing.1
        }) {
            continue;
        }
        consider(patch_newton(patch, x, seed, grid.steps, tol), &mut best);
    }
    match (best, first_error) {
        (Some(f), _) => Ok(f),
        (None, Some(e)) => Err(e),
        (None, None) => {
            let (u, v) = grid.param(0);
            Err(PatchFootError::PatchNotFinite { u, v })
        }
    }
}

fn eval_patch(patch: &mut dyn Patch, u: f64, v: f64) -> Result<PatchJet, PatchFootError> {
    let jet = patch.point_jacobian(u, v);
    if jet.point.is_finite() && jet.du.is_finite() && jet.dv.is_finite() {
        Ok(jet)
    } else {
        Err(PatchFootError::PatchNotFinite { u, v })
    }
}

/// Newton (Levenberg–Marquardt-shifted where not convex) on ½|P(u, v) − x|² from (u, v).
fn patch_newton(
    patch: &mut dyn Patch,
    x: DVec3,
    (mut u, mut v): (f64, f64),
    (hu, hv): (f64, f64),
    tol: &PatchFootTolerance,
) -> Result<PatchFoot, PatchFootError> {
    let ft = &tol.foot;
    let mut min_eigenvalue = f64::NAN;
    let mut residual = f64::INFINITY;
    // The jet at the accepted point of the line search, evaluated there already.
    let mut next_jet: Option<PatchJet> = None;
    for iteration in 0..ft.max_iterations {
        let jet = match next_jet.take() {
            Some(jet) => jet,
            None => eval_patch(patch, u, v)?,
        };
        let normal_raw = jet.du.cross(jet.dv);
        let nl = normal_raw.length();
        if nl == 0.0 || nl <= tol.singular * jet.du.length() * jet.dv.length() {
            return Err(PatchFootError::Singular {
                u,
                v,
                at: jet.point,
            });
        }
        let n = normal_raw / nl;
        let r = x - jet.point;
        let rn = r.dot(n);
        residual = (r - rn * n).length();
        let floor = ROUNDING * (x.abs().max_element() + jet.point.abs().max_element() + r.length());
        let converged = residual <= (ft.relative_residual * ft.scale).max(floor);
        let g = [jet.du.dot(jet.du), jet.du.dot(jet.dv), jet.dv.dot(jet.dv)];
        // Hessian of ½|P − x|²: G + (P − x)·∂²P; second derivatives by central differences.
        let mut h = g;
        if !converged || min_eigenvalue.is_nan() {
            let second = (|| {
                let up = eval_patch(patch, u + hu, v).ok()?;
                let um = eval_patch(patch, u - hu, v).ok()?;
                let vp = eval_patch(patch, u, v + hv).ok()?;
                let vm = eval_patch(patch, u, v - hv).ok()?;
                let puu = (up.du - um.du) / (2.0 * hu);
                let pvv = (vp.dv - vm.dv) / (2.0 * hv);
                let puv = 0.5 * ((up.dv - um.dv) / (2.0 * hu) + (vp.du - vm.du) / (2.0 * hv));
                Some((puu, puv, pvv))
            })();
            match second {
                Some((puu, puv, pvv)) => {
                    h = [g[0] - r.dot(puu), g[1] - r.dot(puv), g[2] - r.dot(pvv)];
                    min_eigenvalue = generalized_min_eigenvalue(h, g);
                }
                None => min_eigenvalue = f64::NAN,
            }
        }
        if converged {
            // A saddle or maximum of the distance: step off downhill (see `foot_point`).
            if min_eigenvalue < -ft.saddle_eigenvalue {
                let e = min_eigenvector(h, g);
                let len = (e[0] * jet.du + e[1] * jet.dv).length();
                if len > 0.0 {
                    let scale_uv = 0.5 * r.length() / len;
                    let (mut su, mut sv) = (scale_uv * e[0], scale_uv * e[1]);
                    let d0 = r.length();
                    let mut escaped = false;
                    for _ in 0..=ft.max_backtracks {
                        let p = patch.point_jacobian(u + su, v + sv).point;
                        if p.is_finite() && (x - p).length() < d0 {
                            u += su;
                            v += sv;
                            escaped = true;
                            break;
                        }
                        su *= 0.5;
                        sv *= 0.5;
                    }
                    if escaped {
                        min_eigenvalue = f64::NAN;
                        continue;
                    }
                }
            }
            return Ok(PatchFoot {
                u,
                v,
                point: jet.point,
                normal: n,
                distance: rn,
                iterations: iteration,
                residual,
                min_eigenvalue,
            });
        }
        // Newton for ∇F = 0 with ∇F = Jᵀ(P − x) = −(Pu·r, Pv·r).
        let w = shifted_solve(h, g, [jet.du.dot(r), jet.dv.dot(r)], ft);
        let (mut su, mut sv) = (w[0], w[1]);
        let d0 = r.length();
        // As for implicit surfaces: the nearest point is within 2|x − P| of P (to first
        // order in parameter space).
        let reach = (su * jet.du + sv * jet.dv).length();
        if reach > 2.0 * d0 {
            su *= 2.0 * d0 / reach;
            sv *= 2.0 * d0 / reach;
        }
        let mut accepted = false;
        for _ in 0..=ft.max_backtracks {
            let trial = patch.point_jacobian(u + su, v + sv);
            let p = trial.point;
            if p.is_finite() && (x - p).length() <= d0 + floor {
                u += su;
                v += sv;
                accepted = true;
                next_jet = (trial.du.is_finite() && trial.dv.is_finite()).then_some(trial);
                break;
            }
            su *= 0.5;
            sv *= 0.5;
        }
        if !accepted {
            return Err(PatchFootError::NoConvergence {
                x,
                u,
                v,
                iterations: iteration + 1,
                residual,
            });
        }
    }
    Err(PatchFootError::NoConvergence {
        x,
        u,
        v,
        iterations: ft.max_iterations,
        residual,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A saddle-shaped patch with several discrete local minima of the distance from points
    /// above and below it.
    struct Wave;

    impl Patch for Wave {
        fn point_jacobian(&mut self, u: f64, v: f64) -> PatchJet {
            let (s, c) = (6.0 * u).sin_cos();
            PatchJet {
                point: DVec3::new(4.0 * u, 4.0 * v, 2.0 * s * (4.0 * v).cos()),
                du: DVec3::new(4.0, 0.0, 12.0 * c * (4.0 * v).cos()),
                dv: DVec3::new(0.0, 4.0, -8.0 * s * (4.0 * v).sin()),
            }
        }
        fn domain(&self) -> ((f64, f64), (f64, f64)) {
            ((0.0, 2.0), (0.0, 1.5))
        }
    }

    /// The seed search over the blocks gives what a scan of every grid point gives (the
    /// search as it was before the blocks): the seeds within a reach are the full list's
    /// prefix up to d − cell ≤ reach, and `first_seed` is its first, the nearest point under
    /// (d², index) unless a seed of the same rounded distance has a lower index.
    #[test]
    fn the_blocks_seeds_are_the_full_scans() {
        fn full_scan(grid: &PatchGrid, x: DVec3) -> (Vec<f64>, Vec<(f64, usize)>) {
            let side = grid.side;
            let d2: Vec<f64> = grid
                .points
                .iter()
                .map(|p| {
                    let d = (*p - x).length_squared();
                    if d.is_finite() { d } else { f64::INFINITY }
                })
                .collect();
            let key = |k: usize| (d2[k], k);
            let seed = |k: usize| {
                let (i, j) = (k / side, k % side);
                d2[k].is_finite()
                    && (i.saturating_sub(1)..=(i + 1).min(side - 1)).all(|a| {
                        (j.saturating_sub(1)..=(j + 1).min(side - 1)).all(|b| {
                            let o = a * side + b;
                            o == k || key(k).partial_cmp(&key(o)) == Some(Ordering::Less)
                        })
                    })
            };
            let mut seeds: Vec<(f64, usize)> = (0..d2.len())
                .filter(|&k| seed(k))
                .map(|k| (d2[k].sqrt(), k))
                .collect();
            seeds.sort_by(|a, b| a.partial_cmp(b).unwrap_or(Ordering::Equal));
            (d2, seeds)
        }
        let mut unit = crate::testing::uniform(0x2545_F491_4F6C_DD1Du64);
        let mut several = 0;
        for patch in [&mut Wave as &mut dyn Patch, &mut Holed] {
            let grid = PatchGrid::new(patch, &PatchFootTolerance::default()).expect("grid");
            for _ in 0..400 {
                // Around the patch, and now and then far from it or on a grid point.
                let mut x = DVec3::new(10.0 * unit() - 1.0, 8.0 * unit() - 1.0, 6.0 * unit() - 3.0);
                if unit() < 0.1 {
                    x *= 50.0;
                } else if unit() < 0.1 {
                    x = grid.points[(unit() * grid.points.len() as f64) as usize];
                }
                if !x.is_finite() {
                    continue;
                }
                let (d2, full) = full_scan(&grid, x);
                several += usize::from(full.len() > 1);
                let nearest = (0..d2.len())
                    .filter(|&k| d2[k].is_finite())
                    .min_by(|&a, &b| {
                        (d2[a], a)
                            .partial_cmp(&(d2[b], b))
                            .unwrap_or(Ordering::Equal)
                    });
                assert_eq!(
                    grid.distances(x).first_seed(),
                    full.first().map(|s| s.1),
                    "{x}"
                );
                assert!(nearest.is_none_or(|n| full.first().is_some_and(|f| f.0 == d2[n].sqrt())));
                for reach in [0.0, 0.1, 0.5, 1.0, 3.0, f64::INFINITY] {
                    let prefix: Vec<_> = full
                        .iter()
                        .copied()
                        .take_while(|&(d, _)| d - grid.cell <= reach)
                        .collect();
                    assert_eq!(grid.distances(x).seeds(reach), prefix, "{x} within {reach}");
                }
            }
        }
        assert!(several > 60, "only {several} points with several seeds");
    }

    /// A patch not finite over part of its extended domain (u < 0): NaN grid points, and
    /// blocks with no finite point.
    struct Holed;

    impl Patch for Holed {
        fn point_jacobian(&mut self, u: f64, v: f64) -> PatchJet {
            let r = u.sqrt();
            PatchJet {
                point: DVec3::new(4.0 * r, 4.0 * v, (3.0 * v).sin()),
                du: DVec3::new(2.0 / r, 0.0, 0.0),
                dv: DVec3::new(0.0, 4.0, 3.0 * (3.0 * v).cos()),
            }
        }
        fn domain(&self) -> ((f64, f64), (f64, f64)) {
            ((0.0, 2.0), (0.0, 1.5))
        }
    }
}
