//! The checked program: what `sema` hands to the compiler and to the mesher. Names are
//! resolved to typed ids; constants are evaluated; `offset`, `product` and `blend` are already
//! rewritten into arithmetic over `Dist` nodes (docs/language.md), and the solids (booleans,
//! primitives) into arithmetic and `min`/`max`, so the only non-arithmetic nodes left are
//! `Dist` and `At` (an expression evaluated at a transformed point). Functions stay separate definitions: the compiler inlines them into
//! a hash-consed IR, which keeps repeated calls shared.

use glam::DVec3;

use crate::span::Span;

macro_rules! id_type {
    ($($(#[$m:meta])* $name:ident),* $(,)?) => {$(
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub struct $name(pub u32);
        impl $name {
            pub fn index(self) -> usize {
                self.0 as usize
            }
        }
    )*};
}

id_type!(
    /// Index into `Program::constants`.
    ConstId,
    /// Index into `Program::functions`.
    FnId,
    /// Index into `Program::surfaces`.
    SurfaceId,
    /// Index into `Program::patches`.
    PatchId,
    /// Index into `Program::curves`.
    CurveId,
);

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Program {
    pub constants: Vec<ConstDef>,
    pub functions: Vec<FnDef>,
    pub surfaces: Vec<SurfaceDef>,
    pub patches: Vec<PatchDef>,
    pub curves: Vec<CurveDef>,
    pub meshes: Vec<MeshDef>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct ConstDef {
    pub name: String,
    pub span: Span,
    /// The evaluated, finite value.
    pub value: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct FnDef {
    pub name: String,
    pub span: Span,
    pub params: Vec<String>,
    /// May use `Param(i)` for its i-th parameter, constants, other functions, and — if
    /// `uses_coordinates` — `Coord`.
    pub body: Expr,
    pub uses_coordinates: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceDef {
    pub name: String,
    pub span: Span,
    /// f(x, y, z); the surface is f = 0.
    pub body: Expr,
}

#[derive(Clone, Debug, PartialEq)]
pub struct PatchDef {
    pub name: String,
    pub span: Span,
    /// Names of the two parameters as written (`u`, `v` in the examples).
    pub params: [String; 2],
    /// Declared domain of the first and second parameter, lo < hi.
    pub u_range: (f64, f64),
    pub v_range: (f64, f64),
    /// X, Y, Z as expressions of `Param(0)` and `Param(1)` (no coordinates).
    pub body: [Expr; 3],
}

#[derive(Clone, Debug, PartialEq)]
pub struct CurveDef {
    pub name: String,
    pub span: Span,
    pub kind: CurveKind,
}

#[derive(Clone, Debug, PartialEq)]
pub enum CurveKind {
    /// The intersection curve of two surfaces, traced from the point nearest `near`.
    Intersection {
        first: SurfaceRef,
        second: SurfaceRef,
        near: DVec3,
    },
    /// A circle; `segments` (the `segments:` argument) fixes the number of polygon edges,
    /// else the polygon is sampled at the step of the mesh that uses it.
    Circle {
        center: DVec3,
        normal: DVec3,
        radius: f64,
        segments: Option<u32>,
    },
    /// The image of a patch's parameter-domain boundary.
    Boundary(PatchId),
    /// A curve walked the other way.
    Reverse(CurveId),
}

#[derive(Clone, Debug, PartialEq)]
pub struct MeshDef {
    pub name: String,
    pub span: Span,
    /// The surface to mesh.
    pub surface: SurfaceRef,
    /// Step length δ > 0.
    pub step: f64,
    pub start: Option<DVec3>,
    /// Global bounding box, lo < hi componentwise.
    pub bbox: Option<(DVec3, DVec3)>,
    /// The first front polygon, instead of the start hexagon.
    pub front: Option<CurveId>,
    /// Bounding front polygons.
    pub bounds: Vec<CurveId>,
    /// Guard against runaway meshes; `None` means the mesher's default.
    pub max_triangles: Option<u64>,
    /// The largest chord error (model units) > 0; `None` means the mesher's default.
    pub tolerance: Option<f64>,
    /// `uniform: true`: the paper's fixed step, no local step.
    pub uniform: bool,
    /// The mean radius ratio the quality stage raises the mesh to, in (0, 1]; `None` means
    /// the mesher's default.
    pub radius_ratio: Option<f64>,
}

/// Where a surface is expected: a named surface, a patch (only inside `dist`), or an
/// expression standing for an anonymous implicit surface.
#[derive(Clone, Debug, PartialEq)]
pub enum SurfaceRef {
    Surface(SurfaceId),
    Patch(PatchId),
    Anonymous(Box<Expr>),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Axis {
    X,
    Y,
    Z,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum UnaryOp {
    Neg,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BinaryOp {
    Add,
    Sub,
    Mul,
    Div,
    /// `^`; the compiler lowers integer exponents to multiplications.
    Pow,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Builtin {
    Sqrt,
    Abs,
    Exp,
    Ln,
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Atan2,
    Sinh,
    Cosh,
    Tanh,
    Min,
    Max,
    Pow,
    Hypot,
}

impl Builtin {
    pub const ALL: [Builtin; 18] = [
        Builtin::Sqrt,
        Builtin::Abs,
        Builtin::Exp,
        Builtin::Ln,
        Builtin::Sin,
        Builtin::Cos,
        Builtin::Tan,
        Builtin::Asin,
        Builtin::Acos,
        Builtin::Atan,
        Builtin::Atan2,
        Builtin::Sinh,
        Builtin::Cosh,
        Builtin::Tanh,
        Builtin::Min,
        Builtin::Max,
        Builtin::Pow,
        Builtin::Hypot,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Builtin::Sqrt => "sqrt",
            Builtin::Abs => "abs",
            Builtin::Exp => "exp",
            Builtin::Ln => "ln",
            Builtin::Sin => "sin",
            Builtin::Cos => "cos",
            Builtin::Tan => "tan",
            Builtin::Asin => "asin",
            Builtin::Acos => "acos",
            Builtin::Atan => "atan",
            Builtin::Atan2 => "atan2",
            Builtin::Sinh => "sinh",
            Builtin::Cosh => "cosh",
            Builtin::Tanh => "tanh",
            Builtin::Min => "min",
            Builtin::Max => "max",
            Builtin::Pow => "pow",
            Builtin::Hypot => "hypot",
        }
    }

    pub fn arity(self) -> usize {
        match self {
            Builtin::Atan2 | Builtin::Min | Builtin::Max | Builtin::Pow | Builtin::Hypot => 2,
            _ => 1,
        }
    }

    pub fn from_name(name: &str) -> Option<Builtin> {
        Builtin::ALL.into_iter().find(|b| b.name() == name)
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ExprKind {
    Number(f64),
    Coord(Axis),
    /// The i-th parameter of the enclosing `fn`, or a patch's u (0) / v (1).
    Param(u32),
    Const(ConstId),
    Unary(UnaryOp, Box<Expr>),
    Binary(BinaryOp, Box<Expr>, Box<Expr>),
    Builtin(Builtin, Vec<Expr>),
    Call(FnId, Vec<Expr>),
    /// The value of a named surface at (x, y, z).
    Surface(SurfaceId),
    /// The oriented distance to a surface (numerical implicitization). `offset`, `product`
    /// and `blend` are rewritten by sema into arithmetic over this node.
    Dist(SurfaceRef),
    /// The first expression evaluated at the point given by the three others (expressions of
    /// the enclosing x, y, z): `translate`, `rotate` and `scale` evaluate a surface at the
    /// inverse-transformed point. Sema never puts a `Dist` inside (a `dist` child is measured
    /// at the point the mesher asks for, not at a transformed one).
    At(Box<Expr>, Box<[Expr; 3]>),
}
