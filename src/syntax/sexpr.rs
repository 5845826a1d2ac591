//! A span-free S-expression dump of the AST: the readable form snapshotted by the tests and
//! compared by the formatter's round-trip test (equal dumps ⇔ equal trees, spans aside).

use std::fmt::Write;

use super::ast::*;

/// One line per statement, e.g. `(surface sphere (- (+ (^ x 2) …) 4))`.
pub fn sexpr(file: &File) -> String {
    let mut s = String::new();
    for item in &file.items {
        item_sexpr(&mut s, item);
        s.push('\n');
    }
    s
}

fn item_sexpr(s: &mut String, item: &Item) {
    match &item.kind {
        ItemKind::Import { path } => {
            let _ = write!(s, "(import {:?}", path.name);
        }
        ItemKind::Const { name, value } => {
            let _ = write!(s, "(const {} ", name.name);
            expr_sexpr(s, value);
        }
        ItemKind::Surface { name, body } => {
            let _ = write!(s, "(surface {} ", name.name);
            expr_sexpr(s, body);
        }
        ItemKind::Curve { name, value } => {
            let _ = write!(s, "(curve {} ", name.name);
            expr_sexpr(s, value);
        }
        ItemKind::Fn { name, params, body } => {
            let ps: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
            let _ = write!(s, "(fn {} ({}) ", name.name, ps.join(" "));
            expr_sexpr(s, body);
        }
        ItemKind::Patch { name, params, body } => {
            let _ = write!(s, "(patch {} (", name.name);
            for (k, p) in params.iter().enumerate() {
                if k > 0 {
                    s.push(' ');
                }
                let _ = write!(s, "({} ", p.name.name);
                expr_sexpr(s, &p.lo);
                s.push(' ');
                expr_sexpr(s, &p.hi);
                s.push(')');
            }
            s.push_str(") ");
            expr_sexpr(s, body);
        }
        ItemKind::Mesh {
            name,
            surface,
            options,
            ..
        } => {
            let _ = write!(s, "(mesh {} ", name.name);
            expr_sexpr(s, surface);
            for o in options {
                let _ = write!(s, " ({}", o.name.name);
                for v in &o.values {
                    s.push(' ');
                    match v {
                        OptionValue::Expr(e) => expr_sexpr(s, e),
                        OptionValue::Range(a, b, _) => {
                            s.push_str("(.. ");
                            expr_sexpr(s, a);
                            s.push(' ');
                            expr_sexpr(s, b);
                            s.push(')');
                        }
                    }
                }
                s.push(')');
            }
        }
    }
    s.push(')');
}

fn expr_sexpr(s: &mut String, e: &Expr) {
    match &e.kind {
        ExprKind::Number { text, .. } => s.push_str(text),
        ExprKind::Name(n) => s.push_str(n),
        ExprKind::Neg(inner) => {
            s.push_str("(neg ");
            expr_sexpr(s, inner);
            s.push(')');
        }
        ExprKind::Binary(op, l, r) => {
            let _ = write!(s, "({} ", op.symbol());
            expr_sexpr(s, l);
            s.push(' ');
            expr_sexpr(s, r);
            s.push(')');
        }
        ExprKind::Call { callee, args } => {
            let _ = write!(s, "({}", callee.name);
            for a in args {
                s.push(' ');
                if let Some(n) = &a.name {
                    let _ = write!(s, "{}: ", n.name);
                }
                expr_sexpr(s, &a.value);
            }
            s.push(')');
        }
        ExprKind::Tuple(parts) => {
            s.push_str("(tuple");
            for p in parts {
                s.push(' ');
                expr_sexpr(s, p);
            }
            s.push(')');
        }
    }
}
