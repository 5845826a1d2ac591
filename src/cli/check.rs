//! `surfc check FILE...`: parse and check every file; diagnostics on stderr. Exit 0 if no file
//! has an error, 2 if a file could not be read, else 1.

use std::path::PathBuf;

use super::ColorMode;

#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// The .surf files to check.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
}

pub fn run(args: CheckArgs, color: ColorMode) -> u8 {
    let mut worst = 0;
    for path in &args.files {
        if let Err(code) = super::load::load(path, color) {
            worst = worst.max(code);
        }
    }
    worst
}
