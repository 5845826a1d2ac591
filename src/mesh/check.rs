//! The one reusable mesh checker of every mesh test: topology (closed and consistently
//! oriented, Euler characteristic, components, no edge in more than two triangles), geometry
//! (vertices in a box, boundary vertices on the box, vertices on the surface, smallest
//! angle) and self-intersection (no two triangles cross other than at shared vertices or
//! edges). Returns every violation found, as data.

use glam::DVec3;
use rayon::prelude::*;

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
    shared < 2 && !beside(vs, t, u) && !beside(vs, u, t) && edges_cross(vs, t, u)
}

/// The exact test of `triangles_cross`: does an edge of one cross the other's interior?
fn edges_cross(vs: &[DVec3], t: [u32; 3], u: [u32; 3]) -> bool {
    let [a, b, c] = t.map(|i| vs[i as usize]);
    let [d, e, f] = u.map(|i| vs[i as usize]);
    [(a, b), (b, c), (c, a)]
        .iter()
        .any(|&(p, q)| segment_crosses(p, q, d, e, f))
        || [(d, e), (e, f), (f, d)]
            .iter()
            .any(|&(p, q)| segment_crosses(p, q, a, b, c))
}

/// Do the corners of `u` that are not corners of `t` lie strictly on one side of `t`'s
/// plane? Then `u` meets that plane at most in the shared corners, which no segment test
/// counts as a crossing: the cheap rejection of almost every pair of neighbours on a smooth
/// mesh (6 edge-against-triangle tests saved). "Strictly" is a margin relative to the
/// sizes, like `segment_crosses`'s, so a nearly coplanar pair still gets the exact test.
fn beside(vs: &[DVec3], t: [u32; 3], u: [u32; 3]) -> bool {
    let [a, b, c] = t.map(|i| vs[i as usize]);
    let n = (b - a).cross(c - a);
    let reach = a.distance(b).max(b.distance(c)).max(c.distance(a));
    let margin = 1e-9 * n.length() * reach;
    let (mut above, mut below) = (false, false);
    for k in u {
        if t.contains(&k) {
            continue;
        }
        let d = n.dot(vs[k as usize] - a);
        if d > margin {
            above = true;
        } else if d < -margin {
            below = true;
        } else {
            return false;
        }
    }
    above != below
}

