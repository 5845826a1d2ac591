//! Smooth unions of solids that share face planes (docs/creases.md, *Flush faces in smooth
//! booleans*). The polynomial smooth minimum rounds wherever its operands are nearly equal,
//! so where two operands coincide on a sheet — an L of two boxes flush at its back, a boss
//! standing flush on a plate — it pushes the shared face out by r/4 over its whole extent.
//! A CAD user rounds only where the operands cross.
//!
//! Both operands of `smooth_union(A, B, r)` lie inside each half-space of their own top-level
//! `max` (a box inside each of its face planes). A face that A and B have in common (the same
//! oriented sheet, decided from the values of the two faces at sample points, not from the
//! text: a moved or turned copy rounds differently) therefore bounds A ∪ B, and clipping the
//! smooth union by it removes only the push: smooth_union′ = max(smin(A, B), F), F the `max`
//! of the common faces. The fillets where A and B cross are untouched; the result stays
//! continuous, and the common faces stay flat and exactly where they were.

use std::collections::HashMap;

use super::ir::{Graph, Node, NodeId};
use super::ops;
use super::tape::Op;

/// `smin` (the smooth minimum of a and b) clipped by the faces that a and b share.
pub fn clip_flush(graph: &mut Graph, smin: NodeId, a: NodeId, b: NodeId) -> NodeId {
    let fa = faces(graph, a);
    let fb = faces(graph, b);
    if fa.is_empty() || fb.is_empty() {
        return smin;
    }
    let mut values = Values::default();
    let mut common: Vec<NodeId> = Vec::new();
    for &x in &fa {
        if fb.iter().any(|&y| values.same_sheet(graph, x, y)) && !common.contains(&x) {
            common.push(x);
        }
    }
    let Some((&first, rest)) = common.split_first() else {
        return smin;
    };
    let clip = rest
        .iter()
        .fold(first, |acc, &f| graph.binary(Op::Max, acc, f));
    graph.binary(Op::Max, smin, clip)
}

/// The faces of a solid's top-level `max`: the operands of a chain of `max` at n, with
/// `|u| − k` read as its two faces u − k and −u − k (a cylinder's caps); n itself if it is
/// no `max`.
fn faces(graph: &mut Graph, n: NodeId) -> Vec<NodeId> {
    let mut out = Vec::new();
    let mut stack = vec![n];
    while let Some(m) = stack.pop() {
        match graph.node(m) {
            Node::Binary(Op::Max, x, y) => {
                stack.push(y);
                stack.push(x);
            }
            Node::Binary(Op::Sub, u, k) if graph.as_const(k).is_some() => match graph.node(u) {
                Node::Unary(Op::Abs, v) => {
                    let up = graph.binary(Op::Sub, v, k);
                    let neg = graph.unary(Op::Neg, v);
                    let down = graph.binary(Op::Sub, neg, k);
                    out.push(up);
                    out.push(down);
                }
                _ => out.push(m),
            },
            _ => out.push(m),
        }
    }
    out
}

/// Points at which two faces are compared: scattered, at several scales, so that no two
/// distinct faces of a part agree at all of them by chance.
const SAMPLES: [[f64; 3]; 8] = [
    [0.137, -0.291, 0.403],
    [-0.719, 0.553, -0.227],
    [1.913, 2.371, -1.117],
    [-2.651, -0.877, 3.319],
    [7.31, -5.17, 2.93],
    [-11.7, 13.9, -6.1],
    [0.0173, 0.0291, -0.0417],
    [43.1, 27.7, -61.3],
];

/// Node values at the sample points, computed once per node.
#[derive(Default)]
struct Values {
    at: HashMap<NodeId, [f64; SAMPLES.len()]>,
}

impl Values {
    /// The node's value at each sample point (NaN for a `dist`, which is not compared).
    fn of(&mut self, graph: &Graph, n: NodeId) -> [f64; SAMPLES.len()] {
        if let Some(v) = self.at.get(&n) {
            return *v;
        }
        let v: [f64; SAMPLES.len()] = match graph.node(n) {
            Node::Input(i) => std::array::from_fn(|k| SAMPLES[k][usize::from(i).min(2)]),
            Node::Const(bits) => [f64::from_bits(bits); SAMPLES.len()],
            Node::Dist(_) => [f64::NAN; SAMPLES.len()],
            Node::Unary(op, a) => {
                let a = self.of(graph, a);
                std::array::from_fn(|k| ops::value(op, a[k], 0.0))
            }
            Node::Binary(op, a, b) => {
                let (a, b) = (self.of(graph, a), self.of(graph, b));
                std::array::from_fn(|k| ops::value(op, a[k], b[k]))
            }
        };
        self.at.insert(n, v);
        v
    }

    /// Whether x and y are one oriented sheet: y = c·x for one c > 0 at every sample point
    /// (to rounding), so their zero sets and sides are one.
    fn same_sheet(&mut self, graph: &Graph, x: NodeId, y: NodeId) -> bool {
        if x == y {
            return true;
        }
        let (vx, vy) = (self.of(graph, x), self.of(graph, y));
        let Some(k) = (0..SAMPLES.len()).max_by(|&i, &j| vx[i].abs().total_cmp(&vx[j].abs()))
        else {
            return false;
        };
        let c = vy[k] / vx[k];
        if !(c.is_finite() && c > 0.0) {
            return false;
        }
        (0..SAMPLES.len()).all(|i| {
            let (a, b) = (c * vx[i], vy[i]);
            a.is_finite() && b.is_finite() && (a - b).abs() <= 1e-12 * (1.0 + a.abs() + b.abs())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// max(x − 1, −x, y − 1, −y): a unit square's faces.
    fn square(g: &mut Graph, dx: f64) -> NodeId {
        let x = g.input(0);
        let y = g.input(1);
        let d = g.constant(dx);
        let xs = g.binary(Op::Sub, x, d);
        let one = g.constant(1.0);
        let faces = [
            g.binary(Op::Sub, xs, one),
            g.unary(Op::Neg, xs),
            g.binary(Op::Sub, y, one),
            g.unary(Op::Neg, y),
        ];
        faces[1..]
            .iter()
            .fold(faces[0], |acc, &f| g.binary(Op::Max, acc, f))
    }

    #[test]
    fn shared_faces_clip_and_others_do_not() {
        let mut g = Graph::new();
        // Side by side in x (shared planes y = 0 and y = 1; x = 1 is shared with opposite
        // sides and must not clip).
        let a = square(&mut g, 0.0);
        let b = square(&mut g, 1.0);
        let smin = g.binary(Op::Min, a, b);
        let clipped = clip_flush(&mut g, smin, a, b);
        assert_ne!(clipped, smin);
        let mut v = Values::default();
        // Every sample of the clip equals max(smin, y − 1, −y).
        let y = g.input(1);
        let one = g.constant(1.0);
        let top = g.binary(Op::Sub, y, one);
        let bottom = g.unary(Op::Neg, y);
        let band = g.binary(Op::Max, top, bottom);
        let expect = g.binary(Op::Max, smin, band);
        assert_eq!(v.of(&g, clipped), v.of(&g, expect));
        // Apart in y: nothing in common, nothing clipped.
        let mut g = Graph::new();
        let a = square(&mut g, 0.0);
        let x = g.input(0);
        let y = g.input(1);
        let three = g.constant(3.0);
        let ys = g.binary(Op::Sub, y, three);
        let far = g.binary(Op::Max, x, ys);
        let smin = g.binary(Op::Min, a, far);
        assert_eq!(clip_flush(&mut g, smin, a, far), smin);
    }
}
