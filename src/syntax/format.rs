//! The canonical formatting of an AST (`surfc fmt`): one statement per line, mesh options one
//! per line indented by four spaces, spaces around `+ - * /` and none around `^`, only the
//! parentheses that precedence needs, numbers as written. Comments are kept: a comment on a
//! line of its own stays before the statement or mesh option that follows it, a comment after
//! code on the same line stays at the end of that line, and a comment written inside an
//! expression moves to the line before its statement (or mesh option). Empty lines between
//! statements are kept (at most one). A definition longer than 100 columns is broken before
//! the top-level `+` and `-` of its body; nothing else is wrapped.

use crate::span::Span;

use super::ast::*;

/// Formats a file canonically. `parse(format(f))` has the same AST as `f` (spans aside), and
/// formatting is idempotent.
pub fn format(file: &File) -> String {
    let mut out = String::new();
    let mut comments: Vec<&Comment> = file.comments.iter().collect();
    comments.sort_by_key(|c| c.span.start);
    let entries: Vec<Span> = file.items.iter().map(|i| i.span).collect();
    // Comments inside a mesh block are placed by the block itself.
    let (inside_mesh, top): (Vec<&Comment>, Vec<&Comment>) =
        comments
            .iter()
            .partition(|c| match containing(&entries, c.span) {
                Some(k) => matches!(file.items[k].kind, ItemKind::Mesh { .. }),
                None => false,
            });
    let placed = assign(&top, &entries);
    for (k, item) in file.items.iter().enumerate() {
        for c in &placed.leading[k] {
            let inside = c.span.start >= item.span.start;
            // A blank line before a comment is kept wherever it was written between
            // statements (also between two leading comments), never for a comment moved out
            // of an expression: its blank line belonged to the inside of the statement.
            if !out.is_empty() && c.blank_line_before && !inside && !out.ends_with("\n\n") {
                out.push('\n');
            }
            out.push_str(&c.text);
            out.push('\n');
        }
        if !out.is_empty() && item.blank_line_before && !out.ends_with("\n\n") {
            out.push('\n');
        }
        let from = inside_mesh.partition_point(|c| c.span.start < item.span.start);
        let to = inside_mesh.partition_point(|c| c.span.start < item.span.end);
        let mine = &inside_mesh[from..to.max(from)];
        out.push_str(&item_text(item, mine));
        for c in &placed.trailing[k] {
            out.push(' ');
            out.push_str(&c.text);
        }
        out.push('\n');
    }
    for c in &placed.footer {
        if !out.is_empty() && c.blank_line_before && !out.ends_with("\n\n") {
            out.push('\n');
        }
        out.push_str(&c.text);
        out.push('\n');
    }
    out
}

/// The entry (in source order, not overlapping) whose span contains `span`'s start.
fn containing(entries: &[Span], span: Span) -> Option<usize> {
    let k = entries
        .partition_point(|e| e.start <= span.start)
        .checked_sub(1)?;
    (span.start < entries[k].end).then_some(k)
}

struct Placed<'c> {
    leading: Vec<Vec<&'c Comment>>,
    trailing: Vec<Vec<&'c Comment>>,
    footer: Vec<&'c Comment>,
}

/// Attaches each comment to an entry: inside an entry → before it; after an entry on the same
/// line → at the end of its line; otherwise before the next entry, or in the footer.
fn assign<'c>(comments: &[&'c Comment], entries: &[Span]) -> Placed<'c> {
    let mut placed = Placed {
        leading: vec![Vec::new(); entries.len()],
        trailing: vec![Vec::new(); entries.len()],
        footer: Vec::new(),
    };
    for &c in comments {
        if let Some(k) = containing(entries, c.span) {
            placed.leading[k].push(c);
            continue;
        }
        // Entries are in source order and do not overlap.
        let after = entries.partition_point(|e| e.start < c.span.start);
        let prev = after.checked_sub(1);
        let next = (after < entries.len()).then_some(after);
        match (prev, next) {
            (Some(p), _) if !c.own_line => placed.trailing[p].push(c),
            (_, Some(n)) => placed.leading[n].push(c),
            _ => placed.footer.push(c),
        }
    }
    placed
}

