//! The surface oracle's interface: what the marcher (and every numerical routine) knows of a
//! surface — a value and a gradient at a point, bounds over a box — nothing of how the
//! surface was written (paper Sect. 2: the representation is hidden behind surfacepoint).
//! The implementations are in `surface`.

use glam::DVec3;

use super::{Interval, IntervalGrad};

/// f(p) and ∇f(p) at one point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ValueGrad {
    pub value: f64,
    pub gradient: DVec3,
}

/// A value an oracle could not compute where it should exist — a foot point of `dist` that
/// was not found — with its place and why (a formula's NaN outside its domain is its value,
/// not a fault).
#[derive(Clone, Debug, PartialEq)]
pub struct Fault {
    /// The query point.
    pub at: DVec3,
    /// Why, with the figures of the failed search (iterations, residual, last point).
    pub reason: String,
}

/// An implicit surface f(x, y, z) = 0.
///
/// Methods take `&mut self` so that an implementation may keep scratch registers or a
/// warm-start cache (foot-point searches) without interior mutability; the marcher owns its
/// surface exclusively. Domain errors (sqrt of a negative, …) come back as NaN or infinity,
/// which callers detect; implementations never panic on them.
pub trait Surface {
    /// f(p).
    fn value(&mut self, p: DVec3) -> f64 {
        self.value_gradient(p).value
    }

    /// f(p) and ∇f(p).
    fn value_gradient(&mut self, p: DVec3) -> ValueGrad;

    /// f and ∇f at each point (`out[i]` for `points[i]`, for i below the shorter length) in
    /// one call, bit for bit what `value_gradient` gives at each, where the surface answers
    /// the same whatever the order of its queries: true then. False, with nothing written,
    /// where it does not (the warm starts of `dist`) or cannot do better than a call a point;
    /// the caller then asks one point at a time, in its own order. Default: false.
    fn value_gradient_batch(&mut self, points: &[DVec3], out: &mut [ValueGrad]) -> bool {
        let _ = (points, out);
        false
    }

    /// An interval holding f(p) for every p of the box `lo ..= hi` where f(p) is defined
    /// (not NaN), or None when the surface cannot bound itself (then nothing may be
    /// concluded; the component search keeps every cell). Default: None.
    fn bound(&mut self, lo: DVec3, hi: DVec3) -> Option<Interval> {
        let _ = (lo, hi);
        None
    }

    /// [`Surface::bound`] with intervals holding the partial derivatives ∂f/∂x, ∂f/∂y,
    /// ∂f/∂z that `axes` asks for over the box (their generalized values where f is not
    /// differentiable: `eval::interval_grad`; the partials not asked for may be the whole
    /// line), or None when the surface cannot bound its derivatives (then the component
    /// search uses `bound` alone). Default: None.
    fn bound_gradient(&mut self, lo: DVec3, hi: DVec3, axes: [bool; 3]) -> Option<IntervalGrad> {
        let _ = (lo, hi, axes);
        None
    }

    /// Whether an element of f's generalized gradient over the box may be orthogonal to both
    /// `across` directions — where a piece of the surface may have its extreme along the
    /// direction orthogonal to them — when the surface can tell more than its interval
    /// partials do (a piecewise f, whose forms' gradients are known one by one: the spine's
    /// [`crate::survey::spine::Creased::gradient_may_face`]). Default: true (nothing
    /// concluded).
    fn gradient_may_face(&mut self, lo: DVec3, hi: DVec3, across: [DVec3; 2]) -> bool {
        let _ = (lo, hi, across);
        true
    }

    /// The first fault met since the oracle was built (its value there was NaN), or None.
    /// The search and the march ask after each step and stop with its place, rather than
    /// go on through NaN (docs/implicitization.md). Default: None.
    fn fault(&self) -> Option<Fault> {
        None
    }
}

impl<S: Surface + ?Sized> Surface for Box<S> {
    fn value(&mut self, p: DVec3) -> f64 {
        (**self).value(p)
    }
    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        (**self).value_gradient(p)
    }
    fn value_gradient_batch(&mut self, points: &[DVec3], out: &mut [ValueGrad]) -> bool {
        (**self).value_gradient_batch(points, out)
    }
    fn bound(&mut self, lo: DVec3, hi: DVec3) -> Option<Interval> {
        (**self).bound(lo, hi)
    }
    fn bound_gradient(&mut self, lo: DVec3, hi: DVec3, axes: [bool; 3]) -> Option<IntervalGrad> {
        (**self).bound_gradient(lo, hi, axes)
    }
    fn gradient_may_face(&mut self, lo: DVec3, hi: DVec3, across: [DVec3; 2]) -> bool {
        (**self).gradient_may_face(lo, hi, across)
    }
    fn fault(&self) -> Option<Fault> {
        (**self).fault()
    }
}

impl<S: Surface + ?Sized> Surface for &mut S {
    fn value(&mut self, p: DVec3) -> f64 {
        (**self).value(p)
    }
    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        (**self).value_gradient(p)
    }
    fn value_gradient_batch(&mut self, points: &[DVec3], out: &mut [ValueGrad]) -> bool {
        (**self).value_gradient_batch(points, out)
    }
    fn bound(&mut self, lo: DVec3, hi: DVec3) -> Option<Interval> {
        (**self).bound(lo, hi)
    }
    fn bound_gradient(&mut self, lo: DVec3, hi: DVec3, axes: [bool; 3]) -> Option<IntervalGrad> {
        (**self).bound_gradient(lo, hi, axes)
    }
    fn gradient_may_face(&mut self, lo: DVec3, hi: DVec3, across: [DVec3; 2]) -> bool {
        (**self).gradient_may_face(lo, hi, across)
    }
    fn fault(&self) -> Option<Fault> {
        (**self).fault()
    }
}
