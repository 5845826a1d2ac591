//! Diagnostics as data (code, severity, labelled spans, help, notes) and their rendering
//! through codespan-reporting. Every message a user reads is worded in `messages`; this file
//! only knows how to print them. Rendering never fails: a span past the end of the source is
//! clamped rather than dropped.

pub mod json;
pub mod messages;
pub mod suggest;

use std::io::Write;

use codespan_reporting::diagnostic as cs;
use codespan_reporting::files::SimpleFiles;
use codespan_reporting::term::{self, termcolor};

use crate::span::{SourceMap, Span};

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    /// The input is wrong: nothing is compiled or meshed.
    Error,
    /// Worth a look; the input is still used.
    Warning,
}

/// One labelled span of a diagnostic. The primary label says what is wrong; secondary labels
/// point at related places (the first definition of a duplicate, the steps of a cycle).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Label {
    /// The place in the source.
    pub span: Span,
    /// What the label says about it.
    pub message: String,
    /// Whether this is the place the diagnostic is about (else a related place).
    pub primary: bool,
}

/// A diagnostic about the user's input.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    /// Stable error code, `E0001` … for errors, `W0001` … for warnings (docs/language.md).
    pub code: &'static str,
    /// Error or warning.
    pub severity: Severity,
    /// What is wrong, in one line.
    pub message: String,
    /// The places in the source, the primary one first where there is one.
    pub labels: Vec<Label>,
    /// A likely fix, if there is one.
    pub help: Option<String>,
    /// Further remarks, each printed as a `note`.
    pub notes: Vec<String>,
}

impl Diagnostic {
    pub fn error(code: &'static str, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            code,
            severity: Severity::Error,
            message: message.into(),
            labels: Vec::new(),
            help: None,
            notes: Vec::new(),
        }
    }

    pub fn warning(code: &'static str, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            severity: Severity::Warning,
            ..Diagnostic::error(code, message)
        }
    }

    pub fn primary(mut self, span: Span, message: impl Into<String>) -> Diagnostic {
        self.labels.push(Label {
            span,
            message: message.into(),
            primary: true,
        });
        self
    }

    pub fn secondary(mut self, span: Span, message: impl Into<String>) -> Diagnostic {
        self.labels.push(Label {
            span,
            message: message.into(),
            primary: false,
        });
        self
    }

    pub fn help(mut self, help: impl Into<String>) -> Diagnostic {
        self.help = Some(help.into());
        self
    }

    pub fn maybe_help(mut self, help: Option<String>) -> Diagnostic {
        self.help = help;
        self
    }

    pub fn note(mut self, note: impl Into<String>) -> Diagnostic {
        self.notes.push(note.into());
        self
    }

    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }

    /// The span of the primary label, if any.
    pub fn primary_span(&self) -> Option<Span> {
        self.labels.iter().find(|l| l.primary).map(|l| l.span)
    }
}

/// True if any diagnostic is an error.
pub fn has_errors(diags: &[Diagnostic]) -> bool {
    diags.iter().any(Diagnostic::is_error)
}

/// Source lines longer than this are not quoted: a label on one becomes a note with its line
/// and column (a megabyte-long line would otherwise be printed once per label).
const MAX_QUOTED_LINE: usize = 1000;

/// The 1-based line and column (in characters) of a byte offset into `source`.
pub fn line_column(source: &str, offset: usize) -> (usize, usize) {
    let (line, column, _) = locate(source, offset);
    (line, column)
}

/// The 1-based line and column of `offset`, and the length of its line.
fn locate(source: &str, offset: usize) -> (usize, usize, usize) {
    let offset = offset.min(source.len());
    let line_start = source[..offset].rfind('\n').map_or(0, |p| p + 1);
    let line_end = source[offset..]
        .find('\n')
        .map_or(source.len(), |p| offset + p);
    let line = source[..line_start].bytes().filter(|&b| b == b'\n').count() + 1;
    let column = source[line_start..offset].chars().count() + 1;
    (line, column, line_end - line_start)
}

/// A span in the map → its file's index and the span local to that file.
fn local(map: &SourceMap, s: Span) -> (usize, Span) {
    let k = map.locate(s.start);
    let base = map.files().get(k).map_or(0, |f| f.base);
    (
        k,
        Span {
            start: s.start - base,
            end: s.end.saturating_sub(base),
        },
    )
}

