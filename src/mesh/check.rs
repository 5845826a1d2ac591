//! The one reusable mesh checker of every mesh test: topology (closed and consistently
//! oriented, Euler characteristic, components, no edge in more than two triangles), geometry
//! (vertices in a box, boundary vertices on the box, vertices on the surface, smallest
//! angle) and self-intersection (no two triangles cross other than at shared vertices or
//! edges). Returns every violation found, as data.

use glam::DVec3;

use super::Mesh;
use super::quality::{max_vertex_error, quality};
use super::topology::{Topology, topology};
use crate::surface::Surface;

/// What a mesh must satisfy. `Default`: no edge in more than two triangles, no degenerate or
/// misoriented triangles, smallest angle ≥ 15°, no self-intersections; everything else off.
#[derive(Clone, Debug, PartialEq)]
pub struct Expect {
    /// Every edge in exactly two triangles (watertight).
    pub closed: bool,
    pub euler: Option<i64>,
    pub components: Option<usize>,
    pub boundary_loops: Option<usize>,
    /// Every vertex inside (lo, hi) up to `box_tolerance`.
    pub bbox: Option<(DVec3, DVec3)>,
    /// Every boundary vertex within `box_tolerance` of a face of `bbox`.
    pub boundary_on_box: bool,
    /// Absolute slack for the box checks.
    pub box_tolerance: f64,
    /// max |f|/|∇f| over the vertices (needs a surface).
    pub max_vertex_error: Option<f64>,
    /// Smallest angle of any triangle, degrees. Default 15.
    pub min_angle_deg: f64,
    pub no_intersections: bool,
    /// Every triangle's normal agrees with its vertices' normals (∇f): n_T · Σ n_v > 0.
    pub normals_agree: bool,
}

impl Default for Expect {
    fn default() -> Self {
        Expect {
            closed: false,
            euler: None,
            components: None,
            boundary_loops: None,
            bbox: None,
            boundary_on_box: false,
            box_tolerance: 1e-9,
            max_vertex_error: None,
            min_angle_deg: 15.0,
            no_intersections: true,
            normals_agree: true,
        }
    }
}

/// One way a mesh fails its expectations.
#[derive(Clone, Debug, PartialEq)]
pub enum Violation {
    Empty,
    NotClosed {
        boundary_edges: usize,
    },
    NonManifold {
        edges: usize,
        first: [u32; 2],
    },
    Misoriented {
        edges: usize,
        first: [u32; 2],
    },
    Degenerate {
        triangles: usize,
    },
    Euler {
        expected: i64,
        found: i64,
    },
    Components {
        expected: usize,
        found: usize,
    },
    BoundaryLoops {
        expected: usize,
        found: usize,
    },
    OutsideBox {
        vertex: u32,
        at: DVec3,
    },
    BoundaryOffBox {
        vertex: u32,
        at: DVec3,
    },
    VertexError {
        expected: f64,
        found: f64,
    },
    MinAngle {
        expected: f64,
        found: f64,
    },
    Intersecting {
        triangles: [u32; 2],
        pairs: usize,
    },
    /// Triangles whose normal points against ∇f.
    Flipped {
        first: u32,
        triangles: usize,
    },
}

