//! The lexical pre-scan that runs before pest: finds the comments, characters that belong to
//! no token, unterminated comments, unbalanced brackets and nesting deeper than the limit,
//! all in one linear pass over the bytes. pest's recursive descent only ever sees text whose
//! brackets are balanced and nested at most `MAX_PAREN_DEPTH` deep, so it cannot run out of
//! stack, and megabytes of garbage are rejected here in linear time.

use crate::diag::{Diagnostic, messages};
use crate::span::Span;

use super::ast::Comment;
use super::limits::{MAX_PAREN_DEPTH, MAX_SYNTAX_DIAGNOSTICS};

/// What the pre-scan found.
pub(crate) struct Scan {
    pub comments: Vec<Comment>,
    pub diagnostics: Vec<Diagnostic>,
}

fn is_token_byte(b: u8) -> bool {
    b.is_ascii_alphanumeric()
        || matches!(
            b,
            b'_' | b' '
                | b'\t'
                | b'\r'
                | b'\n'
                | b'+'
                | b'-'
                | b'*'
                | b'/'
                | b'^'
                | b'('
                | b')'
                | b','
                | b':'
                | b';'
                | b'='
                | b'{'
                | b'}'
                | b'.'
        )
}

/// Nothing but spaces or tabs between the start of the line and `pos`.
pub(crate) fn starts_line(src: &str, pos: usize) -> bool {
    src[..pos]
        .bytes()
        .rev()
        .take_while(|&b| b != b'\n')
        .all(|b| b == b' ' || b == b'\t' || b == b'\r')
}

/// Only whitespace, containing an empty line, between the previous text and `pos` (false
/// at the start of the file).
pub(crate) fn blank_line_before(src: &str, pos: usize) -> bool {
    let before = &src[..pos];
    let text_end = before.trim_end().len();
    text_end > 0 && before[text_end..].bytes().filter(|&b| b == b'\n').count() >= 2
}

struct Collector {
    diagnostics: Vec<Diagnostic>,
    suppressed: usize,
}

impl Collector {
    fn push(&mut self, d: Diagnostic) {
        if self.diagnostics.len() < MAX_SYNTAX_DIAGNOSTICS {
            self.diagnostics.push(d);
        } else {
            self.suppressed += 1;
        }
    }
}

pub(crate) fn scan(src: &str) -> Scan {
    let bytes = src.as_bytes();
    let mut comments = Vec::new();
    let mut out = Collector {
        diagnostics: Vec::new(),
        suppressed: 0,
    };
    // Open parentheses (positions) since the last `;`, `{` or `}`, and open braces.
    let mut parens: Vec<usize> = Vec::new();
    let mut braces: Vec<usize> = Vec::new();
    let mut too_deep_reported = false;
    let mut i = 0;
    let close_statement = |parens: &mut Vec<usize>, out: &mut Collector| {
        if !parens.is_empty() {
            let spans: Vec<Span> = parens.iter().map(|&p| Span::new(p, p + 1)).collect();
            out.push(messages::unclosed_paren(&spans));
            parens.clear();
        }
    };
    while i < bytes.len() {
        let b = bytes[i];
        if b == b'/' && bytes.get(i + 1) == Some(&b'/') {
            let end = src[i..].find('\n').map_or(src.len(), |n| i + n);
            push_comment(src, &mut comments, i, end);
            i = end;
            continue;
        }
        if b == b'/' && bytes.get(i + 1) == Some(&b'*') {
            match src[i + 2..].find("*/") {
                Some(n) => {
                    let end = i + 2 + n + 2;
                    push_comment(src, &mut comments, i, end);
                    i = end;
                }
                None => {
                    out.push(messages::unterminated_comment(Span::new(i, i + 2)));
                    i = bytes.len();
                }
            }
            continue;
        }
        if b == b'"' {
            // A string (an import's path): its characters are no tokens; it ends on its line.
            match src[i + 1..].find(['"', '\n']) {
                Some(n) if bytes[i + 1 + n] == b'"' => i += n + 2,
                _ => {
                    let end = src[i..].find('\n').map_or(src.len(), |n| i + n);
                    out.push(messages::unterminated_string(Span::new(i, end)));
                    i = end;
                }
            }
            continue;
        }
        if !is_token_byte(b) {
            // A run of characters that start no token: one diagnostic for the run.
            let start = i;
            let mut end = i;
            while end < bytes.len() && !is_token_byte(bytes[end]) {
                end += 1;
            }
            // `end` stops at an ASCII byte, hence on a char boundary.
            out.push(messages::stray_characters(
                Span::new(start, end),
                &src[start..end],
            ));
            i = end;
            continue;
        }
        match b {
            b'(' => {
                parens.push(i);
                if parens.len() > MAX_PAREN_DEPTH && !too_deep_reported {
                    out.push(super::nesting_too_deep(Span::new(i, i + 1)));
                    too_deep_reported = true;
                }
            }
            b')' => {
                if parens.pop().is_none() {
                    out.push(messages::unmatched_close(Span::new(i, i + 1), ')'));
                }
                if parens.is_empty() {
                    too_deep_reported = false;
                }
            }
            b';' => close_statement(&mut parens, &mut out),
            b'{' => {
                close_statement(&mut parens, &mut out);
                braces.push(i);
            }
            b'}' => {
                close_statement(&mut parens, &mut out);
                if braces.pop().is_none() {
                    out.push(messages::unmatched_close(Span::new(i, i + 1), '}'));
                }
            }
            _ => {}
        }
        i += 1;
    }
    close_statement(&mut parens, &mut out);
    for &p in &braces {
        out.push(messages::unclosed_brace(Span::new(p, p + 1)));
    }
    let mut diagnostics = out.diagnostics;
    if out.suppressed > 0 {
        diagnostics.push(messages::suppressed(out.suppressed));
    }
    Scan {
        comments,
        diagnostics,
    }
}

