//! The hash-consed IR: an SSA graph of nodes, each built at most once. Nodes are interned as
//! they are built (so common subexpressions share one node without a CSE pass), constants are
//! folded with the evaluator's own arithmetic, and a few exact algebraic identities are
//! applied (listed on [`Graph::binary`]). Ids grow in build order, so every node's operands
//! have smaller ids: the id order is a topological order.

use std::collections::HashMap;

use super::ops;
use super::tape::{Arity, Op};

/// A node of the graph.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(pub u32);

impl NodeId {
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// Index of a `dist` target in the lowering's list of surfaces to measure.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DistId(pub u32);

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Node {
    /// Input i: x, y, z (surface) or u, v (patch).
    Input(u8),
    /// A constant, by its bits (so 0.0 and −0.0 stay apart, and NaN is one node).
    Const(u64),
    Unary(Op, NodeId),
    Binary(Op, NodeId, NodeId),
    /// The distance to an external surface at the input point.
    Dist(DistId),
}

/// Largest |n| for which x^n becomes multiplications; beyond it, `pow`.
pub const MAX_UNROLLED_POWER: u32 = 1 << 16;

/// The graph under construction.
#[derive(Clone, Debug, Default)]
pub struct Graph {
    nodes: Vec<Node>,
    interned: HashMap<Node, NodeId>,
}

impl Graph {
    pub fn new() -> Graph {
        Graph::default()
    }

    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    pub fn node(&self, id: NodeId) -> Node {
        self.nodes[id.index()]
    }

    fn intern(&mut self, node: Node) -> NodeId {
        if let Some(&id) = self.interned.get(&node) {
            return id;
        }
        let id = NodeId(self.nodes.len() as u32);
        self.nodes.push(node);
        self.interned.insert(node, id);
        id
    }

    /// The constant value of a node, if it is one.
    pub fn as_const(&self, id: NodeId) -> Option<f64> {
        match self.node(id) {
            Node::Const(bits) => Some(f64::from_bits(bits)),
            _ => None,
        }
    }

    fn is_const(&self, id: NodeId, c: f64) -> bool {
        self.as_const(id) == Some(c)
    }

    pub fn input(&mut self, i: u8) -> NodeId {
        self.intern(Node::Input(i))
    }

    pub fn constant(&mut self, c: f64) -> NodeId {
        self.intern(Node::Const(c.to_bits()))
    }

    pub fn dist(&mut self, d: DistId) -> NodeId {
        self.intern(Node::Dist(d))
    }

    /// `op a`, folded if a is constant; −(−a) = a.
    pub fn unary(&mut self, op: Op, a: NodeId) -> NodeId {
        debug_assert_eq!(op.arity(), Arity::Unary);
        if let Some(c) = self.as_const(a) {
            return self.constant(ops::value(op, c, 0.0));
        }
        if let (Op::Neg, Node::Unary(Op::Neg, inner)) = (op, self.node(a)) {
            return inner;
        }
        self.intern(Node::Unary(op, a))
    }

    /// `a op b`, folded if both are constant, with these exact identities (they hold for
    /// every f64 a, infinities and NaN included, except where noted):
    /// a + 0 = a and a − 0 = a (up to the sign of a zero result: −0 + 0 = +0);
    /// 0 − a = −a (likewise up to the sign of zero); a + (−b) = a − b; a − (−b) = a + b;
    /// a·1 = a; a·(−1) = −a; a·a = square(a); a/1 = a; a/(−1) = −a; 1/a = recip(a);
    /// a^n for an integer constant n by repeated squaring (not bit-exact against `powf`: the
    /// language defines integer powers as products, docs/language.md).
    /// Not applied: a·0 = 0 and a − a = 0 (false for inf and NaN).
    /// Commutative operands are ordered by id, so a + b and b + a are one node.
    pub fn binary(&mut self, op: Op, a: NodeId, b: NodeId) -> NodeId {
        debug_assert_eq!(op.arity(), Arity::Binary);
        if op == Op::Pow {
            if let Some(n) = self.as_const(b) {
                if n.fract() == 0.0 && n.abs() <= f64::from(MAX_UNROLLED_POWER) {
                    return self.powi(a, n as i32);
                }
            }
        }
        if let (Some(x), Some(y)) = (self.as_const(a), self.as_const(b)) {
            return self.constant(ops::value(op, x, y));
        }
        match op {
            Op::Add => {
                if self.is_const(b, 0.0) {
                    return a;
                }
                if self.is_const(a, 0.0) {
                    return b;
                }
                if let Node::Unary(Op::Neg, nb) = self.node(b) {
                    return self.binary(Op::Sub, a, nb);
                }
                if let Node::Unary(Op::Neg, na) = self.node(a) {
                    return self.binary(Op::Sub, b, na);
                }
            }
            Op::Sub => {
                if self.is_const(b, 0.0) {
                    return a;
                }
                if self.is_const(a, 0.0) {
                    return self.unary(Op::Neg, b);
                }
                if let Node::Unary(Op::Neg, nb) = self.node(b) {
                    return self.binary(Op::Add, a, nb);
                }
            }
            Op::Mul => {
                for (x, y) in [(a, b), (b, a)] {
                    if self.is_const(y, 1.0) {
                        return x;
                    }
                    if self.is_const(y, -1.0) {
                        return self.unary(Op::Neg, x);
                    }
                }
                if a == b {
                    return self.unary(Op::Square, a);
                }
            }
            Op::Div => {
                if self.is_const(b, 1.0) {
                    return a;
                }
                if self.is_const(b, -1.0) {
                    return self.unary(Op::Neg, a);
                }
                if self.is_const(a, 1.0) {
                    return self.unary(Op::Recip, b);
                }
            }
            _ => {}
        }
        let (a, b) = if op.is_commutative() && b < a {
            (b, a)
        } else {
            (a, b)
        };
        self.intern(Node::Binary(op, a, b))
    }