/// Checks `mesh` against `expect`; the surface is needed for `max_vertex_error`.
pub fn check(
    mesh: &Mesh,
    surface: Option<&mut dyn Surface>,
    expect: &Expect,
) -> (Topology, Vec<Violation>) {
    let t = topology(mesh);
    let mut v = Vec::new();
    if mesh.triangles.is_empty() {
        v.push(Violation::Empty);
        return (t, v);
    }
    if expect.closed && !t.boundary_edges.is_empty() {
        v.push(Violation::NotClosed {
            boundary_edges: t.boundary_edges.len(),
        });
    }
    if let Some(&first) = t.non_manifold_edges.first() {
        v.push(Violation::NonManifold {
            edges: t.non_manifold_edges.len(),
            first,
        });
    }
    if let Some(&first) = t.misoriented_edges.first() {
        v.push(Violation::Misoriented {
            edges: t.misoriented_edges.len(),
            first,
        });
    }
    if t.degenerate_triangles > 0 {
        v.push(Violation::Degenerate {
            triangles: t.degenerate_triangles,
        });
    }
    if let Some(e) = expect.euler {
        if e != t.euler_characteristic {
            v.push(Violation::Euler {
                expected: e,
                found: t.euler_characteristic,
            });
        }
    }
    if let Some(c) = expect.components {
        if c != t.components {
            v.push(Violation::Components {
                expected: c,
                found: t.components,
            });
        }
    }
    if let Some(c) = expect.boundary_loops {
        if c != t.boundary_loops.len() {
            v.push(Violation::BoundaryLoops {
                expected: c,
                found: t.boundary_loops.len(),
            });
        }
    }
    if let Some((lo, hi)) = expect.bbox {
        let eps = expect.box_tolerance;
        for tri in &mesh.triangles {
            for &i in tri {
                let p = mesh.vertices[i as usize];
                if !(p.cmpge(lo - eps).all() && p.cmple(hi + eps).all()) {
                    v.push(Violation::OutsideBox { vertex: i, at: p });
                    break;
                }
            }
        }
        v.dedup();
        if expect.boundary_on_box {
            for e in &t.boundary_edges {
                let p = mesh.vertices[e[0] as usize];
                let d = (p - lo).min(hi - p).min_element();
                if d > eps {
                    v.push(Violation::BoundaryOffBox {
                        vertex: e[0],
                        at: p,
                    });
                    break;
                }
            }
        }
    }
    if let (Some(max), Some(s)) = (expect.max_vertex_error, surface) {
        let found = max_vertex_error(mesh, s);
        if found.is_nan() || found > max {
            v.push(Violation::VertexError {
                expected: max,
                found,
            });
        }
    }
    let q = quality(mesh);
    if q.min_angle_deg.is_nan() || q.min_angle_deg < expect.min_angle_deg {
        v.push(Violation::MinAngle {
            expected: expect.min_angle_deg,
            found: q.min_angle_deg,
        });
    }
    if expect.normals_agree && mesh.normals.len() == mesh.vertices.len() {
        let flipped: Vec<u32> = (0..mesh.triangles.len() as u32)
            .filter(|&i| {
                let [a, b, c] = mesh.triangles[i as usize].map(|k| k as usize);
                let n = (mesh.vertices[b] - mesh.vertices[a])
                    .cross(mesh.vertices[c] - mesh.vertices[a]);
                n.dot(mesh.normals[a] + mesh.normals[b] + mesh.normals[c]) <= 0.0
            })
            .collect();
        if let Some(&first) = flipped.first() {
            v.push(Violation::Flipped {
                first,
                triangles: flipped.len(),
            });
        }
    }
    if expect.no_intersections {
        let pairs = intersecting_pairs(mesh);
        if let Some(&first) = pairs.first() {
            v.push(Violation::Intersecting {
                triangles: first,
                pairs: pairs.len(),
            });
        }
    }
    (t, v)
}

/// Does segment p→q cross the interior of triangle (a, b, c)? Möller–Trumbore with margins
/// relative to the edge lengths: touching at an end, an edge or a shared vertex is not a
/// crossing. Coplanar pairs (det ≈ 0) are not reported.
fn segment_crosses(p: DVec3, q: DVec3, a: DVec3, b: DVec3, c: DVec3) -> bool {
    const MARGIN: f64 = 1e-9;
    let d = q - p;
    let (e1, e2) = (b - a, c - a);
    let h = d.cross(e2);
    let det = e1.dot(h);
    let scale = d.length() * e1.length() * e2.length();
    if det.abs() <= 1e-12 * scale {
        return false;
    }
    let inv = 1.0 / det;
    let s = p - a;
    let u = s.dot(h) * inv;
    if u <= MARGIN || u >= 1.0 - MARGIN {
        return false;
    }
    let qv = s.cross(e1);
    let v = d.dot(qv) * inv;
    if v <= MARGIN || u + v >= 1.0 - MARGIN {
        return false;
    }
    let t = e2.dot(qv) * inv;
    t > MARGIN && t < 1.0 - MARGIN
}

/// Do two triangles (given by vertex indices into `vs`) cross? Pairs sharing an edge are
/// never reported; pairs sharing a vertex only if one folds over the other.
fn triangles_cross(vs: &[DVec3], t: [u32; 3], u: [u32; 3]) -> bool {
    let shared = t.iter().filter(|i| u.contains(i)).count();
    if shared >= 2 {
        return false;
    }
    let [a, b, c] = t.map(|i| vs[i as usize]);
    let [d, e, f] = u.map(|i| vs[i as usize]);
    [(a, b), (b, c), (c, a)]
        .iter()
        .any(|&(p, q)| segment_crosses(p, q, d, e, f))
        || [(d, e), (e, f), (f, d)]
            .iter()
            .any(|&(p, q)| segment_crosses(p, q, a, b, c))
}

