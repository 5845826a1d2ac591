//! Compiler: the checked `Program`'s surfaces and patches → hash-consed IR (folded and
//! simplified as it is built, `lower` + `ir`) → register tape (dead code removed, registers
//! allocated by a linear scan, `regalloc`), verified before it runs, with a readable listing
//! (`tape`). `docs/compiler.md` describes the whole pipeline and the opcode list.

pub mod ir;
pub mod lower;
pub mod regalloc;
pub mod tape;

use crate::eval::VmError;
use crate::sema::program::{ConstId, FnId, PatchId, Program, SurfaceId, SurfaceRef};
use crate::span::Span;
use crate::surface::Surface;
use crate::surface::compiled::{CompiledPatch, CompiledSurface};
use lower::{Domain, Lowerer};
use regalloc::AllocError;
use tape::Tape;

/// Why a surface or patch could not be compiled. Variants with a span point at the
/// expression at fault; `NoSuch*` and `Arity` mean the program did not come from sema (a
/// caller's bug).
#[derive(Debug, thiserror::Error)]
pub enum CompileError {
    #[error("surface id {} does not exist", id.0)]
    NoSuchSurface { id: SurfaceId, span: Span },
    #[error("patch id {} does not exist", id.0)]
    NoSuchPatch { id: PatchId },
    #[error("constant id {} does not exist", id.0)]
    NoSuchConst { id: ConstId, span: Span },
    #[error("function id {} does not exist", id.0)]
    NoSuchFn { id: FnId, span: Span },
    #[error("`{name}` takes {expected} arguments but is given {found}")]
    Arity {
        name: String,
        expected: usize,
        found: usize,
        span: Span,
    },
    #[error("`{name}` is defined in terms of itself")]
    Cycle { name: String, span: Span },
    #[error("parameter {index} is used outside a function or patch that has it")]
    UnboundParam { index: u32, span: Span },
    #[error("a patch body cannot use x, y, z, a surface or dist()")]
    CoordinatesInPatch { span: Span },
    #[error("patch `{name}` has no implicit value; use dist({name})")]
    PatchIsNotASurface { name: String },
    #[error("the expression nests deeper than {} levels", lower::MAX_DEPTH)]
    TooDeep { span: Span },
    #[error(transparent)]
    Alloc(#[from] AllocError),
    #[error(transparent)]
    Vm(#[from] VmError),
    #[error("could not build the surface of dist(): {source}")]
    Child {
        span: Span,
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

/// A lowered tape with the targets of its `dist` children (child k is `children[k]`) and the
/// spans where they are written.
#[derive(Clone, Debug)]
pub struct Lowered {
    pub tape: Tape,
    pub children: Vec<(SurfaceRef, Span)>,
}

const SPACE_INPUTS: [&str; 3] = ["x", "y", "z"];

/// The tape of surface `r` of `program` (inputs x, y, z).
pub fn lower_surface(program: &Program, r: &SurfaceRef) -> Result<Lowered, CompileError> {
    let mut lowerer = Lowerer::new(program, Domain::Space);
    let out = match r {
        SurfaceRef::Surface(id) => {
            let span = program
                .surfaces
                .get(id.index())
                .map(|s| s.span)
                .unwrap_or_default();
            lowerer.surface(*id, span)?
        }
        SurfaceRef::Anonymous(e) => lowerer.expr(e, &[])?,
        SurfaceRef::Patch(id) => {
            let def = program
                .patches
                .get(id.index())
                .ok_or(CompileError::NoSuchPatch { id: *id })?;
            return Err(CompileError::PatchIsNotASurface {
                name: def.name.clone(),
            });
        }
    };
    let names = SPACE_INPUTS.iter().map(|s| s.to_string()).collect();
    let (tape, live) = regalloc::allocate(&lowerer.graph, &[out], names)?;
    let children = live
        .iter()
        .map(|d| lowerer.dists[d.0 as usize].clone())
        .collect();
    Ok(Lowered { tape, children })
}

/// The tape of patch `id` (inputs u, v; outputs X, Y, Z).
pub fn lower_patch(program: &Program, id: PatchId) -> Result<Tape, CompileError> {
    let def = program
        .patches
        .get(id.index())
        .ok_or(CompileError::NoSuchPatch { id })?;
    let mut lowerer = Lowerer::new(program, Domain::Patch);
    let params = [lowerer.graph.input(0), lowerer.graph.input(1)];
    let mut outs = [params[0]; 3];
    for (o, e) in outs.iter_mut().zip(&def.body) {
        *o = lowerer.expr(e, &params)?;
    }
    let (tape, _) = regalloc::allocate(&lowerer.graph, &outs, def.params.to_vec())?;
    Ok(tape)
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
    let lowered = lower_surface(program, r)?;
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

/// Compiles patch `id`.
pub fn compile_patch(program: &Program, id: PatchId) -> Result<CompiledPatch, CompileError> {
    let tape = lower_patch(program, id)?;
    let def = program
        .patches
        .get(id.index())
        .ok_or(CompileError::NoSuchPatch { id })?;
    Ok(CompiledPatch::new(tape, (def.u_range, def.v_range))?)
}

/// The listing of a lowered surface: its tape, then what each `dist` child measures.
pub fn listing(program: &Program, lowered: &Lowered) -> String {
    let mut s = lowered.tape.listing();
    for (k, (target, span)) in lowered.children.iter().enumerate() {
        let what = match target {
            SurfaceRef::Surface(id) => program.surfaces.get(id.index()).map(|d| d.name.clone()),
            SurfaceRef::Patch(id) => program.patches.get(id.index()).map(|d| d.name.clone()),
            SurfaceRef::Anonymous(_) => None,
        }
        .unwrap_or_else(|| format!("the expression at bytes {}..{}", span.start, span.end));
        s.push_str(&format!("; #{k} = dist({what})\n"));
    }
    s
}
