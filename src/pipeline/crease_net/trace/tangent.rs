//! Tangent crossings: points where the two faces of a crease touch tangentially and cross
//! like a saddle. Two rods of one radius whose axes cross touch at two points, and there the
//! two ellipses of their crossing meet: the crease direction ∇Lᵢ × ∇Lⱼ vanishes, so no walk
//! passes, and the four arcs that meet there bound four sectors, each face in two opposite
//! ones. The point is solved as the saddle of Lⱼ over Lᵢ's sheet and becomes a corner of
//! the four creases; each face's loops are chained there by their turn around the common
//! normal (`join::chain`).
//!
//! Only a clean saddle is such a corner: Lⱼ zero at the critical point to the spine's tie,
//! its second derivatives of opposite signs with the four arcs at least `MIN_ARC_ANGLE`
//! apart, and each arc, found a little away along its direction, a crease of the two faces.
//! Anything else — spheres that touch at a point, faces that become one sheet where the
//! crease dies out — stays a tangent contact, refused at its place.

use glam::{DMat2, DVec2, DVec3};

use super::{Corner, Tracer, same_faces};
use crate::pipeline::crease_net::CreaseError;
use crate::solve::surfacepoint::tangent_frame;
use crate::survey::faces::{self, Crossing, Leaving};

/// The four arcs must be at least this far apart (radians) for the corner to be meshed:
/// the sectors between them are corners of their pieces' loops.
const MIN_ARC_ANGLE: f64 = 0.05;

/// A stuck walk is this close (in steps) to a tangent crossing found already when it ends
/// there: walks stop within about a thousandth of a step of it, and two such points of one
/// pair of faces are a feature apart.
const REUSE: f64 = 0.1;

/// Where the arcs are looked for: this fraction of the step from the corner, or less where
/// the faces part faster (their relative curvature), so that the arcs are still near the
/// straight lines the second derivatives give.
const ARC_REACH: f64 = 0.1;

/// The sheet of form i above the tangent plane at `origin`, and the value of the other form
/// over it: the point above (u, v), the gradient of h = Lⱼ over (u, v), and h.
struct Chart {
    i: usize,
    j: usize,
    origin: DVec3,
    n: DVec3,
    e1: DVec3,
    e2: DVec3,
}