/// Every pair of triangles (index pairs, smaller first, sorted) that cross, found over uniform
/// grids, one per power-of-two size class: a triangle sits in the grid whose cells are just
/// wider than its longest edge (≤ 8 cells) and is compared with the triangles of its own and
/// every coarser class, so a mesh whose edge lengths vary (a local step) costs no more than
/// a uniform one.
pub fn intersecting_pairs(mesh: &Mesh) -> Vec<[u32; 2]> {
    let vs = &mesh.vertices;
    let tris = &mesh.triangles;
    let longest = |t: &[u32; 3]| {
        (0..3)
            .map(|k| vs[t[k] as usize].distance(vs[t[(k + 1) % 3] as usize]))
            .fold(0.0f64, f64::max)
    };
    let sizes: Vec<f64> = tris.iter().map(longest).collect();
    let largest = sizes.iter().copied().fold(0.0f64, f64::max);
    if tris.is_empty() || !(largest > 0.0 && largest.is_finite()) {
        return Vec::new();
    }
    // Classes below largest·2⁻³⁰ share the finest grid (a few more candidates, no overflow).
    let base = sizes
        .iter()
        .copied()
        .filter(|&s| s > 0.0)
        .fold(largest, f64::min)
        .max(largest * 2f64.powi(-30));
    let class = |s: f64| -> u32 {
        if s <= base {
            0
        } else {
            (s / base).log2().ceil() as u32
        }
    };
    let classes: Vec<u32> = sizes.iter().map(|&s| class(s)).collect();
    let mut present: Vec<u32> = classes.clone();
    present.sort_unstable();
    present.dedup();
    // The grid cells of class `c` a triangle's bounding box touches, as one packed key each
    // (class in 7 bits, 19 bits a coordinate; far cells that wrap onto one key only add
    // candidates, which the crossing test rejects).
    let cells = |t: &[u32; 3], c: u32| {
        let cell = base * 2f64.powi(c as i32);
        let ps = t.map(|k| vs[k as usize]);
        let key = |p: DVec3| (p / cell).floor().as_i64vec3();
        let (lo, hi) = (
            key(ps[0].min(ps[1]).min(ps[2])),
            key(ps[0].max(ps[1]).max(ps[2])),
        );
        const MASK: u64 = (1 << 19) - 1;
        let pack = move |x: i64, y: i64, z: i64| {
            ((c as u64) << 57)
                | ((x as u64 & MASK) << 38)
                | ((y as u64 & MASK) << 19)
                | (z as u64 & MASK)
        };
        (lo.x..=hi.x).flat_map(move |x| {
            (lo.y..=hi.y).flat_map(move |y| (lo.z..=hi.z).map(move |z| pack(x, y, z)))
        })
    };
    // The grid as one sorted list of (cell, triangle): no map, no per-cell allocation.
    let mut grid: Vec<(u64, u32)> = Vec::with_capacity(8 * tris.len());
    for (i, t) in tris.iter().enumerate() {
        grid.extend(cells(t, classes[i]).map(|k| (k, i as u32)));
    }
    grid.sort_unstable();
    let members = |k: u64| {
        let from = grid.partition_point(|e| e.0 < k);
        grid[from..]
            .iter()
            .take_while(move |e| e.0 == k)
            .map(|e| e.1)
    };
    // Bounding boxes: most candidates from a shared cell do not even overlap.
    let boxes: Vec<(DVec3, DVec3)> = tris
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|k| vs[k as usize]);
            (a.min(b).min(c), a.max(b).max(c))
        })
        .collect();
    let mut seen = vec![u32::MAX; tris.len()];
    let mut out = Vec::new();
    for (i, t) in tris.iter().enumerate() {
        let (lo, hi) = boxes[i];
        for &c in present.iter().filter(|&&c| c >= classes[i]) {
            for k in cells(t, c) {
                for j in members(k) {
                    let same = classes[j as usize] == classes[i];
                    if j as usize == i || (same && (j as usize) < i) || seen[j as usize] == i as u32
                    {
                        continue;
                    }
                    seen[j as usize] = i as u32;
                    let (lj, hj) = boxes[j as usize];
                    if lo.cmpgt(hj).any() || lj.cmpgt(hi).any() {
                        continue;
                    }
                    if triangles_cross(vs, *t, tris[j as usize]) {
                        out.push([(i as u32).min(j), (i as u32).max(j)]);
                    }
                }
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_and_touching_triangles() {
        let vs = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
            // A triangle piercing the first one.
            DVec3::new(0.5, 0.5, -1.0),
            DVec3::new(0.5, 0.5, 1.0),
            DVec3::new(1.5, 1.5, 1.0),
            // A neighbour sharing the edge 1–2, folded up.
            DVec3::new(2.0, 2.0, 0.5),
        ];
        assert!(triangles_cross(&vs, [0, 1, 2], [3, 4, 5]));
        assert!(!triangles_cross(&vs, [0, 1, 2], [2, 1, 6]));
        // Sharing vertex 0 and folding back over the first triangle.
        let vs2 = vec![
            DVec3::ZERO,
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
            DVec3::new(1.0, 1.0, 0.5),
            DVec3::new(0.5, 0.2, -0.5),
        ];
        assert!(triangles_cross(&vs2, [0, 1, 2], [0, 3, 4]));
        let m = Mesh {
            vertices: vs,
            normals: vec![DVec3::Z; 7],
            triangles: vec![[0, 1, 2], [3, 4, 5], [2, 1, 6]],
        };
        assert_eq!(intersecting_pairs(&m), vec![[0, 1]]);
    }
}
