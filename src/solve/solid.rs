//! Foot points on a surface with creases — a solid written with `box`, `cylinder`, `union`,
//! `difference`, `min`, `max`, `abs` (docs/implicitization.md §1a): the exact distance `dist`
//! measures and `offset` rounds a solid by. This module owns that search; the forms come
//! through the [`Pieces`] trait, so it knows nothing of how f was written.
//!
//! f picks, point by point, one of a few smooth *forms* Lᵢ (the spine's linear forms of its
//! branches, `survey::spine`). The nearest point q of the zero set from x lies
//! - inside a face: a foot point of x on Lᵢ = 0 (the local search of `solve::foot`; x's
//!   orthogonal projection where the form is affine), or
//! - on a crease: a nearest point of x on the curve Lᵢ = Lⱼ = 0, or
//! - at a corner: a common zero of Lᵢ, Lⱼ, Lₖ,
//!
//! and in each case on the zero set of f itself. Every such *candidate* on the surface bounds
//! the distance from above, so the nearest candidate is the foot point once the candidates
//! include the true one. They are searched as an active-set walk: every form whose interval
//! bound over the cube of half-width r around x holds 0 gets a face candidate; a candidate
//! off the surface (another form is chosen there: x's foot on the plane of a box face lies
//! beyond the face's edge) adds the chosen form to its set, and the larger set is solved in
//! turn (face → crease → corner). r starts at the previous foot's distance (a warm hint) or at
//! 2|f(x)|/|∇f(x)|, and grows until the nearest candidate lies within it: then every form that
//! can vanish within the foot's distance has been tried. Where a form tried is not affine, a
//! global phase on f (the rays of `solve::foot`) starts the faces again from where the
//! surface crosses a ray nearer than 1.25 times the distance found (a second sheet).
//!
//! Creases: Newton along the curve, each iterate projected onto both forms by minimum-norm
//! Gauss–Newton steps, the step along t = ∇Lᵢ × ∇Lⱼ being (x − q)·t / (1 − (x − q)·c″), with
//! the curve's curvature vector c″ from the projections of q ± h·t; corners: 3×3 Newton;
//! planes in closed form from their values and gradients at x.
//!
//! The value is ±|x − q| with the sign of f(x); the gradient the unit normal of the face
//! (checked against the side x lies on: a face foot seen from the wrong side means a nearer
//! point was missed, and is an error, not a value) or the unit vector from q towards x on a
//! crease or corner (signed likewise). Every failure says where and why. Deterministic: the
//! candidates are solved from x alone, in a fixed order, and the nearest wins by (distance,
//! support); a warm hint changes only the first radius.

use std::fmt;

use glam::DVec3;

use super::foot::RAY_DIRECTIONS;
use super::foot::{FootError, foot_point};
use super::surfacepoint::surface_point;
use super::tolerance::{FootTolerance, SolidFootTolerance};
use crate::eval::Interval;
use crate::surface::{Fault, Surface, ValueGrad};

/// A surface with creases as the foot-point search sees it: f and its smooth forms, each
/// with a value, a gradient and an interval bound.
pub trait Pieces {
    /// The number of forms.
    fn count(&self) -> usize;
    /// f and ∇f at p (the gradient of the form chosen there).
    fn whole(&mut self, p: DVec3) -> ValueGrad;
    /// f at p.
    fn whole_value(&mut self, p: DVec3) -> f64 {
        self.whole(p).value
    }
    /// Every form's value at p into `values` (resized to `count`).
    fn form_values(&mut self, p: DVec3, values: &mut Vec<f64>);
    /// Form i's value and gradient at p.
    fn form(&mut self, i: usize, p: DVec3) -> ValueGrad;
    /// Form i's value at p.
    fn form_value(&mut self, i: usize, p: DVec3) -> f64 {
        self.form(i, p).value
    }
    /// An interval holding form i over the box lo..hi (None where it cannot be bounded).
    fn form_bound(&mut self, i: usize, lo: DVec3, hi: DVec3) -> Option<Interval>;
    /// Whether form i is known to be affine (a plane: one sheet, its foot point unique).
    /// Default: false.
    fn is_affine(&self, i: usize) -> bool {
        let _ = i;
        false
    }
    /// The first fault of the surfaces f and the forms are made of (a `dist` inside them).
    /// Default: None.
    fn fault(&self) -> Option<Fault> {
        None
    }
}

/// Which forms a foot point lies on: their indices, ascending.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Support {
    /// Inside the face of form i.
    Face(usize),
    /// On the crease of forms i < j.
    Crease(usize, usize),
    /// At the corner of forms i < j < k.
    Corner(usize, usize, usize),
    /// The query point itself lies on the surface (f = 0 there).
    Itself,
}

