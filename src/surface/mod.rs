//! The surface oracle: what the marcher (and every numerical routine) knows of a surface —
//! a value and a gradient at a point, nothing of how the surface was written (paper Sect. 2:
//! the representation is hidden behind surfacepoint).

pub mod compiled;

use glam::DVec3;

pub mod dist;

use crate::eval::{Interval, IntervalGrad};

pub use dist::{ImplicitDist, PatchDist};

/// f(p) and ∇f(p) at one point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ValueGrad {
    pub value: f64,
    pub gradient: DVec3,
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
}

/// Makes a fresh oracle of a surface, built on the thread that calls it (an oracle is not
/// shared between threads): one per march of the component search or of a piece on the rayon
/// pool, one per block of the quality stage's centroid round. A fresh oracle evaluates as if
/// nothing had been evaluated before (the warm start of `dist`), so what is computed on it
/// does not depend on which thread ran what first. None if it cannot be built.
pub type Fork<'a> = dyn Fn() -> Option<Box<dyn Surface>> + Sync + 'a;

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
}

/// A surface given by a Rust closure returning value and gradient: for tests, benches and
/// native baselines.
pub struct NativeSurface<F>(pub F);

impl<F: FnMut(DVec3) -> ValueGrad> Surface for NativeSurface<F> {
    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        (self.0)(p)
    }
}

/// A parametric patch (u, v) → X(u, v), with its partial derivatives (the 3×2 Jacobian).
/// The formula is valid beyond its declared domain; the domain bounds its `boundary` curve
/// and seeds foot-point searches.
pub trait Patch {
    /// X(u, v), ∂X/∂u, ∂X/∂v.
    fn point_jacobian(&mut self, u: f64, v: f64) -> PatchJet;
    /// Declared domain: (u_lo, u_hi), (v_lo, v_hi).
    fn domain(&self) -> ((f64, f64), (f64, f64));
}

/// A patch point with its partial derivatives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchJet {
    pub point: DVec3,
    pub du: DVec3,
    pub dv: DVec3,
}
