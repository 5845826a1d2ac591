//! The ring around a free vertex (`Fan`), gathered once so that the smoothing's candidate
//! places are judged without index chasing: its quality with the centre at a place, the
//! gradient of its radius ratios, and the guards a move must pass.

use glam::DVec3;

use crate::surface::Surface;

use super::shape::{ratio_of_sides, sin2_of};
use super::{ASCENT_STEP, MAX_FAN, NONE, SMOOTH_GAIN, Stage, midpoint_within, prev};

/// The ring around a free vertex, gathered once per smoothing attempt so that the many
/// candidate places are judged without index chasing: ring points in order (the fan is
/// closed), their normals, and the lengths of the ring's edges (the sides opposite v).
pub(super) struct Fan {
    pub(super) k: usize,
    pub(super) ring: [DVec3; MAX_FAN + 1],
    pub(super) normal: [DVec3; MAX_FAN + 1],
    pub(super) opp: [f64; MAX_FAN + 1],
    /// The ring's edge lengths squared (the guards need no more).
    pub(super) opp2: [f64; MAX_FAN + 1],
}

/// The quality of a fan with its centre at some place: the worst sin² of a smallest angle,
/// the worst radius ratio, the sum of radius ratios.
pub(super) struct FanQuality {
    pub(super) worst: f64,
    pub(super) worst_rr: f64,
    pub(super) sum: f64,
}

impl Fan {
    /// The fan of a closed star (`Stage::star`'s half-edges), or None if it is too long.
    pub(super) fn closed(stage: &Stage<'_>, star: &[u32]) -> Option<Fan> {
        let mut fan = Fan::empty();
        fan.gather(stage, star).then_some(fan)
    }

    /// A fan of no triangles, to `gather` into.
    pub(super) fn empty() -> Fan {
        Fan {
            k: 0,
            ring: [DVec3::ZERO; MAX_FAN + 1],
            normal: [DVec3::ZERO; MAX_FAN + 1],
            opp: [0.0; MAX_FAN + 1],
            opp2: [0.0; MAX_FAN + 1],
        }
    }

    /// Makes this the fan of a closed star (as `closed`) in place; false, and the fan left
    /// as it was, if the star is too long. A loop over every vertex gathers into one fan:
    /// a `Fan` is near a kilobyte, and building and moving one a vertex was a tenth of the
    /// smoothing round's time on the fine sphere.
    pub(super) fn gather(&mut self, stage: &Stage<'_>, star: &[u32]) -> bool {
        let k = star.len();
        if !(3..=MAX_FAN).contains(&k) {
            return false;
        }
        for (i, &e) in star.iter().enumerate() {
            let b = stage.dst(e);
            self.ring[i] = stage.p(b);
            self.normal[i] = stage.normal[b as usize];
        }
        self.close(k);
        for i in 0..k {
            self.opp[i] = self.opp2[i].sqrt();
        }
        true
    }

    /// `gather` of the closed star of v, walked here from the half-edges (as `Stage::star`)
    /// without listing it, and without the ring's edge lengths: for `guards_move` and
    /// `centroid` only (`eval` and `eval_grad` need `gather`). `pos` and `normal` are the
    /// vertices from `base` on (a block of the centroid round, or all of them from 0); the
    /// stage's own are taken out of it for the round.
    pub(super) fn walk(
        &mut self,
        stage: &Stage<'_>,
        pos: &[DVec3],
        normal: &[DVec3],
        base: usize,
        v: u32,
    ) -> Walk {
        let first = stage.out[v as usize];
        if first == NONE {
            return Walk::Open;
        }
        let (mut e, mut k) = (first, 0);
        loop {
            if k == MAX_FAN {
                return Walk::Open;
            }
            let b = stage.dst(e) as usize;
            let Some(i) = b.checked_sub(base).filter(|&i| i < pos.len()) else {
                return Walk::Outside;
            };
            self.ring[k] = pos[i];
            self.normal[k] = normal[i];
            k += 1;
            e = stage.twin[prev(e) as usize];
            if e == NONE {
                return Walk::Open;
            }
            if e == first {
                break;
            }
        }
        if k < 3 {
            return Walk::Open;
        }
        self.close(k);
        Walk::Closed
    }

