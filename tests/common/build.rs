//! Surfaces of `.surf` source built through the public API, as `surfc mesh` builds them:
//! parse, check, `compile_surface` with `dist` children as `ImplicitDist` / `PatchDist`
//! whose foot tolerance has `scale` = the mesh step.
#![allow(dead_code)]

use surfc::compile::CompileError;
use surfc::sema::program::{Program, SurfaceRef};
use surfc::solve::tolerance::{FootTolerance, PatchFootTolerance};
use surfc::surface::compiled::{self as compiled, CompiledSurface};
use surfc::surface::{ImplicitDist, PatchDist, Surface};

/// The checked program of `source`; panics on any diagnostic.
pub fn checked(source: &str) -> Program {
    let (file, diags) = surfc::syntax::parse(source);
    assert!(diags.is_empty(), "parse diagnostics: {diags:?}");
    let file = file.expect("a file without diagnostics parses");
    let (program, diags) = surfc::sema::check(&file);
    assert!(diags.is_empty(), "check diagnostics: {diags:?}");
    program
}

/// Surface `r` with its `dist` children, as `surfc mesh` builds it for a mesh of step `scale`.
pub fn build(
    program: &Program,
    r: &SurfaceRef,
    scale: f64,
) -> Result<CompiledSurface, CompileError> {
    compiled::compile_surface(program, r, &mut |target: &SurfaceRef| -> Result<
        Box<dyn Surface>,
        CompileError,
    > {
        let foot = FootTolerance {
            scale,
            ..FootTolerance::default()
        };
        Ok(match target {
            SurfaceRef::Patch(id) => Box::new(PatchDist::with_tolerance(
                Box::new(compiled::compile_patch(program, *id)?),
                PatchFootTolerance {
                    foot,
                    ..PatchFootTolerance::default()
                },
            )),
            other => Box::new(ImplicitDist::with_tolerance(
                Box::new(build(program, other, scale)?),
                foot,
            )),
        })
    })
}
