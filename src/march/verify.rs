//! The check of a finished triangulation against its surface (docs/cli.md, docs/marcher.md): a mesh that
//! is not the surface is never returned as success. Checked: every edge in one or two
//! triangles, an interior edge once each way, an edge in one triangle only where the front
//! bookkeeping allows one (a given polygon's edge, or between border points on the box and
//! polygon vertices; never a chord between two polygon vertices), no two
//! triangles crossing, no triangle facing against ∇f at its corners, and the chord error at
//! every centroid and edge midpoint within the tolerance.
//!
//! Input: the marcher's mesh with its per-vertex facts. Output: the largest chord error and
//! every flaw found, each with a place and the local step there (where to refine).
//!
//! [`uncovered`] compares two meshes of one surface: whether every vertex of one lies near
//! the other (a uniform-step mesh against the local step's, `march::march_verified`).

use glam::DVec3;

use std::collections::HashMap;

use super::marcher::Triangulation;
use crate::mesh::Mesh;
use crate::mesh::check::{closest_on_triangle, intersecting_pairs_with_edges};
use crate::mesh::edges::Edges;
use crate::solve::surface_point;
use crate::solve::tolerance::SurfacePointTolerance;
use crate::surface::{Surface, ValueGrad};

/// One way a mesh is not its surface.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum Flaw {
    #[error("an edge in more than two triangles")]
    NonManifoldEdge,
    #[error("two triangles on one edge facing opposite ways")]
    Misoriented,
    #[error("an open edge where the mesh should be closed (not on a bound or the box)")]
    OpenEdge,
    #[error("triangles crossing each other")]
    Crossing,
    #[error("a triangle facing against the surface normal")]
    Folded,
    #[error("a chord error of {error:.3e} above the tolerance {tolerance:.3e}")]
    Chord { error: f64, tolerance: f64 },
}

/// A flaw at a place, with the local step the triangles there were made with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Found {
    pub flaw: Flaw,
    pub at: DVec3,
    pub h: f64,
}

/// What the verification found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Verdict {
    /// The largest distance from a centroid or an edge midpoint to the surface.
    pub max_chord_error: f64,
    /// Topological and crossing flaws (a wrong mesh).
    pub wrong: Vec<Found>,
    /// Places where the chord error exceeds the tolerance.
    pub coarse: Vec<Found>,
}

/// Checks `m` against `surface`; `tolerance` is the largest chord error allowed, `scale` the
/// length surfacepoint's tolerances are relative to (the step).
pub(super) fn verify(
    surface: &mut dyn Surface,
    m: &Triangulation,
    tolerance: f64,
    scale: f64,
    sp_tol: &SurfacePointTolerance,
) -> Verdict {
    let mesh = &m.mesh;
    // The edges' uses, for the edge flaws and for the crossing check's certificate alike.
    let edges = Edges::new(mesh.vertices.len(), &mesh.triangles);
    // The crossing check needs only the mesh: on another thread of the pool (`--threads`)
    // while this one evaluates the surface; the flaws are put together in the same order
    // either way.
    let mut pairs = Vec::new();
    let mut v = Verdict::default();
    if rayon::current_num_threads() > 1 {
        rayon::in_place_scope(|s| {
            s.spawn(|_| pairs = intersecting_pairs_with_edges(mesh, None, &edges));
            v = against_surface(surface, m, &edges, tolerance, scale, sp_tol);
        });
    } else {
        pairs = intersecting_pairs_with_edges(mesh, None, &edges);
        v = against_surface(surface, m, &edges, tolerance, scale, sp_tol);
    }
    let crossings = pairs.iter().flatten().map(|&t| {
        let t = &mesh.triangles[t as usize];
        Found {
            flaw: Flaw::Crossing,
            at: centroid(mesh, t),
            h: h_of(m, t),
        }
    });
    // Edge flaws first, then crossings, then folds (the order the first flaw is taken from).
    let edge_flaws = v
        .wrong
        .iter()
        .take_while(|f| f.flaw != Flaw::Folded)
        .count();
    v.wrong.splice(edge_flaws..edge_flaws, crossings);
    v
}

/// An edge of a given polygon (front or bound) that the mesh's flaws are laid to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoarseEdge {
    pub ends: [DVec3; 2],
    /// Its midpoint, as the chord errors' points are made (`against_surface`), bit for bit.
    pub mid: DVec3,
    pub length: f64,
    /// The smaller local step at its two ends.
    pub h: f64,
}

