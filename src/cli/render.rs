//! `surfc render FILE -o OUT.png|OUT.svg [--only NAME]... [--size WxH] [--view AZ,EL]`: meshes
//! the selected blocks as `surfc mesh` does and draws them into one picture.

use std::path::PathBuf;

use super::load::load;
use super::mesh::{mesh_blocks, named, select};
use super::{ColorMode, EXIT_USAGE, EngineChoice};
use crate::mesh::render::{RenderOptions, parse_size, parse_view, write_picture_file};

#[derive(clap::Args, Debug)]
pub struct RenderArgs {
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
    let loaded = match load(&args.file, color) {
        Ok(l) => l,
        Err(code) => return code,
    };
    let meshed = match select(&loaded, &args.only)
        .and_then(|blocks| mesh_blocks(&loaded, &blocks, color, args.quiet, args.engine.into()))
    {
        Ok(m) => m,
        Err(code) => return code,
    };
    if let Err(e) = write_picture_file(&args.output, &named(&meshed), &options) {
        eprintln!("error: {e}");
        return EXIT_USAGE;
    }
    0
}
