//! Compiler: the checked `Program`'s surfaces and patches → hash-consed IR (folded and
//! simplified as it is built, `lower` + `ir`) → register tape (dead code removed, registers
//! allocated by a linear scan, `regalloc`), verified before it runs, with a readable listing
//! (`tape`). `docs/compiler.md` describes the whole pipeline and the opcode list.

pub mod flush;
pub mod ir;
pub mod lower;
pub mod ops;
pub mod regalloc;
pub mod spine;
pub mod tape;

use crate::compile::tape::VmError;
use crate::sema::program::{ConstId, FnId, PatchId, Program, SurfaceId, SurfaceRef};
use crate::span::Span;
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
    #[error("dist() cannot be evaluated at a transformed point")]
    DistInTransform { span: Span },
    #[error("a patch body cannot use x, y, z, a surface or dist()")]
    CoordinatesInPatch { span: Span },
    #[error("patch `{name}` has no implicit value; use dist({name})")]
    PatchIsNotASurface { name: String },
    #[error("the expression nests deeper than {} levels", lower::MAX_DEPTH)]
    TooDeep { span: Span },
    #[error(
        "the surface has more than {limit} operations after inlining{}",
        if chain.is_empty() { String::new() } else { format!(" {}", chain.join(" → ")) }
    )]
    TooLarge {
        /// The number of IR nodes when lowering stopped.
        nodes: usize,
        limit: usize,
        /// The functions being inlined, outermost first.
        chain: Vec<String>,
        /// The outermost call of the chain (or the expression being lowered).
        span: Span,
    },
    #[error("`dist` is nested more than {limit} deep: {}", chain.join(" → "))]
    DistTooDeep {
        limit: usize,
        /// What each `dist` measures, outermost first.
        chain: Vec<String>,
    },
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

/// How deep `dist` may nest (`dist` of a surface that uses `dist` is depth 2). Each level
/// evaluates the one inside it tens of times per foot point, so the work grows about
/// 30-fold a level: depth 3 is seconds for a small mesh, depth 4 minutes.
pub const MAX_DIST_DEPTH: usize = 3;

const SPACE_INPUTS: [&str; 3] = ["x", "y", "z"];

/// The tape of surface `r` of `program` (inputs x, y, z).
pub fn lower_surface(program: &Program, r: &SurfaceRef) -> Result<Lowered, CompileError> {
    let (lowerer, out) = lower_graph(program, r)?;
    allocate_space(&lowerer, out)
}

/// The tape of node `out` of `lowerer`'s graph, inputs x, y, z, with its live `dist` targets.
fn allocate_space(lowerer: &Lowerer<'_>, out: ir::NodeId) -> Result<Lowered, CompileError> {
    let names = SPACE_INPUTS.iter().map(|s| s.to_string()).collect();
    let (tape, live) = regalloc::allocate(&lowerer.graph, &[out], names)?;
    let children = live
        .iter()
        .map(|d| lowerer.dists[d.0 as usize].clone())
        .collect();
    Ok(Lowered { tape, children })
}

/// Surface `r` lowered to the IR: the lowerer (graph and `dist` targets) and the root node.
fn lower_graph<'p>(
    program: &'p Program,
    r: &SurfaceRef,
) -> Result<(Lowerer<'p>, ir::NodeId), CompileError> {
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
    Ok((lowerer, out))
}

/// The spine of surface `r` (`spine`): None when no `min`, `max` or `abs` switches on it,
/// else the spine with each branch lowered to its own tape.
pub fn lower_spine(
    program: &Program,
    r: &SurfaceRef,
) -> Result<Option<(crate::survey::spine::Spine, Vec<Lowered>)>, CompileError> {
    let (mut lowerer, out) = lower_graph(program, r)?;
    let smooth = std::mem::take(&mut lowerer.smooth_mins);
    let Some(found) = spine::find(&mut lowerer.graph, &smooth, out) else {
        return Ok(None);
    };
    let branches = found
        .branches
        .iter()
        .map(|&b| allocate_space(&lowerer, b))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Some((found.spine, branches)))
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

/// Checks that surface `r` stays within the compiler's limits without compiling it to
/// machine code: its size after inlining (`TooLarge`) and, following its `dist` targets,
/// the depth of `dist` (`DistTooDeep`, wrapped in `Child` errors like `compile_surface`'s).
/// `outer` names the `dist`s around `r`, outermost first. Cheap: lowering stops at the limits.
pub fn check_limits(
    program: &Program,
    r: &SurfaceRef,
    outer: &mut Vec<String>,
) -> Result<(), CompileError> {
    let lowered = lower_surface(program, r)?;
    for (target, span) in &lowered.children {
        let result = if let Err(e) = enter_dist(program, target, outer) {
            Err(e)
        } else if let SurfaceRef::Patch(_) = target {
            Ok(())
        } else {
            check_limits(program, target, outer)
        };
        outer.pop();
        result.map_err(|e| CompileError::Child {
            span: *span,
            source: Box::new(e),
        })?;
    }
    Ok(())
}

/// Enters a `dist` of `target` inside the `dist`s `outer` names: pushes its name (the caller
/// pops it), or says that this is one `dist` too deep.
pub fn enter_dist(
    program: &Program,
    target: &SurfaceRef,
    outer: &mut Vec<String>,
) -> Result<(), CompileError> {
    outer.push(target_name(program, target).unwrap_or_else(|| "…".to_string()));
    if outer.len() > MAX_DIST_DEPTH {
        return Err(CompileError::DistTooDeep {
            limit: MAX_DIST_DEPTH,
            chain: outer.iter().map(|n| format!("dist({n})")).collect(),
        });
    }
    Ok(())
}