impl Support {
    /// Its forms (the first `n` of the array).
    fn forms(self) -> ([usize; 3], usize) {
        match self {
            Support::Face(i) => ([i, 0, 0], 1),
            Support::Crease(i, j) => ([i, j, 0], 2),
            Support::Corner(i, j, k) => ([i, j, k], 3),
            Support::Itself => ([0; 3], 0),
        }
    }

    /// The support with form `k` added (None when it has three forms already or holds k).
    fn with(self, k: usize) -> Option<Support> {
        Some(match self {
            Support::Face(i) if i != k => Support::Crease(i.min(k), i.max(k)),
            Support::Crease(i, j) if i != k && j != k => {
                let mut f = [i, j, k];
                f.sort_unstable();
                Support::Corner(f[0], f[1], f[2])
            }
            _ => return None,
        })
    }
}

impl fmt::Display for Support {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Support::Face(i) => write!(f, "the face of form {i}"),
            Support::Crease(i, j) => write!(f, "the crease of forms {i} and {j}"),
            Support::Corner(i, j, k) => write!(f, "the corner of forms {i}, {j} and {k}"),
            Support::Itself => write!(f, "the query point"),
        }
    }
}

/// A foot point on a surface with creases.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolidFoot {
    /// q: the nearest point of the surface found.
    pub point: DVec3,
    /// ±|x − q|, negative where f(x) < 0.
    pub distance: f64,
    /// The gradient of the distance at x: the face's unit normal, or ±(x − q)/|x − q| on a
    /// crease or corner (the sign of f(x)).
    pub gradient: DVec3,
    /// Which forms q lies on.
    pub support: Support,
    /// Iterations of the solve that found q.
    pub iterations: u32,
    /// Its residual: the part of x − q along the face or crease (0 at a corner).
    pub residual: f64,
    /// Candidates solved for this query (faces, creases and corners).
    pub solves: u32,
}

/// Why one candidate could not be solved.
#[derive(Clone, Debug, PartialEq)]
pub struct SolveFailure {
    pub support: Support,
    /// The last iterate.
    pub at: DVec3,
    pub iterations: u32,
    pub residual: f64,
    pub reason: FailureReason,
}

/// What went wrong in a candidate's solve.
#[derive(Clone, Debug, PartialEq)]
pub enum FailureReason {
    /// The cap on iterations, or no step decreased the distance.
    NoConvergence,
    /// The forms' normals are (nearly) parallel there: no crease or corner is defined.
    Tangent,
    /// A form is not finite there.
    NotFinite,
    /// The face's foot-point search failed (`solve::foot`).
    Face(Box<FootError>),
}

impl fmt::Display for SolveFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.reason {
            FailureReason::Face(ref e) => write!(f, "{}: {e}", self.support),
            FailureReason::NoConvergence => write!(
                f,
                "{}: no convergence after {} iterations, last point {}, residual {:e}",
                self.support, self.iterations, self.at, self.residual
            ),
            FailureReason::Tangent => write!(
                f,
                "{}: the forms meet tangentially near {} (no crease or corner is defined there)",
                self.support, self.at
            ),
            FailureReason::NotFinite => write!(
                f,
                "{}: a form is not finite at {} (iteration {})",
                self.support, self.at, self.iterations
            ),
        }
    }
}

/// Why the foot-point search on a surface with creases failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SolidFootError {
    /// The query is not finite, or f is not finite there.
    #[error("f is not finite at the query point {x} (value {value})")]
    NotFinite { x: DVec3, value: f64 },
    /// x lies on the surface where its gradient vanishes: no normal.
    #[error("the query point {x} lies on the surface where its gradient vanishes")]
    ZeroGradient { x: DVec3 },
    /// No candidate on the surface was found within the largest radius tried.
    #[error(
        "no foot point of {x}: no face, crease or corner within {radius:e} lies on the surface after {solves} solves{}",
        last.as_ref().map(|l| format!(" (last failure: {l})")).unwrap_or_default()
    )]
    NoFoot {
        x: DVec3,
        radius: f64,
        solves: u32,
        last: Option<Box<SolveFailure>>,
    },
    /// The nearest point found is a face point seen from the side opposite to f(x)'s sign:
    /// the segment from x to it crosses the surface, so a nearer point was missed.
    #[error(
        "the nearest point found from {x}, {point} on {support}, lies on the wrong side (distance {distance:e}): a nearer point of the surface was missed"
    )]
    WrongSide {
        x: DVec3,
        point: DVec3,
        support: Support,
        distance: f64,
    },
}

impl SolidFootError {
    /// The query point.
    pub fn location(&self) -> DVec3 {
        match *self {
            SolidFootError::NotFinite { x, .. }
            | SolidFootError::ZeroGradient { x }
            | SolidFootError::NoFoot { x, .. }
            | SolidFootError::WrongSide { x, .. } => x,
        }
    }
}