fn push_comment(src: &str, comments: &mut Vec<Comment>, start: usize, end: usize) {
    comments.push(Comment {
        text: src[start..end].trim_end().to_string(),
        span: Span::new(start, end),
        own_line: starts_line(src, start),
        blank_line_before: blank_line_before(src, start),
    });
}

/// Skips whitespace and comments from `pos`; returns the position of the next token (or the
/// end). Comments are known to be terminated (the pre-scan passed).
pub(crate) fn skip_trivia(src: &str, mut pos: usize) -> usize {
    let bytes = src.as_bytes();
    loop {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if src[pos..].starts_with("//") {
            pos = src[pos..].find('\n').map_or(src.len(), |n| pos + n);
        } else if src[pos..].starts_with("/*") {
            pos = src[pos + 2..]
                .find("*/")
                .map_or(src.len(), |n| pos + 2 + n + 2);
        } else {
            return pos;
        }
    }
}

/// The token starting at `pos` (after trivia): its span, or an empty span at the end.
pub(crate) fn token_at(src: &str, pos: usize) -> Span {
    let start = skip_trivia(src, pos);
    let bytes = src.as_bytes();
    if start >= bytes.len() {
        return Span::new(bytes.len(), bytes.len());
    }
    let b = bytes[start];
    let mut end = start + 1;
    if b.is_ascii_alphanumeric() || b == b'_' {
        while end < bytes.len()
            && (bytes[end].is_ascii_alphanumeric()
                || bytes[end] == b'_'
                || (b.is_ascii_digit()
                    && bytes[end] == b'.'
                    && bytes.get(end + 1).is_some_and(u8::is_ascii_digit)))
        {
            end += 1;
        }
    } else if b == b'"' {
        end = src[end..]
            .find(['"', '\n'])
            .map_or(src.len(), |n| end + n + 1)
            .min(src.len());
    } else if b == b'.' && bytes.get(end) == Some(&b'.') {
        end += 1;
    } else {
        // One character (may be multi-byte only if the pre-scan did not run).
        while end < bytes.len() && !src.is_char_boundary(end) {
            end += 1;
        }
    }
    Span::new(start, end)
}

/// The end of the last token that starts in `from..pos` (or `from` if none): where a missing
/// `;` belongs.
pub(crate) fn end_of_previous_token(src: &str, from: usize, pos: usize) -> usize {
    let mut end = from;
    let mut p = from;
    loop {
        let t = token_at(src, p);
        if t.start as usize >= pos || t.start == t.end {
            return end;
        }
        end = t.end as usize;
        p = end;
    }
}
