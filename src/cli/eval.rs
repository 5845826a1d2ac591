//! `surfc eval FILE SURFACE X Y Z [--json]`: value and gradient at a point.

use std::path::{Path, PathBuf};

use glam::DVec3;

use super::load::Loaded;
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
    /// Print one JSON object `{"value": V, "gradient": [GX, GY, GZ]}`.
    #[arg(long)]
    pub json: bool,
    /// How surfaces are evaluated: machine code compiled from the tape, or the interpreter.
    #[arg(long, value_enum, default_value_t = EngineChoice::Native)]
    pub engine: EngineChoice,
}

/// The id of the surface called `name`, or a message listing the known surfaces and
/// `EXIT_INPUT`.
fn find_surface(program: &Program, name: &str) -> Result<SurfaceId, u8> {
    if let Some(i) = program.surfaces.iter().position(|s| s.name == name) {
        return Ok(SurfaceId(i as u32));
    }
    let known: Vec<&str> = program.surfaces.iter().map(|s| s.name.as_str()).collect();
    if known.is_empty() {
        eprintln!("error: no surface `{name}`: the file defines no surfaces");
    } else {
        eprintln!(
            "error: no surface `{name}`; the file defines: {}",
            known.join(", ")
        );
    }
    Err(EXIT_INPUT)
}

/// The file, checked, and the id of its surface `name`; else the exit code (the diagnostics or
/// the message are printed).
pub(crate) fn load_surface(
    file: &Path,
    name: &str,
    color: ColorMode,
) -> Result<(Loaded, SurfaceId), u8> {
    let loaded = super::load::load(file, color)?;
    let id = find_surface(&loaded.program, name)?;
    Ok((loaded, id))
}

/// Reports why a surface of `loaded` could not be compiled: a diagnostic with its span for a
/// limit the user reached, else a message. `EXIT_INPUT`.
pub(crate) fn report_compile_error(e: &CompileError, loaded: &Loaded, color: ColorMode) -> u8 {
    match super::build::limit_diagnostic(e) {
        Some(d) => crate::diag::emit_stderr(
            &[d],
            &loaded.path.display().to_string(),
            &loaded.source,
            super::load::stderr_color(color),
        ),
        None => eprintln!("error: cannot compile the surface: {e}"),
    }
    EXIT_INPUT
}

pub fn run(args: EvalArgs, color: ColorMode) -> u8 {
    let (loaded, id) = match load_surface(&args.file, &args.surface, color) {
        Ok(found) => found,
        Err(code) => return code,
    };
    // dist() children measure their tolerances against a unit length: eval has no step.
    let builder = super::build::Builder::new(&loaded.program, args.engine.into());
    let mut surface = match builder.surface(&SurfaceRef::Surface(id), 1.0) {
        Ok(s) => s,
        Err(e) => return report_compile_error(&e, &loaded, color),
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
