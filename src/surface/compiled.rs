//! Surfaces and patches backed by compiled tapes: the [`Surface`] and [`Patch`] oracles over
//! the evaluator of `eval`, and their construction from a checked program: [`compile_surface`]
//! (the compiler's tape, each `dist` child built by a factory), [`compile_spine`] (the branches
//! of a creased surface), [`compile_patch`].

use std::sync::atomic::{AtomicU64, Ordering};

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
    /// The tape's runs on this surface so far, added to the process's [`evaluations`] when
    /// it is dropped.
    counts: Evaluations,
}

/// Runs of compiled surface tapes, for the benches' evaluations per output vertex
/// (`benches/speed.rs`): at points, value alone or value and gradient (a batch counts its
/// points), and on boxes (`bound`, `bound_gradient`: interval evaluations). A `dist` child's
/// own tape counts its runs too.
///
/// Why a hook in the library: `surfc mesh`'s path (`pipeline::mesh_source`) builds its
/// surfaces itself (`pipeline::build::Builder`: the block's surface, the spine's branches,
/// the fresh oracles of every fork), so a bench cannot wrap them as `benches/march.rs` wraps
/// the surface it marches. Each surface counts in plain fields of its own (an add beside a
/// run of the tape, no shared memory touched, no branch: nothing measurable) and adds them to
/// the process's totals once, when it is dropped. Counting changes no value computed. A
/// cargo feature would not be cheaper, and the bench could turn it on only through a
/// dev-dependency of the crate on itself, which turns it on for every test build as well.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Evaluations {
    /// f at a point.
    pub values: u64,
    /// f and ∇f at a point.
    pub value_gradients: u64,
    /// f bounded over a box, with or without bounds on its partials.
    pub intervals: u64,
}

impl Evaluations {
    /// Point evaluations: value alone, or value and gradient.
    pub fn points(&self) -> u64 {
        self.values + self.value_gradients
    }

    /// The evaluations counted since `earlier`.
    pub fn since(&self, earlier: &Evaluations) -> Evaluations {
        Evaluations {
            values: self.values - earlier.values,
            value_gradients: self.value_gradients - earlier.value_gradients,
            intervals: self.intervals - earlier.intervals,
        }
    }
}

static VALUES: AtomicU64 = AtomicU64::new(0);
static VALUE_GRADIENTS: AtomicU64 = AtomicU64::new(0);
static INTERVALS: AtomicU64 = AtomicU64::new(0);

/// The evaluations of every compiled surface dropped so far in this process (a surface still
/// alive is not counted yet).
pub fn evaluations() -> Evaluations {
    Evaluations {
        values: VALUES.load(Ordering::Relaxed),
        value_gradients: VALUE_GRADIENTS.load(Ordering::Relaxed),
        intervals: INTERVALS.load(Ordering::Relaxed),
    }
}

impl Drop for CompiledSurface {
    fn drop(&mut self) {
        let c = self.counts;
        VALUES.fetch_add(c.values, Ordering::Relaxed);
        VALUE_GRADIENTS.fetch_add(c.value_gradients, Ordering::Relaxed);
        INTERVALS.fetch_add(c.intervals, Ordering::Relaxed);
    }
}

impl CompiledSurface {
    /// A surface from a tape with three inputs and its `dist` children.
    pub fn new(tape: Tape, children: Vec<Box<dyn Surface>>) -> Result<Self, VmError> {
        Ok(CompiledSurface {
            vm: Vm::new(tape, children)?,
            counts: Evaluations::default(),
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
        self.counts.values += points.len().min(out.len()) as u64;
        self.vm.value_batch(points, out);
    }

    /// f and ∇f at each point, for i below the shorter length.
    pub fn value_gradient_batch(&mut self, points: &[DVec3], out: &mut [ValueGrad]) {
        self.counts.value_gradients += points.len().min(out.len()) as u64;
        self.vm.value_grad_batch(points, out);
    }
}

impl Surface for CompiledSurface {
    fn value(&mut self, p: DVec3) -> f64 {
        self.counts.values += 1;
        self.vm.value(&[p.x, p.y, p.z])
    }

    /// In one run of the tape, where it has no `dist` children (whose warm starts make the
    /// order of the points matter).
    fn value_gradient_batch(&mut self, points: &[DVec3], out: &mut [ValueGrad]) -> bool {
        if self.vm.has_children() {
            return false;
        }
        self.counts.value_gradients += points.len().min(out.len()) as u64;
        self.vm.value_grad_batch(points, out);
        true
    }

    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        self.counts.value_gradients += 1;
        let g = self.vm.value_grad(&[p.x, p.y, p.z]);
        ValueGrad {
            value: g.v,
            gradient: DVec3::new(g.dx, g.dy, g.dz),
        }
    }

    /// The tape run on intervals (interpreted: the search asks a few thousand cells).
    fn bound(&mut self, lo: DVec3, hi: DVec3) -> Option<Interval> {
        self.counts.intervals += 1;
        Some(self.vm.interval(lo, hi))
    }

    fn bound_gradient(&mut self, lo: DVec3, hi: DVec3, axes: [bool; 3]) -> Option<IntervalGrad> {
        self.counts.intervals += 1;
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
