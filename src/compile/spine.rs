//! Finds the spine of a surface in its IR (`survey::spine`): the `min`, `max` and `abs` nodes
//! reachable from the root through negation, sums and differences, products and quotients by
//! a constant, and `min`/`max`/`abs` themselves. The maximal subexpressions without such a
//! node are the branches, each lowered to a tape of its own. A `min` inside a product (the
//! smooth booleans) is not on the spine: it switches between terms that agree to first order,
//! so it makes no crease.

use std::collections::HashMap;

use super::ir::{Graph, Node, NodeId};
use super::tape::Op;
use crate::survey::spine::{Spine, Term};

/// A spine and the IR node of each of its branches.
pub struct Found {
    pub spine: Spine,
    pub branches: Vec<NodeId>,
}

/// The spine of the surface rooted at `root`, or None when no switch is on it.
pub fn find(graph: &Graph, root: NodeId) -> Option<Found> {
    let mut finder = Finder {
        graph,
        switches: HashMap::new(),
        terms: Vec::new(),
        term_of: HashMap::new(),
        branches: Vec::new(),
    };
    if !finder.has_switch(root) {
        return None;
    }
    finder.term(root);
    let branches = finder.branches.len();
    let spine = Spine::new(finder.terms, branches).ok()?;
    Some(Found {
        spine,
        branches: finder.branches,
    })
}

struct Finder<'g> {
    graph: &'g Graph,
    switches: HashMap<NodeId, bool>,
    terms: Vec<Term>,
    term_of: HashMap<NodeId, usize>,
    branches: Vec<NodeId>,
}

impl Finder<'_> {
    /// The operand scaled by a constant in `a·c`, `c·a` or `a/c`, with the factor.
    fn scaled(&self, n: NodeId) -> Option<(NodeId, f64)> {
        match self.graph.node(n) {
            Node::Binary(Op::Mul, a, b) => match (self.graph.as_const(a), self.graph.as_const(b)) {
                (_, Some(c)) => Some((a, c)),
                (Some(c), _) => Some((b, c)),
                _ => None,
            },
            Node::Binary(Op::Div, a, b) => self.graph.as_const(b).map(|c| (a, 1.0 / c)),
            _ => None,
        }
    }

    /// Whether a min, max or abs is reachable from n through spine operations.
    fn has_switch(&mut self, n: NodeId) -> bool {
        if let Some(&s) = self.switches.get(&n) {
            return s;
        }
        let s = match self.graph.node(n) {
            Node::Unary(Op::Abs, _) | Node::Binary(Op::Min | Op::Max, _, _) => true,
            Node::Unary(Op::Neg, a) => self.has_switch(a),
            Node::Binary(Op::Add | Op::Sub, a, b) => self.has_switch(a) || self.has_switch(b),
            _ => match self.scaled(n) {
                Some((a, c)) if c.is_finite() => self.has_switch(a),
                _ => false,
            },
        };
        self.switches.insert(n, s);
        s
    }

    fn push(&mut self, n: NodeId, t: Term) -> usize {
        let i = self.terms.len();
        self.terms.push(t);
        self.term_of.insert(n, i);
        i
    }

    /// The term of node n (built once; operands first, so the order is topological).
    fn term(&mut self, n: NodeId) -> usize {
        if let Some(&i) = self.term_of.get(&n) {
            return i;
        }
        if let Some(c) = self.graph.as_const(n) {
            return self.push(n, Term::Const(c));
        }
        if !self.has_switch(n) {
            let k = self.branches.len();
            self.branches.push(n);
            return self.push(n, Term::Branch(k));
        }
        let t = match self.graph.node(n) {
            Node::Unary(Op::Abs, a) => Term::Abs(self.term(a)),
            Node::Unary(Op::Neg, a) => Term::Neg(self.term(a)),
            Node::Binary(op @ (Op::Min | Op::Max | Op::Add | Op::Sub), a, b) => {
                let (a, b) = (self.term(a), self.term(b));
                match op {
                    Op::Min => Term::Min(a, b),
                    Op::Max => Term::Max(a, b),
                    Op::Add => Term::Add(a, b),
                    _ => Term::Sub(a, b),
                }
            }
            _ => {
                // has_switch holds, so n is a constant multiple of a spine node.
                let (a, c) = self.scaled(n).unwrap_or((n, 1.0));
                Term::Scale(c, self.term(a))
            }
        };
        self.push(n, t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spine_stops_at_smooth_subexpressions() {
        let mut g = Graph::new();
        let x = g.input(0);
        let y = g.input(1);
        let x2 = g.unary(Op::Square, x);
        let y2 = g.unary(Op::Square, y);
        let s = g.binary(Op::Add, x2, y2);
        let ny = g.unary(Op::Neg, y);
        let m = g.binary(Op::Max, s, ny);
        let two = g.constant(2.0);
        let root = g.binary(Op::Mul, m, two);
        let found = find(&g, root).unwrap();
        assert_eq!(found.branches, vec![s, ny]);
        assert_eq!(found.spine.branch_count(), 2);
    }

    #[test]
    fn a_min_inside_a_product_is_no_spine() {
        let mut g = Graph::new();
        let x = g.input(0);
        let y = g.input(1);
        let m = g.binary(Op::Min, x, y);
        let root = g.binary(Op::Mul, m, x);
        assert!(find(&g, root).is_none());
    }
}
