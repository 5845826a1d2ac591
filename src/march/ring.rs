//! Front polygons as index-linked rings: nodes in one arena with `next`/`prev` links and the
//! front each belongs to. A point may stand in several nodes (the doubled points of a union,
//! the two ends of a split), so rings link nodes, not points. No operation shifts arrays:
//! replace, split and unite relink a constant number of nodes (plus relabelling the part that
//! changes front).

/// A mesh point (= mesh vertex index).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct PointId(pub u32);

/// A node of a front ring.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct NodeId(pub u32);

/// A front polygon.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FrontId(pub u32);

impl PointId {
    pub fn index(self) -> usize {
        self.0 as usize
    }
}
impl NodeId {
    pub fn index(self) -> usize {
        self.0 as usize
    }
}
impl FrontId {
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// All fronts' rings.
#[derive(Clone, Debug, Default)]
pub struct Rings {
    point: Vec<PointId>,
    next: Vec<NodeId>,
    prev: Vec<NodeId>,
    front: Vec<FrontId>,
    alive: Vec<bool>,
    /// Per front: one live node (any), and the number of nodes.
    head: Vec<NodeId>,
    len: Vec<usize>,
}

impl Rings {
    pub fn node_count(&self) -> usize {
        self.point.len()
    }
    pub fn point(&self, n: NodeId) -> PointId {
        self.point[n.index()]
    }
    pub fn next(&self, n: NodeId) -> NodeId {
        self.next[n.index()]
    }
    pub fn prev(&self, n: NodeId) -> NodeId {
        self.prev[n.index()]
    }
    pub fn front(&self, n: NodeId) -> FrontId {
        self.front[n.index()]
    }
    pub fn alive(&self, n: NodeId) -> bool {
        self.alive[n.index()]
    }
    pub fn len(&self, f: FrontId) -> usize {
        self.len[f.index()]
    }
    pub fn head(&self, f: FrontId) -> NodeId {
        self.head[f.index()]
    }

    fn push_node(&mut self, p: PointId, f: FrontId) -> NodeId {
        let id = NodeId(self.point.len() as u32);
        self.point.push(p);
        self.next.push(id);
        self.prev.push(id);
        self.front.push(f);
        self.alive.push(true);
        id
    }

    fn new_front(&mut self, head: NodeId, len: usize) -> FrontId {
        let f = FrontId(self.head.len() as u32);
        self.head.push(head);
        self.len.push(len);
        f
    }

    fn link(&mut self, a: NodeId, b: NodeId) {
        self.next[a.index()] = b;
        self.prev[b.index()] = a;
    }

    /// A new front whose ring walks `points` in order (at least one point).
    pub fn make_ring(&mut self, points: &[PointId]) -> (FrontId, Vec<NodeId>) {
        let f = FrontId(self.head.len() as u32);
        let nodes: Vec<NodeId> = points.iter().map(|&p| self.push_node(p, f)).collect();
        for i in 0..nodes.len() {
            self.link(nodes[i], nodes[(i + 1) % nodes.len()]);
        }
        let f2 = self.new_front(nodes[0], nodes.len());
        debug_assert_eq!(f, f2);
        (f, nodes)
    }

    /// The nodes of a front in ring order, starting at its head.
    pub fn walk(&self, f: FrontId) -> Vec<NodeId> {
        let mut out = Vec::with_capacity(self.len(f));
        let start = self.head(f);
        let mut n = start;
        for _ in 0..self.len(f) {
            out.push(n);
            n = self.next(n);
        }
        debug_assert_eq!(n, start);
        out
    }

    /// Replaces node `m` by new nodes for `points` (in ring order between prev(m) and
    /// next(m)); `m` dies. Returns the new nodes.
    pub fn replace(&mut self, m: NodeId, points: &[PointId]) -> Vec<NodeId> {
        let f = self.front(m);
        let (mut a, b) = (self.prev(m), self.next(m));
        let mut out = Vec::with_capacity(points.len());
        for &p in points {
            let n = self.push_node(p, f);
            self.link(a, n);
            a = n;
            out.push(n);
        }
        self.link(a, b);
        self.alive[m.index()] = false;
        let fi = f.index();
        self.len[fi] = self.len[fi] + points.len() - 1;
        if self.head[fi] == m {
            self.head[fi] = b;
        }
        out
    }

    /// Kills every node of front `f` and empties it.
    pub fn clear(&mut self, f: FrontId) {
        for n in self.walk(f) {
            self.alive[n.index()] = false;
        }
        self.len[f.index()] = 0;
    }

    /// True if the arc strictly between `a` and `b` (walking `next` from `a`) has no more
    /// nodes than the arc strictly between `b` and `a`. Costs O(the shorter arc).
    pub fn forward_arc_shorter(&self, a: NodeId, b: NodeId) -> bool {
        let (mut x, mut y) = (self.next(a), self.next(b));
        loop {
            if x == b {
                return true;
            }
            if y == a {
                return false;
            }
            x = self.next(x);
            y = self.next(y);
        }
    }

