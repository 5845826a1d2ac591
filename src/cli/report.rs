//! How a command fails: the exit code and what went wrong, as data. Every error is printed
//! on stderr when it happens (diagnostics through codespan, other errors as one `error:`
//! line); a command run with `--json` also prints them all on stdout as one object,
//! `{"errors": [{code, severity, message, file, line, column, help, notes, labels}, …]}`
//! (docs/cli.md), so that a script reading stdout always gets JSON, and with it everything
//! the diagnostic on stderr says.

use std::path::Path;

use serde::Serialize;

use super::{EXIT_INPUT, EXIT_USAGE};
use crate::diag::{self, Diagnostic};
use crate::span::SourceMap;

pub use crate::diag::json::ErrorJson;

/// The `code` of an error that is not a diagnostic about the input: a usage error (exit 2).
pub const CODE_USAGE: &str = "usage";
/// The `code` of an input or output failure: a file that cannot be read or written (exit 2).
pub const CODE_IO: &str = "io";
/// The `code` of an input error that has no diagnostic code of its own (exit 1).
pub const CODE_INPUT: &str = "input";

/// A failed command: its exit code and its errors (already printed on stderr).
#[derive(Clone, Debug, PartialEq)]
pub struct Failure {
    pub exit: u8,
    pub errors: Vec<ErrorJson>,
}

impl Failure {
    /// Prints `error: MESSAGE` on stderr; a failure with that one error.
    pub fn new(exit: u8, code: &str, message: String, file: Option<&Path>) -> Failure {
        eprintln!("error: {message}");
        Failure {
            exit,
            errors: vec![ErrorJson {
                code: code.to_owned(),
                severity: "error",
                message,
                file: file.map(|p| p.display().to_string()),
                line: None,
                column: None,
                help: None,
                notes: Vec::new(),
                labels: Vec::new(),
            }],
        }
    }

    /// A usage error (exit 2).
    pub fn usage(message: String) -> Failure {
        Failure::new(EXIT_USAGE, CODE_USAGE, message, None)
    }

    /// A file that cannot be read or written (exit 2).
    pub fn io(message: String, file: &Path) -> Failure {
        Failure::new(EXIT_USAGE, CODE_IO, message, Some(file))
    }

    /// Diagnostics about `source` (exit 1): printed on stderr, kept as JSON entries.
    pub fn diagnostics(diags: &[Diagnostic], file: &str, source: &str, color: bool) -> Failure {
        Failure::diagnostics_map(diags, &SourceMap::single(file, source), color)
    }

    /// [`Failure::diagnostics`] of diagnostics whose spans point into several files.
    pub fn diagnostics_map(diags: &[Diagnostic], map: &SourceMap, color: bool) -> Failure {
        diag::emit_stderr_map(diags, map, color);
        Failure {
            exit: EXIT_INPUT,
            errors: diags
                .iter()
                .map(|d| ErrorJson::from_diagnostic(d, map))
                .collect(),
        }
    }

    /// Ends a command: prints `{"errors": […]}` on stdout if `json`; the exit code.
    pub fn finish(self, json: bool) -> u8 {
        if json {
            #[derive(Serialize)]
            struct Errors {
                errors: Vec<ErrorJson>,
            }
            let text = serde_json::to_string(&Errors {
                errors: self.errors,
            })
            .unwrap_or_default();
            // The exit code says the command failed; a stdout that cannot take the report
            // does not change it.
            let _ = super::print_stdout(&format!("{text}\n"));
        }
        self.exit
    }
}
