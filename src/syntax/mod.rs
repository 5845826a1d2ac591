//! Syntax: `.surf` text → pest parse tree → owned AST in which every node carries its span.
//! Knows nothing of meaning (that is `sema`) or of meshing.
//!
//! `parse` runs a linear lexical pre-scan first (`scan`: comments, stray characters,
//! brackets, nesting depth), then pest one statement at a time, so that every statement's
//! syntax error is reported and a broken statement does not hide the next ones. The owned
//! AST is returned only when the whole file parsed. `format` prints an AST canonically, with
//! its comments; `sexpr` dumps it span-free for tests.

pub mod ast;
mod format;
pub mod imports;
mod lower;
mod scan;
mod sexpr;

use pest::Parser;
use pest_derive::Parser;

use crate::diag::{Diagnostic, messages};
use crate::span::Span;

pub use format::format;
pub use sexpr::sexpr;

#[derive(Parser)]
#[grammar = "../grammar/surf.pest"]
struct SurfParser;

/// Fixed limits that keep every input from exhausting the stack or the screen.
pub mod limits {
    /// Parentheses nested deeper than this are a diagnostic (checked before pest runs).
    pub const MAX_PAREN_DEPTH: usize = 64;
    /// Expression trees deeper than this (counting operators, unary minus, parentheses and
    /// calls) are a diagnostic. Later stages may recurse over expressions freely.
    pub const MAX_EXPR_DEPTH: usize = 200;
    /// At most this many syntax diagnostics are kept; the rest are counted in one note.
    pub const MAX_SYNTAX_DIAGNOSTICS: usize = 30;
}

/// E0005 with the limits above.
pub fn nesting_too_deep(span: crate::span::Span) -> Diagnostic {
    messages::nesting_too_deep(span, limits::MAX_PAREN_DEPTH, limits::MAX_EXPR_DEPTH)
}

/// The text of a file's bytes, or the diagnostic for a file that is not UTF-8 (E0009), to be
/// rendered with `String::from_utf8_lossy(bytes)` as the source.
pub fn source_text(bytes: &[u8]) -> Result<&str, Diagnostic> {
    std::str::from_utf8(bytes).map_err(|e| {
        let offset = e.valid_up_to();
        let line = bytes[..offset].iter().filter(|&&b| b == b'\n').count() + 1;
        messages::not_utf8(offset, line)
    })
}

/// Parses a file. The AST is `Some` only if there is no syntax error; the diagnostics are
/// every syntax error found (capped at `limits::MAX_SYNTAX_DIAGNOSTICS`).
pub fn parse(source: &str) -> (Option<ast::File>, Vec<Diagnostic>) {
    parse_at(source, 0)
}

/// [`parse`] of a file that starts at byte `base` of a [`crate::span::SourceMap`]: every span
/// of the AST and the diagnostics is shifted by `base`.
pub fn parse_at(source: &str, base: u32) -> (Option<ast::File>, Vec<Diagnostic>) {
    let (file, mut diags) = parse_local(source, base as usize);
    if base > 0 {
        for d in &mut diags {
            for l in &mut d.labels {
                l.span = Span {
                    start: l.span.start.saturating_add(base),
                    end: l.span.end.saturating_add(base),
                };
            }
        }
    }
    (file, diags)
}

/// The parse with AST spans shifted by `base` and diagnostics' spans local.
fn parse_local(source: &str, base: usize) -> (Option<ast::File>, Vec<Diagnostic>) {
    let scanned = scan::scan(source);
    if !scanned.diagnostics.is_empty() {
        return (None, scanned.diagnostics);
    }
    let mut items = Vec::new();
    let mut diags = Vec::new();
    let mut suppressed = 0usize;
    let mut pos = 0;
    loop {
        pos = scan::skip_trivia(source, pos);
        if pos >= source.len() {
            break;
        }
        if diags.len() >= limits::MAX_SYNTAX_DIAGNOSTICS {
            // Count what is left by statement starts, roughly: enough to tell the user.
            suppressed += 1;
            pos = recover(source, pos, pos + 1, false);
            continue;
        }
        match SurfParser::parse(Rule::statement_only, &source[pos..]) {
            Ok(mut pairs) => {
                let Some(stmt) = pairs.next().and_then(|p| p.into_inner().next()) else {
                    diags.push(messages::internal_parse(Span::new(pos, pos)));
                    break;
                };
                let end = pos + stmt.as_span().end();
                let lower = lower::Lower { offset: base + pos };
                match lower.statement(stmt) {
                    Ok(mut item) => {
                        item.blank_line_before = scan::blank_line_before(source, pos);
                        items.push(item);
                    }
                    Err(mut d) => {
                        // Diagnostics stay local here; `parse_at` shifts them all.
                        for l in &mut d.labels {
                            l.span = Span::new(
                                (l.span.start as usize).saturating_sub(base),
                                (l.span.end as usize).saturating_sub(base),
                            );
                        }
                        diags.push(d)
                    }
                }
                pos = end.max(pos + 1);
            }
            Err(e) => {
                let at = match e.location {
                    pest::error::InputLocation::Pos(p) => pos + p,
                    pest::error::InputLocation::Span((p, _)) => pos + p,
                };
                let (positives, negatives) = match &e.variant {
                    pest::error::ErrorVariant::ParsingError {
                        positives,
                        negatives,
                    } => (positives.clone(), negatives.clone()),
                    pest::error::ErrorVariant::CustomError { .. } => (Vec::new(), Vec::new()),
                };
                diags.push(syntax_error(source, pos, at, &positives, &negatives));
                // After a missing `;` the next statement starts where the error is.
                let resume_at_error = positives.contains(&Rule::semi);
                pos = recover(source, pos, at, resume_at_error);
            }
        }
    }
    if suppressed > 0 {
        diags.push(messages::suppressed(suppressed));
    }
    if diags.is_empty() {
        let mut comments = scanned.comments;
        for c in &mut comments {
            c.span = Span::new(c.span.start as usize + base, c.span.end as usize + base);
        }
        let file = ast::File { items, comments };
        (Some(file), diags)
    } else {
        (None, diags)
    }
}

