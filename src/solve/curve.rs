//! Curves (docs/language.md): intersection curves, circles, patch boundaries, reversal — each
//! sampled at a step δ into a [`Polygon`], the first front or a bounding front of the marcher.
//!
//! Invariants of every polygon built here: consecutive vertices are ≈ δ apart and never
//! farther than δ along the curve (n = ⌈L/δ⌉ segments of equal arc length L/n), a closed
//! polygon does not repeat its first vertex at the end, and the construction is
//! deterministic (same input, same vertices bit for bit).
//!
//! Orientation conventions:
//! - `intersection`: walks along ∇f1 × ∇f2; closed curves start at the curve point nearest
//!   `near`; open ones (clipped by the box) start where the curve enters the box.
//! - `circle`: counter-clockwise around `normal` (right-hand rule), starting at
//!   center + radius·t1 with t1 the first tangent of `surfacepoint::tangent_frame(normal)`.
//! - `boundary`: the parameter rectangle counter-clockwise in (u, v) from (u_lo, v_lo): the
//!   edge v = v_lo first; counter-clockwise around Pu × Pv in object space.
//! - `reverse`: the other way round, keeping the first vertex first (closed polygons).

use glam::{DMat3, DVec3};

use super::surfacepoint::{SurfacePointError, surface_point, tangent_frame};
use super::tolerance::{CurveTolerance, SurfacePointTolerance};
use crate::surface::{Patch, Surface, ValueGrad};

/// Rounding floor of lengths, in units of the largest coordinate magnitude involved.
const ROUNDING: f64 = 64.0 * f64::EPSILON;

/// A sampled curve: vertices in order; `closed` means the last vertex connects to the first
/// (which is not repeated).
#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    pub points: Vec<DVec3>,
    pub closed: bool,
}

/// Why a curve could not be built. Input errors (the author's curve is wrong) come first,
/// numerical failures last.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum CurveError {
    #[error("the step {step} is not a positive finite number")]
    InvalidStep { step: f64 },
    #[error("the circle (center {center}, normal {normal}, radius {radius}) is degenerate")]
    InvalidCircle {
        center: DVec3,
        normal: DVec3,
        radius: f64,
    },
    #[error("the box {lo} .. {hi} is empty or not finite")]
    InvalidBox { lo: DVec3, hi: DVec3 },
    #[error("the patch domain u in {u:?}, v in {v:?} is empty or not finite")]
    BadDomain { u: (f64, f64), v: (f64, f64) },
    #[error(
        "the surfaces do not meet near {near}: the best point found, {best}, is {residual:.3e} away from one of them"
    )]
    NoMeeting {
        near: DVec3,
        best: DVec3,
        residual: f64,
    },
    #[error(
        "the surfaces touch (or one is singular) at {at}: their normals are parallel (sine {sine:e}), the intersection has no tangent"
    )]
    TangentVanishes { at: DVec3, sine: f64 },
    #[error("the curve starts at {start}, outside its box")]
    StartOutsideBox { start: DVec3 },
    #[error("a surface is not finite at {at}")]
    NotFinite { at: DVec3 },
    #[error("the patch is not finite at (u, v) = ({u}, {v})")]
    PatchNotFinite { u: f64, v: f64 },
    #[error(
        "the curve from {start} did not close (nor leave the box) within arc length {length}; last point {last}"
    )]
    NoClosure {
        start: DVec3,
        length: f64,
        last: DVec3,
    },
    #[error("a point near {at} could not be corrected onto both surfaces")]
    CorrectionFailed { at: DVec3 },
    #[error("the polygon would have {count} vertices, more than the limit {max}")]
    TooManyVertices { count: f64, max: usize },
    #[error("vertex {index} could not be projected onto the surface: {source}")]
    Projection {
        index: usize,
        #[source]
        source: SurfacePointError,
    },
}

fn check_step(step: f64) -> Result<(), CurveError> {
    if step.is_finite() && step > 0.0 {
        Ok(())
    } else {
        Err(CurveError::InvalidStep { step })
    }
}

