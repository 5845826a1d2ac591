//! `surfc eval FILE SURFACE X Y Z [--json]`: value and gradient at a point.

use std::path::PathBuf;

use super::ColorMode;

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
}

pub fn run(_args: EvalArgs, _color: ColorMode) -> u8 {
    super::not_yet("eval")
}
