//! `surfc eval FILE SURFACE X Y Z [--json]`: value and gradient at a point.

use std::path::{Path, PathBuf};

use glam::DVec3;

use super::load::Loaded;
use super::report::{CODE_INPUT, Failure};
use super::{ColorMode, EXIT_INPUT, EngineChoice};
use crate::compile::CompileError;
use crate::sema::program::{Program, SurfaceId, SurfaceRef};
use crate::surface::Surface;

#[derive(clap::Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct EvalArgs {
    pub file: PathBuf,
    /// The name of a `surface` definition.
    pub surface: String,
    pub x: f64,
    pub y: f64,
    pub z: f64,
    /// Print one JSON object `{"value": V, "gradient": [GX, GY, GZ]}` (on failure:
    /// `{"errors": [...]}`).
    #[arg(long)]
    pub json: bool,
    /// How surfaces are evaluated: machine code compiled from the tape, or the interpreter.
    #[arg(long, value_enum, default_value_t = EngineChoice::Native)]
    pub engine: EngineChoice,
    /// Set a constant of the file: `-D NAME=VALUE` (repeatable).
    #[command(flatten)]
    pub defines: super::load::DefineArgs,
}

/// The id of the surface called `name`, or a failure (exit 1) listing the known surfaces.
fn find_surface(program: &Program, name: &str, file: &Path) -> Result<SurfaceId, Failure> {
    if let Some(i) = program.surfaces.iter().position(|s| s.name == name) {
        return Ok(SurfaceId(i as u32));
    }
    let known: Vec<&str> = program.surfaces.iter().map(|s| s.name.as_str()).collect();
    let message = if known.is_empty() {
        format!("no surface `{name}`: the file defines no surfaces")
    } else {
        format!(
            "no surface `{name}`; the file defines: {}",
            known.join(", ")
        )
    };
    Err(Failure::new(EXIT_INPUT, CODE_INPUT, message, Some(file)))
}

/// The file, checked, and the id of its surface `name`; else the failure (the diagnostics
/// or the message are printed).
pub(crate) fn load_surface(
    file: &Path,
    name: &str,
    color: ColorMode,
    defines: &super::load::DefineArgs,
) -> Result<(Loaded, SurfaceId), Failure> {
    let loaded = super::load::load_reported(file, color, defines)?;
    let id = find_surface(&loaded.program, name, file)?;
    Ok((loaded, id))
}

/// Why a surface of `loaded` could not be compiled (exit 1): a diagnostic with its span for a
/// limit the user reached, else a message.
pub(crate) fn compile_failure(e: &CompileError, loaded: &Loaded, color: ColorMode) -> Failure {
    match crate::pipeline::build::limit_diagnostic(e) {
        Some(d) => Failure::diagnostics_map(&[d], &loaded.map, super::load::stderr_color(color)),
        None => Failure::new(
            EXIT_INPUT,
            CODE_INPUT,
            format!("cannot compile the surface: {e}"),
            None,
        ),
    }
}

pub fn run(args: EvalArgs, color: ColorMode) -> u8 {
    let (loaded, id) = match load_surface(&args.file, &args.surface, color, &args.defines) {
        Ok(found) => found,
        Err(failure) => return failure.finish(args.json),
    };
    // dist() children measure their tolerances against a unit length: eval has no step.
    let builder = crate::pipeline::build::Builder::new(&loaded.program, args.engine.into());
    let mut surface = match builder.surface(&SurfaceRef::Surface(id), 1.0) {
        Ok(s) => s,
        Err(e) => return compile_failure(&e, &loaded, color).finish(args.json),
    };
    let p = DVec3::new(args.x, args.y, args.z);
    let vg = surface.value_gradient(p);
    let g = vg.gradient;
    if args.json {
        // A struct keeps the keys in the documented order; NaN and infinities print as null.
        #[derive(serde::Serialize)]
        struct Json {
            value: f64,
            gradient: [f64; 3],
        }
        let out = Json {
            value: vg.value,
            gradient: [g.x, g.y, g.z],
        };
        super::print_stdout(&format!(
            "{}\n",
            serde_json::to_string(&out).unwrap_or_default()
        ))
    } else {
        super::print_stdout(&format!(
            "{}({}, {}, {}) = {}, gradient ({}, {}, {})\n",
            args.surface, p.x, p.y, p.z, vg.value, g.x, g.y, g.z
        ))
    }
}
