//! Smoothing of one vertex: a free vertex moved on the surface for its fan's angle or
//! radius ratios (`smooth`, candidates from the angle-based position, the ring's mean and
//! the worst triangle's ideal apex, or a step up the ratios' gradient), a border vertex
//! slid along its box face (`slide`); `relax` picks which.

use glam::DVec3;

use crate::surface::Surface;

use super::fan::{Fan, FanQuality};
use super::shape::radius_ratio;
use super::{ANGLE_GAIN, KEEP_ANGLE, MAX_FAN, Project, SMOOTH_GAIN, Stage, min_sin, prev};

impl Stage<'_> {
    /// The worst smallest-angle sine, the worst radius ratio and the sum of radius ratios of
    /// the fan of v (half-edges `star`) with v at `p`.
    fn star_quality(&self, star: &[u32], p: DVec3) -> (f64, f64, f64) {
        let (mut worst, mut worst_rr, mut sum) = (f64::INFINITY, f64::INFINITY, 0.0);
        for &e in star {
            let (b, c) = (self.p(self.dst(e)), self.p(self.org(prev(e))));
            worst = worst.min(min_sin(p, b, c));
            let rr = radius_ratio(p, b, c);
            worst_rr = worst_rr.min(rr);
            sum += rr;
        }
        (worst, worst_rr, sum)
    }

    /// Zhou–Shimada's angle-based position for v, in the tangent plane at v: each ring
    /// neighbour proposes the point at v's distance on the bisector of its own angle in the
    /// ring; the mean of the proposals.
    fn angle_based(&self, v: u32, star: &[u32]) -> DVec3 {
        let (p, n) = (self.p(v), self.normal[v as usize]);
        let flat = |q: DVec3| q - (q - p).dot(n) * n;
        let k = star.len().min(MAX_FAN);
        let mut ring = [DVec3::ZERO; MAX_FAN];
        for (r, &e) in ring.iter_mut().zip(star) {
            *r = flat(self.p(self.dst(e)));
        }
        let mut sum = DVec3::ZERO;
        for j in 0..k {
            let pj = ring[j];
            let (before, after) = (ring[(j + k - 1) % k], ring[(j + 1) % k]);
            let mut bis = (before - pj).normalize_or_zero() + (after - pj).normalize_or_zero();
            if bis.dot(p - pj) < 0.0 {
                bis = -bis;
            }
            let bis = bis.normalize_or_zero();
            if bis == DVec3::ZERO {
                sum += p;
            } else {
                sum += pj + p.distance(pj) * bis;
            }
        }
        sum / k as f64
    }

    /// The apex of the equilateral triangle over the far edge of the fan's worst triangle
    /// (in the tangent plane at v): where the worst triangle wants v.
    fn ideal_apex(&self, v: u32, star: &[u32]) -> DVec3 {
        let (p, n) = (self.p(v), self.normal[v as usize]);
        // The first worst triangle (as `min_by` would pick it), each sine computed once.
        let mut worst: Option<(f64, (DVec3, DVec3))> = None;
        for &e in star {
            let (b, c) = (self.p(self.dst(e)), self.p(self.org(prev(e))));
            let sin = min_sin(p, b, c);
            if worst.is_none_or(|(w, _)| sin.total_cmp(&w).is_lt()) {
                worst = Some((sin, (b, c)));
            }
        }
        worst.map_or(p, |(_, (b, c))| {
            let d = c - b;
            let left = n.cross(d).normalize_or_zero();
            let m = 0.5 * (b + c);
            let m = m - (m - p).dot(n) * n;
            m + left * (d.length() * 3f64.sqrt() / 2.0)
        })
    }

    /// Moves free vertex v to a better place on the surface. For the angle (`ratio` false:
    /// the rounds proper and insertions on trial), where the fan has a triangle of radius
    /// ratio below `below`: the angle-based position, the mean of the ring and halfway to
    /// either or towards the worst triangle's ideal apex, the first that is better (the
    /// fan's smallest angle rises, or stays and its radius ratios rise by `ANGLE_GAIN`). For
    /// the ratios (`polish`): first a step up the gradient of the fan's sum of radius ratios
    /// (`Fan::ascent`), then the same candidates, better if the smallest angle rises or the
    /// ratios rise by `SMOOTH_GAIN` while the smallest angle stays at or above min(its old
    /// value, `KEEP_ANGLE`). The candidate is projected; the move is kept if the fan is
    /// still better there, every triangle faces ∇f and no edge of the fan grows beyond its
    /// longest.
    fn smooth(
        &mut self,
        v: u32,
        star: &[u32],
        below: f64,
        ratio: bool,
        project: &mut dyn FnMut(DVec3) -> Option<(DVec3, DVec3)>,
    ) -> bool {
        let Some(fan) = Fan::closed(self, star) else {
            return false;
        };
        let p = self.p(v);
        let for_angle = !ratio;
        let (old, gradient) = if for_angle {
            (fan.eval(p), DVec3::ZERO)
        } else {
            fan.eval_grad(p)
        };
        let longest = fan.longest(p);
        let (keep, gain) = if for_angle {
            (old.worst, ANGLE_GAIN)
        } else {
            (old.worst.min(KEEP_ANGLE.sin().powi(2)), SMOOTH_GAIN)
        };
        let better = |q: &FanQuality| {
            q.worst > old.worst * (1.0 + 1e-6) || (q.worst >= keep && q.sum > old.sum + gain)
        };
        let n = self.normal[v as usize];
        // For the ratios, a fan with a triangle below the target tries the angle's candidates
        // first (the ascent would take the move and leave the angle where it is); the others
        // the ascent first. For the angle, only the angle's candidates.
        let angle_first = for_angle || old.worst < self.bad_sin2;
        let by_ratio = || {
            if for_angle {
                return None;
            }
            fan.ascent(p, n, gradient, longest.sqrt())?
                .into_iter()
                .find(|&q| better(&fan.eval(q)))
        };
        let by_angle = |s: &Self| {
            if old.worst_rr >= below {
                return None;
            }
            let ring_mean = fan.ring[..fan.k]
                .iter()
                .map(|&q| q - (q - p).dot(n) * n)
                .sum::<DVec3>()
                / fan.k as f64;
            let ab = s.angle_based(v, star);
            [ab, ring_mean, 0.5 * (p + ab), 0.5 * (p + ring_mean)]
                .into_iter()
                .find(|&q| better(&fan.eval(q)))
                .or_else(|| {
                    // Towards the worst triangle's ideal apex, computed only when the
                    // candidates above fail.
                    let ideal = s.ideal_apex(v, star);
                    [
                        0.5 * (p + ideal),
                        0.75 * p + 0.25 * ideal,
                        0.875 * p + 0.125 * ideal,
                    ]
                    .into_iter()
                    .find(|&q| better(&fan.eval(q)))
                })
        };
        let target = if angle_first {
            by_angle(self).or_else(by_ratio)
        } else {
            by_ratio().or_else(|| by_angle(self))
        };
        let Some(target) = target else {
            return false;
        };
        let Some((sp, sn)) = project(target) else {
            return false;
        };
        if better(&fan.eval(sp)) && fan.holds(sp, sn, longest) {
            self.place(v, sp, sn);
            true
        } else {
            false
        }
    }

    /// Puts v at `to` (point, normal) if the fan is `better` there, every triangle of it
    /// still faces ∇f and no edge of it is longer than `longest` (squared): what a move
    /// checks once its target is on the surface. Returns whether v moved.
    fn move_if(
        &mut self,
        v: u32,
        star: &[u32],
        to: (DVec3, DVec3),
        longest: f64,
        better: &dyn Fn(&Self, DVec3) -> bool,
    ) -> bool {
        let (sp, sn) = to;
        let (old_p, old_n) = (self.p(v), self.normal[v as usize]);
        self.pos[v as usize] = sp;
        self.normal[v as usize] = sn;
        let ok = better(self, sp)
            && star.iter().all(|&e| {
                let t = self.tri[(e / 3) as usize];
                self.facing(t, self.corners(t))
                    && sp.distance_squared(self.p(self.dst(e))) <= longest
            });
        self.pos[v as usize] = old_p;
        self.normal[v as usize] = old_n;
        if ok {
            self.place(v, sp, sn);
        }
        ok
    }

    /// Moves vertex v to a better place if it may move: a free vertex on the surface
    /// (`smooth`), a border vertex along its box face (`slide`). `star` is scratch space.
    pub(super) fn relax(
        &mut self,
        v: u32,
        star: &mut Vec<u32>,
        below: f64,
        ratio: bool,
        surface: &mut dyn Surface,
        project: &mut Project<'_>,
    ) -> bool {
        if self.free(v) {
            if !self.star(v, star) {
                return false;
            }
            let mut proj = |q: DVec3| project(surface, q);
            self.smooth(v, star, below, ratio, &mut proj)
        } else if let Some(face) = self.slide_face(v).filter(|_| !ratio) {
            self.open_star(v, star) && self.slide(v, star, face, below, surface)
        } else {
            false
        }
    }

    /// The box face a border vertex may slide on, as (axis, value): a border point that is
    /// no polygon vertex, touches no non-manifold edge, and lies on exactly one face of the
    /// box (a point on a box edge or corner stays, so the box's edges keep their points).
    fn slide_face(&self, v: u32) -> Option<(usize, f64)> {
        let i = v as usize;
        if i < self.fixed || !self.border[i] || self.frozen[i] {
            return None;
        }
        self.face_of(self.p(v))
    }

    /// Slides border vertex v along the curve where the surface meets its box face (the
    /// face coordinate held exactly, `face_point`), if a place on that curve raises the
    /// fan's quality as `smooth` asks. Targets: the point between the two boundary
    /// neighbours, and the worst triangle's ideal apex and the ring's mean projected onto
    /// the curve's tangent, each also halfway.
    fn slide(
        &mut self,
        v: u32,
        star: &[u32],
        face: (usize, f64),
        below: f64,
        surface: &mut dyn Surface,
    ) -> bool {
        let p = self.p(v);
        let (old_worst, old_worst_rr, old_sum) = self.star_quality(star, p);
        if old_worst_rr >= below {
            return false;
        }
        let (axis, value) = face;
        let n = self.normal[v as usize];
        let mut along = DVec3::ZERO;
        along[axis] = 1.0;
        let tangent = n.cross(along).normalize_or_zero();
        if tangent == DVec3::ZERO {
            return false;
        }
        let (Some(&e0), Some(&e1)) = (star.first(), star.last()) else {
            return false;
        };
        let (b0, b1) = (self.p(self.dst(e0)), self.p(self.org(prev(e1))));
        let ring_mean =
            star.iter().map(|&e| self.p(self.dst(e))).sum::<DVec3>() / star.len() as f64;
        let ideal = self.ideal_apex(v, star);
        let on_line = |q: DVec3| p + tangent * (q - p).dot(tangent);
        let targets = [on_line(0.5 * (b0 + b1)), on_line(ideal), on_line(ring_mean)];
        let better = |s: &Self, q: DVec3| {
            let (w, _, sum) = s.star_quality(star, q);
            w > old_worst * (1.0 + 1e-6) || (w >= old_worst && sum > old_sum + ANGLE_GAIN)
        };
        let longest = star
            .iter()
            .map(|&e| p.distance_squared(self.p(self.dst(e))))
            .fold(0.0f64, f64::max);
        let scale = self.h[v as usize];
        for target in targets.into_iter().flat_map(|q| [q, 0.5 * (p + q)]) {
            if !better(self, target) {
                continue;
            }
            let Some((sp, sn)) = face_point(surface, target, axis, value, scale) else {
                continue;
            };
            if self.in_box(sp)
                && self.face_of(sp) == Some(face)
                && self.move_if(v, star, (sp, sn), longest, &better)
            {
                return true;
            }
        }
        false
    }

    /// The face of the box point p is on, as (axis, value), if it is on exactly one (a slide
    /// must not end on a box edge, where the next could not tell its face).
    fn face_of(&self, p: DVec3) -> Option<(usize, f64)> {
        let (lo, hi) = self.bbox?;
        let mut on = (0..3).filter_map(|k| {
            [lo[k], hi[k]]
                .into_iter()
                .find(|&b| p[k] == b)
                .map(|b| (k, b))
        });
        let face = on.next()?;
        on.next().is_none().then_some(face)
    }
}

/// The point of the surface in the plane x[axis] = value nearest q (Newton on f with the
/// gradient's component along the axis removed), its unit normal; None if it does not
/// converge to within 1e-13·scale.
pub(super) fn face_point(
    surface: &mut dyn Surface,
    q: DVec3,
    axis: usize,
    value: f64,
    scale: f64,
) -> Option<(DVec3, DVec3)> {
    let mut u = q;
    u[axis] = value;
    for _ in 0..32 {
        let vg = surface.value_gradient(u);
        let mut g = vg.gradient;
        g[axis] = 0.0;
        let gg = g.length_squared();
        if !(vg.value.is_finite() && gg > 0.0 && gg.is_finite()) {
            return None;
        }
        let step = g * (vg.value / gg);
        if step.length() > scale {
            // The surface runs nearly parallel to the face here.
            return None;
        }
        u -= step;
        u[axis] = value;
        if step.length() <= (1e-12 * scale).max(8.0 * f64::EPSILON * u.abs().max_element()) {
            let n = surface.value_gradient(u).gradient.normalize_or_zero();
            return (n != DVec3::ZERO).then_some((u, n));
        }
    }
    None
}
