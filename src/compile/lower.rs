//! Lowering: the checked `Program`'s expression of one surface (or a patch's three
//! coordinates) → nodes of the hash-consed [`Graph`]. Constants become numbers, `fn` calls are
//! inlined (memoised on the function and its argument nodes, so nested repeated calls cost one
//! body each), a named surface is replaced by its body (lowered once per point it is evaluated
//! at), each distinct `dist` target becomes one `Dist` node, and `At` (a transform) lowers its
//! expression with x, y, z bound to the nodes of the transformed point.

use std::collections::HashMap;

use super::CompileError;
use super::ir::{DistId, Graph, NodeId};
use super::tape::Op;
use crate::sema::program::{
    Axis, BinaryOp, Builtin, Expr, ExprKind, FnId, Program, SurfaceId, SurfaceRef, UnaryOp,
};
use crate::span::Span;

/// How deep expressions and inlined calls may nest before lowering gives up (instead of
/// overflowing the stack).
pub const MAX_DEPTH: u32 = 1000;

/// The most IR nodes (operations, constants and inputs, each distinct one once) a surface or
/// patch may have after its functions are inlined. Inlining can grow a program exponentially
/// (`fn f1(t) = f0(f0(t)); fn f2(t) = f1(f1(t)); …`), so the size is checked as nodes are
/// made and lowering stops as soon as it passes the limit. The largest surface of the gallery
/// has a few hundred nodes; a tape of this size compiles to machine code in about a
/// second and evaluates in tens of microseconds.
pub const MAX_NODES: usize = 20_000;

/// What the expression being lowered is a function of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Domain {
    /// x, y, z: inputs 0, 1, 2.
    Space,
    /// A patch's u, v: inputs 0, 1 (its `Param(0)`, `Param(1)`).
    Patch,
}

/// A memoised call: the function, its argument nodes, and the x, y, z it sees (`None`: the
/// inputs).
type CallKey = (FnId, Vec<NodeId>, Option<[NodeId; 3]>);

/// The lowering of expressions of one program into one graph.
pub struct Lowerer<'p> {
    program: &'p Program,
    domain: Domain,
    pub graph: Graph,
    /// Memoised calls: the function, its argument nodes and the point it is evaluated at.
    calls: HashMap<CallKey, NodeId>,
    surfaces: HashMap<(SurfaceId, Option<[NodeId; 3]>), NodeId>,
    /// The nodes x, y, z stand for inside an `At` (a transform); `None`: the inputs.
    coords: Option<[NodeId; 3]>,
    /// Functions and surfaces being lowered (a cycle check; sema forbids cycles, but a
    /// hand-built program must not overflow the stack).
    active_fns: Vec<FnId>,
    /// Where each of `active_fns` was called (the first is the outermost call).
    call_spans: Vec<Span>,
    active_surfaces: Vec<SurfaceId>,
    /// The targets of `dist`, each once, in order of first appearance, with where.
    pub dists: Vec<(SurfaceRef, Span)>,
    /// The nodes that are a smooth boolean's smooth minimum (`sema::solids::is_smooth_min`),
    /// with their operands a, b and radius r: the spine lifts the `min`/`max` inside them
    /// (`compile::spine`).
    pub smooth_mins: HashMap<NodeId, [NodeId; 3]>,
    depth: u32,
}