/// Number of segments ⌈length/step⌉ (at least `min`), refused above the vertex limit.
fn segment_count(length: f64, step: f64, min: usize, max: usize) -> Result<usize, CurveError> {
    let count = (length / step).ceil();
    if count.is_nan() || count > max as f64 {
        return Err(CurveError::TooManyVertices { count, max });
    }
    Ok((count as usize).max(min))
}

// ---------------------------------------------------------------------------------------------
// Intersection curves.

/// The intersection curve of two surfaces, traced from its point nearest `near`, sampled at
/// `step`, clipped at `bbox` when given. Default tolerances.
pub fn intersection(
    s1: &mut dyn Surface,
    s2: &mut dyn Surface,
    near: DVec3,
    step: f64,
    bbox: Option<(DVec3, DVec3)>,
) -> Result<Polygon, CurveError> {
    intersection_with(s1, s2, near, step, bbox, &CurveTolerance::default())
}

/// `intersection` with explicit tolerances.
pub fn intersection_with(
    s1: &mut dyn Surface,
    s2: &mut dyn Surface,
    near: DVec3,
    step: f64,
    bbox: Option<(DVec3, DVec3)>,
    tol: &CurveTolerance,
) -> Result<Polygon, CurveError> {
    check_step(step)?;
    if let Some((lo, hi)) = bbox
        && !(lo.is_finite() && hi.is_finite() && lo.cmplt(hi).all())
    {
        return Err(CurveError::InvalidBox { lo, hi });
    }
    if !near.is_finite() {
        return Err(CurveError::NotFinite { at: near });
    }
    let mut pair = Pair { s1, s2, tol, step };
    let start = pair.seek(near)?;
    let start = pair.slide(start, near)?;
    if let Some((lo, hi)) = bbox
        && !inside(start, lo, hi)
    {
        return Err(CurveError::StartOutsideBox { start });
    }
    let (forward, end) = pair.trace(start, 1.0, bbox)?;
    let (fine, closed) = match end {
        End::Closed => (forward, true),
        End::Exited => {
            let (mut backward, _) = pair.trace(start, -1.0, bbox)?;
            backward.reverse();
            backward.extend_from_slice(&forward[1..]);
            (backward, false)
        }
    };
    let points = pair.resample(&fine, closed)?;
    Ok(Polygon { points, closed })
}

fn inside(p: DVec3, lo: DVec3, hi: DVec3) -> bool {
    p.cmpge(lo).all() && p.cmple(hi).all()
}

enum End {
    Closed,
    Exited,
}

/// Two surfaces and the settings of one tracing.
struct Pair<'a> {
    s1: &'a mut dyn Surface,
    s2: &'a mut dyn Surface,
    tol: &'a CurveTolerance,
    step: f64,
}