/// Every pair of triangles (index pairs, smaller first, sorted) that cross, in time linear in
/// the mesh (plus one sort). Triangles go into uniform grids, one per power-of-two size
/// class: a triangle is a *resident* of the grid whose cells are just wider than its
/// bounding box's largest side (so the box touches ≤ 2 cells an axis) and a *guest* of every
/// coarser grid present, so a mesh whose edge lengths vary (a local step) costs no more than
/// a uniform one. All (cell, triangle) entries are sorted once; within each cell's run every
/// pair with a resident is looked at, and only in the one cell that holds the lowest corner
/// of the overlap of their boxes, so no pair is tested twice and no lookup structure is
/// needed.
pub fn intersecting_pairs(mesh: &Mesh) -> Vec<[u32; 2]> {
    let vs = &mesh.vertices;
    let tris = &mesh.triangles;
    let boxes: Vec<(DVec3, DVec3)> = tris
        .par_iter()
        .map(|t| {
            let [a, b, c] = t.map(|k| vs[k as usize]);
            (a.min(b).min(c), a.max(b).max(c))
        })
        .collect();
    let sizes: Vec<f64> = boxes
        .iter()
        .map(|(lo, hi)| (*hi - *lo).max_element())
        .collect();
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
    // A cell of class `c` as one packed key (class in 7 bits, 19 bits a coordinate; far
    // cells that wrap onto one key only add candidates, which the tests below reject).
    let cell_index = |p: DVec3, c: u32| (p / (base * 2f64.powi(c as i32))).floor().as_i64vec3();
    let pack = |c: u32, x: i64, y: i64, z: i64| {
        const MASK: u64 = (1 << 19) - 1;
        ((c as u64) << 57)
            | ((x as u64 & MASK) << 38)
            | ((y as u64 & MASK) << 19)
            | (z as u64 & MASK)
    };
    let key = |p: DVec3, c: u32| {
        let k = cell_index(p, c);
        pack(c, k.x, k.y, k.z)
    };
    let cells = |(lo, hi): (DVec3, DVec3), c: u32| {
        let (l, h) = (cell_index(lo, c), cell_index(hi, c));
        (l.x..=h.x).flat_map(move |x| {
            (l.y..=h.y).flat_map(move |y| (l.z..=h.z).map(move |z| pack(c, x, y, z)))
        })
    };
    // On every thread of the pool (`--threads`): the entries, their sort and the cells' runs
    // are independent; the pairs are sorted at the end, so the result is the same for any
    // number of threads.
    let mut grid: Vec<(u64, u32)> = boxes
        .par_iter()
        .enumerate()
        .flat_map_iter(|(i, &b)| {
            let least = classes[i];
            present
                .iter()
                .filter(move |&&c| c >= least)
                .flat_map(move |&c| cells(b, c).map(move |k| (k, i as u32)))
        })
        .collect();
    grid.par_sort_unstable();
    let mut out: Vec<[u32; 2]> = grid
        .par_chunk_by(|x, y| x.0 == y.0)
        .flat_map_iter(|run| {
            let (k, c) = (run[0].0, (run[0].0 >> 57) as u32);
            let mut found = Vec::new();
            for (x, &(_, i)) in run.iter().enumerate() {
                let (li, hi) = boxes[i as usize];
                for &(_, j) in &run[x + 1..] {
                    // Two guests meet in the grid of the coarser of them.
                    if classes[i as usize] < c && classes[j as usize] < c {
                        continue;
                    }
                    let (lj, hj) = boxes[j as usize];
                    if li.cmpgt(hj).any() || lj.cmpgt(hi).any() || key(li.max(lj), c) != k {
                        continue;
                    }
                    if triangles_cross(vs, tris[i as usize], tris[j as usize]) {
                        found.push([i.min(j), i.max(j)]);
                    }
                }
            }
            found
        })
        .collect();
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

    /// The grid search with its plane rejection finds exactly the pairs that the exact test
    /// finds over all pairs, on soups of triangles of sizes over three orders of magnitude,
    /// many sharing corners (fans that fold) and many crossing.
    #[test]
    fn grid_search_finds_what_all_pairs_find() {
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut unit = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for round in 0..20 {
            let mut vs = Vec::new();
            let mut tris = Vec::new();
            for _ in 0..150 {
                let size = 10f64.powf(-3.0 * unit());
                let centre = DVec3::new(unit(), unit(), 0.2 * unit());
                let corner = |unit: &mut dyn FnMut() -> f64| {
                    centre + size * DVec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5)
                };
                let reuse = !vs.is_empty() && unit() < 0.5;
                let a = if reuse {
                    (unit() * vs.len() as f64) as u32
                } else {
                    vs.push(corner(&mut unit));
                    vs.len() as u32 - 1
                };
                vs.push(corner(&mut unit));
                vs.push(corner(&mut unit));
                let n = vs.len() as u32;
                tris.push([a, n - 2, n - 1]);
            }
            let mut all = Vec::new();
            for i in 0..tris.len() {
                for j in i + 1..tris.len() {
                    let shared = tris[i].iter().filter(|k| tris[j].contains(k)).count();
                    if shared < 2 && edges_cross(&vs, tris[i], tris[j]) {
                        all.push([i as u32, j as u32]);
                    }
                }
            }
            let m = Mesh {
                normals: vec![DVec3::Z; vs.len()],
                vertices: vs,
                triangles: tris,
            };
            assert!(
                !all.is_empty(),
                "round {round}: the soup should cross somewhere"
            );
            assert_eq!(intersecting_pairs(&m), all, "round {round}");
        }
    }
}
