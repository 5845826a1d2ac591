//! The surface oracle: what the marcher (and every numerical routine) knows of a surface —
//! a value and a gradient at a point, nothing of how the surface was written (paper Sect. 2:
//! the representation is hidden behind surfacepoint).

pub mod compiled;

use glam::DVec3;

pub mod dist;

pub use crate::values::{Fault, Surface, ValueGrad};

pub use dist::{ImplicitDist, PatchDist, SolidDist};

/// Makes a fresh oracle of a surface, built on the thread that calls it (an oracle is not
/// shared between threads): one per march of the component search or of a piece on the rayon
/// pool, one per block of the quality stage's centroid round. A fresh oracle evaluates as if
/// nothing had been evaluated before (the warm start of `dist`), so what is computed on it
/// does not depend on which thread ran what first. None if it cannot be built.
pub type Fork<'a> = dyn Fn() -> Option<Box<dyn Surface>> + Sync + 'a;

/// Makes fresh oracles of the branches of a surface's spine (`survey::spine`), in the
/// spine's order, as [`Fork`] makes one of the whole: a smooth piece of a creased surface
/// marched on the rayon pool evaluates its form on branches of its own
/// (`survey::spine::Detached`). None if they cannot be built.
pub type BranchFork<'a> = dyn Fn() -> Option<Vec<Box<dyn Surface>>> + Sync + 'a;

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