/// The first flaw (in `flaws`' order) that is a given polygon's, with that polygon's edge: a
/// chord error at the midpoint of one of its edges (the edge's own chord strays from the
/// surface), or any flaw within two edge lengths of an edge longer than `limit` local steps
/// at its ends (the marcher sees a polygon vertex only within `near_distance`·h of a front
/// point, so with `limit` = 2·`near_distance` a front may pass between the two vertices).
/// Refining cannot mend such a flaw: the polygon's vertices are given (shared with other
/// meshes), and a finer local step only makes its edges longer relative to the step.
pub(super) fn coarse_polygon_edge(
    m: &Triangulation,
    flaws: &[Found],
    limit: f64,
) -> Option<(CoarseEdge, Found)> {
    if flaws.is_empty() {
        return None;
    }
    let v = &m.mesh.vertices;
    let edges: Vec<CoarseEdge> = m
        .polygon_edges
        .iter()
        .map(|&[a, b]| {
            let (a, b) = (a as usize, b as usize);
            CoarseEdge {
                ends: [v[a], v[b]],
                mid: 0.5 * (v[a] + v[b]),
                length: v[a].distance(v[b]),
                h: m.h[a].min(m.h[b]),
            }
        })
        .collect();
    let mut midpoints: Vec<([u64; 3], usize)> = edges
        .iter()
        .enumerate()
        .map(|(i, e)| (e.mid.to_array().map(f64::to_bits), i))
        .collect();
    midpoints.sort_unstable();
    let coarse: Vec<&CoarseEdge> = edges.iter().filter(|e| e.length > limit * e.h).collect();
    flaws.iter().find_map(|f| {
        let own = matches!(f.flaw, Flaw::Chord { .. })
            .then(|| {
                let key = f.at.to_array().map(f64::to_bits);
                let i = midpoints.partition_point(|m| m.0 < key);
                midpoints.get(i).filter(|m| m.0 == key).map(|m| &edges[m.1])
            })
            .flatten();
        own.or_else(|| {
            coarse
                .iter()
                .find(|e| f.at.distance(e.mid) <= 2.0 * e.length)
                .copied()
        })
        .map(|e| (*e, *f))
    })
}

fn h_of(m: &Triangulation, t: &[u32; 3]) -> f64 {
    t.iter().map(|&k| m.h[k as usize]).fold(0.0f64, f64::max)
}

fn centroid(mesh: &crate::mesh::Mesh, t: &[u32; 3]) -> DVec3 {
    t.iter().map(|&k| mesh.vertices[k as usize]).sum::<DVec3>() / 3.0
}

/// Everything but the crossings: the edges' uses, the folds and the chord errors (edge flaws
/// before folds in `wrong`).
fn against_surface(
    surface: &mut dyn Surface,
    m: &Triangulation,
    edges: &Edges,
    tolerance: f64,
    scale: f64,
    sp_tol: &SurfacePointTolerance,
) -> Verdict {
    let mesh = &m.mesh;
    let vs = &mesh.vertices;
    let mut v = Verdict::default();
    // An edge may be open between border points and polygon vertices; between two polygon
    // vertices only if it is an edge of a given polygon (a missing triangle at a polygon's
    // corner leaves an open chord between two of them).
    let fixed = |k: u32| (k as usize) < m.fixed;
    let may_open = |k: u32| fixed(k) || m.border[k as usize];
    let allowed_open = |a: u32, b: u32| {
        if fixed(a) && fixed(b) {
            m.polygon_edges.binary_search(&[a.min(b), a.max(b)]).is_ok()
        } else {
            may_open(a) && may_open(b)
        }
    };
    // The chord error at every edge midpoint (in edge order), then at every centroid (in
    // triangle order), evaluated a batch at a time: no list of 2.5 points a triangle is kept.
    let mut chords = Chords {
        surface,
        tolerance,
        scale,
        sp_tol,
        points: Vec::with_capacity(BATCH),
        steps: Vec::with_capacity(BATCH),
        grads: Vec::new(),
    };
    for (a, b, run) in edges.runs() {
        let at = 0.5 * (vs[a as usize] + vs[b as usize]);
        let h = m.h[a as usize].max(m.h[b as usize]);
        let flaw = match run.len() {
            1 if !allowed_open(a, b) => Some(Flaw::OpenEdge),
            2 if run[0].forward() == run[1].forward() => Some(Flaw::Misoriented),
            n if n > 2 => Some(Flaw::NonManifoldEdge),
            _ => None,
        };
        if let Some(flaw) = flaw {
            v.wrong.push(Found { flaw, at, h });
        }
        chords.push(at, h, &mut v);
    }
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|k| vs[k as usize]);
        let n = (b - a).cross(c - a);
        let normals: DVec3 = t.iter().map(|&k| mesh.normals[k as usize]).sum();
        if n.dot(normals) <= 0.0 {
            v.wrong.push(Found {
                flaw: Flaw::Folded,
                at: centroid(mesh, t),
                h: h_of(m, t),
            });
        }
        chords.push(centroid(mesh, t), h_of(m, t), &mut v);
    }
    chords.flush(&mut v);
    v
}

