//! `surfc render FILE -o OUT.png|OUT.svg [--only NAME]... [--size WxH] [--view AZ,EL]`.

use std::path::PathBuf;

use super::ColorMode;

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
}

pub fn run(_args: RenderArgs, _color: ColorMode) -> u8 {
    super::not_yet("render")
}
