//! `surfc check FILE...`: parse and check every file, and check that its surfaces stay within
//! the compiler's limits; diagnostics on stderr. Exit 0 if no file has an error, 2 if a file
//! could not be read, else 1.

use std::path::PathBuf;

use super::load::{Loaded, stderr_color};
use super::{ColorMode, EXIT_INPUT};
use crate::compile;
use crate::diag;
use crate::sema::program::{SurfaceId, SurfaceRef};

#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// The .surf files to check.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Set a constant of the file: `-D NAME=VALUE` (repeatable).
    #[command(flatten)]
    pub defines: super::load::DefineArgs,
}

pub fn run(args: CheckArgs, color: ColorMode) -> u8 {
    let mut worst = 0;
    for path in &args.files {
        let code = match super::load::load(path, color, &args.defines) {
            Ok(loaded) => check_limits(&loaded, color),
            Err(code) => code,
        };
        worst = worst.max(code);
    }
    worst
}

/// The compiler's limits (docs/language.md "Limits"), checked for every surface and mesh
/// block without compiling to machine code: the first surface past one is reported (the
/// surfaces built on it would repeat the same diagnostic). 0, or `EXIT_INPUT`.
fn check_limits(loaded: &Loaded, color: ColorMode) -> u8 {
    let program = &loaded.program;
    let surfaces = (0..program.surfaces.len()).map(|k| SurfaceRef::Surface(SurfaceId(k as u32)));
    let meshed = program.meshes.iter().map(|m| m.surface.clone());
    for r in surfaces.chain(meshed) {
        if matches!(r, SurfaceRef::Patch(_)) {
            continue;
        }
        if let Err(e) = compile::check_limits(program, &r, &mut Vec::new()) {
            if let Some(d) = crate::pipeline::build::limit_diagnostic(&e) {
                diag::emit_stderr_map(&[d], &loaded.map, stderr_color(color));
                return EXIT_INPUT;
            }
        }
    }
    0
}
