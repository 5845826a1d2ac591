//! The one reusable mesh checker of every mesh test: topology (closed and consistently
//! oriented, Euler characteristic, components, no edge in more than two triangles), geometry
//! (vertices in a box, boundary vertices on the box, vertices on the surface, smallest
//! angle) and self-intersection (no two triangles cross other than at shared vertices or
//! edges). Returns every violation found, as data.

use glam::DVec3;
use rayon::prelude::*;

use super::Mesh;
use super::edges::Edges;
use super::height_fields::NOT_CERTIFIED;
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
/// never reported; pairs sharing a vertex only if one folds over the other. `plane` is `t`'s
/// plane for `beside`, made here where it is `None`: a caller testing `t` against many
/// triangles makes it once.
fn triangles_cross(vs: &[DVec3], t: [u32; 3], u: [u32; 3], plane: &mut Option<Plane>) -> bool {
    let shared = t.iter().filter(|i| u.contains(i)).count();
    shared < 2
        && !plane
            .get_or_insert_with(|| Plane::of(vs, t))
            .beside(vs, t, u)
        && !Plane::of(vs, u).beside(vs, u, t)
        && edges_cross(vs, t, u)
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

/// A triangle's plane as `beside` tests against it: a corner, the normal (unnormalised) and
/// the margin of "strictly on one side".
struct Plane {
    corner: DVec3,
    normal: DVec3,
    margin: f64,
}

impl Plane {
    /// The plane of triangle `t`.
    fn of(vs: &[DVec3], t: [u32; 3]) -> Plane {
        let [a, b, c] = t.map(|i| vs[i as usize]);
        let normal = (b - a).cross(c - a);
        // One square root for the longest side (the same bits as the largest of three
        // lengths).
        let reach = a
            .distance_squared(b)
            .max(b.distance_squared(c))
            .max(c.distance_squared(a))
            .sqrt();
        Plane {
            corner: a,
            normal,
            margin: 1e-9 * normal.length() * reach,
        }
    }

    /// Do the corners of `u` that are not corners of `t` (this plane's triangle) lie strictly
    /// on one side of it? Then `u` meets the plane at most in the shared corners, which no
    /// segment test counts as a crossing: the cheap rejection of almost every pair of
    /// neighbours on a smooth mesh (6 edge-against-triangle tests saved). "Strictly" is a
    /// margin relative to the sizes, like `segment_crosses`'s, so a nearly coplanar pair
    /// still gets the exact test.
    fn beside(&self, vs: &[DVec3], t: [u32; 3], u: [u32; 3]) -> bool {
        let (mut above, mut below) = (false, false);
        for k in u {
            if t.contains(&k) {
                continue;
            }
            let d = self.normal.dot(vs[k as usize] - self.corner);
            if d > self.margin {
                above = true;
            } else if d < -self.margin {
                below = true;
            } else {
                return false;
            }
        }
        above != below
    }
}

/// Every pair of triangles (index pairs, smaller first, sorted) that cross, in time linear in
/// the mesh (plus one sort of one or two entries a triangle).
///
/// Triangles go into uniform grids, one per power-of-two size class: class `c` has cells of
/// width `w_c = W·2⁻ᶜ` (`W` just above the largest triangle's bounding-box side) and holds as
/// *resident* every triangle whose box side fits `w_c` (with a margin) but not `w_{c+1}`,
/// and as *guest* every finer triangle, each at the one cell holding its box's lowest
/// corner. Two boxes no wider than a cell that overlap have lowest corners in the same or
/// adjacent cells (the margin keeps this true under rounding: cell coordinates are taken
/// relative to the mesh's lowest corner, so their error is ≈ 2⁻³² of a cell), so every
/// overlapping pair is found by looking at each cell against itself and its 13 neighbours
/// of one half-shell, in the grid of the coarser of the two (guest–guest pairs skipped).
/// Each pair is looked at exactly once. The cells are linear keys `(x·ny + y)·nz + z`, so a
/// neighbour's key is the cell's plus a constant and one sorted pass with a moving pointer
/// per offset finds it, with no lookup structure. The scans read boxes and corners copied in
/// entry order (a cell's neighbours gathered into one list), test boxes without a branch a
/// comparison, and make a triangle's plane for the rejection once for all its neighbours.
pub fn intersecting_pairs(mesh: &Mesh) -> Vec<[u32; 2]> {
    intersecting_pairs_across(mesh, None)
}

/// `intersecting_pairs` by the search alone, every triangle in its grids, without the
/// certificate of `mesh::height_fields`: the same pairs, for the tests and benchmarks that
/// compare the two.
pub fn intersecting_pairs_searched(mesh: &Mesh) -> Vec<[u32; 2]> {
    grid_pairs(&mesh.vertices, &mesh.triangles, None)
}

/// A triangle's group in `intersecting_pairs_across` that is tested against every triangle.
pub const ANY_GROUP: u32 = u32::MAX;

/// `intersecting_pairs`, but with `groups` (one a triangle) pairs of two triangles of the
/// same group other than `ANY_GROUP` are not looked at: meshes checked each on its own
/// before they were put together (the pieces of a creased surface), checked again only
/// across one another and where something moved since.
pub fn intersecting_pairs_across(mesh: &Mesh, groups: Option<&[u32]>) -> Vec<[u32; 2]> {
    crossing_pairs(&mesh.vertices, &mesh.triangles, groups)
}

/// `intersecting_pairs_across` of the triangles `tris` over the vertices `vs`, for a mesh
/// still being made (the quality stage's, before it is a `Mesh`).
///
/// The search is first made over the triangles that `height_fields` leaves, skipping pairs
/// of one certified patch as well as of one group; where that finds a pair, it is made
/// again over every triangle, so the pairs returned are always the whole search's (every
/// pair it finds is one the first search looks at: the two triangles are left, and their
/// patches or groups differ).
pub fn crossing_pairs(vs: &[DVec3], tris: &[[u32; 3]], groups: Option<&[u32]>) -> Vec<[u32; 2]> {
    crossing_pairs_over(vs, tris, groups, None)
}

/// `intersecting_pairs_across` of a mesh whose edges' uses (`Edges::new` of its vertices and
/// triangles) are at hand, for the certificate.
pub fn intersecting_pairs_with_edges(
    mesh: &Mesh,
    groups: Option<&[u32]>,
    edges: &Edges,
) -> Vec<[u32; 2]> {
    crossing_pairs_over(&mesh.vertices, &mesh.triangles, groups, Some(edges))
}

/// `crossing_pairs`, with the edges' uses where the caller has them.
fn crossing_pairs_over(
    vs: &[DVec3],
    tris: &[[u32; 3]],
    groups: Option<&[u32]>,
    edges: Option<&Edges>,
) -> Vec<[u32; 2]> {
    if tris.len() >= CERTIFY_FROM
        && let Some(left) = super::height_fields::uncertified(vs, tris, edges)
    {
        // A certified patch's group: numbered after every group given.
        let after = groups.map_or(0, |g| {
            g.iter()
                .filter(|&&x| x != ANY_GROUP)
                .max()
                .map_or(0, |&m| u64::from(m) + 1)
        });
        if after + u64::from(left.patches) < u64::from(ANY_GROUP) {
            let sub: Vec<[u32; 3]> = left.triangles.iter().map(|&t| tris[t as usize]).collect();
            let sub_groups: Vec<u32> = left
                .triangles
                .iter()
                .zip(&left.patch)
                .map(|(&t, &p)| match p {
                    NOT_CERTIFIED => groups.map_or(ANY_GROUP, |g| g[t as usize]),
                    p => (after + u64::from(p)) as u32,
                })
                .collect();
            if grid_pairs(vs, &sub, Some(&sub_groups)).is_empty() {
                return Vec::new();
            }
        }
    }
    grid_pairs(vs, tris, groups)
}

/// Triangles from which `crossing_pairs` first tries the certificate (below, the search is
/// cheap anyway).
const CERTIFY_FROM: usize = 2048;

/// The search of `crossing_pairs` over every triangle.
pub(super) fn grid_pairs(vs: &[DVec3], tris: &[[u32; 3]], groups: Option<&[u32]>) -> Vec<[u32; 2]> {
    debug_assert!(groups.is_none_or(|g| g.len() == tris.len()));
    let slot = |i: u32| {
        let corners = tris[i as usize];
        let [a, b, c] = corners.map(|k| vs[k as usize]);
        Slot {
            lo: a.min(b).min(c),
            hi: a.max(b).max(c),
            corners,
            triangle: i,
        }
    };
    let boxes: Vec<(DVec3, DVec3)> = (0..tris.len() as u32)
        .into_par_iter()
        .map(|i| {
            let s = slot(i);
            (s.lo, s.hi)
        })
        .collect();
    // Triangles with a non-finite corner have no place in a grid (and are no surface).
    let finite = |b: &(DVec3, DVec3)| b.0.is_finite() && b.1.is_finite();
    let (lo, hi, largest) = boxes.iter().filter(|b| finite(b)).fold(
        (DVec3::INFINITY, DVec3::NEG_INFINITY, 0.0f64),
        |(lo, hi, s), b| (lo.min(b.0), hi.max(b.1), s.max((b.1 - b.0).max_element())),
    );
    if !(largest > 0.0 && largest.is_finite()) {
        return Vec::new();
    }
    let grids = Grids::new(lo, hi, largest);
    // Every triangle's class: the finest whose cells its box fits, capped at the finest grid.
    let classes: Vec<u32> = boxes
        .par_iter()
        .map(|b| grids.class_of((b.1 - b.0).max_element()))
        .collect();
    let mut present = vec![false; grids.cells.len()];
    for (b, &c) in boxes.iter().zip(&classes) {
        if finite(b) {
            present[c as usize] = true;
        }
    }
    // One entry a triangle in its own grid, and one in each coarser grid present with the
    // guest bit set (so residents come first in a cell's run). A triangle not finite gets the
    // key `NOWHERE`, sorted last and cut off: a list of known length, made in place.
    let mut entries: Vec<(u64, u32)> = boxes
        .par_iter()
        .zip(&classes)
        .enumerate()
        .map(|(i, (b, &c))| {
            let key = if finite(b) {
                grids.key(c, b.0)
            } else {
                NOWHERE
            };
            (key, i as u32)
        })
        .collect();
    let guests: Vec<(u64, u32)> = boxes
        .par_iter()
        .zip(&classes)
        .enumerate()
        .filter(|&(_, (b, &own))| own > 0 && finite(b))
        .flat_map_iter(|(i, (b, &own))| {
            let (grids, present) = (&grids, &present);
            (0..own)
                .filter(move |&c| present[c as usize])
                .map(move |c| (grids.key(c, b.0) | 1, i as u32))
        })
        .collect();
    drop((boxes, classes));
    entries.extend(guests);
    // On every thread of the pool (`--threads`); the pairs are sorted at the end, so the
    // result is the same for any number of threads.
    entries.par_sort_unstable();
    entries.truncate(entries.partition_point(|e| e.0 != NOWHERE));
    let runs: Vec<Run> = entries
        .chunk_by(|x, y| x.0 >> 1 == y.0 >> 1)
        .scan(0u32, |at, run| {
            let start = *at;
            *at += run.len() as u32;
            let residents = run.iter().take_while(|e| e.0 & 1 == 0).count() as u32;
            Some(Run {
                cell: run[0].0 & !1,
                start,
                mid: start + residents,
                end: *at,
            })
        })
        .collect();
    // The triangles in entry order, so that the scans below read them in memory order (their
    // boxes made again: the same bits, and less memory than keeping them).
    let slots: Vec<Slot> = entries.par_iter().map(|&(_, i)| slot(i)).collect();
    drop(entries);
    const CHUNK: usize = 1 << 12;
    let mut out: Vec<[u32; 2]> = runs
        .par_chunks(CHUNK)
        .enumerate()
        .flat_map_iter(|(n, chunk)| {
            let mut found = Vec::new();
            // The neighbour runs, one moving pointer an offset (restarted where the class
            // changes, since the offsets depend on the grid's shape).
            let mut class = u32::MAX;
            let mut offsets = [0u64; 13];
            let mut at = [0usize; 13];
            // The neighbour runs' entries, residents first: one contiguous list to scan
            // (a run holds a handful of entries, a neighbour run about as many).
            let mut near: Vec<Slot> = Vec::new();
            for (k, r) in chunk.iter().enumerate() {
                let c = (r.cell >> CLASS_SHIFT) as u32;
                if c != class {
                    class = c;
                    offsets = grids.half_shell(c);
                    for (p, d) in at.iter_mut().zip(offsets) {
                        *p = n * CHUNK
                            + k
                            + runs[n * CHUNK + k..].partition_point(|x| x.cell < r.cell + d);
                    }
                }
                let mut neighbours = [0usize; 13];
                let mut m = 0;
                near.clear();
                for (p, d) in at.iter_mut().zip(offsets) {
                    let target = r.cell + d;
                    while *p < runs.len() && runs[*p].cell < target {
                        *p += 1;
                    }
                    if let Some(s) = runs.get(*p).filter(|s| s.cell == target) {
                        near.extend_from_slice(&slots[s.start as usize..s.mid as usize]);
                        neighbours[m] = *p;
                        m += 1;
                    }
                }
                let residents = near.len();
                for &p in &neighbours[..m] {
                    let s = &runs[p];
                    near.extend_from_slice(&slots[s.mid as usize..s.end as usize]);
                }
                // Each resident against the later entries of its cell and every neighbour
                // entry; each guest against the neighbours' residents.
                for a in r.start..r.end {
                    let x = &slots[a as usize];
                    let mut plane = None;
                    // x's group, unless it is tested against every triangle.
                    let group = groups
                        .map(|g| (g, g[x.triangle as usize]))
                        .filter(|&(_, gx)| gx != ANY_GROUP);
                    let mut scan = |ys: &[Slot]| {
                        for y in ys {
                            if group.is_some_and(|(g, gx)| g[y.triangle as usize] == gx) {
                                continue;
                            }
                            if !apart(x, y) && triangles_cross(vs, x.corners, y.corners, &mut plane)
                            {
                                let (i, j) = (x.triangle, y.triangle);
                                found.push([i.min(j), i.max(j)]);
                            }
                        }
                    };
                    if a < r.mid {
                        scan(&slots[a as usize + 1..r.end as usize]);
                        scan(&near);
                    } else {
                        scan(&near[..residents]);
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

/// A triangle's box and corners.
#[derive(Clone, Copy)]
struct Slot {
    lo: DVec3,
    hi: DVec3,
    corners: [u32; 3],
    triangle: u32,
}

/// Are the boxes of two slots apart? All six comparisons without a branch between them: on
/// a mesh about one neighbour in four overlaps, and a branch a comparison mispredicts.
#[inline(always)]
fn apart(x: &Slot, y: &Slot) -> bool {
    (x.lo.x > y.hi.x)
        | (x.lo.y > y.hi.y)
        | (x.lo.z > y.hi.z)
        | (y.lo.x > x.hi.x)
        | (y.lo.y > x.hi.y)
        | (y.lo.z > x.hi.z)
}

/// One cell's entries in the sorted list: residents `start..mid`, guests `mid..end`.
struct Run {
    /// The entry key without its guest bit.
    cell: u64,
    start: u32,
    mid: u32,
    end: u32,
}

/// The key of a triangle with no cell (a corner not finite): above every cell's key.
const NOWHERE: u64 = u64::MAX;
/// Where the class sits in a key: above 57 bits of linear cell index and the guest bit.
const CLASS_SHIFT: u32 = 58;
/// Cells an axis at most (so three axes fit 57 bits), margins included.
const AXIS_CELLS: f64 = (1u64 << 19) as f64;
/// A box fits a cell if its side is at most this fraction of the width: the room for
/// rounding in the cell coordinates (≈ 2⁻³² of a cell, see `intersecting_pairs`).
const FIT: f64 = 1.0 - 1.0 / (1u64 << 20) as f64;

/// The grids of `intersecting_pairs`: class `c`'s cell width and shape.
struct Grids {
    lo: DVec3,
    /// Per class from coarsest: (width, cells an axis with one empty cell of margin each side).
    cells: Vec<(f64, [u64; 3])>,
}

impl Grids {
    fn new(lo: DVec3, hi: DVec3, largest: f64) -> Self {
        let extent = hi - lo;
        let coarsest = largest / FIT * (1.0 + 1e-12);
        // Finer classes down to 2⁻³⁰ of the largest, while a grid's cells fit the key.
        let mut cells = Vec::new();
        for c in 0..=30 {
            let w = coarsest * 2f64.powi(-c);
            let n = (extent / w).floor() + 3.0;
            if n.max_element() > AXIS_CELLS {
                break;
            }
            cells.push((w, [n.x as u64, n.y as u64, n.z as u64]));
        }
        if cells.is_empty() {
            // The mesh is more than 2¹⁹ of its largest triangle wide: one grid coarse enough.
            let w = (extent.max_element() / (AXIS_CELLS - 4.0)).max(coarsest);
            let n = (extent / w).floor() + 3.0;
            cells.push((w, [n.x as u64, n.y as u64, n.z as u64]));
        }
        Grids { lo, cells }
    }

    /// The finest class whose cells a box of side `s` fits.
    fn class_of(&self, s: f64) -> u32 {
        let mut c = 0;
        while c + 1 < self.cells.len() && s <= self.cells[c + 1].0 * FIT {
            c += 1;
        }
        c as u32
    }

    /// The key of the cell of class `c` holding `p` (guest bit clear).
    fn key(&self, c: u32, p: DVec3) -> u64 {
        let (w, [nx, ny, nz]) = self.cells[c as usize];
        let q = (p - self.lo) / w;
        // Rounded down (the cast truncates, the same as the floor of a value at or above 0),
        // clamped (only rounding at the far side can reach past the last cell) and shifted by
        // the margin cell, so that a neighbour's key is the cell's plus a constant.
        let axis = |v: f64, n: u64| (v.max(0.0) as u64).min(n - 3) + 1;
        let (x, y, z) = (axis(q.x, nx), axis(q.y, ny), axis(q.z, nz));
        (u64::from(c) << CLASS_SHIFT) | (((x * ny + y) * nz + z) << 1)
    }

    /// The key offsets of the 13 neighbours after a cell (those whose linear key is larger).
    fn half_shell(&self, c: u32) -> [u64; 13] {
        let (_, [_, ny, nz]) = self.cells[c as usize];
        let mut out = [0u64; 13];
        let mut k = 0;
        for dx in 0..=1i64 {
            for dy in -1..=1i64 {
                for dz in -1..=1i64 {
                    let d = (dx * ny as i64 + dy) * nz as i64 + dz;
                    if d > 0 {
                        out[k] = (d as u64) << 1;
                        k += 1;
                    }
                }
            }
        }
        out
    }
}

/// The point of triangle abc closest to p (Ericson, *Real-Time Collision Detection* 5.1.5).
pub fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom == 0.0 {
        // Degenerate triangle: its first corner.
        return a;
    }
    a + ab * (vb / denom) + ac * (vc / denom)
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
        assert!(triangles_cross(&vs, [0, 1, 2], [3, 4, 5], &mut None));
        assert!(!triangles_cross(&vs, [0, 1, 2], [2, 1, 6], &mut None));
        // Sharing vertex 0 and folding back over the first triangle.
        let vs2 = vec![
            DVec3::ZERO,
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
            DVec3::new(1.0, 1.0, 0.5),
            DVec3::new(0.5, 0.2, -0.5),
        ];
        assert!(triangles_cross(&vs2, [0, 1, 2], [0, 3, 4], &mut None));
        let m = Mesh {
            vertices: vs,
            normals: vec![DVec3::Z; 7],
            triangles: vec![[0, 1, 2], [3, 4, 5], [2, 1, 6]],
            sides: Vec::new(),
        };
        assert_eq!(intersecting_pairs(&m), vec![[0, 1]]);
        // A triangle with a corner not finite has no cell: it is left out (its key sorted
        // last and cut off), and the crossing among the others is still found.
        let mut m = m;
        m.vertices.extend([
            DVec3::new(f64::NAN, 0.0, 0.0),
            DVec3::new(0.0, f64::INFINITY, 0.0),
        ]);
        m.normals.resize(m.vertices.len(), DVec3::Z);
        m.triangles = vec![[7, 0, 1], [0, 1, 2], [8, 4, 5], [3, 4, 5], [7, 8, 2]];
        assert_eq!(intersecting_pairs(&m), vec![[1, 3]]);
    }

    /// The grid search with its plane rejection finds exactly the pairs that the exact test
    /// finds over all pairs, on soups of triangles of sizes over three orders of magnitude,
    /// many sharing corners (fans that fold) and many crossing; the same soups far from the
    /// origin (cell coordinates relative to the mesh, rounding at cell borders), spread
    /// wider than the finest grids can key (the one coarse grid), and with a fine class
    /// beside a coarse one.
    #[test]
    fn grid_search_finds_what_all_pairs_find() {
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut unit = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let places = [
            (DVec3::ZERO, 1.0),
            (DVec3::new(1.0e6, -3.0e5, 7.0e4), 1.0),
            (DVec3::new(-0.5, 0.25, 1.0), 1.0e7),
            (DVec3::new(3.0, 3.0, 3.0), 1.0e-3),
        ];
        let mut within = 0;
        for round in 0..40 {
            let (offset, spread) = places[round % places.len()];
            let mut vs = Vec::new();
            let mut tris = Vec::new();
            for _ in 0..150 {
                let size = 10f64.powf(-3.0 * unit());
                // In the wide soups, triangles in a few clusters (so that some still cross).
                let cluster = (unit() * 3.0).floor();
                let centre = if spread > 1.0 {
                    offset
                        + spread * DVec3::new(cluster, 0.5 * cluster, 0.0)
                        + DVec3::new(unit(), unit(), 0.2 * unit())
                } else {
                    offset + spread * DVec3::new(unit(), unit(), 0.2 * unit())
                };
                let corner = |unit: &mut dyn FnMut() -> f64| {
                    centre + size * DVec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5)
                };
                // (Not across the wide soup's clusters: a triangle 10⁷ long beside ones of
                // 10⁻³ is below the segment test's precision, boxes apart or not.)
                let reuse = !vs.is_empty() && unit() < 0.5 && spread <= 1.0;
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
                sides: Vec::new(),
            };
            assert!(
                !all.is_empty(),
                "round {round}: the soup should cross somewhere"
            );
            let brute: Vec<[u32; 2]> = (0..m.triangles.len() as u32)
                .flat_map(|i| (i + 1..m.triangles.len() as u32).map(move |j| [i, j]))
                .filter(|&[i, j]| {
                    triangles_cross(
                        &m.vertices,
                        m.triangles[i as usize],
                        m.triangles[j as usize],
                        &mut None,
                    )
                })
                .collect();
            // The plane rejection agrees with the segment tests where the coordinates leave
            // them digits (not at 10⁷ with triangles of 10⁻³: both are rounding there).
            if spread <= 1.0 {
                assert_eq!(brute, all, "round {round}: the plane rejection");
            }
            assert_eq!(intersecting_pairs(&m), brute, "round {round}");
            // With groups (three, and some triangles in every group's company): exactly the
            // pairs across groups or with an `ANY_GROUP` triangle.
            let groups: Vec<u32> = (0..m.triangles.len())
                .map(|_| match (unit() * 4.0) as u32 {
                    3 => ANY_GROUP,
                    g => g,
                })
                .collect();
            let across: Vec<[u32; 2]> = brute
                .iter()
                .copied()
                .filter(|&[i, j]| {
                    let (gi, gj) = (groups[i as usize], groups[j as usize]);
                    gi != gj || gi == ANY_GROUP
                })
                .collect();
            within += brute.len() - across.len();
            assert_eq!(
                intersecting_pairs_across(&m, Some(&groups)),
                across,
                "round {round}"
            );
        }
        assert!(within > 0, "no crossing pair within a group was left out");
    }
}