    /// a^n by repeated squaring; a^0 = 1 (as `powf` gives, even for NaN), a^−n = 1/a^n.
    pub fn powi(&mut self, a: NodeId, n: i32) -> NodeId {
        if n == 0 {
            return self.constant(1.0);
        }
        if n < 0 {
            let p = self.powi(a, n.unsigned_abs() as i32);
            return self.unary(Op::Recip, p);
        }
        let mut result: Option<NodeId> = None;
        let mut base = a;
        let mut n = n as u32;
        loop {
            if n & 1 == 1 {
                result = Some(match result {
                    None => base,
                    Some(r) => self.binary(Op::Mul, r, base),
                });
            }
            n >>= 1;
            if n == 0 {
                break;
            }
            base = self.unary(Op::Square, base);
        }
        result.unwrap_or(a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_subexpressions_are_one_node() {
        let mut g = Graph::new();
        let x = g.input(0);
        let y = g.input(1);
        let s1 = g.binary(Op::Add, x, y);
        let s2 = g.binary(Op::Add, y, x);
        assert_eq!(s1, s2);
        let n = g.nodes().len();
        let m1 = g.binary(Op::Mul, s1, s1);
        let m2 = g.binary(Op::Mul, s2, s2);
        assert_eq!(m1, m2);
        assert_eq!(g.node(m1), Node::Unary(Op::Square, s1));
        assert_eq!(g.nodes().len(), n + 1);
    }

    #[test]
    fn constants_fold_and_identities_apply() {
        let mut g = Graph::new();
        let x = g.input(0);
        let two = g.constant(2.0);
        let three = g.constant(3.0);
        let five = g.binary(Op::Add, two, three);
        assert_eq!(g.as_const(five), Some(5.0));
        let zero = g.constant(0.0);
        let one = g.constant(1.0);
        assert_eq!(g.binary(Op::Add, x, zero), x);
        assert_eq!(g.binary(Op::Mul, one, x), x);
        assert_eq!(g.binary(Op::Pow, x, one), x);
        let nx = g.unary(Op::Neg, x);
        assert_eq!(g.unary(Op::Neg, nx), x);
        // x·0 stays: it is NaN for infinite x.
        let x0 = g.binary(Op::Mul, x, zero);
        assert_eq!(g.node(x0), Node::Binary(Op::Mul, x, zero));
    }

    #[test]
    fn integer_powers_become_products() {
        let mut g = Graph::new();
        let x = g.input(0);
        let seven = g.constant(7.0);
        let p = g.binary(Op::Pow, x, seven);
        // x^7 = x · x² · x⁴: two squarings and two products.
        let x2 = g.unary(Op::Square, x);
        let x4 = g.unary(Op::Square, x2);
        let x3 = g.binary(Op::Mul, x, x2);
        assert_eq!(g.node(p), Node::Binary(Op::Mul, x3, x4));
        let m2 = g.constant(-2.0);
        let q = g.binary(Op::Pow, x, m2);
        assert_eq!(g.node(q), Node::Unary(Op::Recip, x2));
        let zero = g.constant(0.0);
        let r = g.binary(Op::Pow, x, zero);
        assert_eq!(g.as_const(r), Some(1.0));
    }
}