impl Pair<'_> {
    fn eval(&mut self, p: DVec3) -> Result<(ValueGrad, ValueGrad), CurveError> {
        let a = self.s1.value_gradient(p);
        let b = self.s2.value_gradient(p);
        let finite = |vg: &ValueGrad| vg.value.is_finite() && vg.gradient.is_finite();
        if finite(&a) && finite(&b) {
            Ok((a, b))
        } else {
            Err(CurveError::NotFinite { at: p })
        }
    }

    fn floor(&self, p: DVec3) -> f64 {
        (self.tol.relative_step * self.step).max(ROUNDING * p.abs().max_element())
    }

    /// The unit tangent ∇f1 × ∇f2 / |…| at p, or TangentVanishes.
    fn tangent(&mut self, p: DVec3) -> Result<DVec3, CurveError> {
        let (a, b) = self.eval(p)?;
        let c = a.gradient.cross(b.gradient);
        let sine = sine(a.gradient, b.gradient);
        if sine.is_nan() || sine < self.tol.tangent_sine {
            return Err(CurveError::TangentVanishes { at: p, sine });
        }
        Ok(c / c.length())
    }

    /// Newton on (f1, f2) with the minimum-norm step, from `near` to a point on both
    /// surfaces. The residual of a point is max |f_i|/|∇f_i|, the first-order distance to the
    /// farther surface.
    fn seek(&mut self, near: DVec3) -> Result<DVec3, CurveError> {
        let mut p = near;
        let mut best = (f64::INFINITY, near);
        for _ in 0..self.tol.max_seek_iterations {
            let (a, b) = self.eval(p)?;
            let residual =
                (a.value.abs() / a.gradient.length()).max(b.value.abs() / b.gradient.length());
            if residual < best.0 {
                best = (residual, p);
            }
            let sine = sine(a.gradient, b.gradient);
            if sine < self.tol.tangent_sine && residual <= self.step {
                return Err(CurveError::TangentVanishes { at: p, sine });
            }
            let delta = min_norm_step(a, b, self.tol.tangent_sine);
            if !delta.is_finite() {
                break;
            }
            let len = delta.length();
            p -= delta;
            if len <= self.floor(p) {
                // A stationary point of the (pseudo-inverse) iteration need not lie on both
                // surfaces: where the normals are parallel it is a least-squares compromise.
                let (a, b) = self.eval(p)?;
                let residual =
                    (a.value.abs() / a.gradient.length()).max(b.value.abs() / b.gradient.length());
                if residual > self.tol.meet_residual * self.step {
                    break;
                }
                self.tangent(p)?;
                return Ok(p);
            }
        }
        Err(CurveError::NoMeeting {
            near,
            best: best.1,
            residual: best.0,
        })
    }

    /// Slides p along the curve to the curve point nearest `near` (locally): move by the
    /// tangential part of near − p (at most δ), correct in the plane normal to the tangent.
    /// Stops when the tangential part is below the tolerance or stops shrinking.
    fn slide(&mut self, mut p: DVec3, near: DVec3) -> Result<DVec3, CurveError> {
        let mut last = f64::INFINITY;
        for _ in 0..self.tol.max_slide_iterations {
            let t = self.tangent(p)?;
            let s = (near - p).dot(t);
            if s.abs() <= self.floor(p) || s.abs() >= last {
                break;
            }
            last = s.abs();
            let q = p + s.clamp(-self.step, self.step) * t;
            match self.correct(q, Some((q, t))) {
                Some(c) => p = c,
                None => break,
            }
        }
        Ok(p)
    }

    /// Newton onto both surfaces from p0; with a plane (origin, normal), onto the point of the
    /// curve in that plane (3×3 Newton), else with the minimum-norm step. None if it fails.
    fn correct(&mut self, p0: DVec3, plane: Option<(DVec3, DVec3)>) -> Option<DVec3> {
        let mut p = p0;
        for _ in 0..self.tol.max_corrector_iterations {
            let (a, b) = self.eval(p).ok()?;
            let delta = match plane {
                Some((o, m)) => {
                    let rows = DMat3::from_cols(a.gradient, b.gradient, m).transpose();
                    let det = rows.determinant();
                    let size = a.gradient.length() * b.gradient.length() * m.length();
                    if det.is_nan() || det.abs() <= self.tol.tangent_sine * size {
                        return None;
                    }
                    rows.inverse() * DVec3::new(a.value, b.value, m.dot(p - o))
                }
                None => min_norm_step(a, b, self.tol.tangent_sine),
            };
            if !delta.is_finite() {
                return None;
            }
            let len = delta.length();
            p -= delta;
            if len <= self.floor(p) {
                return Some(p);
            }
        }
        None
    }

    /// Traces from `start` in direction `dir`·(∇f1 × ∇f2) at δ/substeps until the curve closes
    /// or leaves the box (the exit point, on the box face, is the last point).
    fn trace(
        &mut self,
        start: DVec3,
        dir: f64,
        bbox: Option<(DVec3, DVec3)>,
    ) -> Result<(Vec<DVec3>, End), CurveError> {
        let tol = self.tol;
        let h0 = self.step / f64::from(tol.substeps.max(1));
        let budget = tol.max_length * self.step;
        let max_points = tol
            .max_vertices
            .saturating_mul(tol.substeps.max(1) as usize);
        let mut points = vec![start];
        let mut p = start;
        let mut t = dir * self.tangent(p)?;
        let mut h = h0;
        let mut length = 0.0;
        loop {
            if length > budget {
                return Err(CurveError::NoClosure {
                    start,
                    length,
                    last: p,
                });
            }
            if points.len() > max_points {
                return Err(CurveError::TooManyVertices {
                    count: points.len() as f64,
                    max: max_points,
                });
            }
            let mut halvings = 0;
            let (next, next_t) = loop {
                let q = p + h * t;
                if let Some(c) = self.correct(q, Some((q, t))) {
                    let next_t = dir * self.tangent(c)?;
                    let chord = (c - p).length();
                    let turn = t.angle_between(next_t);
                    if (0.5 * h..=1.5 * h).contains(&chord)
                        && turn <= tol.max_turn
                        && (c - p).dot(t) > 0.0
                    {
                        break (c, next_t);
                    }
                }
                halvings += 1;
                if halvings > tol.max_halvings {
                    return Err(CurveError::CorrectionFailed { at: p });
                }
                h *= 0.5;
            };
            let seg = next - p;
            // Relative to the current step, so that a loop shorter than a few nominal steps
            // (traced with halved steps to keep the turn small) neither closes early nor
            // runs round twice.
            if points.len() >= 3 {
                let s = ((start - p).dot(seg) / seg.length_squared()).clamp(0.0, 1.0);
                if (p + s * seg - start).length() <= tol.closure_radius * h {
                    return Ok((points, End::Closed));
                }
            }
            if let Some((lo, hi)) = bbox
                && !inside(next, lo, hi)
            {
                points.push(self.exit(p, next, lo, hi)?);
                return Ok((points, End::Exited));
            }
            points.push(next);
            length += seg.length();
            p = next;
            t = next_t;
            h = (2.0 * h).min(h0);
        }
    }

    /// The curve point on the face of the box that the segment p (inside) → q (outside)
    /// crosses first.
    fn exit(&mut self, p: DVec3, q: DVec3, lo: DVec3, hi: DVec3) -> Result<DVec3, CurveError> {
        let d = q - p;
        let mut best = (f64::INFINITY, 0, 0.0);
        for k in 0..3 {
            let wall = if q[k] > hi[k] {
                hi[k]
            } else if q[k] < lo[k] {
                lo[k]
            } else {
                continue;
            };
            let s = (wall - p[k]) / d[k];
            if s < best.0 {
                best = (s, k, wall);
            }
        }
        let (s, k, wall) = best;
        let mut y = p + s.clamp(0.0, 1.0) * d;
        y[k] = wall;
        let mut axis = DVec3::ZERO;
        axis[k] = 1.0;
        let mut c = self
            .correct(y, Some((y, axis)))
            .ok_or(CurveError::CorrectionFailed { at: y })?;
        c[k] = wall;
        Ok(c)
    }

    /// Resamples a fine polyline uniformly by arc length: n = ⌈L/δ⌉ segments, each new vertex
    /// corrected onto the curve in the plane normal to the polyline there. The first vertex
    /// (and, for open curves, the last) is kept.
    fn resample(&mut self, fine: &[DVec3], closed: bool) -> Result<Vec<DVec3>, CurveError> {
        let Some(line) = ArcLength::new(fine, closed) else {
            return Ok(fine.to_vec());
        };
        let n = segment_count(
            line.total(),
            self.step,
            if closed { 3 } else { 1 },
            self.tol.max_vertices,
        )?;
        line.resample(n, |y, dir| {
            if dir == DVec3::ZERO {
                None
            } else {
                self.correct(y, Some((y, dir)))
            }
        })
        .map_err(|at| CurveError::CorrectionFailed { at })
    }
}

