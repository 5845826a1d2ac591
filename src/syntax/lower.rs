//! pest pairs → owned AST, one function per rule. Expressions arrive as a flat sequence of
//! operands and operators; they are climbed by precedence here (+ − < * / < unary − < ^,
//! `^` right-associative), with a bound on the depth of the tree built, so that neither this
//! recursion nor any later walk over the tree can overflow the stack.

use pest::iterators::Pair;

use crate::diag::{Diagnostic, messages};
use crate::span::Span;

use super::Rule;
use super::ast::*;
use super::limits::MAX_EXPR_DEPTH;

pub(crate) struct Lower {
    /// Byte offset of the parsed slice in the file.
    pub offset: usize,
}

type Res<T> = Result<T, Diagnostic>;

/// An operand or operator of a flat expression.
enum Tok<'i> {
    Neg(Span),
    Op(BinOp),
    Primary(Pair<'i, Rule>),
}

impl Lower {
    fn span(&self, p: &Pair<'_, Rule>) -> Span {
        let s = p.as_span();
        Span::new(self.offset + s.start(), self.offset + s.end())
    }

    fn ident(&self, p: Pair<'_, Rule>) -> Ident {
        Ident {
            name: p.as_str().to_string(),
            span: self.span(&p),
        }
    }

    /// Lowers the pair of one statement (a child of `statement_only`).
    pub fn statement(&self, p: Pair<'_, Rule>) -> Res<Item> {
        let span = self.span(&p);
        let rule = p.as_rule();
        // Keywords and punctuation are pairs too; keep only the meaningful children.
        let mut inner = p.into_inner().filter(|c| {
            !matches!(
                c.as_rule(),
                Rule::kw_import
                    | Rule::kw_const
                    | Rule::kw_fn
                    | Rule::kw_surface
                    | Rule::kw_patch
                    | Rule::kw_curve
                    | Rule::kw_mesh
                    | Rule::eq
                    | Rule::semi
                    | Rule::comma
                    | Rule::lparen
                    | Rule::rparen
                    | Rule::lbrace
            )
        });
        let mut next = || inner.next().ok_or_else(|| messages::internal_parse(span));
        let kind = match rule {
            Rule::import_def => {
                let s = next()?;
                let quoted = self.span(&s);
                let text = s.as_str();
                ItemKind::Import {
                    path: Ident {
                        name: text[1..text.len() - 1].to_string(),
                        span: quoted,
                    },
                }
            }
            Rule::const_def => ItemKind::Const {
                name: self.ident(next()?),
                value: self.expr(next()?, 0)?.0,
            },
            Rule::surface_def => ItemKind::Surface {
                name: self.ident(next()?),
                body: self.expr(next()?, 0)?.0,
            },
            Rule::curve_def => ItemKind::Curve {
                name: self.ident(next()?),
                value: self.expr(next()?, 0)?.0,
            },
            Rule::fn_def => {
                let name = self.ident(next()?);
                let mut params = Vec::new();
                let mut body = None;
                for c in inner {
                    match c.as_rule() {
                        Rule::ident => params.push(self.ident(c)),
                        _ => body = Some(self.expr(c, 0)?.0),
                    }
                }
                ItemKind::Fn {
                    name,
                    params,
                    body: body.ok_or_else(|| messages::internal_parse(span))?,
                }
            }
            Rule::patch_def => {
                let name = self.ident(next()?);
                let mut params = Vec::new();
                let mut body = None;
                for c in inner {
                    match c.as_rule() {
                        Rule::patch_param => params.push(self.patch_param(c)?),
                        _ => body = Some(self.expr(c, 0)?.0),
                    }
                }
                ItemKind::Patch {
                    name,
                    params,
                    body: body.ok_or_else(|| messages::internal_parse(span))?,
                }
            }
            Rule::mesh_def => {
                let name = self.ident(next()?);
                let surface = self.expr(next()?, 0)?.0;
                let mut options = Vec::new();
                let mut close = span;
                for c in inner {
                    match c.as_rule() {
                        Rule::mesh_option => options.push(self.mesh_option(c)?),
                        Rule::rbrace => close = self.span(&c),
                        _ => {}
                    }
                }
                ItemKind::Mesh {
                    name,
                    surface,
                    options,
                    close,
                }
            }
            _ => return Err(messages::internal_parse(span)),
        };
        Ok(Item {
            kind,
            span,
            blank_line_before: false,
        })
    }