/// Form i of `pieces` as a smooth surface of its own (for the face search of `solve::foot`).
struct FormSurface<'a> {
    pieces: &'a mut dyn Pieces,
    form: usize,
}

impl Surface for FormSurface<'_> {
    fn value(&mut self, p: DVec3) -> f64 {
        self.pieces.form_value(self.form, p)
    }

    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        self.pieces.form(self.form, p)
    }
}

/// f of `pieces` as a surface (for surfacepoint in the global phase).
struct WholeSurface<'a> {
    pieces: &'a mut dyn Pieces,
}

impl Surface for WholeSurface<'_> {
    fn value(&mut self, p: DVec3) -> f64 {
        self.pieces.whole_value(p)
    }

    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        self.pieces.whole(p)
    }
}

/// A solved candidate: a point on one, two or three forms.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    point: DVec3,
    distance: f64,
    iterations: u32,
    residual: f64,
    /// A face's unit normal at the point (zero for creases and corners).
    normal: DVec3,
}

/// A support searched from x, with its candidate where it was solved.
#[derive(Clone, Copy, Debug)]
struct Tried {
    support: Support,
    candidate: Option<Candidate>,
}

/// The search of one query: its candidates, solved once each.
struct Search<'a> {
    pieces: &'a mut dyn Pieces,
    x: DVec3,
    /// The sign of f(x): the side a face foot must see x on.
    sign: f64,
    /// Distances within this are one (`on_surface` times the scale).
    floor: f64,
    tol: &'a SolidFootTolerance,
    best: Option<(Support, Candidate)>,
    solves: u32,
    last_failure: Option<SolveFailure>,
    /// Whether a face not known to be a plane was searched (only then can a form have a
    /// second sheet that the global phase must look for).
    curved: bool,
    scratch: &'a mut SolidScratch,
}

/// The lists a search fills, kept between queries (a distance surface asks millions).
#[derive(Debug, Default)]
pub struct SolidScratch {
    /// Every support searched from x, in the order tried (a query tries a handful: a list
    /// beats a map).
    tried: Vec<Tried>,
    /// Forms' values at a point.
    values: Vec<f64>,
    /// Each form's value and gradient at x, once asked (the planes' solves, bounds and
    /// values elsewhere come from them).
    at_x: Vec<Option<ValueGrad>>,
}

/// The foot point of x on the surface with creases `pieces`. `hint`, a point of the surface
/// (the previous query's foot), sets the first search radius; it never changes the answer
/// beyond the solves' convergence tolerance. See the module documentation.
pub fn solid_foot(
    pieces: &mut dyn Pieces,
    x: DVec3,
    hint: Option<DVec3>,
    tol: &SolidFootTolerance,
) -> Result<SolidFoot, SolidFootError> {
    solid_foot_in(pieces, x, hint, tol, &mut SolidScratch::default())
}

/// [`solid_foot`] with its lists in `scratch` (the same answer, fewer allocations).
pub fn solid_foot_in(
    pieces: &mut dyn Pieces,
    x: DVec3,
    hint: Option<DVec3>,
    tol: &SolidFootTolerance,
    scratch: &mut SolidScratch,
) -> Result<SolidFoot, SolidFootError> {
    let fx = pieces.whole(x);
    if !x.is_finite() || !fx.value.is_finite() || !fx.gradient.is_finite() {
        return Err(SolidFootError::NotFinite { x, value: fx.value });
    }
    let scale = tol.foot.scale;
    let gl = fx.gradient.length();
    if fx.value == 0.0 {
        if gl == 0.0 {
            return Err(SolidFootError::ZeroGradient { x });
        }
        return Ok(SolidFoot {
            point: x,
            distance: 0.0,
            gradient: fx.gradient / gl,
            support: Support::Itself,
            iterations: 0,
            residual: 0.0,
            solves: 0,
        });
    }
    let sign = fx.value.signum();
    let floor = tol.on_surface * scale;
    let mut radius = match hint {
        Some(q) if q.is_finite() => (x - q).length(),
        _ if gl > 0.0 => tol.first_radius * fx.value.abs() / gl,
        _ => scale,
    }
    .max(floor);
    scratch.tried.clear();
    scratch.at_x.clear();
    scratch.at_x.resize(pieces.count(), None);
    let mut search = Search {
        pieces,
        x,
        sign,
        floor,
        tol,
        best: None,
        solves: 0,
        last_failure: None,
        curved: false,
        scratch,
    };
    let mut rounds = 0;
    loop {
        for i in 0..search.pieces.count() {
            if search.may_vanish(i, radius) {
                search.explore(Support::Face(i), None);
            }
        }
        rounds += 1;
        match search.best {
            Some((_, c)) if c.distance <= radius => break,
            // Every form that can be zero within the nearest candidate's distance is tried
            // in one more round.
            Some((_, c)) => radius = c.distance * (1.0 + 1e-9) + floor,
            None => radius *= tol.radius_growth,
        }
        if rounds >= tol.max_rounds || !radius.is_finite() {
            break;
        }
    }
    search.global(fx.value);
    let Some((support, c)) = search.best else {
        return Err(SolidFootError::NoFoot {
            x,
            radius,
            solves: search.solves,
            last: search.last_failure.map(Box::new),
        });
    };
    let gradient = match support {
        Support::Face(_) => {
            let n = c.normal;
            // At a face foot x − q is parallel to the normal; x must lie on the side f(x)'s
            // sign says, else the segment from x to q crosses the surface nearer.
            if sign * (x - c.point).dot(n) < -floor {
                return Err(SolidFootError::WrongSide {
                    x,
                    point: c.point,
                    support,
                    distance: sign * c.distance,
                });
            }
            n
        }
        _ if c.distance > floor => sign * (x - c.point) / c.distance,
        // On the crease itself (to rounding): the gradient of the form chosen at x.
        _ => fx.gradient / gl,
    };
    if !gradient.is_finite() {
        return Err(SolidFootError::ZeroGradient { x: c.point });
    }
    Ok(SolidFoot {
        point: c.point,
        distance: sign * c.distance,
        gradient,
        support,
        iterations: c.iterations,
        residual: c.residual,
        solves: search.solves,
    })
}