/// A fine polyline measured by arc length, for resampling it into segments of equal length.
pub struct ArcLength<'a> {
    fine: &'a [DVec3],
    closed: bool,
    /// Arc length from the first vertex to each vertex (and, closed, back to the first).
    cumulative: Vec<f64>,
}

impl<'a> ArcLength<'a> {
    /// None for a polyline without a segment.
    pub fn new(fine: &'a [DVec3], closed: bool) -> Option<Self> {
        let m = fine.len();
        let segments = if closed { m } else { m.saturating_sub(1) };
        if segments == 0 {
            return None;
        }
        let mut cumulative = Vec::with_capacity(segments + 1);
        cumulative.push(0.0);
        for i in 0..segments {
            let len = (fine[(i + 1) % m] - fine[i]).length();
            cumulative.push(cumulative[i] + len);
        }
        Some(ArcLength {
            fine,
            closed,
            cumulative,
        })
    }

    /// The polyline's length.
    pub fn total(&self) -> f64 {
        self.cumulative[self.cumulative.len() - 1]
    }

    /// `n` segments of equal arc length: the first vertex, n − 1 points at equal arc lengths
    /// put through `correct` (the point on the polyline and the unit direction of its segment,
    /// zero for a degenerate one), and for an open polyline the last vertex. The point where
    /// `correct` failed, if it did.
    pub fn resample(
        &self,
        n: usize,
        correct: impl FnMut(DVec3, DVec3) -> Option<DVec3>,
    ) -> Result<Vec<DVec3>, DVec3> {
        let total = self.total();
        self.resample_at((1..n).map(|k| total * k as f64 / n as f64), correct)
    }

