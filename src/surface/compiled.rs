//! Surfaces and patches backed by compiled tapes: the [`Surface`] and [`Patch`] oracles over
//! the evaluator of `eval`, and their construction from a checked program: [`compile_surface`]
//! (the compiler's tape, each `dist` child built by a factory), [`compile_spine`] (the branches
//! of a creased surface), [`compile_patch`].

use glam::DVec3;

use super::{Fault, Patch, PatchJet, Surface, ValueGrad};
use crate::compile::tape::Tape;
use crate::compile::{CompileError, Lowered, lower_patch, lower_spine, lower_surface};
use crate::eval::native::NativeError;
use crate::eval::{Engine, Grad, Interval, IntervalGrad, Vm, VmError};
use crate::sema::program::{PatchId, Program, SurfaceRef};
use crate::survey::spine::Spine;

/// An implicit surface f(x, y, z) = 0 evaluated from its tape.
#[derive(Debug)]
pub struct CompiledSurface {
    vm: Vm,
}

impl CompiledSurface {
    /// A surface from a tape with three inputs and its `dist` children.
    pub fn new(tape: Tape, children: Vec<Box<dyn Surface>>) -> Result<Self, VmError> {
        Ok(CompiledSurface {
            vm: Vm::new(tape, children)?,
        })
    }

    pub fn tape(&self) -> &Tape {
        self.vm.tape()
    }

    /// Chooses the engine (native code by default).
    pub fn set_engine(&mut self, engine: Engine) {
        self.vm.set_engine(engine);
    }

    /// Why the interpreter evaluates although native code was asked for (known after the
    /// first evaluation).
    pub fn native_error(&self) -> Option<&NativeError> {
        self.vm.native_error()
    }

    /// f at each point: `out[i] = f(points[i])` for i below the shorter length.
    pub fn value_batch(&mut self, points: &[DVec3], out: &mut [f64]) {
        self.vm.value_batch(points, out);
    }

    /// f and ∇f at each point, for i below the shorter length.
    pub fn value_gradient_batch(&mut self, points: &[DVec3], out: &mut [ValueGrad]) {
        self.vm.value_grad_batch(points, out);
    }
}

impl Surface for CompiledSurface {
    fn value(&mut self, p: DVec3) -> f64 {
        self.vm.value(&[p.x, p.y, p.z])
    }

    /// In one run of the tape, where it has no `dist` children (whose warm starts make the
    /// order of the points matter).
    fn value_gradient_batch(&mut self, points: &[DVec3], out: &mut [ValueGrad]) -> bool {
        if self.vm.has_children() {
            return false;
        }
        self.vm.value_grad_batch(points, out);
        true
    }

    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        let g = self.vm.value_grad(&[p.x, p.y, p.z]);
        ValueGrad {
            value: g.v,
            gradient: DVec3::new(g.dx, g.dy, g.dz),
        }
    }

    /// The tape run on intervals (interpreted: the search asks a few thousand cells).
    fn bound(&mut self, lo: DVec3, hi: DVec3) -> Option<Interval> {
        Some(self.vm.interval(lo, hi))
    }

    fn bound_gradient(&mut self, lo: DVec3, hi: DVec3, axes: [bool; 3]) -> Option<IntervalGrad> {
        Some(self.vm.interval_grad(lo, hi, axes))
    }

    fn fault(&self) -> Option<Fault> {
        self.vm.fault()
    }
}

/// A parametric patch (u, v) → (X, Y, Z) evaluated from its tape; the Jacobian comes from
/// dual numbers in (u, v).
#[derive(Debug)]
pub struct CompiledPatch {
    vm: Vm,
    domain: ((f64, f64), (f64, f64)),
}

impl CompiledPatch {
    /// A patch from a tape with two inputs, three outputs and no children.
    pub fn new(tape: Tape, domain: ((f64, f64), (f64, f64))) -> Result<Self, VmError> {
        Ok(CompiledPatch {
            vm: Vm::new(tape, Vec::new())?,
            domain,
        })
    }

    pub fn tape(&self) -> &Tape {
        self.vm.tape()
    }
}

impl Patch for CompiledPatch {
    fn point_jacobian(&mut self, u: f64, v: f64) -> PatchJet {
        let mut g = [Grad::default(); 3];
        self.vm.grad_outputs(&[u, v], &mut g);
        PatchJet {
            point: DVec3::new(g[0].v, g[1].v, g[2].v),
            du: DVec3::new(g[0].dx, g[1].dx, g[2].dx),
            dv: DVec3::new(g[0].dy, g[1].dy, g[2].dy),
        }
    }

    fn domain(&self) -> ((f64, f64), (f64, f64)) {
        self.domain
    }
}

/// Builds the surface a `dist()` measures (the foot-point distance surfaces of
/// `surface::dist`; any `Surface` in tests).
pub type ChildFactory<'a, E> = dyn FnMut(&SurfaceRef) -> Result<Box<dyn Surface>, E> + 'a;

/// Compiles surface `r`, building the surface of each `dist` child with `factory` (which may
/// call `compile_surface` again for nested `dist`).
pub fn compile_surface<E>(
    program: &Program,
    r: &SurfaceRef,
    factory: &mut ChildFactory<'_, E>,
) -> Result<CompiledSurface, CompileError>
where
    E: Into<Box<dyn std::error::Error + Send + Sync>>,
{
    build_lowered(lower_surface(program, r)?, factory)
}

/// A lowered tape as a surface, its `dist` children built by `factory`.
fn build_lowered<E>(
    lowered: Lowered,
    factory: &mut ChildFactory<'_, E>,
) -> Result<CompiledSurface, CompileError>
where
    E: Into<Box<dyn std::error::Error + Send + Sync>>,
{
    let mut children = Vec::with_capacity(lowered.children.len());
    for (target, span) in &lowered.children {
        let child = factory(target).map_err(|e| CompileError::Child {
            span: *span,
            source: e.into(),
        })?;
        children.push(child);
    }
    Ok(CompiledSurface::new(lowered.tape, children)?)
}

/// The spine of surface `r` with each branch compiled (its `dist` children built by
/// `factory`), or None when the surface has no `min`, `max` or `abs` on its spine.
pub fn compile_spine<E>(
    program: &Program,
    r: &SurfaceRef,
    factory: &mut ChildFactory<'_, E>,
) -> Result<Option<(Spine, Vec<CompiledSurface>)>, CompileError>
where
    E: Into<Box<dyn std::error::Error + Send + Sync>>,
{
    let Some((spine, branches)) = lower_spine(program, r)? else {
        return Ok(None);
    };
    let mut compiled = Vec::with_capacity(branches.len());
    for lowered in branches {
        compiled.push(build_lowered(lowered, factory)?);
    }
    Ok(Some((spine, compiled)))
}

/// Compiles patch `id`.
pub fn compile_patch(program: &Program, id: PatchId) -> Result<CompiledPatch, CompileError> {
    let tape = lower_patch(program, id)?;
    let def = program
        .patches
        .get(id.index())
        .ok_or(CompileError::NoSuchPatch { id })?;
    Ok(CompiledPatch::new(tape, (def.u_range, def.v_range))?)
}