fn to_codespan(d: &Diagnostic, map: &SourceMap) -> cs::Diagnostic<usize> {
    let text = |k: usize| map.files().get(k).map_or("", |f| f.text.as_str());
    let clamp = |k: usize, s: Span| {
        let source = text(k);
        let source_len = source.len();
        let r = s.range();
        let end = r.end.min(source_len);
        let start = r.start.min(end);
        // Keep both ends on char boundaries (spans come from our own scanner, but a clamp
        // could land inside a character).
        let fix = |mut p: usize| {
            while p > 0 && !source.is_char_boundary(p) {
                p -= 1;
            }
            p
        };
        fix(start)..fix(end)
    };
    let mut long_line_notes = Vec::new();
    let severity = match d.severity {
        Severity::Error => cs::Severity::Error,
        Severity::Warning => cs::Severity::Warning,
    };
    let labels = d
        .labels
        .iter()
        .filter(|l| {
            let (k, s) = local(map, l.span);
            let (line, column, len) = locate(text(k), s.start as usize);
            let quoted = len <= MAX_QUOTED_LINE;
            if !quoted {
                long_line_notes.push(format!("at line {line}, column {column}: {}", l.message));
            }
            quoted
        })
        .map(|l| {
            let style = if l.primary {
                cs::LabelStyle::Primary
            } else {
                cs::LabelStyle::Secondary
            };
            let (k, s) = local(map, l.span);
            cs::Label::new(style, k, clamp(k, s)).with_message(l.message.clone())
        })
        .collect();
    let mut notes = long_line_notes;
    if let Some(h) = &d.help {
        notes.push(format!("help: {h}"));
    }
    notes.extend(d.notes.iter().map(|n| format!("note: {n}")));
    cs::Diagnostic::new(severity)
        .with_code(d.code)
        .with_message(d.message.clone())
        .with_labels(labels)
        .with_notes(notes)
}

/// Renders diagnostics as text, with ANSI colours if `color`.
pub fn render(diags: &[Diagnostic], file_name: &str, source: &str, color: bool) -> String {
    render_map(diags, &SourceMap::single(file_name, source), color)
}

/// [`render`] of diagnostics whose spans point into several files.
pub fn render_map(diags: &[Diagnostic], map: &SourceMap, color: bool) -> String {
    let mut buffer = if color {
        termcolor::Buffer::ansi()
    } else {
        termcolor::Buffer::no_color()
    };
    write_to(&mut buffer, diags, map);
    String::from_utf8_lossy(buffer.as_slice()).into_owned()
}

/// Prints diagnostics to stderr, coloured if `color`.
pub fn emit_stderr(diags: &[Diagnostic], file_name: &str, source: &str, color: bool) {
    emit_stderr_map(diags, &SourceMap::single(file_name, source), color)
}

/// [`emit_stderr`] of diagnostics whose spans point into several files.
pub fn emit_stderr_map(diags: &[Diagnostic], map: &SourceMap, color: bool) {
    let choice = if color {
        termcolor::ColorChoice::Always
    } else {
        termcolor::ColorChoice::Never
    };
    let stream = termcolor::StandardStream::stderr(choice);
    let mut lock = stream.lock();
    write_to(&mut lock, diags, map);
    let _ = lock.flush();
}

fn write_to<W: termcolor::WriteColor>(writer: &mut W, diags: &[Diagnostic], map: &SourceMap) {
    let mut files = SimpleFiles::new();
    for f in map.files() {
        files.add(f.name.as_str(), f.text.as_str());
    }
    let config = term::Config::default();
    for d in diags {
        let cd = to_codespan(d, map);
        if term::emit_to_write_style(writer, &config, &files, &cd).is_err() {
            // A span that codespan cannot place (never expected after clamping): print the
            // message alone rather than lose it.
            let _ = writeln!(writer, "{}[{}]: {}", severity_word(d), d.code, d.message);
        }
    }
}

fn severity_word(d: &Diagnostic) -> &'static str {
    match d.severity {
        Severity::Error => "error",
        Severity::Warning => "warning",
    }
}