impl Search<'_> {
    /// Solves `support` (once; a face's local search from surfacepoint(`start`), x itself
    /// by default) and, where its point is not on the surface, the supports with each form
    /// chosen there added.
    fn explore(&mut self, support: Support, start: Option<DVec3>) {
        // A face searched from another start is another search; its creases and corners,
        // solved from x, are the same.
        if start.is_none() && self.scratch.tried.iter().any(|t| t.support == support) {
            return;
        }
        self.solves += 1;
        let solved = match (support, self.planes(support)) {
            (_, Some(solved)) => solved,
            (Support::Face(i), None) => {
                self.curved = true;
                self.face(i, start)
            }
            (Support::Crease(i, j), None) => self.crease(i, j),
            (Support::Corner(i, j, k), None) => self.corner(i, j, k),
            (Support::Itself, None) => return,
        };
        let c = match solved {
            Ok(c) => c,
            Err(e) => {
                if start.is_none() {
                    self.scratch.tried.push(Tried {
                        support,
                        candidate: None,
                    });
                }
                self.last_failure = Some(e);
                return;
            }
        };
        let scale = self.tol.foot.scale;
        let f = self.pieces.whole_value(c.point);
        // The tolerances in f's units: by the length of the first form's gradient (at x:
        // the forms' gradients change little between x and the candidate, and the
        // tolerances are far above the solves' errors).
        let gl = self.at_x(support.forms().0[0]).gradient.length();
        let on = f.is_finite() && f.abs() <= self.tol.on_surface * scale * gl;
        if start.is_none() {
            self.scratch.tried.push(Tried {
                support,
                candidate: Some(c),
            });
        }
        if on {
            self.consider(support, c);
            return;
        }
        if !f.is_finite() || matches!(support, Support::Corner(..)) {
            return;
        }
        // The forms chosen at the point (f equals them there, to the tie): their crease or
        // corner with the support's forms is where the piece of the surface ends.
        let mut values = std::mem::take(&mut self.scratch.values);
        self.values_at(c.point, &mut values);
        let tie = self.tol.tie * scale * gl.max(f64::MIN_POSITIVE);
        for (k, v) in values.iter().enumerate() {
            if (v - f).abs() <= tie
                && let Some(next) = support.with(k)
            {
                self.explore(next, None);
            }
        }
        self.scratch.values = values;
    }

    /// Form i's value and gradient at x (evaluated once per query).
    fn at_x(&mut self, i: usize) -> ValueGrad {
        match self.scratch.at_x[i] {
            Some(l) => l,
            None => {
                let l = self.pieces.form(i, self.x);
                self.scratch.at_x[i] = Some(l);
                l
            }
        }
    }

    /// Whether form i's interval bound over the cube of half-width `radius` around x holds
    /// 0 (a plane's from its value and gradient at x, outward by rounding).
    fn may_vanish(&mut self, i: usize, radius: f64) -> bool {
        let bound = if self.pieces.is_affine(i) {
            let l = self.at_x(i);
            let w = l.gradient.abs().element_sum() * radius;
            let slack = ROUNDING * (l.value.abs() + w + l.gradient.abs().dot(self.x.abs()));
            l.value
                .is_finite()
                .then(|| Interval::new(l.value - w - slack, l.value + w + slack))
        } else {
            let r = DVec3::splat(radius);
            self.pieces.form_bound(i, self.x - r, self.x + r)
        };
        bound.is_none_or(|b| b.lo <= 0.0 && 0.0 <= b.hi)
    }

    /// Every form's value at p: a plane's from its value and gradient at x, the others
    /// evaluated.
    fn values_at(&mut self, p: DVec3, values: &mut Vec<f64>) {
        let n = self.pieces.count();
        if (0..n).all(|k| self.pieces.is_affine(k)) {
            values.clear();
            for k in 0..n {
                let l = self.at_x(k);
                values.push(l.value + l.gradient.dot(p - self.x));
            }
        } else {
            self.pieces.form_values(p, values);
        }
    }

    /// The candidate of a support whose forms are all planes, in closed form from their
    /// values and gradients at x: the orthogonal projection of x onto the plane, the line
    /// (minimum-norm solution of the two equations) or the point where the three meet. None
    /// when a form is not known to be a plane.
    fn planes(&mut self, support: Support) -> Option<Result<Candidate, SolveFailure>> {
        let (forms, n) = support.forms();
        if n == 0 || !forms[..n].iter().all(|&k| self.pieces.is_affine(k)) {
            return None;
        }
        let x = self.x;
        let mut l = [ValueGrad::default(); 3];
        for (m, &k) in forms[..n].iter().enumerate() {
            l[m] = self.at_x(k);
        }
        let fail = |reason| SolveFailure {
            support,
            at: x,
            iterations: 0,
            residual: f64::NAN,
            reason,
        };
        let (delta, normal) = match l[..n] {
            [a] => {
                let g2 = a.gradient.length_squared();
                if g2.is_nan() || g2 <= 0.0 {
                    return Some(Err(fail(FailureReason::Tangent)));
                }
                (a.gradient * (a.value / g2), a.gradient / g2.sqrt())
            }
            [a, b] => {
                let (ga, gb) = (a.gradient, b.gradient);
                let g = [ga.dot(ga), ga.dot(gb), gb.dot(gb)];
                let det = g[0] * g[2] - g[1] * g[1];
                if det.is_nan() || det <= self.tol.tangent_sine.powi(2) * g[0] * g[2] {
                    return Some(Err(fail(FailureReason::Tangent)));
                }
                let l0 = (g[2] * a.value - g[1] * b.value) / det;
                let l1 = (g[0] * b.value - g[1] * a.value) / det;
                (l0 * ga + l1 * gb, DVec3::ZERO)
            }
            [a, b, c] => {
                let m = glam::DMat3::from_cols(a.gradient, b.gradient, c.gradient).transpose();
                let size = a.gradient.length() * b.gradient.length() * c.gradient.length();
                let det = m.determinant().abs();
                if det.is_nan() || det <= self.tol.tangent_sine * size {
                    return Some(Err(fail(FailureReason::Tangent)));
                }
                (
                    m.inverse() * DVec3::new(a.value, b.value, c.value),
                    DVec3::ZERO,
                )
            }
            _ => return None,
        };
        let q = x - delta;
        if !q.is_finite() {
            return Some(Err(fail(FailureReason::NotFinite)));
        }
        Some(Ok(Candidate {
            point: q,
            distance: delta.length(),
            iterations: 0,
            residual: 0.0,
            normal,
        }))
    }

    /// Keeps c if it is the nearest so far (ties: the smaller support, so that the order in
    /// which candidates were found does not matter). Of two feet at one distance, a face
    /// that sees x from its own side beats one that sees it from the wrong side: where two
    /// solids touch (a boss standing on a plate), the boss's cap lies in the plate's face
    /// with the opposite normal, and a point under the plate's face has both as its foot.
    fn consider(&mut self, support: Support, c: Candidate) {
        let wrong = |s: Support, c: &Candidate| {
            matches!(s, Support::Face(_))
                && self.sign * (self.x - c.point).dot(c.normal) < -self.floor
        };
        let nearer = self.best.is_none_or(|(s, b)| {
            if (c.distance - b.distance).abs() <= self.floor && wrong(s, &b) != wrong(support, &c) {
                wrong(s, &b)
            } else {
                (c.distance, support) < (b.distance, s)
            }
        });
        if nearer {
            self.best = Some((support, c));
        }
    }

    /// The global phase (as `solve::foot`'s, on f itself): f sampled along the fixed rays
    /// from x at `global_margin` times the nearest distance found, those within
    /// `global_skip_cos` of the direction to that point skipped; a sign opposite to f(x)
    /// proves that the surface crosses the ray inside that radius, so the faces chosen at
    /// surfacepoint(ray point) are searched again from there (a second sheet of a form, or a
    /// part of the surface whose form's local search from x went elsewhere).
    fn global(&mut self, fx: f64) {
        let ft = self.tol.foot;
        let Some((_, first)) = self.best else {
            return;
        };
        let d = first.distance;
        // Planes have one sheet each, and every one that can reach within the distance was
        // searched: nothing is left to find.
        if ft.global_margin <= 0.0 || d == 0.0 || !self.curved {
            return;
        }
        let x = self.x;
        let towards = (first.point - x) / d;
        let radius = ft.global_margin * d;
        for &(a, b, c) in RAY_DIRECTIONS.iter() {
            let u = DVec3::new(a, b, c).normalize();
            if u.dot(towards) > ft.global_skip_cos {
                continue;
            }
            let y = x + radius * u;
            let fy = self.pieces.whole_value(y);
            if !fy.is_finite() || fy.signum() == fx.signum() {
                continue;
            }
            let mut whole = WholeSurface {
                pieces: &mut *self.pieces,
            };
            let Ok(sp) = surface_point(&mut whole, y, ft.scale, &ft.surface_point) else {
                continue;
            };
            let mut values = std::mem::take(&mut self.scratch.values);
            self.pieces.form_values(sp.point, &mut values);
            let tie = self.tol.tie * ft.scale;
            let chosen: Vec<usize> = (0..values.len())
                .filter(|&k| values[k].abs() <= tie * self.at_x(k).gradient.length())
                .collect();
            self.scratch.values = values;
            for k in chosen {
                // The face of a plane searched from x already: the search from here would
                // end where that one did.
                let n = self.pieces.form(k, sp.point).gradient.normalize();
                let same_plane = self.scratch.tried.iter().any(|t| {
                    t.support == Support::Face(k)
                        && t.candidate.is_some_and(|c| {
                            (c.normal - n).length() <= self.tol.same_plane
                                && (sp.point - c.point).dot(c.normal).abs()
                                    <= self.tol.same_plane * ft.scale
                        })
                });
                if !same_plane {
                    self.explore(Support::Face(k), Some(sp.point));
                }
            }
        }
    }

    /// x's foot point on the whole zero set of form i by the local search of `solve::foot`
    /// from surfacepoint(`start`) (x by default); the global phase is f's (`global`).
    fn face(&mut self, i: usize, start: Option<DVec3>) -> Result<Candidate, SolveFailure> {
        let x = self.x;
        let mut surface = FormSurface {
            pieces: &mut *self.pieces,
            form: i,
        };
        let local = FootTolerance {
            global_margin: 0.0,
            ..self.tol.foot
        };
        match foot_point(&mut surface, x, start, &local) {
            Ok(f) => Ok(Candidate {
                point: f.point,
                distance: (x - f.point).length(),
                iterations: f.iterations,
                residual: f.residual,
                normal: f.normal,
            }),
            Err(e) => {
                let (at, iterations, residual) = match e {
                    FootError::NoConvergence {
                        last,
                        iterations,
                        residual,
                        ..
                    } => (last, iterations, residual),
                    FootError::SurfacePoint {
                        iteration, source, ..
                    } => (source.location(), iteration, f64::NAN),
                    FootError::NotFinite { x } => (x, 0, f64::NAN),
                };
                Err(SolveFailure {
                    support: Support::Face(i),
                    at,
                    iterations,
                    residual,
                    reason: FailureReason::Face(Box::new(e)),
                })
            }
        }
    }

    /// The rounding floor of lengths at p.
    fn rounding(&self, p: DVec3) -> f64 {
        ROUNDING * (self.x.abs().max_element() + p.abs().max_element())
    }

    /// p moved onto forms i and j by minimum-norm Gauss–Newton steps.
    fn onto_two(&mut self, i: usize, j: usize, p: DVec3) -> Result<DVec3, SolveFailure> {
        let support = Support::Crease(i, j);
        let scale = self.tol.foot.scale;
        let mut q = p;
        let mut step = f64::INFINITY;
        for iteration in 0..self.tol.projection_iterations {
            let a = self.pieces.form(i, q);
            let b = self.pieces.form(j, q);
            let fail = |reason, residual| SolveFailure {
                support,
                at: q,
                iterations: iteration,
                residual,
                reason,
            };
            let finite = a.value.is_finite()
                && b.value.is_finite()
                && a.gradient.is_finite()
                && b.gradient.is_finite();
            if !finite {
                return Err(fail(FailureReason::NotFinite, step));
            }
            let (ga, gb) = (a.gradient, b.gradient);
            let g = [ga.dot(ga), ga.dot(gb), gb.dot(gb)];
            let det = g[0] * g[2] - g[1] * g[1];
            if det.is_nan() || det <= self.tol.tangent_sine.powi(2) * g[0] * g[2] {
                return Err(fail(FailureReason::Tangent, step));
            }
            let l0 = (g[2] * a.value - g[1] * b.value) / det;
            let l1 = (g[0] * b.value - g[1] * a.value) / det;
            let delta = -(l0 * ga + l1 * gb);
            step = delta.length();
            q += delta;
            if step <= (self.tol.foot.relative_residual * scale).max(self.rounding(q)) {
                return Ok(q);
            }
        }
        Err(SolveFailure {
            support,
            at: q,
            iterations: self.tol.projection_iterations,
            residual: step,
            reason: FailureReason::NoConvergence,
        })
    }

    /// The nearest point of x on the curve Lᵢ = Lⱼ = 0 near x's projection onto it.
    fn crease(&mut self, i: usize, j: usize) -> Result<Candidate, SolveFailure> {
        let support = Support::Crease(i, j);
        let x = self.x;
        let scale = self.tol.foot.scale;
        let h = self.tol.curve_step * scale;
        let mut q = self.onto_two(i, j, x)?;
        let mut residual = f64::INFINITY;
        for iteration in 0..self.tol.foot.max_iterations {
            let ga = self.pieces.form(i, q).gradient;
            let gb = self.pieces.form(j, q).gradient;
            let cross = ga.cross(gb);
            let t = cross / cross.length();
            if !t.is_finite() {
                return Err(SolveFailure {
                    support,
                    at: q,
                    iterations: iteration,
                    residual,
                    reason: FailureReason::Tangent,
                });
            }
            let r = x - q;
            let along = r.dot(t);
            residual = along.abs();
            let floor = self.rounding(q) * (1.0 + r.length());
            if residual <= (self.tol.foot.relative_residual * scale).max(floor) {
                return Ok(Candidate {
                    point: q,
                    distance: r.length(),
                    iterations: iteration,
                    residual,
                    normal: DVec3::ZERO,
                });
            }
            // The curve's curvature vector from the projections of q ± h·t (both about h
            // along the curve): the second derivative of ½|c(s) − x|² is 1 − (x − q)·c″.
            let ahead = self.onto_two(i, j, q + h * t)?;
            let behind = self.onto_two(i, j, q - h * t)?;
            let c2 = (ahead + behind - 2.0 * q) / (h * h);
            let curvature = (1.0 - r.dot(c2)).max(self.tol.foot.min_newton_eigenvalue);
            let mut s = along / curvature;
            let d0 = r.length();
            if s.abs() > 2.0 * d0 {
                s = 2.0 * d0 * s.signum();
            }
            let mut next = None;
            for _ in 0..=self.tol.foot.max_backtracks {
                if let Ok(p) = self.onto_two(i, j, q + s * t)
                    && (x - p).length() <= d0 + floor
                {
                    next = Some(p);
                    break;
                }
                s *= 0.5;
            }
            match next {
                Some(p) => q = p,
                None => {
                    return Err(SolveFailure {
                        support,
                        at: q,
                        iterations: iteration + 1,
                        residual,
                        reason: FailureReason::NoConvergence,
                    });
                }
            }
        }
        Err(SolveFailure {
            support,
            at: q,
            iterations: self.tol.foot.max_iterations,
            residual,
            reason: FailureReason::NoConvergence,
        })
    }

    /// The common zero of forms i, j and k nearest x's Newton path: 3×3 Newton from x.
    fn corner(&mut self, i: usize, j: usize, k: usize) -> Result<Candidate, SolveFailure> {
        let support = Support::Corner(i, j, k);
        let x = self.x;
        let scale = self.tol.foot.scale;
        let mut q = x;
        let mut step = f64::INFINITY;
        for iteration in 0..self.tol.projection_iterations {
            let a = self.pieces.form(i, q);
            let b = self.pieces.form(j, q);
            let c = self.pieces.form(k, q);
            let fail = |reason, residual| SolveFailure {
                support,
                at: q,
                iterations: iteration,
                residual,
                reason,
            };
            let values = DVec3::new(a.value, b.value, c.value);
            let finite = values.is_finite()
                && a.gradient.is_finite()
                && b.gradient.is_finite()
                && c.gradient.is_finite();
            if !finite {
                return Err(fail(FailureReason::NotFinite, step));
            }
            let m = glam::DMat3::from_cols(a.gradient, b.gradient, c.gradient).transpose();
            let det = m.determinant();
            let size = a.gradient.length() * b.gradient.length() * c.gradient.length();
            if det.is_nan() || det.abs() <= self.tol.tangent_sine * size {
                return Err(fail(FailureReason::Tangent, step));
            }
            let delta = -(m.inverse() * values);
            step = delta.length();
            q += delta;
            if step <= (self.tol.foot.relative_residual * scale).max(self.rounding(q)) {
                return Ok(Candidate {
                    point: q,
                    distance: (x - q).length(),
                    iterations: iteration + 1,
                    residual: 0.0,
                    normal: DVec3::ZERO,
                });
            }
        }
        Err(SolveFailure {
            support,
            at: q,
            iterations: self.tol.projection_iterations,
            residual: step,
            reason: FailureReason::NoConvergence,
        })
    }
}