fn item_text(item: &Item, comments: &[&Comment]) -> String {
    match &item.kind {
        ItemKind::Import { path } => format!("import \"{}\";", path.name),
        ItemKind::Const { name, value } => definition(&format!("const {} = ", name.name), value),
        ItemKind::Surface { name, body } => definition(&format!("surface {} = ", name.name), body),
        ItemKind::Curve { name, value } => format!("curve {} = {};", name.name, expr(value)),
        ItemKind::Fn { name, params, body } => {
            let ps: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
            definition(&format!("fn {}({}) = ", name.name, ps.join(", ")), body)
        }
        ItemKind::Patch { name, params, body } => {
            let ps: Vec<String> = params
                .iter()
                .map(|p| format!("{}: {}..{}", p.name.name, expr(&p.lo), expr(&p.hi)))
                .collect();
            format!("patch {}({}) = {};", name.name, ps.join(", "), expr(body))
        }
        ItemKind::Mesh {
            name,
            surface,
            options,
            close,
        } => {
            // Entry 0 is the header (up to the surface expression), then the options.
            let mut entries = vec![Span::new(
                item.span.start as usize,
                surface.span.end as usize,
            )];
            entries.extend(options.iter().map(|o| o.span));
            let inner: Vec<&Comment> = comments
                .iter()
                .copied()
                .filter(|c| c.span.start < close.start)
                .collect();
            let placed = assign(&inner, &entries);
            let mut s = String::new();
            for c in &placed.leading[0] {
                s.push_str(&c.text);
                s.push('\n');
            }
            s.push_str(&format!("mesh {} = {} {{", name.name, expr(surface)));
            for c in &placed.trailing[0] {
                s.push(' ');
                s.push_str(&c.text);
            }
            s.push('\n');
            for (k, o) in options.iter().enumerate() {
                for c in &placed.leading[k + 1] {
                    s.push_str("    ");
                    s.push_str(&c.text);
                    s.push('\n');
                }
                let values: Vec<String> = o
                    .values
                    .iter()
                    .map(|v| match v {
                        OptionValue::Expr(e) => expr(e),
                        OptionValue::Range(a, b, _) => format!("{} .. {}", expr(a), expr(b)),
                    })
                    .collect();
                s.push_str(&format!("    {}: {};", o.name.name, values.join(", ")));
                for c in &placed.trailing[k + 1] {
                    s.push(' ');
                    s.push_str(&c.text);
                }
                s.push('\n');
            }
            for c in &placed.footer {
                s.push_str("    ");
                s.push_str(&c.text);
                s.push('\n');
            }
            s.push('}');
            s
        }
    }
}

/// Lines longer than this are broken before the top-level `+` and `-` of a definition's
/// body, one term per line (terms themselves are not broken).
const MAX_LINE: usize = 100;

/// `head` followed by the body and `;`, broken into terms if the line would be too long.
fn definition(head: &str, body: &Expr) -> String {
    let one_line = format!("{head}{};", expr(body));
    if one_line.len() <= MAX_LINE {
        return one_line;
    }
    // The left spine of the sum: ((t0 ± t1) ± t2) …
    let mut terms = Vec::new();
    let mut e = body;
    while let ExprKind::Binary(op @ (BinOp::Add | BinOp::Sub), l, r) = &e.kind {
        terms.push((*op, r.as_ref()));
        e = l;
    }
    if terms.is_empty() {
        return one_line;
    }
    let mut s = String::from(head);
    write_expr(&mut s, e, SUM);
    for (op, term) in terms.iter().rev() {
        s.push_str("\n    ");
        s.push_str(op.symbol());
        s.push(' ');
        write_expr(&mut s, term, PRODUCT);
    }
    s.push(';');
    s
}

/// Binding strength: what an operand position requires of the expression put there.
const SUM: u8 = 1;
const PRODUCT: u8 = 2;
const UNARY: u8 = 3;
const POWER: u8 = 4;
const ATOM: u8 = 5;

fn precedence(e: &Expr) -> u8 {
    match &e.kind {
        ExprKind::Binary(BinOp::Add | BinOp::Sub, ..) => SUM,
        ExprKind::Binary(BinOp::Mul | BinOp::Div, ..) => PRODUCT,
        ExprKind::Neg(_) => UNARY,
        ExprKind::Binary(BinOp::Pow, ..) => POWER,
        _ => ATOM,
    }
}

/// Formats an expression (the depth of the tree is bounded by the parser).
pub fn expr(e: &Expr) -> String {
    let mut s = String::new();
    write_expr(&mut s, e, 0);
    s
}

fn write_expr(s: &mut String, e: &Expr, need: u8) {
    let paren = precedence(e) < need;
    if paren {
        s.push('(');
    }
    match &e.kind {
        ExprKind::Number { text, .. } => s.push_str(text),
        ExprKind::Name(n) => s.push_str(n),
        ExprKind::Neg(inner) => {
            s.push('-');
            write_expr(s, inner, UNARY);
        }
        ExprKind::Binary(op, l, r) => {
            let (left_need, right_need) = match op {
                BinOp::Add | BinOp::Sub => (SUM, PRODUCT),
                BinOp::Mul | BinOp::Div => (PRODUCT, UNARY),
                BinOp::Pow => (ATOM, UNARY),
            };
            write_expr(s, l, left_need);
            if *op == BinOp::Pow {
                s.push('^');
            } else {
                s.push(' ');
                s.push_str(op.symbol());
                s.push(' ');
            }
            write_expr(s, r, right_need);
        }
        ExprKind::Call { callee, args } => {
            s.push_str(&callee.name);
            s.push('(');
            for (k, a) in args.iter().enumerate() {
                if k > 0 {
                    s.push_str(", ");
                }
                if let Some(n) = &a.name {
                    s.push_str(&n.name);
                    s.push_str(": ");
                }
                write_expr(s, &a.value, 0);
            }
            s.push(')');
        }
        ExprKind::Tuple(parts) => {
            s.push('(');
            for (k, p) in parts.iter().enumerate() {
                if k > 0 {
                    s.push_str(", ");
                }
                write_expr(s, p, 0);
            }
            s.push(')');
        }
    }
    if paren {
        s.push(')');
    }
}
