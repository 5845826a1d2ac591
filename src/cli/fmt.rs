//! `surfc fmt FILE`: print the file in canonical formatting on stdout (comments kept). A file
//! with syntax errors is not formatted: its diagnostics go to stderr and the exit code is 1.

use std::path::PathBuf;

use crate::diag;
use crate::syntax;

use super::ColorMode;

#[derive(clap::Args, Debug)]
pub struct FmtArgs {
    /// The .surf file to format.
    pub file: PathBuf,
}

pub fn run(args: FmtArgs, color: ColorMode) -> u8 {
    let source = match super::load::read(&args.file, color) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let (file, diags) = syntax::parse(&source);
    let Some(file) = file else {
        let color = super::load::stderr_color(color);
        diag::emit_stderr(&diags, &args.file.display().to_string(), &source, color);
        return super::EXIT_INPUT;
    };
    super::print_stdout(&syntax::format(&file))
}
