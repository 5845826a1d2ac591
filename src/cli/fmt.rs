//! `surfc fmt FILE... [--check | --write]`: canonical formatting (comments kept). Without a
//! flag the formatted files are printed on stdout, one after the other; `--check` prints the
//! name of every file that would change (one a line, on stdout) and exits 1 if there is any;
//! `--write` rewrites the files that would change, atomically. A file with syntax errors is
//! not formatted: its diagnostics go to stderr and the exit code is 1. `-` is standard input
//! (which `--write` cannot rewrite). Exit codes: the worst over the files.

use std::path::{Path, PathBuf};

use crate::diag;
use crate::mesh::write::write_atomic;
use crate::syntax;

use super::load::{input_name, is_stdin, read, stderr_color};
use super::{ColorMode, EXIT_INPUT, EXIT_USAGE};

#[derive(clap::Args, Debug)]
pub struct FmtArgs {
    /// The .surf files to format; `-` reads standard input.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Change nothing: list the files whose formatting would change, exit 1 if any.
    #[arg(long, conflicts_with = "write")]
    pub check: bool,
    /// Rewrite the files whose formatting would change.
    #[arg(long)]
    pub write: bool,
}

pub fn run(args: FmtArgs, color: ColorMode) -> u8 {
    if args.write && args.files.iter().any(|f| is_stdin(f)) {
        eprintln!(
            "error: `--write` cannot rewrite standard input; format it to stdout without `--write`"
        );
        return EXIT_USAGE;
    }
    let mut worst = 0;
    for path in &args.files {
        let code = match format_file(path, color) {
            Err(code) => code,
            Ok((source, formatted)) => {
                if args.check {
                    if formatted == source {
                        0
                    } else {
                        match super::print_stdout(&format!("{}\n", input_name(path))) {
                            0 => EXIT_INPUT,
                            code => code,
                        }
                    }
                } else if args.write {
                    rewrite(path, &source, &formatted)
                } else {
                    super::print_stdout(&formatted)
                }
            }
        };
        worst = worst.max(code);
    }
    worst
}

/// The file's text and its canonical formatting; Err(exit code) if it cannot be read or
/// parsed (the diagnostics are printed).
fn format_file(path: &Path, color: ColorMode) -> Result<(String, String), u8> {
    let source = read(path, color)?;
    let (file, diags) = syntax::parse(&source);
    let Some(file) = file else {
        diag::emit_stderr(&diags, &input_name(path), &source, stderr_color(color));
        return Err(EXIT_INPUT);
    };
    let formatted = syntax::format(&file);
    Ok((source, formatted))
}

/// Replaces the file with its formatting if that differs; the exit code.
fn rewrite(path: &Path, source: &str, formatted: &str) -> u8 {
    if formatted == source {
        return 0;
    }
    match write_atomic(path, |out| out.write_all(formatted.as_bytes())) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            EXIT_USAGE
        }
    }
}