    /// The arc length of the polyline's point nearest q.
    pub fn nearest(&self, q: DVec3) -> f64 {
        let (fine, m) = (self.fine, self.fine.len());
        let mut best = (f64::INFINITY, 0.0);
        for i in 0..self.cumulative.len() - 1 {
            let (a, b) = (fine[i], fine[(i + 1) % m]);
            let w = nearest_on_segment(q, a, b);
            let d = q.distance_squared(a.lerp(b, w));
            if d < best.0 {
                best = (
                    d,
                    self.cumulative[i] + w * (self.cumulative[i + 1] - self.cumulative[i]),
                );
            }
        }
        best.1
    }

    /// The arc length from the first vertex to fine vertex i.
    pub fn at(&self, i: usize) -> f64 {
        self.cumulative[i.min(self.cumulative.len() - 1)]
    }

    /// As [`ArcLength::resample`], with the inner points at the given increasing arc lengths
    /// (strictly between 0 and the total).
    pub fn resample_at(
        &self,
        arcs: impl Iterator<Item = f64>,
        mut correct: impl FnMut(DVec3, DVec3) -> Option<DVec3>,
    ) -> Result<Vec<DVec3>, DVec3> {
        let (fine, m) = (self.fine, self.fine.len());
        let mut out = Vec::with_capacity(arcs.size_hint().0 + 2);
        out.push(fine[0]);
        for s in arcs {
            let (_, y, direction) = self.locate(s);
            out.push(correct(y, direction).ok_or(y)?);
        }
        if !self.closed {
            out.push(fine[m - 1]);
        }
        Ok(out)
    }

    /// The point at arc length s: its segment, the point and the segment's unit direction
    /// (zero for a degenerate one).
    pub fn locate(&self, s: f64) -> (usize, DVec3, DVec3) {
        let (fine, m) = (self.fine, self.fine.len());
        let segments = self.cumulative.len() - 1;
        let i = self
            .cumulative
            .partition_point(|&c| c <= s)
            .clamp(1, segments)
            - 1;
        let (a, b) = (fine[i], fine[(i + 1) % m]);
        let seg_len = self.cumulative[i + 1] - self.cumulative[i];
        let w = if seg_len > 0.0 {
            (s - self.cumulative[i]) / seg_len
        } else {
            0.0
        };
        (i, a.lerp(b, w), (b - a).normalize_or_zero())
    }
}

