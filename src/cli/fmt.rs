//! `surfc fmt FILE`: print the file in canonical formatting.

use std::path::PathBuf;

use super::ColorMode;

#[derive(clap::Args, Debug)]
pub struct FmtArgs {
    /// The .surf file to format.
    pub file: PathBuf,
}

pub fn run(_args: FmtArgs, _color: ColorMode) -> u8 {
    super::not_yet("fmt")
}
