//! Topology of a triangle mesh: edges with their uses, boundary edges and loops, non-manifold
//! edges, orientation consistency, Euler characteristic, connected components. Everything is
//! computed in sorted order, so results are deterministic; the cost is linear in the mesh.

use std::collections::BTreeMap;

use super::Mesh;
use super::edges::{Edges, index_bound};

/// An undirected edge (smaller vertex index first).
pub type Edge = [u32; 2];

/// The topology of a mesh.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Topology {
    pub vertices: usize,
    /// Vertices used by at least one triangle.
    pub used_vertices: usize,
    pub triangles: usize,
    pub edges: usize,
    /// Edges in exactly one triangle, directed as in that triangle.
    pub boundary_edges: Vec<[u32; 2]>,
    /// Closed loops of boundary edges, each in the direction of its triangles' edges.
    pub boundary_loops: Vec<Vec<u32>>,
    /// Edges in more than two triangles.
    pub non_manifold_edges: Vec<Edge>,
    /// Interior edges used twice in the same direction (the two triangles disagree).
    pub misoriented_edges: Vec<Edge>,
    /// Triangles with a repeated vertex.
    pub degenerate_triangles: usize,
    /// V − E + F over the used vertices.
    pub euler_characteristic: i64,
    /// Connected components of triangles (through shared edges or vertices).
    pub components: usize,
}

impl Topology {
    /// Every edge in exactly two triangles, once in each direction.
    pub fn is_closed_and_oriented(&self) -> bool {
        self.boundary_edges.is_empty()
            && self.non_manifold_edges.is_empty()
            && self.misoriented_edges.is_empty()
            && self.degenerate_triangles == 0
    }
}

/// The root of `x` in a union–find forest (`parent[r] == r` at a root), halving the path.
pub(super) fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let p = parent[parent[x as usize] as usize];
        parent[x as usize] = p;
        x = p;
    }
    x
}

/// Joins the sets of `a` and `b`, the smaller root the root of both (so that the roots, and
/// the numbering read from them, do not depend on the order of the joins' arguments).
pub(super) fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra.max(rb) as usize] = ra.min(rb);
    }
}

/// Computes the topology of `mesh`, in time linear in its size (edges from
/// [`Edges`], components by union–find).
pub fn topology(mesh: &Mesh) -> Topology {
    let nv = index_bound(mesh.vertices.len(), &mesh.triangles);
    // The edges and the components are independent: side by side on the rayon pool.
    let (edges, (used, mut parent, degenerate)) = rayon::join(
        || Edges::new(mesh.vertices.len(), &mesh.triangles),
        || {
            let mut degenerate = 0;
            let mut used = vec![false; nv];
            let mut parent: Vec<u32> = (0..nv as u32).collect();
            for t in &mesh.triangles {
                if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                    degenerate += 1;
                }
                for &k in t {
                    used[k as usize] = true;
                }
                // Two of the three edges join all three corners.
                for (a, b) in [(t[0], t[1]), (t[1], t[2])] {
                    union(&mut parent, a, b);
                }
            }
            (used, parent, degenerate)
        },
    );
    let mut boundary_edges = Vec::new();
    let mut non_manifold_edges = Vec::new();
    let mut misoriented_edges = Vec::new();
    let mut edge_count = 0usize;
    for (lo, hi, run) in edges.runs() {
        edge_count += 1;
        let forward = run.iter().filter(|u| u.forward()).count();
        match run.len() {
            1 => boundary_edges.push(if forward == 1 { [lo, hi] } else { [hi, lo] }),
            2 => {
                if forward != 1 {
                    misoriented_edges.push([lo, hi]);
                }
            }
            _ => non_manifold_edges.push([lo, hi]),
        }
    }
    let used_vertices = used.iter().filter(|&&u| u).count();
    // Every vertex of a set is used (unused ones stay alone), so each set's root is a used
    // vertex that is its own parent.
    let components = (0..nv as u32)
        .filter(|&v| used[v as usize] && find(&mut parent, v) == v)
        .count();
    let boundary_loops = loops(&boundary_edges);
    Topology {
        vertices: mesh.vertices.len(),
        used_vertices,
        triangles: mesh.triangles.len(),
        edges: edge_count,
        euler_characteristic: used_vertices as i64 - edge_count as i64
            + mesh.triangles.len() as i64,
        boundary_edges,
        boundary_loops,
        non_manifold_edges,
        misoriented_edges,
        degenerate_triangles: degenerate,
        components,
    }
}

/// Chains directed boundary edges into loops (starting each at its smallest unused edge).
/// A vertex with several outgoing boundary edges is followed in index order.
fn loops(edges: &[[u32; 2]]) -> Vec<Vec<u32>> {
    let mut out_edges: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    for (i, e) in edges.iter().enumerate() {
        out_edges.entry(e[0]).or_default().push(i);
    }
    let mut used = vec![false; edges.len()];
    let mut result = Vec::new();
    for start in 0..edges.len() {
        if used[start] {
            continue;
        }
        let mut lp = Vec::new();
        let mut e = start;
        loop {
            used[e] = true;
            lp.push(edges[e][0]);
            let next = out_edges
                .get(&edges[e][1])
                .and_then(|v| v.iter().copied().find(|&i| !used[i]));
            match next {
                Some(n) => e = n,
                None => break,
            }
        }
        result.push(lp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn tetra() -> Mesh {
        Mesh {
            vertices: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
            normals: vec![DVec3::Z; 4],
            triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
            sides: Vec::new(),
        }
    }

    #[test]
    fn tetrahedron_is_closed_with_euler_two() {
        let t = topology(&tetra());
        assert!(t.is_closed_and_oriented(), "{t:?}");
        assert_eq!((t.euler_characteristic, t.components, t.edges), (2, 1, 6));
    }

    #[test]
    fn open_and_flipped_meshes_are_reported() {
        let mut m = tetra();
        m.triangles.pop();
        let t = topology(&m);
        assert_eq!(t.boundary_edges.len(), 3);
        assert_eq!(t.boundary_loops.len(), 1);
        assert_eq!(t.boundary_loops[0].len(), 3);
        assert_eq!(t.euler_characteristic, 1);
        let mut m = tetra();
        m.triangles[3] = [0, 2, 3];
        let t = topology(&m);
        assert_eq!(t.misoriented_edges.len(), 3);
        let mut m = tetra();
        m.triangles.push([0, 1, 2]);
        assert_eq!(topology(&m).non_manifold_edges.len(), 3);
    }
}
