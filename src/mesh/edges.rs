//! The edges of a triangle mesh in linear time: every use of an undirected edge by a
//! triangle, grouped by edge in (lower vertex, higher vertex) order. The topology report and
//! the marcher's verification both walk these runs; a counting sort by the lower vertex
//! (each vertex has a handful of edges) replaces a map or a global sort of all edges.

/// One use of an undirected edge {lo, hi} by a triangle, packed in one word whose order is
/// that of (hi, forward, triangle): the higher vertex in the upper 32 bits, whether the
/// triangle runs the edge from lo to hi in bit 31, the triangle below. (As a struct of
/// three fields it took 12 bytes, written zeroed then scattered, and compared field by field
/// in the buckets' sorts: the joined fine sphere's 3.7 M uses took 46 ms, now 32.)
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct EdgeUse(u64);

impl EdgeUse {
    const FORWARD: u64 = 1 << 31;

    fn new(hi: u32, forward: bool, triangle: u32) -> EdgeUse {
        EdgeUse(u64::from(hi) << 32 | u64::from(forward) << 31 | u64::from(triangle))
    }

    /// The higher vertex of the edge.
    #[inline]
    pub fn hi(self) -> u32 {
        (self.0 >> 32) as u32
    }

    /// Whether the triangle runs the edge from lo to hi.
    #[inline]
    pub fn forward(self) -> bool {
        self.0 & Self::FORWARD != 0
    }

    /// The triangle.
    #[inline]
    pub fn triangle(self) -> u32 {
        (self.0 & (Self::FORWARD - 1)) as u32
    }
}

impl std::fmt::Debug for EdgeUse {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EdgeUse")
            .field("hi", &self.hi())
            .field("forward", &self.forward())
            .field("triangle", &self.triangle())
            .finish()
    }
}

/// Every edge use of a mesh, bucketed by the edge's lower vertex and sorted within each
/// bucket by (hi, forward, triangle): the order a sort of (lo, hi, forward, triangle) gives.
pub struct Edges {
    /// `uses[start[v]..start[v + 1]]` are the uses of the edges whose lower vertex is v.
    start: Vec<u32>,
    uses: Vec<EdgeUse>,
}

impl Edges {
    /// The edge uses of `triangles` over `vertices` vertices (indices at or above it are
    /// counted too: the buckets grow to the largest index). At most 2³¹ triangles, whose
    /// indices alone would take 24 GiB.
    pub fn new(vertices: usize, triangles: &[[u32; 3]]) -> Edges {
        assert!(
            triangles.len() <= 1 << 31,
            "an edge use numbers its triangle in 31 bits"
        );
        let n = index_bound(vertices, triangles);
        let mut start = vec![0u32; n + 1];
        for t in triangles {
            for k in 0..3 {
                start[t[k].min(t[(k + 1) % 3]) as usize + 1] += 1;
            }
        }
        for v in 0..n {
            start[v + 1] += start[v];
        }
        let mut fill = start.clone();
        let mut uses = vec![EdgeUse(0); 3 * triangles.len()];
        for (i, t) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let slot = &mut fill[a.min(b) as usize];
                uses[*slot as usize] = EdgeUse::new(a.max(b), a < b, i as u32);
                *slot += 1;
            }
        }
        for v in 0..n {
            let bucket = &mut uses[start[v] as usize..start[v + 1] as usize];
            // Buckets hold about six uses; a fan around one vertex may hold many.
            if bucket.len() <= 16 {
                insertion_sort(bucket);
            } else {
                bucket.sort_unstable();
            }
        }
        Edges { start, uses }
    }

    /// Each undirected edge as (lo, hi, its uses), in (lo, hi) order.
    #[inline]
    pub fn runs(&self) -> Runs<'_> {
        Runs {
            edges: self,
            lo: 0,
            at: 0,
        }
    }
}