    /// Sets the fan's size to k (ring points 0..k gathered) and completes it: the closing
    /// copy of the first ring point and the ring's edge lengths squared (`walk`'s fans, for
    /// the guard only, need no more; `gather` adds the lengths).
    fn close(&mut self, k: usize) {
        self.k = k;
        // The closing copy: triangle i is (centre, ring[i], ring[i + 1]).
        self.ring[k] = self.ring[0];
        self.normal[k] = self.normal[0];
        for i in 0..k {
            self.opp2[i] = self.ring[i].distance_squared(self.ring[i + 1]);
        }
    }

    /// The fan's quality with its centre at p.
    pub(super) fn eval(&self, p: DVec3) -> FanQuality {
        self.measure::<false>(p).0
    }

    /// The fan's quality with its centre at p and the gradient of its sum of radius ratios
    /// with respect to p.
    pub(super) fn eval_grad(&self, p: DVec3) -> (FanQuality, DVec3) {
        self.measure::<true>(p)
    }

    /// One pass over the fan's triangles (p, a, b): with u = a − p, w = b − p, c = u × w
    /// and sides x = |u|, y = |b − a|, z = |w|, the radius ratio is 4|c|²/(xyz(x+y+z))
    /// (`ratio_of_sides`) and sin² of the smallest angle |c|²·m²/(xyz)², m the shortest
    /// side. With `GRAD`, also Σ ∇ratio = Σ ratio·∇ ln ratio, where ∇|c|² = 2(u − w) × c,
    /// ∇x = −u/x, ∇z = −w/z and ln ratio = ln |c|² − ln x − ln z − ln(x+y+z) + const.
    fn measure<const GRAD: bool>(&self, p: DVec3) -> (FanQuality, DVec3) {
        let mut q = FanQuality {
            worst: f64::INFINITY,
            worst_rr: f64::INFINITY,
            sum: 0.0,
        };
        let mut grad = DVec3::ZERO;
        let mut u = self.ring[0] - p;
        let mut x = u.length();
        // With `GRAD`, 1/x, carried over as 1/z of the triangle before: the gradient
        // multiplies by reciprocals, three divisions a triangle instead of eighteen.
        let mut inv_x = if GRAD { 1.0 / x } else { 0.0 };
        for i in 0..self.k {
            let w = self.ring[i + 1] - p;
            let (y, z) = (self.opp[i], w.length());
            let inv_z = if GRAD { 1.0 / z } else { 0.0 };
            let c = u.cross(w);
            let area2 = c.length_squared();
            let xyz = x * y * z;
            let rr = ratio_of_sides(x, y, z, area2);
            let m = x.min(y).min(z);
            let sin2 = if xyz > 0.0 {
                area2 * m * m / (xyz * xyz)
            } else {
                0.0
            };
            q.worst = q.worst.min(sin2);
            q.worst_rr = q.worst_rr.min(rr);
            q.sum += rr;
            if GRAD && rr > 0.0 {
                // −∇x = u/x and −∇z = w/z, the unit vectors along the two edges at p.
                let (ux, wz) = (u * inv_x, w * inv_z);
                grad += rr
                    * ((u - w).cross(c) * (2.0 / area2)
                        + ux * inv_x
                        + wz * inv_z
                        + (ux + wz) * (1.0 / (x + y + z)));
            }
            (u, x, inv_x) = (w, z, inv_z);
        }
        (q, grad)
    }

    /// The longest edge from p to the ring, squared.
    pub(super) fn longest(&self, p: DVec3) -> f64 {
        self.ring[..self.k]
            .iter()
            .map(|&q| p.distance_squared(q))
            .fold(0.0, f64::max)
    }

    /// The centroid of the ring, moved into the tangent plane at p (normal n): where the
    /// first smoothing round puts the fan's centre (`Stage::centroid_round`).
    pub(super) fn centroid(&self, p: DVec3, n: DVec3) -> DVec3 {
        let d = self.ring[..self.k].iter().sum::<DVec3>() / self.k as f64 - p;
        p + d - d.dot(n) * n
    }

    /// The worst sin² of a smallest angle of the fan with its centre at p (as `eval`'s
    /// `worst`, without square roots: sin² = |c|²·m²/(x²y²z²), m the shortest side).
    pub(super) fn worst_sin2(&self, p: DVec3) -> f64 {
        let mut worst = f64::INFINITY;
        let mut u = self.ring[0] - p;
        let mut x2 = u.length_squared();
        for i in 0..self.k {
            let w = self.ring[i + 1] - p;
            let (y2, z2) = (self.opp2[i], w.length_squared());
            worst = worst.min(sin2_of(u.cross(w).length_squared(), x2, y2, z2));
            (u, x2) = (w, z2);
        }
        worst
    }