    fn patch_param(&self, p: Pair<'_, Rule>) -> Res<PatchParam> {
        let span = self.span(&p);
        let mut name = None;
        let mut bounds = Vec::new();
        for c in p.into_inner() {
            match c.as_rule() {
                Rule::ident => name = Some(self.ident(c)),
                Rule::expr => bounds.push(self.expr(c, 0)?.0),
                _ => {}
            }
        }
        let mut bounds = bounds.into_iter();
        match (name, bounds.next(), bounds.next()) {
            (Some(name), Some(lo), Some(hi)) => Ok(PatchParam { name, lo, hi, span }),
            _ => Err(messages::internal_parse(span)),
        }
    }

    fn mesh_option(&self, p: Pair<'_, Rule>) -> Res<MeshOption> {
        let span = self.span(&p);
        let mut name = None;
        let mut values = Vec::new();
        for c in p.into_inner() {
            match c.as_rule() {
                Rule::ident => name = Some(self.ident(c)),
                Rule::option_item => {
                    let item_span = self.span(&c);
                    let mut exprs = Vec::new();
                    for e in c.into_inner().filter(|e| e.as_rule() == Rule::expr) {
                        exprs.push(self.expr(e, 0)?.0);
                    }
                    let mut exprs = exprs.into_iter();
                    values.push(match (exprs.next(), exprs.next()) {
                        (Some(a), None) => OptionValue::Expr(a),
                        (Some(a), Some(b)) => OptionValue::Range(a, b, item_span),
                        _ => return Err(messages::internal_parse(item_span)),
                    });
                }
                _ => {}
            }
        }
        let name = name.ok_or_else(|| messages::internal_parse(span))?;
        Ok(MeshOption { name, values, span })
    }

    /// Lowers an `expr` pair. `depth` is the depth of the tree above it; returns the
    /// expression and the depth of its own tree.
    fn expr(&self, p: Pair<'_, Rule>, depth: usize) -> Res<(Expr, usize)> {
        let span = self.span(&p);
        let toks: Vec<Tok<'_>> = p
            .into_inner()
            .map(|c| match c.as_rule() {
                Rule::neg => Tok::Neg(self.span(&c)),
                Rule::add => Tok::Op(BinOp::Add),
                Rule::sub => Tok::Op(BinOp::Sub),
                Rule::mul => Tok::Op(BinOp::Mul),
                Rule::div => Tok::Op(BinOp::Div),
                Rule::pow => Tok::Op(BinOp::Pow),
                _ => Tok::Primary(c),
            })
            .collect();
        let mut climber = Climber {
            lower: self,
            toks: toks.into_iter().peekable(),
            whole: span,
        };
        climber.sum(depth)
    }