    /// Step 2, first case: splits the ring of `x` and `y` (same front) into the old front
    /// x → y → next(y) … prev(x) → x and a new front x' → next(x) … prev(y) → y' → x', where
    /// x', y' are new nodes of the points of x and y. Returns (new front, x', y'). Costs
    /// O(length of the new front): call it with the shorter arc between x and y.
    pub fn split(&mut self, x: NodeId, y: NodeId) -> (FrontId, NodeId, NodeId) {
        let old = self.front(x);
        debug_assert_eq!(old, self.front(y));
        let (xn, yp) = (self.next(x), self.prev(y));
        let nf = FrontId(self.head.len() as u32);
        let x2 = self.push_node(self.point(x), nf);
        let y2 = self.push_node(self.point(y), nf);
        self.link(x, y);
        self.link(x2, xn);
        self.link(yp, y2);
        self.link(y2, x2);
        let mut count = 0;
        let mut n = x2;
        loop {
            self.front[n.index()] = nf;
            count += 1;
            n = self.next(n);
            if n == x2 {
                break;
            }
        }
        let nf2 = self.new_front(x2, count);
        debug_assert_eq!(nf, nf2);
        let oi = old.index();
        self.len[oi] = self.len[oi] + 2 - count;
        self.head[oi] = x;
        (nf, x2, y2)
    }

    /// Step 2, second case: unites the front of `b` into the front of `a` (different fronts):
    /// a → b' → next(b) … prev(b) → b → a' → (old next(a)), with new nodes b' (first
    /// appearance of b's point) and a' (second appearance of a's point). The front of `b`
    /// is emptied. Returns (b', a'). Costs O(length of b's front).
    pub fn unite(&mut self, a: NodeId, b: NodeId) -> (NodeId, NodeId) {
        let (fa, fb) = (self.front(a), self.front(b));
        debug_assert_ne!(fa, fb);
        for n in self.walk(fb) {
            self.front[n.index()] = fa;
        }
        let (an, bn) = (self.next(a), self.next(b));
        let b1 = self.push_node(self.point(b), fa);
        let a2 = self.push_node(self.point(a), fa);
        self.link(a, b1);
        self.link(b1, bn);
        self.link(b, a2);
        self.link(a2, an);
        let (ai, bi) = (fa.index(), fb.index());
        self.len[ai] += self.len[bi] + 2;
        self.len[bi] = 0;
        (b1, a2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(r: &Rings, f: FrontId) -> Vec<u32> {
        r.walk(f).into_iter().map(|n| r.point(n).0).collect()
    }

    fn ids(v: &[u32]) -> Vec<PointId> {
        v.iter().map(|&i| PointId(i)).collect()
    }

    fn consistent(r: &Rings, f: FrontId) {
        for n in r.walk(f) {
            assert!(r.alive(n));
            assert_eq!(r.front(n), f);
            assert_eq!(r.prev(r.next(n)), n);
        }
    }

    #[test]
    fn replace_inserts_in_order_and_kills_the_node() {
        let mut r = Rings::default();
        let (f, nodes) = r.make_ring(&ids(&[0, 1, 2, 3]));
        let new = r.replace(nodes[0], &ids(&[7, 8]));
        assert_eq!(new.len(), 2);
        assert!(!r.alive(nodes[0]));
        assert_eq!(r.len(f), 5);
        assert_eq!(pts(&r, f), vec![1, 2, 3, 7, 8]);
        r.replace(nodes[2], &[]);
        assert_eq!(pts(&r, f), vec![1, 3, 7, 8]);
        consistent(&r, f);
    }

    #[test]
    fn split_makes_two_rings_sharing_the_chord() {
        let mut r = Rings::default();
        let (f, n) = r.make_ring(&ids(&[0, 1, 2, 3, 4, 5, 6, 7]));
        assert!(r.forward_arc_shorter(n[1], n[4]));
        assert!(!r.forward_arc_shorter(n[4], n[1]));
        let (g, x2, y2) = r.split(n[1], n[4]);
        assert_eq!(pts(&r, f), vec![1, 4, 5, 6, 7, 0]);
        assert_eq!(pts(&r, g), vec![1, 2, 3, 4]);
        assert_eq!((r.point(x2).0, r.point(y2).0), (1, 4));
        assert_eq!((r.len(f), r.len(g)), (6, 4));
        consistent(&r, f);
        consistent(&r, g);
    }

    #[test]
    fn unite_doubles_the_two_points() {
        let mut r = Rings::default();
        let (f, a) = r.make_ring(&ids(&[0, 1, 2, 3]));
        let (g, b) = r.make_ring(&ids(&[10, 11, 12]));
        let (b1, a2) = r.unite(a[1], b[1]);
        assert_eq!(pts(&r, f), vec![0, 1, 11, 12, 10, 11, 1, 2, 3]);
        assert_eq!((r.point(b1).0, r.point(a2).0), (11, 1));
        assert_eq!(r.next(a[1]), b1);
        assert_eq!(r.len(g), 0);
        assert_eq!(r.len(f), 9);
        consistent(&r, f);
    }
}