/// Where on the segment a..b the point nearest q lies, as a fraction of the way from a (0
/// for a degenerate segment).
pub fn nearest_on_segment(q: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let l2 = ab.length_squared();
    if l2 > 0.0 {
        ((q - a).dot(ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// |n1 × n2| for the unit normals of two gradients (0 if either vanishes).
fn sine(g1: DVec3, g2: DVec3) -> f64 {
    let d = g1.length() * g2.length();
    if d > 0.0 {
        g1.cross(g2).length() / d
    } else {
        0.0
    }
}

/// The minimum-norm Newton step Δ = Jᵀ(JJᵀ)⁻¹F for F = (f1, f2), J = (∇f1; ∇f2); where the
/// normals are nearly parallel, the pseudo-inverse drops the small singular direction.
pub(crate) fn min_norm_step(a: ValueGrad, b: ValueGrad, tangent_sine: f64) -> DVec3 {
    let (g1, g2) = (a.gradient, b.gradient);
    let (m11, m12, m22) = (g1.dot(g1), g1.dot(g2), g2.dot(g2));
    let det = m11 * m22 - m12 * m12;
    if det > tangent_sine * tangent_sine * m11 * m22 {
        let y1 = (m22 * a.value - m12 * b.value) / det;
        let y2 = (m11 * b.value - m12 * a.value) / det;
        return y1 * g1 + y2 * g2;
    }
    // Pseudo-inverse: keep the large eigenvalue λ of JJᵀ only (its eigenvector e).
    let mean = 0.5 * (m11 + m22);
    let half = (0.5 * (m11 - m22)).hypot(m12);
    let lambda = mean + half;
    if lambda <= 0.0 {
        return DVec3::NAN;
    }
    let e = if m11 >= m22 {
        (lambda - m22, m12)
    } else {
        (m12, lambda - m11)
    };
    let el = (e.0 * e.0 + e.1 * e.1).sqrt();
    let e = if el > 0.0 {
        (e.0 / el, e.1 / el)
    } else {
        (1.0, 0.0)
    };
    let y = (e.0 * a.value + e.1 * b.value) / lambda;
    y * (e.0 * g1 + e.1 * g2)
}

// ---------------------------------------------------------------------------------------------
// Circles.

/// The circle as a closed polygon of n = ⌈2πr/δ⌉ (at least 3) equal segments: see
/// `circle_segments`.
pub fn circle(center: DVec3, normal: DVec3, radius: f64, step: f64) -> Result<Polygon, CurveError> {
    check_step(step)?;
    let n = segment_count(
        std::f64::consts::TAU * radius,
        step,
        3,
        CurveTolerance::default().max_vertices,
    )?;
    circle_segments(center, normal, radius, n)
}

/// The circle as a closed polygon of n (at least 3) equal segments, vertex k at
/// center + r(cos(2πk/n) t1 + sin(2πk/n) t2), (t1, t2) = `tangent_frame(normal/|normal|)`:
/// counter-clockwise around `normal`, starting at center + r·t1.
pub fn circle_segments(
    center: DVec3,
    normal: DVec3,
    radius: f64,
    n: usize,
) -> Result<Polygon, CurveError> {
    let bad = CurveError::InvalidCircle {
        center,
        normal,
        radius,
    };
    let Some(n_hat) = normal.try_normalize() else {
        return Err(bad);
    };
    if !(center.is_finite() && radius.is_finite() && radius > 0.0) || n < 3 {
        return Err(bad);
    }
    let max = CurveTolerance::default().max_vertices;
    if n > max {
        return Err(CurveError::TooManyVertices {
            count: n as f64,
            max,
        });
    }
    let (t1, t2) = tangent_frame(n_hat);
    let points = (0..n)
        .map(|k| {
            let (sin, cos) = (std::f64::consts::TAU * k as f64 / n as f64).sin_cos();
            center + radius * (cos * t1 + sin * t2)
        })
        .collect();
    Ok(Polygon {
        points,
        closed: true,
    })
}

/// Each vertex replaced by surfacepoint(vertex) on `surface` (docs/language.md: a curve's points are
/// projected onto the surface that uses it). `scale` is the mesh step.
pub fn project_onto(
    surface: &mut dyn Surface,
    polygon: &Polygon,
    scale: f64,
    tolerance: &SurfacePointTolerance,
) -> Result<Polygon, CurveError> {
    let points = polygon
        .points
        .iter()
        .enumerate()
        .map(|(index, &p)| {
            surface_point(surface, p, scale, tolerance)
                .map(|sp| sp.point)
                .map_err(|source| CurveError::Projection { index, source })
        })
        .collect::<Result<_, _>>()?;
    Ok(Polygon {
        points,
        closed: polygon.closed,
    })
}

// ---------------------------------------------------------------------------------------------
// Patch boundaries.

/// Samples per edge and per δ of the arc-length table of `boundary`.
const ARC_TABLE_DENSITY: usize = 32;

/// Entries of one edge's arc-length table at most (a tiny step on a long edge must not
/// allocate gigabytes; the table then has fewer samples than one per δ/32).
const MAX_ARC_TABLE: usize = 1 << 22;

/// The image of the boundary of the patch's declared parameter rectangle, counter-clockwise in
/// (u, v) from (u_lo, v_lo), closed. Each edge gets ⌈L_e/δ⌉ segments of equal object-space
/// arc length (from a dense arc-length table, inverted by linear interpolation); the four
/// corners are vertices. An edge that collapses to a point adds nothing.
pub fn boundary(patch: &mut dyn Patch, step: f64) -> Result<Polygon, CurveError> {
    check_step(step)?;
    let (ud, vd) = patch.domain();
    let valid = |(lo, hi): (f64, f64)| lo.is_finite() && hi.is_finite() && hi > lo;
    if !valid(ud) || !valid(vd) {
        return Err(CurveError::BadDomain { u: ud, v: vd });
    }
    let corners = [(ud.0, vd.0), (ud.1, vd.0), (ud.1, vd.1), (ud.0, vd.1)];
    let max = CurveTolerance::default().max_vertices;
    let mut points: Vec<DVec3> = Vec::new();
    for e in 0..4 {
        let (a, b) = (corners[e], corners[(e + 1) % 4]);
        let at = |s: f64| (a.0 + s * (b.0 - a.0), a.1 + s * (b.1 - a.1));
        let mut eval = |s: f64| {
            let (u, v) = at(s);
            let p = patch.point_jacobian(u, v).point;
            if p.is_finite() {
                Ok(p)
            } else {
                Err(CurveError::PatchNotFinite { u, v })
            }
        };
        // A coarse pass sizes the table, a dense one measures arc length.
        let coarse = 64;
        let mut rough = 0.0;
        let mut prev = eval(0.0)?;
        for i in 1..=coarse {
            let p = eval(i as f64 / coarse as f64)?;
            rough += (p - prev).length();
            prev = p;
        }
        let dense = segment_count(rough, step, 1, max)?
            .saturating_mul(ARC_TABLE_DENSITY)
            .clamp(coarse, MAX_ARC_TABLE);
        let mut table = Vec::with_capacity(dense + 1);
        let mut prev = eval(0.0)?;
        table.push((0.0, 0.0));
        let mut length = 0.0;
        for i in 1..=dense {
            let s = i as f64 / dense as f64;
            let p = eval(s)?;
            length += (p - prev).length();
            table.push((s, length));
            prev = p;
        }
        let start = eval(0.0)?;
        if points.last() != Some(&start) {
            points.push(start);
        }
        if length == 0.0 {
            continue;
        }
        let n = segment_count(length, step, 1, max)?;
        for k in 1..n {
            let target = length * k as f64 / n as f64;
            let i = table.partition_point(|&(_, l)| l <= target).clamp(1, dense) - 1;
            let ((s0, l0), (s1, l1)) = (table[i], table[i + 1]);
            let s = if l1 > l0 {
                s0 + (target - l0) / (l1 - l0) * (s1 - s0)
            } else {
                s0
            };
            points.push(eval(s)?);
        }
    }
    if points.len() > 1 && points.first() == points.last() {
        points.pop();
    }
    Ok(Polygon {
        points,
        closed: true,
    })
}

// ---------------------------------------------------------------------------------------------
// Reversal.

/// The polygon walked the other way. A closed polygon keeps its first vertex first
/// (p0, p_{n−1}, …, p1), so a curve and its reverse share their start; an open one is simply
/// reversed (it then starts at the other end).
pub fn reverse(polygon: &Polygon) -> Polygon {
    let mut points = polygon.points.clone();
    if polygon.closed && points.len() > 1 {
        points[1..].reverse();
    } else {
        points.reverse();
    }
    Polygon {
        points,
        closed: polygon.closed,
    }
}
