//! Finds the spine of a surface in its IR (`survey::spine`): the `min`, `max` and `abs` nodes
//! reachable from the root through negation, sums and differences, products and quotients by
//! a constant, and `min`/`max`/`abs` themselves. The maximal subexpressions without such a
//! node are the branches, each lowered to a tape of its own. A `min` inside a product (the
//! clamp of a smooth boolean's blend) is not on the spine: it switches between terms that
//! agree to first order, so it makes no crease.
//!
//! A smooth boolean whose operand has a sharp part (`smooth_union(box(…), sphere(…), r)`) is
//! lifted: smin is non-decreasing in each argument, so smin(max(a₁, a₂), b) =
//! max(smin(a₁, b), smin(a₂, b)) exactly (likewise for `min`, and `abs(u)` = max(u, −u)),
//! after negations, sums and constant factors are moved inside the choice. The lifted choice
//! becomes a `Select` chosen by the original node's operands (a₁ − a₂), and each smin of
//! smooth operands is a branch. A lifted spine larger than the limits is not used: the
//! surface is then read as before (its hidden edges refused by `survey::gradient_jump`).

use std::collections::HashMap;

use super::ir::{Graph, Node, NodeId};
use super::tape::Op;
use crate::survey::spine::{MAX_FORMS, Spine, Term};

/// A spine and the IR node of each of its branches.
pub struct Found {
    pub spine: Spine,
    pub branches: Vec<NodeId>,
}

/// The most terms a lifted spine may have (lifting multiplies the operands of nested smooth
/// booleans); beyond it the smooth booleans are not lifted.
const MAX_TERMS: usize = 4096;

/// The spine of the surface rooted at `root`, or None when no switch is on it. `smooth` holds
/// the smooth minima of the smooth booleans (`Lowerer::smooth_mins`): node → [a, b, r]. New
/// nodes (the lifted smooth minima, the selectors) are added to `graph`.
pub fn find(
    graph: &mut Graph,
    smooth: &HashMap<NodeId, [NodeId; 3]>,
    root: NodeId,
) -> Option<Found> {
    for lift in [true, false] {
        let mut finder = Finder {
            graph: &mut *graph,
            smooth: if lift { smooth.clone() } else { HashMap::new() },
            switches: HashMap::new(),
            terms: Vec::new(),
            term_of: HashMap::new(),
            branches: Vec::new(),
            too_large: false,
        };
        if !finder.has_switch(root) {
            if !lift {
                return None;
            }
            continue;
        }
        finder.term(root);
        let lifted = finder.terms.iter().any(|t| matches!(t, Term::Select(..)));
        let (terms, branches, too_large) = (finder.terms, finder.branches, finder.too_large);
        let Ok(spine) = Spine::new(terms, branches.len()) else {
            continue;
        };
        if lifted && (too_large || spine.forms(MAX_FORMS).is_err()) {
            continue;
        }
        return Some(Found { spine, branches });
    }
    None
}

struct Finder<'g> {
    graph: &'g mut Graph,
    /// The smooth minima (node → [a, b, r]): the lowerer's, and those lifting makes.
    smooth: HashMap<NodeId, [NodeId; 3]>,
    switches: HashMap<NodeId, bool>,
    terms: Vec<Term>,
    term_of: HashMap<NodeId, usize>,
    branches: Vec<NodeId>,
    too_large: bool,
}