/// Points whose chord error is to be checked: a batch's values and gradients in one call.
const BATCH: usize = 256;

/// The chord errors' points waiting for their batch, with the local steps there.
struct Chords<'a> {
    surface: &'a mut dyn Surface,
    tolerance: f64,
    scale: f64,
    sp_tol: &'a SurfacePointTolerance,
    points: Vec<DVec3>,
    steps: Vec<f64>,
    grads: Vec<ValueGrad>,
}

impl Chords<'_> {
    /// Checks the chord error at `at` (made with the local step `h`) into `v`: now or with
    /// its batch, in the order pushed either way.
    fn push(&mut self, at: DVec3, h: f64, v: &mut Verdict) {
        self.points.push(at);
        self.steps.push(h);
        if self.points.len() == BATCH {
            self.flush(v);
        }
    }

    /// The waiting points' chord errors into `v`: f and ∇f in one call where the surface
    /// allows, else point after point with each one's surface point (the order the warm
    /// starts of `dist` see).
    fn flush(&mut self, v: &mut Verdict) {
        let n = self.points.len();
        self.grads.resize(n, ValueGrad::default());
        let batched = self
            .surface
            .value_gradient_batch(&self.points, &mut self.grads);
        for i in 0..n {
            let (at, h) = (self.points[i], self.steps[i]);
            let vg = if batched {
                self.grads[i]
            } else {
                self.surface.value_gradient(at)
            };
            let error = chord_error(
                &mut *self.surface,
                at,
                vg,
                self.tolerance,
                self.scale,
                self.sp_tol,
            );
            v.max_chord_error = v.max_chord_error.max(error);
            if error > self.tolerance {
                v.coarse.push(Found {
                    flaw: Flaw::Chord {
                        error,
                        tolerance: self.tolerance,
                    },
                    at,
                    h,
                });
            }
        }
        self.points.clear();
        self.steps.clear();
    }
}

/// The distance from `q` to the surface, given f and ∇f there: the linear estimate |f|/|∇f|
/// where it is well below the tolerance (its error is second order), else the distance to
/// surfacepoint(q).
fn chord_error(
    surface: &mut dyn Surface,
    q: DVec3,
    vg: ValueGrad,
    tolerance: f64,
    scale: f64,
    sp_tol: &SurfacePointTolerance,
) -> f64 {
    let g = vg.gradient.length();
    if vg.value == 0.0 {
        return 0.0;
    }
    let estimate = vg.value.abs() / g;
    if estimate.is_finite() && estimate < 0.25 * tolerance {
        return estimate;
    }
    match surface_point(surface, q, scale, sp_tol) {
        Ok(sp) => sp.point.distance(q),
        // No surface point from here: as far from the surface as it gets.
        Err(_) => f64::INFINITY,
    }
}

/// Vertices of `reference` farther than `reach` from every triangle of `mesh`: how many, and
/// the farthest of the first `UNCOVERED_MEASURED` of them with its distance; None when
/// every vertex is within `reach`. Triangles are hashed into cells of side `reach` (each
/// into the cells its box grown by `reach` meets), so a vertex looks into its own cell only.
pub(super) fn uncovered(reference: &Mesh, mesh: &Mesh, reach: f64) -> Option<(DVec3, f64, usize)> {
    let cell = |p: DVec3| (p / reach).floor().to_array().map(|c| c as i64);
    let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = tri.map(|i| mesh.vertices[i as usize]);
        let (lo, hi) = (cell(a.min(b).min(c) - reach), cell(a.max(b).max(c) + reach));
        // A triangle longer than the search is ever made of (a degenerate input) is left
        // out rather than hashed into millions of cells: its vertices' cells still see it.
        if (0..3).any(|k| hi[k] - lo[k] > UNCOVERED_MAX_CELLS) {
            for p in [a, b, c] {
                cells.entry(cell(p)).or_default().push(t as u32);
            }
            continue;
        }
        for i in lo[0]..=hi[0] {
            for j in lo[1]..=hi[1] {
                for k in lo[2]..=hi[2] {
                    cells.entry([i, j, k]).or_default().push(t as u32);
                }
            }
        }
    }
    let distance = |p: DVec3, ts: &mut dyn Iterator<Item = u32>| {
        ts.map(|t| {
            let [a, b, c] = mesh.triangles[t as usize].map(|i| mesh.vertices[i as usize]);
            (closest_on_triangle(p, a, b, c) - p).length()
        })
        .fold(f64::INFINITY, f64::min)
    };
    let mut worst: Option<(DVec3, f64)> = None;
    let mut count = 0;
    for &p in &reference.vertices {
        let near = cells
            .get(&cell(p))
            .map_or(f64::INFINITY, |ts| distance(p, &mut ts.iter().copied()));
        if near <= reach {
            continue;
        }
        count += 1;
        if count > UNCOVERED_MEASURED {
            continue;
        }
        // How far it is, over every triangle.
        let d = distance(p, &mut (0..mesh.triangles.len() as u32));
        if worst.is_none_or(|(_, w)| d > w) {
            worst = Some((p, d));
        }
    }
    worst.map(|(p, d)| (p, d, count))
}