/// The name of a named surface or patch; None for an expression.
fn target_name(program: &Program, r: &SurfaceRef) -> Option<String> {
    match r {
        SurfaceRef::Surface(id) => program.surfaces.get(id.index()).map(|d| d.name.clone()),
        SurfaceRef::Patch(id) => program.patches.get(id.index()).map(|d| d.name.clone()),
        SurfaceRef::Anonymous(_) => None,
    }
}

/// The listing of a lowered surface: its tape, then what each `dist` child measures.
pub fn listing(program: &Program, lowered: &Lowered) -> String {
    let mut s = lowered.tape.listing();
    for (k, (target, span)) in lowered.children.iter().enumerate() {
        let what = target_name(program, target)
            .unwrap_or_else(|| format!("the expression at bytes {}..{}", span.start, span.end));
        s.push_str(&format!("; #{k} = dist({what})\n"));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sema::program::{Axis, BinaryOp, Expr, ExprKind, FnDef, PatchDef, SurfaceDef};
    use crate::surface::compiled::CompiledSurface;
    use crate::values::Surface as _;

    fn e(kind: ExprKind) -> Expr {
        Expr {
            kind,
            span: Span::new(3, 7),
        }
    }

    fn surface(name: &str, body: Expr) -> SurfaceDef {
        SurfaceDef {
            name: name.into(),
            span: Span::default(),
            body,
        }
    }

    fn lower(p: &Program, id: u32) -> Result<Lowered, CompileError> {
        lower_surface(p, &SurfaceRef::Surface(SurfaceId(id)))
    }

    #[test]
    fn a_hand_built_cycle_is_an_error_not_a_stack_overflow() {
        let p = Program {
            surfaces: vec![
                surface("a", e(ExprKind::Surface(SurfaceId(1)))),
                surface("b", e(ExprKind::Surface(SurfaceId(0)))),
            ],
            functions: vec![FnDef {
                name: "f".into(),
                span: Span::default(),
                params: vec!["t".into()],
                body: e(ExprKind::Call(FnId(0), vec![e(ExprKind::Param(0))])),
                uses_coordinates: false,
            }],
            ..Program::default()
        };
        assert!(matches!(lower(&p, 0), Err(CompileError::Cycle { name, .. }) if name == "a"));
        let call = e(ExprKind::Call(FnId(0), vec![e(ExprKind::Coord(Axis::X))]));
        let p2 = Program {
            surfaces: vec![surface("s", call)],
            ..p
        };
        assert!(matches!(lower(&p2, 0), Err(CompileError::Cycle { name, .. }) if name == "f"));
    }

    #[test]
    fn misuse_is_reported_with_its_span() {
        let p = Program {
            surfaces: vec![surface("s", e(ExprKind::Param(0)))],
            patches: vec![PatchDef {
                name: "p".into(),
                span: Span::default(),
                params: ["u".into(), "v".into()],
                u_range: (0.0, 1.0),
                v_range: (0.0, 1.0),
                body: [
                    e(ExprKind::Param(0)),
                    e(ExprKind::Coord(Axis::Z)),
                    e(ExprKind::Param(1)),
                ],
            }],
            ..Program::default()
        };
        assert!(matches!(
            lower(&p, 0),
            Err(CompileError::UnboundParam { index: 0, span }) if span == Span::new(3, 7)
        ));
        assert!(matches!(
            lower_patch(&p, PatchId(0)),
            Err(CompileError::CoordinatesInPatch { .. })
        ));
        assert!(matches!(
            lower_surface(&p, &SurfaceRef::Patch(PatchId(0))),
            Err(CompileError::PatchIsNotASurface { name }) if name == "p"
        ));
        assert!(matches!(
            lower(&p, 9),
            Err(CompileError::NoSuchSurface { .. })
        ));
    }

    #[test]
    fn too_deep_an_expression_is_an_error() {
        let mut body = e(ExprKind::Coord(Axis::X));
        for _ in 0..lower::MAX_DEPTH + 5 {
            body = e(ExprKind::Binary(
                BinaryOp::Add,
                Box::new(body),
                Box::new(e(ExprKind::Number(1.0))),
            ));
        }
        let p = Program {
            surfaces: vec![surface("deep", body)],
            ..Program::default()
        };
        assert!(matches!(lower(&p, 0), Err(CompileError::TooDeep { .. })));
    }

    #[test]
    fn a_constant_surface_compiles_to_an_empty_tape() {
        let p = Program {
            surfaces: vec![surface(
                "c",
                e(ExprKind::Binary(
                    BinaryOp::Mul,
                    Box::new(e(ExprKind::Number(2.0))),
                    Box::new(e(ExprKind::Number(3.0))),
                )),
            )],
            ..Program::default()
        };
        let l = lower(&p, 0).unwrap();
        assert!(l.tape.instrs().is_empty());
        assert_eq!(l.tape.constants(), &[6.0]);
        let mut s = CompiledSurface::new(l.tape, vec![]).unwrap();
        let vg = s.value_gradient(glam::DVec3::new(1.0, 2.0, 3.0));
        assert_eq!((vg.value, vg.gradient), (6.0, glam::DVec3::ZERO));
    }
}