/// Rounding floor of lengths, in units of the largest coordinate magnitude involved.
const ROUNDING: f64 = 64.0 * f64::EPSILON;

#[cfg(test)]
mod tests {
    use super::*;

    /// The box [-1, 1]³ as max(|x|, |y|, |z|) − 1 written as six planes, and a ball
    /// union: forms as closures.
    struct Planes {
        /// (normal, offset): the form n·p − offset.
        planes: Vec<(DVec3, f64)>,
        /// true: f = max of the forms (an intersection of half-spaces), else min.
        max: bool,
    }

    impl Planes {
        fn cube() -> Planes {
            let mut planes = Vec::new();
            for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
                planes.push((axis, 1.0));
                planes.push((-axis, 1.0));
            }
            Planes { planes, max: true }
        }
    }

    impl Pieces for Planes {
        fn count(&self) -> usize {
            self.planes.len()
        }
        fn whole(&mut self, p: DVec3) -> ValueGrad {
            let mut best: Option<ValueGrad> = None;
            for i in 0..self.planes.len() {
                let f = self.form(i, p);
                let better = best.is_none_or(|b| {
                    if self.max {
                        f.value > b.value
                    } else {
                        f.value < b.value
                    }
                });
                if better {
                    best = Some(f);
                }
            }
            best.unwrap_or_default()
        }
        fn form_values(&mut self, p: DVec3, values: &mut Vec<f64>) {
            values.clear();
            for i in 0..self.planes.len() {
                values.push(self.form(i, p).value);
            }
        }
        fn form(&mut self, i: usize, p: DVec3) -> ValueGrad {
            let (n, o) = self.planes[i];
            ValueGrad {
                value: n.dot(p) - o,
                gradient: n,
            }
        }
        fn form_bound(&mut self, i: usize, lo: DVec3, hi: DVec3) -> Option<Interval> {
            let (n, o) = self.planes[i];
            let c = (lo + hi) * 0.5;
            let r = (hi - lo) * 0.5;
            let mid = n.dot(c) - o;
            let w = n.abs().dot(r);
            Some(Interval::new(mid - w, mid + w))
        }
        fn is_affine(&self, _: usize) -> bool {
            true
        }
    }

    /// The exact signed distance to the cube [-1, 1]³.
    fn cube_distance(p: DVec3) -> f64 {
        let q = p.abs() - DVec3::ONE;
        q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
    }

    #[test]
    fn the_distance_to_a_cube_is_exact_at_faces_edges_and_corners() {
        let tol = SolidFootTolerance::default();
        let mut cube = Planes::cube();
        let mut unit = crate::testing::uniform(0x9E37_79B9_7F4A_7C15);
        for _ in 0..2000 {
            let x = DVec3::new(unit(), unit(), unit()) * 6.0 - DVec3::splat(3.0);
            let f = solid_foot(&mut cube, x, None, &tol).expect("a foot point");
            let d = cube_distance(x);
            assert!(
                (f.distance - d).abs() <= 1e-12,
                "{x}: {} against {d}",
                f.distance
            );
            // The gradient against central differences of the exact distance.
            let e = 1e-6;
            let g = DVec3::new(
                cube_distance(x + DVec3::X * e) - cube_distance(x - DVec3::X * e),
                cube_distance(x + DVec3::Y * e) - cube_distance(x - DVec3::Y * e),
                cube_distance(x + DVec3::Z * e) - cube_distance(x - DVec3::Z * e),
            ) / (2.0 * e);
            if (g.length() - 1.0).abs() < 1e-6 {
                assert!(
                    (f.gradient - g).length() <= 1e-6,
                    "{x}: {} against {g}",
                    f.gradient
                );
            }
        }
    }

    #[test]
    fn a_corner_is_the_foot_beyond_it() {
        let tol = SolidFootTolerance::default();
        let x = DVec3::new(1.5, 1.5, 1.5);
        let f = solid_foot(&mut Planes::cube(), x, None, &tol).expect("a foot point");
        assert_eq!(f.support, Support::Corner(0, 2, 4));
        assert!((f.point - DVec3::ONE).length() <= 1e-15);
        assert!((f.distance - 0.75f64.sqrt()).abs() <= 1e-15);
        assert!((f.gradient - DVec3::ONE.normalize()).length() <= 1e-15);
    }
}