    /// The smoothing rounds' guard for moving the fan's centre from `from` to `to` (normal
    /// n there), in one pass over the fan at `to`: every triangle faces ∇f (as `holds`),
    /// the smallest angle stays at or above the smaller of `keep` (sin²) and what it was,
    /// and every edge from `to` longer than the fan's longest from `from` has its midpoint
    /// within `tolerance` of the surface (|f|/|∇f|, as a flip's new diagonal).
    pub(super) fn guards_move(
        &self,
        from: DVec3,
        to: DVec3,
        n: DVec3,
        keep: f64,
        surface: &mut dyn Surface,
        tolerance: f64,
    ) -> bool {
        let longest = self.longest(from);
        let mut worst = f64::INFINITY;
        // Bit i: the edge from `to` to ring point i grew beyond `longest`.
        let mut grown = 0u32;
        let mut u = self.ring[0] - to;
        let mut x2 = u.length_squared();
        for i in 0..self.k {
            let w = self.ring[i + 1] - to;
            let (y2, z2) = (self.opp2[i], w.length_squared());
            let c = u.cross(w);
            if !(c.dot(n) > 0.0 && c.dot(self.normal[i]) > 0.0 && c.dot(self.normal[i + 1]) > 0.0) {
                return false;
            }
            worst = worst.min(sin2_of(c.length_squared(), x2, y2, z2));
            if x2 > longest {
                grown |= 1 << i;
            }
            (u, x2) = (w, z2);
        }
        // Most fans stay above `keep`: then the fan where it was is not measured.
        if worst < keep && worst < self.worst_sin2(from) {
            return false;
        }
        (0..self.k)
            .filter(|&i| grown & (1 << i) != 0)
            .all(|i| midpoint_within(surface, to, self.ring[i], tolerance))
    }

    /// Every triangle with the centre at p (normal n) faces the side ∇f points to at its
    /// three corners, and no edge from p is longer than `longest` (squared).
    pub(super) fn holds(&self, p: DVec3, n: DVec3, longest: f64) -> bool {
        (0..self.k).all(|i| {
            let t = (self.ring[i] - p).cross(self.ring[i + 1] - p);
            t.dot(n) > 0.0
                && t.dot(self.normal[i]) > 0.0
                && t.dot(self.normal[i + 1]) > 0.0
                && p.distance_squared(self.ring[i]) <= longest
        })
    }

    /// A step up the gradient `g` of the fan's sum of radius ratios at p, in the tangent
    /// plane at p (normal n): the slope along it at `ASCENT_STEP`·`len` fixes the step by
    /// the secant rule (between a sixteenth of that and twice it). None where the gradient
    /// cannot gain `SMOOTH_GAIN` within that reach; else that step, a quarter and a
    /// sixteenth of it, for the caller to judge in turn.
    pub(super) fn ascent(&self, p: DVec3, n: DVec3, g: DVec3, len: f64) -> Option<[DVec3; 3]> {
        let g = g - g.dot(n) * n;
        let slope = g.length();
        let reach = 2.0 * ASCENT_STEP * len;
        // Also None for a NaN slope (a degenerate fan).
        if slope * reach <= SMOOTH_GAIN || slope.is_nan() {
            return None;
        }
        let dir = g / slope;
        let probe = ASCENT_STEP * len;
        let slope_there = self.eval_grad(p + dir * probe).1.dot(dir);
        let t = if slope_there < slope {
            (probe * slope / (slope - slope_there)).clamp(probe / 16.0, reach)
        } else {
            reach
        };
        Some([1.0, 0.25, 0.0625].map(|f| p + dir * (f * t)))
    }
}

/// What `Fan::walk` found around a vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Walk {
    /// A closed fan of 3 to `MAX_FAN` triangles, gathered.
    Closed,
    /// An open fan (a boundary), or one of more than `MAX_FAN` triangles: not smoothed.
    Open,
    /// A ring vertex outside the vertices given (another block of the centroid round).
    Outside,
}
