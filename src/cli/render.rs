//! `surfc render FILE|MESHFILE -o OUT.png|OUT.svg [--only NAME]... [--size WxH] [--view AZ,EL]`:
//! meshes the selected blocks of a `.surf` file as `surfc mesh` does, or reads the meshes of
//! a mesh file (OBJ, STL, PLY, OFF, GLB, 3MF: chosen by the extension), and draws them into
//! one picture.

use std::path::PathBuf;

use super::load::load;
use super::mesh::{mesh_blocks, select};
use super::{ColorMode, EXIT_INPUT, EXIT_USAGE, EngineChoice};
use crate::mesh::NamedMesh;
use crate::mesh::read::{ReadError, read_mesh_file};
use crate::mesh::render::{RenderOptions, parse_size, parse_view, write_picture_file};
use crate::mesh::write::Format;
use crate::pipeline::named;

#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// A .surf file (`-`: standard input), or a mesh file: .obj, .stl, .ply, .off, .glb, .3mf.
    pub file: PathBuf,
    /// The picture to write: .png or .svg.
    #[arg(short, long, required = true)]
    pub output: PathBuf,
    /// Draw only the named mesh blocks (repeatable).
    #[arg(long = "only", value_name = "NAME")]
    pub only: Vec<String>,
    /// Picture size in pixels, WxH.
    #[arg(long, default_value = "800x600")]
    pub size: String,
    /// View direction: azimuth and elevation in degrees, AZ,EL.
    #[arg(long, default_value = "30,25", allow_hyphen_values = true)]
    pub view: String,
    /// No progress spinner on stderr.
    #[arg(long, short)]
    pub quiet: bool,
    /// How surfaces are evaluated: machine code compiled from the tape, or the interpreter.
    #[arg(long, value_enum, default_value_t = EngineChoice::Native)]
    pub engine: EngineChoice,
    /// Set a constant of the file: `-D NAME=VALUE` (repeatable).
    #[command(flatten)]
    pub defines: super::load::DefineArgs,
}

pub fn run(args: RenderArgs, color: ColorMode) -> u8 {
    let options = match (parse_size(&args.size), parse_view(&args.view)) {
        (Ok((width, height)), Ok(view)) => RenderOptions {
            width,
            height,
            view,
            ..RenderOptions::default()
        },
        (Err(e), _) => {
            eprintln!("error: --size {}: {e}", args.size);
            return EXIT_USAGE;
        }
        (_, Err(e)) => {
            eprintln!("error: --view {}: {e}", args.view);
            return EXIT_USAGE;
        }
    };
    // A file whose extension names a mesh format is a mesh to draw; anything else (`.surf`,
    // `-`) is meshed first.
    if let Ok(format) = Format::from_path(&args.file) {
        return render_mesh_file(&args, format, &options);
    }
    let loaded = match load(&args.file, color, &args.defines) {
        Ok(l) => l,
        Err(code) => return code,
    };
    let meshed = match select(&loaded, &args.only)
        .and_then(|blocks| mesh_blocks(&loaded, &blocks, color, args.quiet, args.engine.into()))
    {
        Ok(m) => m,
        Err(failure) => return failure.exit,
    };
    draw(&args, &named(&meshed), &options)
}

/// Draws the meshes of a mesh file (those `--only` names, if any).
fn render_mesh_file(args: &RenderArgs, format: Format, options: &RenderOptions) -> u8 {
    let meshes = match read_mesh_file(&args.file, format) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("error: {e}");
            return match e {
                ReadError::Parse { .. } => EXIT_INPUT,
                ReadError::Io { .. } | ReadError::Unsupported { .. } => EXIT_USAGE,
            };
        }
    };
    for name in &args.only {
        if !meshes.iter().any(|(n, _)| n == name) {
            let known: Vec<&str> = meshes.iter().map(|(n, _)| n.as_str()).collect();
            eprintln!(
                "error: `{}` has no mesh `{name}`; its meshes are: {}",
                args.file.display(),
                known.join(", ")
            );
            return EXIT_USAGE;
        }
    }
    let named: Vec<NamedMesh> = meshes
        .iter()
        .filter(|(name, _)| args.only.is_empty() || args.only.contains(name))
        .map(|(name, mesh)| NamedMesh { name, mesh })
        .collect();
    draw(args, &named, options)
}

/// Writes the picture; the exit code.
fn draw(args: &RenderArgs, meshes: &[NamedMesh], options: &RenderOptions) -> u8 {
    if let Err(e) = write_picture_file(&args.output, meshes, options) {
        eprintln!("error: {e}");
        return EXIT_USAGE;
    }
    0
}
