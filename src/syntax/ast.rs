//! The owned syntax tree: what the text says, before any meaning. Every node carries its
//! span; names are still strings. Precedence is already resolved (no parenthesis nodes: the
//! formatter puts back the parentheses that precedence needs). Comments are kept beside the
//! items so that the formatter can put them back.

use crate::span::Span;

/// A parsed file: its statements in source order and its comments.
#[derive(Clone, Debug, PartialEq)]
pub struct File {
    pub items: Vec<Item>,
    /// Every comment of the file, in source order.
    pub comments: Vec<Comment>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Comment {
    /// The comment as written, with its `//` or `/* */`.
    pub text: String,
    pub span: Span,
    /// Nothing but whitespace precedes it on its line.
    pub own_line: bool,
    /// An empty line separates it from what precedes it.
    pub blank_line_before: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Ident {
    pub name: String,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Item {
    pub kind: ItemKind,
    pub span: Span,
    /// An empty line separates it from the previous statement or comment (kept by `fmt`).
    pub blank_line_before: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ItemKind {
    /// `import "path";`: `path.name` is the path as written between the quotes, its span
    /// the string literal's.
    Import {
        path: Ident,
    },
    Const {
        name: Ident,
        value: Expr,
    },
    Fn {
        name: Ident,
        params: Vec<Ident>,
        body: Expr,
    },
    Surface {
        name: Ident,
        body: Expr,
    },
    Patch {
        name: Ident,
        params: Vec<PatchParam>,
        body: Expr,
    },
    Curve {
        name: Ident,
        value: Expr,
    },
    Mesh {
        name: Ident,
        surface: Expr,
        options: Vec<MeshOption>,
        /// The span of the closing `}` (comments before it stay inside the block).
        close: Span,
    },
}

impl ItemKind {
    pub fn name(&self) -> &Ident {
        match self {
            ItemKind::Import { path: name }
            | ItemKind::Const { name, .. }
            | ItemKind::Fn { name, .. }
            | ItemKind::Surface { name, .. }
            | ItemKind::Patch { name, .. }
            | ItemKind::Curve { name, .. }
            | ItemKind::Mesh { name, .. } => name,
        }
    }

    /// The keyword that introduces the statement.
    pub fn keyword(&self) -> &'static str {
        match self {
            ItemKind::Import { .. } => "import",
            ItemKind::Const { .. } => "const",
            ItemKind::Fn { .. } => "fn",
            ItemKind::Surface { .. } => "surface",
            ItemKind::Patch { .. } => "patch",
            ItemKind::Curve { .. } => "curve",
            ItemKind::Mesh { .. } => "mesh",
        }
    }
}

/// `u: lo..hi` in a patch's parameter list.
#[derive(Clone, Debug, PartialEq)]
pub struct PatchParam {
    pub name: Ident,
    pub lo: Expr,
    pub hi: Expr,
    pub span: Span,
}

/// `name: value, value, …;` in a mesh block; a value may be a range `a .. b`.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshOption {
    pub name: Ident,
    pub values: Vec<OptionValue>,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum OptionValue {
    Expr(Expr),
    Range(Expr, Expr, Span),
}

impl OptionValue {
    pub fn span(&self) -> Span {
        match self {
            OptionValue::Expr(e) => e.span,
            OptionValue::Range(_, _, s) => *s,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
}

impl BinOp {
    pub fn symbol(self) -> &'static str {
        match self {
            BinOp::Add => "+",
            BinOp::Sub => "-",
            BinOp::Mul => "*",
            BinOp::Div => "/",
            BinOp::Pow => "^",
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ExprKind {
    /// A literal; `text` as written (the formatter keeps it), `value` its f64 (may be inf if
    /// the literal is too large: sema reports it).
    Number {
        text: String,
        value: f64,
    },
    Name(String),
    Neg(Box<Expr>),
    Binary(BinOp, Box<Expr>, Box<Expr>),
    Call {
        callee: Ident,
        args: Vec<Arg>,
    },
    /// `(a, b, …)` with at least two components.
    Tuple(Vec<Expr>),
}

/// A call argument, positional or `name: value`.
#[derive(Clone, Debug, PartialEq)]
pub struct Arg {
    pub name: Option<Ident>,
    pub value: Expr,
}
