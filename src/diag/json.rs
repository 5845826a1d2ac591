//! Diagnostics as JSON data: the entries of `{"errors": […]}` that `surfc mesh --json` prints
//! on failure (docs/cli.md) and that the library API and the Python package hand on. Each
//! says everything the rendered diagnostic says (code, message, the place as file, line and
//! column, help, notes, every label); the command line's errors without a place use the same
//! type.

use serde::Serialize;

use super::{Diagnostic, Label, Severity, line_column};
use crate::span::{SourceMap, Span};

/// One entry of `{"errors": […]}`. `file`, `line` and `column` are null where the error has
/// no place in a file (line and column are 1-based, the column in characters). `help`,
/// `notes` and `labels` are a diagnostic's (null and empty for other errors).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ErrorJson {
    pub code: String,
    pub severity: &'static str,
    pub message: String,
    pub file: Option<String>,
    pub line: Option<usize>,
    pub column: Option<usize>,
    /// A likely fix (the diagnostic's `help`).
    pub help: Option<String>,
    /// Further remarks, in order (the diagnostic's `note`s): for E0601, why the mesh could
    /// not be completed and where.
    pub notes: Vec<String>,
    /// Every labelled place, the primary one first.
    pub labels: Vec<LabelJson>,
}

/// A labelled place of a diagnostic in `--json`: what the label says, whether it is the
/// place the diagnostic is about, and where it is (as `ErrorJson` places an error).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LabelJson {
    pub message: String,
    pub primary: bool,
    pub file: Option<String>,
    pub line: Option<usize>,
    pub column: Option<usize>,
}

/// The file, line and column of a span (None where the span lies in no file of `map`).
fn place(span: Span, map: &SourceMap) -> Option<(String, (usize, usize))> {
    let f = map.files().get(map.locate(span.start))?;
    let place = line_column(&f.text, (span.start - f.base) as usize);
    Some((f.name.clone(), place))
}

impl ErrorJson {
    /// A diagnostic about `source` (read from `file`), placed at its primary label.
    pub fn from_diagnostic(d: &Diagnostic, map: &SourceMap) -> ErrorJson {
        let located = d.primary_span().and_then(|span| place(span, map));
        let file = located
            .as_ref()
            .map(|(name, _)| name.clone())
            .or_else(|| map.files().first().map(|f| f.name.clone()));
        let at = located.map(|(_, place)| place);
        // The primary label first, then the others in their order.
        let mut labels: Vec<&Label> = d.labels.iter().filter(|l| l.primary).collect();
        labels.extend(d.labels.iter().filter(|l| !l.primary));
        ErrorJson {
            code: d.code.to_owned(),
            severity: match d.severity {
                Severity::Error => "error",
                Severity::Warning => "warning",
            },
            message: d.message.clone(),
            file,
            line: at.map(|(line, _)| line),
            column: at.map(|(_, column)| column),
            help: d.help.clone(),
            notes: d.notes.clone(),
            labels: labels
                .into_iter()
                .map(|l| {
                    let located = place(l.span, map);
                    LabelJson {
                        message: l.message.clone(),
                        primary: l.primary,
                        file: located.as_ref().map(|(name, _)| name.clone()),
                        line: located.as_ref().map(|(_, (line, _))| *line),
                        column: located.as_ref().map(|(_, (_, column))| *column),
                    }
                })
                .collect(),
        }
    }
}