/// The iterator of [`Edges::runs`]: one walk along the uses, the bucket's vertex moved on
/// where a bucket ends. (Written out: as a `flat_map` of `chunk_by`s it was a call a run,
/// which the topology of the fine sphere's 1.9 M edges spent 1 % of the run in.)
pub struct Runs<'a> {
    edges: &'a Edges,
    /// The bucket (lower vertex) of the use at `at`, or past the last bucket.
    lo: usize,
    at: usize,
}

impl<'a> Iterator for Runs<'a> {
    type Item = (u32, u32, &'a [EdgeUse]);

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        let (start, uses) = (&self.edges.start, &self.edges.uses);
        // The bucket the next use is in (empty buckets skipped).
        while self.lo + 1 < start.len() && start[self.lo + 1] as usize <= self.at {
            self.lo += 1;
        }
        let end = *start.get(self.lo + 1)? as usize;
        let from = self.at;
        let hi = uses[from].hi();
        let mut to = from + 1;
        while to < end && uses[to].hi() == hi {
            to += 1;
        }
        self.at = to;
        Some((self.lo as u32, hi, &uses[from..to]))
    }
}

/// `vertices`, or one past the largest index of `triangles` where that is more (the bound
/// `Edges::new` and `topology` both size their per-vertex tables by).
pub fn index_bound(vertices: usize, triangles: &[[u32; 3]]) -> usize {
    if triangles.is_empty() {
        return vertices;
    }
    let largest = (triangles.iter()).fold(0, |m: u32, t| m.max(t[0]).max(t[1]).max(t[2]));
    (largest as usize + 1).max(vertices)
}

fn insertion_sort(s: &mut [EdgeUse]) {
    for i in 1..s.len() {
        let mut j = i;
        while j > 0 && s[j] < s[j - 1] {
            s.swap(j, j - 1);
            j -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The runs against a plain sort of every (lo, hi, forward, triangle), on meshes with
    /// fans of every size (buckets on both sides of the insertion-sort limit).
    #[test]
    fn a_packed_use_keeps_its_fields_and_their_order() {
        let fields = [
            (0, false, 0),
            (0, false, (1 << 31) - 1),
            (0, true, 0),
            (1, false, 0),
            (u32::MAX, false, 5),
            (u32::MAX, true, (1 << 31) - 1),
        ];
        for (i, &(hi, forward, triangle)) in fields.iter().enumerate() {
            let u = EdgeUse::new(hi, forward, triangle);
            assert_eq!((u.hi(), u.forward(), u.triangle()), (hi, forward, triangle));
            for &other in &fields[i + 1..] {
                let w = EdgeUse::new(other.0, other.1, other.2);
                assert!(u < w, "{u:?} before {w:?}, as (hi, forward, triangle)");
            }
        }
    }

    /// The runs against a plain sort of every (lo, hi, forward, triangle), on meshes with
    /// fans of every size (buckets on both sides of the insertion-sort limit).
    #[test]
    fn runs_are_a_sort_of_all_edge_uses() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = |n: u32| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % u64::from(n)) as u32
        };
        for &(nv, nt) in &[(4u32, 3usize), (30, 200), (500, 3000), (3, 40)] {
            let triangles: Vec<[u32; 3]> =
                (0..nt).map(|_| [next(nv), next(nv), next(nv)]).collect();
            let mut expected: Vec<(u32, u32, bool, u32)> = Vec::new();
            for (i, t) in triangles.iter().enumerate() {
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    expected.push((a.min(b), a.max(b), a < b, i as u32));
                }
            }
            expected.sort_unstable();
            let edges = Edges::new(nv as usize, &triangles);
            let got: Vec<(u32, u32, bool, u32)> = edges
                .runs()
                .flat_map(|(lo, hi, run)| {
                    assert!(run.iter().all(|u| u.hi() == hi));
                    run.iter().map(move |u| (lo, hi, u.forward(), u.triangle()))
                })
                .collect();
            assert_eq!(got, expected);
            let distinct = {
                let mut e: Vec<(u32, u32)> = expected.iter().map(|e| (e.0, e.1)).collect();
                e.dedup();
                e.len()
            };
            assert_eq!(edges.runs().count(), distinct);
        }
    }
}