    fn primary(&self, p: Pair<'_, Rule>, depth: usize) -> Res<(Expr, usize)> {
        let span = self.span(&p);
        if depth > MAX_EXPR_DEPTH {
            return Err(super::nesting_too_deep(span));
        }
        match p.as_rule() {
            Rule::number => {
                let text = p.as_str().to_string();
                // The grammar admits only digits, one `.`, and an exponent: always parses
                // (a literal beyond f64's range becomes inf, which sema reports).
                let value = text.parse::<f64>().unwrap_or(f64::NAN);
                Ok((
                    Expr {
                        kind: ExprKind::Number { text, value },
                        span,
                    },
                    1,
                ))
            }
            Rule::ident => Ok((
                Expr {
                    kind: ExprKind::Name(p.as_str().to_string()),
                    span,
                },
                1,
            )),
            Rule::paren => {
                let mut parts = Vec::new();
                let mut d = 0;
                for c in p.into_inner().filter(|c| c.as_rule() == Rule::expr) {
                    let (e, ed) = self.expr(c, depth + 1)?;
                    d = d.max(ed);
                    parts.push(e);
                }
                if parts.len() == 1 {
                    let mut e = parts.pop().ok_or_else(|| messages::internal_parse(span))?;
                    // The parentheses belong to the expression's span: labels then cover
                    // what the user wrote.
                    e.span = span;
                    Ok((e, d))
                } else {
                    Ok((
                        Expr {
                            kind: ExprKind::Tuple(parts),
                            span,
                        },
                        d + 1,
                    ))
                }
            }
            Rule::call => {
                let mut inner = p.into_inner();
                let callee =
                    self.ident(inner.next().ok_or_else(|| messages::internal_parse(span))?);
                let mut args = Vec::new();
                let mut d = 0;
                for a in inner.filter(|c| c.as_rule() == Rule::arg) {
                    let mut name = None;
                    let mut value = None;
                    for c in a.into_inner() {
                        match c.as_rule() {
                            Rule::ident => name = Some(self.ident(c)),
                            Rule::expr => {
                                let (e, ed) = self.expr(c, depth + 1)?;
                                d = d.max(ed);
                                value = Some(e);
                            }
                            _ => {}
                        }
                    }
                    let value = value.ok_or_else(|| messages::internal_parse(span))?;
                    args.push(Arg { name, value });
                }
                Ok((
                    Expr {
                        kind: ExprKind::Call { callee, args },
                        span,
                    },
                    d + 1,
                ))
            }
            _ => Err(messages::internal_parse(span)),
        }
    }
}

struct Climber<'l, 'i> {
    lower: &'l Lower,
    toks: std::iter::Peekable<std::vec::IntoIter<Tok<'i>>>,
    whole: Span,
}

fn binary(op: BinOp, l: (Expr, usize), r: (Expr, usize)) -> Res<(Expr, usize)> {
    let depth = 1 + l.1.max(r.1);
    let span = l.0.span.join(r.0.span);
    if depth > MAX_EXPR_DEPTH {
        return Err(super::nesting_too_deep(span));
    }
    Ok((
        Expr {
            kind: ExprKind::Binary(op, Box::new(l.0), Box::new(r.0)),
            span,
        },
        depth,
    ))
}

impl Climber<'_, '_> {
    fn peek_op(&mut self) -> Option<BinOp> {
        match self.toks.peek() {
            Some(Tok::Op(op)) => Some(*op),
            _ => None,
        }
    }

    /// `a + b - c …`, left-associative, built by a loop.
    fn sum(&mut self, depth: usize) -> Res<(Expr, usize)> {
        let mut lhs = self.product(depth)?;
        while let Some(op @ (BinOp::Add | BinOp::Sub)) = self.peek_op() {
            self.toks.next();
            let rhs = self.product(depth)?;
            lhs = binary(op, lhs, rhs)?;
        }
        Ok(lhs)
    }

    fn product(&mut self, depth: usize) -> Res<(Expr, usize)> {
        let mut lhs = self.prefix(depth)?;
        while let Some(op @ (BinOp::Mul | BinOp::Div)) = self.peek_op() {
            self.toks.next();
            let rhs = self.prefix(depth)?;
            lhs = binary(op, lhs, rhs)?;
        }
        Ok(lhs)
    }

    /// Unary minus (binds looser than `^`: `-x^2` is `-(x^2)`) and the right-associative
    /// `^` chain; recursion depth bounded by `MAX_EXPR_DEPTH`.
    fn prefix(&mut self, depth: usize) -> Res<(Expr, usize)> {
        if depth > MAX_EXPR_DEPTH {
            return Err(super::nesting_too_deep(self.whole));
        }
        match self.toks.next() {
            Some(Tok::Neg(neg)) => {
                let (inner, d) = self.prefix(depth + 1)?;
                let span = neg.join(inner.span);
                Ok((
                    Expr {
                        kind: ExprKind::Neg(Box::new(inner)),
                        span,
                    },
                    d + 1,
                ))
            }
            Some(Tok::Primary(p)) => {
                let base = self.lower.primary(p, depth)?;
                if self.peek_op() == Some(BinOp::Pow) {
                    self.toks.next();
                    let exponent = self.prefix(depth + 1)?;
                    binary(BinOp::Pow, base, exponent)
                } else {
                    Ok(base)
                }
            }
            _ => Err(messages::internal_parse(self.whole)),
        }
    }
}