const KEYWORDS: [&str; 7] = ["import", "const", "fn", "surface", "patch", "curve", "mesh"];

/// The keyword at the start of the statement at `start`, if it is one.
fn statement_keyword(src: &str, start: usize) -> Option<&'static str> {
    let t = scan::token_at(src, start);
    KEYWORDS.into_iter().find(|k| &src[t.range()] == *k)
}

/// What is expected, in the user's words, for one pest rule.
fn describe(rule: Rule) -> Option<&'static str> {
    Some(match rule {
        Rule::semi => "`;`",
        Rule::comma => "`,`",
        Rule::colon => "`:`",
        Rule::eq => "`=`",
        Rule::dotdot => "`..`",
        Rule::lparen => "`(`",
        Rule::rparen => "`)`",
        Rule::lbrace => "`{`",
        Rule::rbrace => "`}`",
        Rule::add | Rule::sub | Rule::mul | Rule::div | Rule::pow => "an operator",
        Rule::number | Rule::neg | Rule::paren | Rule::call | Rule::expr | Rule::arg => {
            "an expression"
        }
        Rule::ident => "a name",
        Rule::patch_param => "a parameter such as `u: 0..1`",
        Rule::mesh_option => "a mesh option such as `step: 0.1;`",
        Rule::string => "a file name in quotes, such as `\"parts.surf\"`",
        Rule::kw_import
        | Rule::kw_const
        | Rule::kw_fn
        | Rule::kw_surface
        | Rule::kw_patch
        | Rule::kw_curve
        | Rule::kw_mesh => "a definition",
        _ => return None,
    })
}

/// Turns pest's expectation at `at` into a diagnostic worded in the user's terms.
fn syntax_error(
    src: &str,
    stmt_start: usize,
    at: usize,
    positives: &[Rule],
    negatives: &[Rule],
) -> Diagnostic {
    let found = scan::token_at(src, at);
    let found_text = &src[found.range()];
    let keyword = statement_keyword(src, stmt_start);
    let Some(keyword) = keyword else {
        return messages::expected_statement(found, found_text, &KEYWORDS);
    };
    // Inside a mesh block's braces the statement is a mesh option.
    let in_block = keyword == "mesh" && src[stmt_start..at.min(src.len())].contains('{');
    let context = messages::statement_context(keyword, in_block);
    if positives.contains(&Rule::semi) {
        let end = scan::end_of_previous_token(src, stmt_start, at);
        return messages::expected_semicolon(Span::new(end, end), found, found_text, context);
    }
    let mut expected: Vec<&'static str> = Vec::new();
    for r in positives {
        if let Some(d) = describe(*r) {
            if !expected.contains(&d) {
                expected.push(d);
            }
        }
    }
    // A name or a `(` is already an expression.
    if expected.contains(&"an expression") {
        expected.retain(|d| *d != "a name" && *d != "`(`");
    }
    if expected.is_empty() && !negatives.is_empty() {
        expected.push("a name");
    }
    let is_keyword = KEYWORDS.contains(&found_text);
    messages::expected_tokens(found, found_text, &expected, context, is_keyword)
}

/// Where to resume after a syntax error at `at` in the statement starting at `start`: after
/// the enclosing mesh block if the error is inside one, else at the next `;` or `}` (after
/// it) or the next statement keyword, whichever comes first (the token at `at` itself only
/// if `resume_at_error`).
fn recover(src: &str, start: usize, at: usize, resume_at_error: bool) -> usize {
    let bytes = src.as_bytes();
    let in_block = statement_keyword(src, start) == Some("mesh")
        && src[start..at.min(src.len())].contains('{');
    let mut p = at.min(src.len());
    loop {
        let t = scan::token_at(src, p);
        if t.start == t.end {
            return src.len();
        }
        let (ts, te) = (t.start as usize, t.end as usize);
        let text = &src[ts..te];
        if in_block {
            if bytes[ts] == b'}' {
                return te;
            }
        } else if bytes[ts] == b';' || bytes[ts] == b'}' {
            return te;
        } else if ts > start && (ts > at || resume_at_error) && KEYWORDS.contains(&text) {
            return ts;
        }
        p = te;
    }
}
