//! `surfc check FILE...`: parse and check; diagnostics on stderr.

use std::path::PathBuf;

use super::ColorMode;

#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// The .surf files to check.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
}

pub fn run(_args: CheckArgs, _color: ColorMode) -> u8 {
    super::not_yet("check")
}