/// A choice moved to the top of an expression: the operand taken where the selector term is
/// ≥ 0, the other one, and the selector.
type Split = (NodeId, NodeId, usize);

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

    /// Whether a min, max or abs is reachable from n through spine operations (and, when
    /// lifting, through the operands of a smooth minimum).
    fn has_switch(&mut self, n: NodeId) -> bool {
        if let Some(&s) = self.switches.get(&n) {
            return s;
        }
        let s = if let Some(&[a, b, _]) = self.smooth.get(&n) {
            self.has_switch(a) || self.has_switch(b)
        } else {
            match self.graph.node(n) {
                Node::Unary(Op::Abs, _) | Node::Binary(Op::Min | Op::Max, _, _) => true,
                Node::Unary(Op::Neg, a) => self.has_switch(a),
                Node::Binary(Op::Add | Op::Sub, a, b) => self.has_switch(a) || self.has_switch(b),
                _ => match self.scaled(n) {
                    Some((a, c)) if c.is_finite() => self.has_switch(a),
                    _ => false,
                },
            }
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

    fn branch(&mut self, n: NodeId) -> usize {
        let k = self.branches.len();
        self.branches.push(n);
        self.push(n, Term::Branch(k))
    }

    /// The term of node n (built once; operands first, so the order is topological).
    fn term(&mut self, n: NodeId) -> usize {
        if let Some(&i) = self.term_of.get(&n) {
            return i;
        }
        if self.terms.len() > MAX_TERMS {
            // Given up; `find` drops this spine.
            self.too_large = true;
            return self.push(n, Term::Const(0.0));
        }
        if let Some(c) = self.graph.as_const(n) {
            return self.push(n, Term::Const(c));
        }
        if !self.has_switch(n) {
            return self.branch(n);
        }
        if self.smooth.contains_key(&n) {
            return match self.split(n) {
                Some((a, b, s)) => {
                    let (a, b) = (self.term(a), self.term(b));
                    self.push(n, Term::Select(a, b, s))
                }
                // A choice that cannot be moved out (a factor 0): read as before.
                None => self.branch(n),
            };
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

    /// n (which has a switch) written as a choice at its top: the min, max or abs nearest the
    /// root, with the negations, sums, constant factors and smooth minima above it moved into
    /// both operands. The selector is the original choice's: a − b for max(a, b), b − a for
    /// min(a, b), u for abs(u) = max(u, −u). None for a factor 0 or one not finite.
    fn split(&mut self, n: NodeId) -> Option<Split> {
        if let Some(&[a, b, r]) = self.smooth.get(&n) {
            return if self.has_switch(a) {
                let (a1, a2, s) = self.split(a)?;
                Some((self.smin(a1, b, r), self.smin(a2, b, r), s))
            } else {
                let (b1, b2, s) = self.split(b)?;
                Some((self.smin(a, b1, r), self.smin(a, b2, r), s))
            };
        }
        let g = &mut *self.graph;
        match g.node(n) {
            Node::Binary(Op::Max, a, b) => {
                let d = g.binary(Op::Sub, a, b);
                Some((a, b, self.term(d)))
            }
            Node::Binary(Op::Min, a, b) => {
                let d = g.binary(Op::Sub, b, a);
                Some((a, b, self.term(d)))
            }
            Node::Unary(Op::Abs, u) => {
                let neg = g.unary(Op::Neg, u);
                Some((u, neg, self.term(u)))
            }
            Node::Unary(Op::Neg, u) => {
                let (a, b, s) = self.split(u)?;
                let g = &mut *self.graph;
                Some((g.unary(Op::Neg, a), g.unary(Op::Neg, b), s))
            }
            Node::Binary(op @ (Op::Add | Op::Sub), u, v) => {
                let (a, b, s) = if self.has_switch(u) {
                    let (a, b, s) = self.split(u)?;
                    let g = &mut *self.graph;
                    (g.binary(op, a, v), g.binary(op, b, v), s)
                } else {
                    let (a, b, s) = self.split(v)?;
                    let g = &mut *self.graph;
                    (g.binary(op, u, a), g.binary(op, u, b), s)
                };
                Some((a, b, s))
            }
            _ => {
                let (u, c) = self.scaled(n)?;
                if !(c.is_finite() && c != 0.0) {
                    return None;
                }
                let (a, b, s) = self.split(u)?;
                let g = &mut *self.graph;
                let c = g.constant(c);
                Some((g.binary(Op::Mul, a, c), g.binary(Op::Mul, b, c), s))
            }
        }
    }

    /// The smooth minimum of a and b with radius r, built as `sema::solids` writes it
    /// (h = clamp(0.5 + 0.5·(b − a)/r, 0, 1), mix(b, a, h) − r·h·(1 − h)), and known as one.
    fn smin(&mut self, a: NodeId, b: NodeId, r: NodeId) -> NodeId {
        let g = &mut *self.graph;
        let half = g.constant(0.5);
        let one = g.constant(1.0);
        let zero = g.constant(0.0);
        let ba = g.binary(Op::Sub, b, a);
        let q = g.binary(Op::Div, ba, r);
        let hq = g.binary(Op::Mul, half, q);
        let t = g.binary(Op::Add, half, hq);
        let lo = g.binary(Op::Min, t, one);
        let h = g.binary(Op::Max, lo, zero);
        let ab = g.binary(Op::Sub, a, b);
        let m = g.binary(Op::Mul, ab, h);
        let mix = g.binary(Op::Add, b, m);
        let rh = g.binary(Op::Mul, r, h);
        let oh = g.binary(Op::Sub, one, h);
        let round = g.binary(Op::Mul, rh, oh);
        let n = g.binary(Op::Sub, mix, round);
        self.smooth.insert(n, [a, b, r]);
        n
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
        let found = find(&mut g, &HashMap::new(), root).unwrap();
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
        assert!(find(&mut g, &HashMap::new(), root).is_none());
    }
}