impl Tracer<'_> {
    /// The corner where the crease of forms i and j, stuck at p with their normals nearly
    /// parallel, meets the point where its faces touch and cross (see the module
    /// documentation): found already, or solved and added. None when there is no clean
    /// saddle there (the caller reports the tangent contact).
    pub(in crate::pipeline::crease_net) fn tangent_crossing(
        &mut self,
        i: usize,
        j: usize,
        p: DVec3,
    ) -> Result<Option<usize>, CreaseError> {
        for (id, corner) in self.corners.iter().enumerate() {
            if corner.tangent.is_some()
                && corner.at.distance(p) <= REUSE * self.step
                && same_faces(self.c, corner.leaving[0].faces, i, j)
            {
                return Ok(Some(id));
            }
        }
        let n = self.c.form(i, p).gradient.normalize_or_zero();
        if n == DVec3::ZERO {
            return Ok(None);
        }
        let (e1, e2) = tangent_frame(n);
        let chart = Chart {
            i,
            j,
            origin: p,
            n,
            e1,
            e2,
        };
        // Newton on ∇h = 0, the second derivatives by central differences of ∇h.
        let delta = 1e-4 * self.step;
        let mut uv = DVec2::ZERO;
        let mut hessian = DMat2::ZERO;
        let mut converged = false;
        for _ in 0..40 {
            let Some((_, g, _)) = self.over(&chart, uv) else {
                return Ok(None);
            };
            let mut cols = [DVec2::ZERO; 2];
            for (axis, col) in cols.iter_mut().enumerate() {
                let d = if axis == 0 {
                    DVec2::new(delta, 0.0)
                } else {
                    DVec2::new(0.0, delta)
                };
                let (Some((_, ga, _)), Some((_, gb, _))) =
                    (self.over(&chart, uv + d), self.over(&chart, uv - d))
                else {
                    return Ok(None);
                };
                *col = (ga - gb) / (2.0 * delta);
            }
            let off = 0.5 * (cols[0].y + cols[1].x);
            hessian = DMat2::from_cols(DVec2::new(cols[0].x, off), DVec2::new(off, cols[1].y));
            let d = hessian.inverse() * g;
            if !d.is_finite() {
                return Ok(None);
            }
            uv -= d;
            if uv.length() > REUSE * self.step {
                return Ok(None);
            }
            if d.length() <= 1e-13 * self.step {
                converged = true;
                break;
            }
        }
        let Some((at, _, h)) = self.over(&chart, uv) else {
            return Ok(None);
        };
        let gj = self.pair(i, j, at).1.gradient.length();
        if !converged || h.abs() > self.eps(gj) || !self.inside(at) {
            return Ok(None);
        }
        // A saddle: second derivatives of opposite signs along the eigenvectors.
        let (a, b, c) = (hessian.x_axis.x, hessian.x_axis.y, hessian.y_axis.y);
        let mid = 0.5 * (a + c);
        let radius = (0.25 * (a - c) * (a - c) + b * b).sqrt();
        let (up, down) = (mid + radius, mid - radius);
        if !(up > 0.0 && down < 0.0) {
            return Ok(None);
        }
        let w1 = if (up - c).abs() >= (up - a).abs() {
            DVec2::new(up - c, b)
        } else {
            DVec2::new(b, up - a)
        }
        .normalize_or_zero();
        if w1 == DVec2::ZERO {
            return Ok(None);
        }
        let w2 = w1.perp();
        // The zero lines of the quadratic: up·(d·w1)² + down·(d·w2)² = 0.
        let half = (up / -down).sqrt().atan();
        if half.min(std::f64::consts::FRAC_PI_2 - half) < 0.5 * MIN_ARC_ANGLE {
            return Ok(None);
        }
        let reach = (ARC_REACH * self.step).min(ARC_REACH * gj / up.max(-down));
        let normal = self.c.whole(at).gradient.normalize_or_zero();
        let (scale, fs) = (self.scale(), self.faces());
        let mut leaving = Vec::with_capacity(4);
        for (cos, sin) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
            let d2 = cos * half.cos() * w1 + sin * half.sin() * w2;
            let d = d2.x * e1 + d2.y * e2;
            let y = at + reach * d;
            let Some(q) = self.correct(i, j, y, y, d) else {
                return Ok(None);
            };
            if !(0.5 * reach..=2.0 * reach).contains(&q.distance(at)) {
                return Ok(None);
            }
            let Ok(mut t) = self.tangent(i, j, q) else {
                return Ok(None);
            };
            if t.dot(d) < 0.0 {
                t = -t;
            }
            let Crossing::Crease { faces } = faces::crossing(self.c, q, t, &scale, &fs)? else {
                return Ok(None);
            };
            if !same_faces(self.c, faces, i, j) {
                return Ok(None);
            }
            leaving.push(Leaving {
                faces,
                direction: (q - at).normalize_or_zero(),
                at: q,
            });
        }
        if crate::trace::enabled() {
            eprintln!(
                "creases: the faces of {i} and {j} touch and cross at {at}: a corner of four creases"
            );
        }
        self.corners.push(Corner {
            at,
            leaving,
            hand_over: false,
            tangent: Some(normal),
            dying: None,
        });
        Ok(Some(self.corners.len() - 1))
    }

    /// The point of form i's sheet above `uv` of the chart (Newton along the chart's normal),
    /// the gradient over (u, v) of the other form there, and its value. None where the sheet
    /// is not a graph over the chart's plane.
    fn over(&mut self, chart: &Chart, uv: DVec2) -> Option<(DVec3, DVec2, f64)> {
        let mut x = chart.origin + uv.x * chart.e1 + uv.y * chart.e2;
        let mut a = self.c.form(chart.i, x);
        for _ in 0..40 {
            let along = a.gradient.dot(chart.n);
            if along.is_nan() || along.abs() <= 0.5 * a.gradient.length() {
                return None;
            }
            let w = a.value / along;
            x -= w * chart.n;
            a = self.c.form(chart.i, x);
            if w.abs() <= 1e-15 * self.step.max(x.abs().max_element()) {
                break;
            }
        }
        let b = self.pair(chart.i, chart.j, x).1;
        let along = a.gradient.dot(chart.n);
        // The sheet's tangents over the chart's axes.
        let su = chart.e1 - (a.gradient.dot(chart.e1) / along) * chart.n;
        let sv = chart.e2 - (a.gradient.dot(chart.e2) / along) * chart.n;
        let g = DVec2::new(b.gradient.dot(su), b.gradient.dot(sv));
        (x.is_finite() && g.is_finite()).then_some((x, g, b.value))
    }
}