impl<'p> Lowerer<'p> {
    pub fn new(program: &'p Program, domain: Domain) -> Lowerer<'p> {
        Lowerer {
            program,
            domain,
            graph: Graph::new(),
            calls: HashMap::new(),
            surfaces: HashMap::new(),
            coords: None,
            active_fns: Vec::new(),
            call_spans: Vec::new(),
            active_surfaces: Vec::new(),
            dists: Vec::new(),
            smooth_mins: HashMap::new(),
            depth: 0,
        }
    }

    /// The body of surface `id`, lowered once.
    pub fn surface(&mut self, id: SurfaceId, span: Span) -> Result<NodeId, CompileError> {
        if let Some(&n) = self.surfaces.get(&(id, self.coords)) {
            return Ok(n);
        }
        let def = self
            .program
            .surfaces
            .get(id.index())
            .ok_or(CompileError::NoSuchSurface { id, span })?;
        if self.domain == Domain::Patch {
            return Err(CompileError::CoordinatesInPatch { span });
        }
        if self.active_surfaces.contains(&id) {
            return Err(CompileError::Cycle {
                name: def.name.clone(),
                span,
            });
        }
        self.active_surfaces.push(id);
        let n = self.expr(&def.body, &[]);
        self.active_surfaces.pop();
        let n = n?;
        self.surfaces.insert((id, self.coords), n);
        Ok(n)
    }

    /// The operands of U when `dist_part − d` is `offset(U, d)` of a union U (`min` of two or
    /// more operands, named surfaces read through) by a number d > 0; None otherwise.
    ///
    /// The outward offset of a union is the union of its operands' offsets, exactly: outside
    /// U the distance to U is the least of the distances to its operands, and inside U both
    /// are negative. Lowered so, the concave edges where operands meet — creases of the
    /// offset surface that `dist` of the whole would hide inside one smooth branch — are
    /// `min` switches the crease search traces (docs/creases.md); each operand's own edges
    /// are rounded by its `dist` as before.
    fn offset_of_union(&self, dist_part: &Expr, d: &Expr, params: &[NodeId]) -> Option<Vec<Expr>> {
        let (ExprKind::Dist(target), ExprKind::Number(d)) = (&dist_part.kind, &d.kind) else {
            return None;
        };
        // Inside a function's body the operands may read its parameters, which a `dist`
        // target of its own cannot: left as it is.
        if d.is_nan() || *d <= 0.0 || !params.is_empty() || self.coords.is_some() {
            return None;
        }
        let body = match target {
            SurfaceRef::Surface(id) => &self.program.surfaces.get(id.index())?.body,
            SurfaceRef::Anonymous(e) => e,
            SurfaceRef::Patch(_) => return None,
        };
        let mut parts = Vec::new();
        self.union_operands(body, &mut parts, 0);
        (parts.len() >= 2).then_some(parts)
    }

    /// The operands of the `min`s at the top of `e` (through named surfaces), in order.
    fn union_operands(&self, e: &Expr, out: &mut Vec<Expr>, depth: u32) {
        match &e.kind {
            ExprKind::Builtin(Builtin::Min, args) if args.len() == 2 && depth < MAX_DEPTH => {
                for arg in args {
                    self.union_operands(arg, out, depth + 1);
                }
            }
            ExprKind::Surface(id)
                if depth < MAX_DEPTH
                    && !self.active_surfaces.contains(id)
                    && self.program.surfaces.get(id.index()).is_some_and(|def| {
                        matches!(def.body.kind, ExprKind::Builtin(Builtin::Min, _))
                    }) =>
            {
                self.union_operands(&self.program.surfaces[id.index()].body, out, depth + 1);
            }
            _ => out.push(e.clone()),
        }
    }

    /// min over `parts` of `dist(part) − d`: the offset of their union (`offset_of_union`).
    fn union_of_offsets(
        &mut self,
        parts: Vec<Expr>,
        d: &Expr,
        span: Span,
        params: &[NodeId],
    ) -> Result<NodeId, CompileError> {
        let d = self.expr(d, params)?;
        let mut union = None;
        for part in parts {
            let target = match part.kind {
                ExprKind::Surface(id) => SurfaceRef::Surface(id),
                _ => SurfaceRef::Anonymous(Box::new(part)),
            };
            let dist = Expr {
                kind: ExprKind::Dist(target),
                span,
            };
            let dist = self.expr(&dist, params)?;
            let offset = self.graph.binary(Op::Sub, dist, d);
            union = Some(match union {
                None => offset,
                Some(u) => self.graph.binary(Op::Min, u, offset),
            });
        }
        union.ok_or(CompileError::TooDeep { span })
    }

    /// An expression whose `Param(i)` are `params[i]`.
    pub fn expr(&mut self, e: &Expr, params: &[NodeId]) -> Result<NodeId, CompileError> {
        if self.depth >= MAX_DEPTH {
            return Err(CompileError::TooDeep { span: e.span });
        }
        if self.graph.nodes().len() > MAX_NODES {
            return Err(self.too_large(e.span));
        }
        self.depth += 1;
        let n = self.expr_inner(e, params);
        self.depth -= 1;
        n
    }

    fn expr_inner(&mut self, e: &Expr, params: &[NodeId]) -> Result<NodeId, CompileError> {
        let span = e.span;
        Ok(match &e.kind {
            ExprKind::Number(c) => self.graph.constant(*c),
            ExprKind::Coord(axis) => {
                if self.domain == Domain::Patch {
                    return Err(CompileError::CoordinatesInPatch { span });
                }
                let k = match axis {
                    Axis::X => 0,
                    Axis::Y => 1,
                    Axis::Z => 2,
                };
                match self.coords {
                    Some(c) => c[k],
                    None => self.graph.input(k as u8),
                }
            }
            ExprKind::Param(i) => *params
                .get(*i as usize)
                .ok_or(CompileError::UnboundParam { index: *i, span })?,
            ExprKind::Const(id) => {
                let c = self
                    .program
                    .constants
                    .get(id.index())
                    .ok_or(CompileError::NoSuchConst { id: *id, span })?;
                self.graph.constant(c.value)
            }
            ExprKind::Unary(UnaryOp::Neg, a) => {
                let a = self.expr(a, params)?;
                self.graph.unary(Op::Neg, a)
            }
            ExprKind::Binary(BinaryOp::Sub, a, b)
                if let Some(parts) = self.offset_of_union(a, b, params) =>
            {
                return self.union_of_offsets(parts, b, a.span, params);
            }
            ExprKind::Binary(op, a, b) => {
                let a = self.expr(a, params)?;
                let b = self.expr(b, params)?;
                let op = match op {
                    BinaryOp::Add => Op::Add,
                    BinaryOp::Sub => Op::Sub,
                    BinaryOp::Mul => Op::Mul,
                    BinaryOp::Div => Op::Div,
                    BinaryOp::Pow => Op::Pow,
                };
                self.graph.binary(op, a, b)
            }
            ExprKind::Builtin(builtin, args) => {
                let mut nodes = Vec::with_capacity(args.len());
                for arg in args {
                    nodes.push(self.expr(arg, params)?);
                }
                let op = builtin_op(*builtin);
                match (builtin.arity(), &nodes[..]) {
                    (1, &[a]) => self.graph.unary(op, a),
                    (2, &[a, b]) => self.graph.binary(op, a, b),
                    _ => {
                        return Err(CompileError::Arity {
                            name: builtin.name().to_string(),
                            expected: builtin.arity(),
                            found: args.len(),
                            span,
                        });
                    }
                }
            }
            ExprKind::Call(id, args) => {
                let def = self
                    .program
                    .functions
                    .get(id.index())
                    .ok_or(CompileError::NoSuchFn { id: *id, span })?;
                if args.len() != def.params.len() {
                    return Err(CompileError::Arity {
                        name: def.name.clone(),
                        expected: def.params.len(),
                        found: args.len(),
                        span,
                    });
                }
                let mut nodes = Vec::with_capacity(args.len());
                for arg in args {
                    nodes.push(self.expr(arg, params)?);
                }
                let key = (*id, nodes, self.coords);
                if let Some(&n) = self.calls.get(&key) {
                    return Ok(n);
                }
                if self.active_fns.contains(id) {
                    return Err(CompileError::Cycle {
                        name: def.name.clone(),
                        span,
                    });
                }
                self.active_fns.push(*id);
                self.call_spans.push(span);
                let n = self.expr(&def.body, &key.1);
                self.active_fns.pop();
                self.call_spans.pop();
                let n = n?;
                let n = match (crate::sema::solids::is_smooth_min(def), &key.1[..]) {
                    (true, &[a, b, r]) => {
                        self.smooth_mins.insert(n, [a, b, r]);
                        // Faces the two operands share stay flat (`compile::flush`).
                        super::flush::clip_flush(&mut self.graph, n, a, b)
                    }
                    _ => n,
                };
                self.calls.insert(key, n);
                n
            }
            ExprKind::Surface(id) => self.surface(*id, span)?,
            ExprKind::Dist(target) => {
                if self.domain == Domain::Patch {
                    return Err(CompileError::CoordinatesInPatch { span });
                }
                if self.coords.is_some() {
                    return Err(CompileError::DistInTransform { span });
                }
                let k = match self.dists.iter().position(|(t, _)| t == target) {
                    Some(k) => k,
                    None => {
                        self.dists.push((target.clone(), span));
                        self.dists.len() - 1
                    }
                };
                self.graph.dist(DistId(k as u32))
            }
            ExprKind::At(inner, point) => {
                if self.domain == Domain::Patch {
                    return Err(CompileError::CoordinatesInPatch { span });
                }
                let mut at = [NodeId(0); 3];
                for (k, p) in point.iter().enumerate() {
                    at[k] = self.expr(p, params)?;
                }
                let outer = self.coords.replace(at);
                let n = self.expr(inner, params);
                self.coords = outer;
                n?
            }
        })
    }
}

impl Lowerer<'_> {
    /// The error for a graph past `MAX_NODES`: the chain of functions being inlined (outermost
    /// first) and the outermost call, which is where the user can change something.
    fn too_large(&self, at: Span) -> CompileError {
        let chain = self
            .active_fns
            .iter()
            .map(|f| {
                self.program
                    .functions
                    .get(f.index())
                    .map_or_else(|| format!("#{}", f.0), |d| d.name.clone())
            })
            .collect();
        CompileError::TooLarge {
            nodes: self.graph.nodes().len(),
            limit: MAX_NODES,
            chain,
            span: self.call_spans.first().copied().unwrap_or(at),
        }
    }
}

fn builtin_op(b: Builtin) -> Op {
    match b {
        Builtin::Sqrt => Op::Sqrt,
        Builtin::Abs => Op::Abs,
        Builtin::Exp => Op::Exp,
        Builtin::Ln => Op::Ln,
        Builtin::Sin => Op::Sin,
        Builtin::Cos => Op::Cos,
        Builtin::Tan => Op::Tan,
        Builtin::Asin => Op::Asin,
        Builtin::Acos => Op::Acos,
        Builtin::Atan => Op::Atan,
        Builtin::Atan2 => Op::Atan2,
        Builtin::Sinh => Op::Sinh,
        Builtin::Cosh => Op::Cosh,
        Builtin::Tanh => Op::Tanh,
        Builtin::Min => Op::Min,
        Builtin::Max => Op::Max,
        Builtin::Pow => Op::Pow,
        Builtin::Hypot => Op::Hypot,
    }
}
