//! Reading, parsing and checking one `.surf` file for a command: every diagnostic (warnings
//! too) goes to stderr; the checked program comes back only if there is no error.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use crate::diag::{self, Diagnostic};
use crate::sema::{self, program::Program};
use crate::syntax::{self, ast};

use super::{ColorMode, EXIT_INPUT, EXIT_USAGE};

/// A file that parsed and checked without errors.
// The mesh, eval and bytecode commands read the fields; until they land, `check` does not.
#[allow(dead_code)]
#[derive(Debug)]
pub(crate) struct Loaded {
    pub path: PathBuf,
    pub source: String,
    pub ast: ast::File,
    pub program: Program,
}

/// Whether diagnostics on stderr are coloured.
pub(crate) fn stderr_color(color: ColorMode) -> bool {
    match color {
        ColorMode::Always => true,
        ColorMode::Never => false,
        ColorMode::Auto => std::io::stderr().is_terminal(),
    }
}

/// Reads a file as text. A missing or unreadable file is a message and `EXIT_USAGE`; a file
/// that is not UTF-8 is a diagnostic (E0009) and `EXIT_INPUT`.
pub(crate) fn read(path: &Path, color: ColorMode) -> Result<String, u8> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("error: cannot read `{}`: {e}", path.display());
            return Err(EXIT_USAGE);
        }
    };
    match syntax::source_text(&bytes) {
        Ok(s) => Ok(s.to_string()),
        Err(d) => {
            let lossy = String::from_utf8_lossy(&bytes);
            diag::emit_stderr(
                &[d],
                &path.display().to_string(),
                &lossy,
                stderr_color(color),
            );
            Err(EXIT_INPUT)
        }
    }
}

/// Parses and checks source text; returns the AST, the program (if the file parsed) and
/// every diagnostic.
pub(crate) fn analyse(source: &str) -> (Option<(ast::File, Program)>, Vec<Diagnostic>) {
    let (file, mut diags) = syntax::parse(source);
    let Some(file) = file else {
        return (None, diags);
    };
    let (program, more) = sema::check(&file);
    diags.extend(more);
    (Some((file, program)), diags)
}

/// Reads, parses and checks `path`, printing every diagnostic to stderr. Err(exit code) if the
/// file cannot be read (2) or has errors (1).
pub(crate) fn load(path: &Path, color: ColorMode) -> Result<Loaded, u8> {
    let source = read(path, color)?;
    let (checked, diags) = analyse(&source);
    if !diags.is_empty() {
        diag::emit_stderr(
            &diags,
            &path.display().to_string(),
            &source,
            stderr_color(color),
        );
    }
    match checked {
        Some((ast, program)) if !diag::has_errors(&diags) => Ok(Loaded {
            path: path.to_path_buf(),
            source,
            ast,
            program,
        }),
        _ => Err(EXIT_INPUT),
    }
}