/// Cells along an axis a triangle may be hashed into in [`uncovered`].
const UNCOVERED_MAX_CELLS: i64 = 64;
/// Vertices [`uncovered`] measures the distance of (each against every triangle).
const UNCOVERED_MEASURED: usize = 64;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Mesh;
    use crate::surface::{NativeSurface, ValueGrad};

    /// The plane z = 0 (∇f = +z) and a pentagon 0…4 given as a polygon (fixed), meshed as a
    /// fan from vertex 0 with `triangles`.
    fn pentagon(triangles: Vec<[u32; 3]>) -> Verdict {
        let vertices: Vec<DVec3> = (0..5)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 5.0;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        let n = vertices.len();
        let mut polygon_edges: Vec<[u32; 2]> = (0..n as u32)
            .map(|i| {
                let j = (i + 1) % n as u32;
                [i.min(j), i.max(j)]
            })
            .collect();
        polygon_edges.sort_unstable();
        let m = Triangulation {
            mesh: Mesh {
                normals: vec![DVec3::Z; n],
                vertices,
                triangles,
                sides: Vec::new(),
            },
            border: vec![false; n],
            fixed: n,
            polygon_edges,
            h: vec![1.0; n],
            wanted: vec![1.0; n],
            floored: None,
        };
        let mut plane = NativeSurface(|p: DVec3| ValueGrad {
            value: p.z,
            gradient: DVec3::Z,
        });
        verify(&mut plane, &m, 0.1, 1.0, &SurfacePointTolerance::default())
    }

    #[test]
    fn a_polygon_meshed_whole_has_only_its_own_edges_open() {
        let v = pentagon(vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
        assert!(v.wrong.is_empty(), "{:?}", v.wrong);
    }

    #[test]
    fn a_triangle_missing_at_a_polygon_corner_is_an_open_edge() {
        // Without the triangle (0, 3, 4) the chord 0–3 between two polygon vertices is open:
        // polygon vertices at both ends do not make it allowed.
        let v = pentagon(vec![[0, 1, 2], [0, 2, 3]]);
        let open: Vec<_> = v
            .wrong
            .iter()
            .filter(|f| f.flaw == Flaw::OpenEdge)
            .collect();
        assert_eq!(open.len(), 1, "{:?}", v.wrong);
        let chord_middle = 0.5
            * (DVec3::new(1.0, 0.0, 0.0) + {
                let a = 3.0 * std::f64::consts::TAU / 5.0;
                DVec3::new(a.cos(), a.sin(), 0.0)
            });
        assert!(open[0].at.distance(chord_middle) < 1e-12, "{:?}", open[0]);
    }

    /// `uncovered`: a unit square of two triangles covers the points above it within the
    /// reach, not those beyond it nor a point off its side; the farthest is reported.
    #[test]
    fn uncovered_finds_the_points_far_from_the_mesh() {
        let square = Mesh {
            vertices: vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            ..Mesh::default()
        };
        let points = |ps: &[DVec3]| Mesh {
            vertices: ps.to_vec(),
            ..Mesh::default()
        };
        let near = points(&[DVec3::new(0.5, 0.5, 0.05), DVec3::new(1.04, 0.5, 0.0)]);
        assert_eq!(uncovered(&near, &square, 0.1), None);
        let far = points(&[
            DVec3::new(0.5, 0.5, 0.05),
            DVec3::new(0.2, 0.3, 0.5),
            DVec3::new(2.0, 0.5, 0.0),
        ]);
        let (p, d, count) = uncovered(&far, &square, 0.1).expect("two far points");
        assert_eq!((p, count), (DVec3::new(2.0, 0.5, 0.0), 2));
        assert!((d - 1.0).abs() < 1e-15, "{d}");
    }
}
