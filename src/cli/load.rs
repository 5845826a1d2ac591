//! Reading, parsing and checking one `.surf` file for a command: every diagnostic (warnings
//! too) goes to stderr; the checked program comes back only if there is no error.

use std::io::{IsTerminal, Read};
use std::path::{Path, PathBuf};

use crate::diag::{self, Diagnostic};
use crate::sema::{self, program::Program};
use crate::syntax::{self, ast};

use super::ColorMode;
use super::report::Failure;

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

/// The name standard input goes by in diagnostics and messages.
pub(crate) const STDIN_NAME: &str = "<stdin>";

/// Whether a FILE argument means standard input (`-`).
pub(crate) fn is_stdin(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// The name of an input in messages: its path, or `<stdin>`.
pub(crate) fn input_name(path: &Path) -> String {
    if is_stdin(path) {
        STDIN_NAME.to_owned()
    } else {
        path.display().to_string()
    }
}

/// Reads a file (or standard input, for `-`) as text. A missing or unreadable file is an I/O
/// failure (exit 2); a file that is not UTF-8 is a diagnostic (E0009, exit 1).
pub(crate) fn read_source(path: &Path, color: ColorMode) -> Result<String, Failure> {
    let bytes = if is_stdin(path) {
        let mut bytes = Vec::new();
        std::io::stdin()
            .lock()
            .read_to_end(&mut bytes)
            .map(|_| bytes)
    } else {
        std::fs::read(path)
    };
    let bytes =
        bytes.map_err(|e| Failure::io(format!("cannot read `{}`: {e}", input_name(path)), path))?;
    match syntax::source_text(&bytes) {
        Ok(s) => Ok(s.to_string()),
        Err(d) => {
            let lossy = String::from_utf8_lossy(&bytes);
            Err(Failure::diagnostics(
                &[d],
                &input_name(path),
                &lossy,
                stderr_color(color),
            ))
        }
    }
}

/// [`read_source`] for commands that need only the exit code.
pub(crate) fn read(path: &Path, color: ColorMode) -> Result<String, u8> {
    read_source(path, color).map_err(|f| f.exit)
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

/// Reads, parses and checks `path` (`-`: standard input), printing every diagnostic to
/// stderr. Err if the file cannot be read (exit 2) or has errors (exit 1).
pub(crate) fn load_reported(path: &Path, color: ColorMode) -> Result<Loaded, Failure> {
    let source = read_source(path, color)?;
    let (checked, diags) = analyse(&source);
    let name = input_name(path);
    match checked {
        Some((ast, program)) if !diag::has_errors(&diags) => {
            if !diags.is_empty() {
                diag::emit_stderr(&diags, &name, &source, stderr_color(color));
            }
            Ok(Loaded {
                path: path.to_path_buf(),
                source,
                ast,
                program,
            })
        }
        _ => Err(Failure::diagnostics(
            &diags,
            &name,
            &source,
            stderr_color(color),
        )),
    }
}

/// [`load_reported`] for commands that need only the exit code.
pub(crate) fn load(path: &Path, color: ColorMode) -> Result<Loaded, u8> {
    load_reported(path, color).map_err(|f| f.exit)
}
