//! The check of a finished triangulation against its surface (DESIGN.md §3, §4a): a mesh that
//! is not the surface is never returned as success. Checked: every edge in one or two
//! triangles, an interior edge once each way, an edge in one triangle only where the front
//! bookkeeping allows one (between polygon vertices or border points on the box), no two
//! triangles crossing, no triangle facing against ∇f at its corners, and the chord error at
//! every centroid and edge midpoint within the tolerance.
//!
//! Input: the marcher's mesh with its per-vertex facts. Output: the largest chord error and
//! every flaw found, each with a place and the local step there (where to refine).

use glam::DVec3;

use super::marcher::Triangulation;
use crate::mesh::check::intersecting_pairs;
use crate::solve::surface_point;
use crate::solve::tolerance::SurfacePointTolerance;
use crate::surface::Surface;

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
    let vs = &mesh.vertices;
    let mut v = Verdict::default();
    let h_of = |t: &[u32; 3]| t.iter().map(|&k| m.h[k as usize]).fold(0.0f64, f64::max);
    let centroid = |t: &[u32; 3]| t.iter().map(|&k| vs[k as usize]).sum::<DVec3>() / 3.0;

    // Edges as (lo, hi, direction), sorted: uses of one edge are adjacent.
    let mut edges: Vec<(u32, u32, bool, u32)> = Vec::with_capacity(3 * mesh.triangles.len());
    for (i, t) in mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b), a < b, i as u32));
        }
    }
    edges.sort_unstable();
    let allowed_open = |k: u32| (k as usize) < m.fixed || m.border[k as usize];
    let mut midpoints = Vec::with_capacity(edges.len() / 2 + 1);
    let mut i = 0;
    while i < edges.len() {
        let (a, b) = (edges[i].0, edges[i].1);
        let mut j = i;
        while j < edges.len() && edges[j].0 == a && edges[j].1 == b {
            j += 1;
        }
        let at = 0.5 * (vs[a as usize] + vs[b as usize]);
        let h = m.h[a as usize].max(m.h[b as usize]);
        let flaw = match j - i {
            1 if !(allowed_open(a) && allowed_open(b)) => Some(Flaw::OpenEdge),
            2 if edges[i].2 == edges[i + 1].2 => Some(Flaw::Misoriented),
            n if n > 2 => Some(Flaw::NonManifoldEdge),
            _ => None,
        };
        if let Some(flaw) = flaw {
            v.wrong.push(Found { flaw, at, h });
        }
        midpoints.push((at, h));
        i = j;
    }

    for pair in intersecting_pairs(mesh) {
        for t in pair {
            let t = &mesh.triangles[t as usize];
            v.wrong.push(Found {
                flaw: Flaw::Crossing,
                at: centroid(t),
                h: h_of(t),
            });
        }
    }

    let mut chord_points = midpoints;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|k| vs[k as usize]);
        let n = (b - a).cross(c - a);
        let normals: DVec3 = t.iter().map(|&k| mesh.normals[k as usize]).sum();
        if n.dot(normals) <= 0.0 {
            v.wrong.push(Found {
                flaw: Flaw::Folded,
                at: centroid(t),
                h: h_of(t),
            });
        }
        chord_points.push((centroid(t), h_of(t)));
    }
    for (at, h) in chord_points {
        let error = chord_error(surface, at, tolerance, scale, sp_tol);
        v.max_chord_error = v.max_chord_error.max(error);
        if error > tolerance {
            v.coarse.push(Found {
                flaw: Flaw::Chord { error, tolerance },
                at,
                h,
            });
        }
    }
    v
}

/// The distance from `q` to the surface: the linear estimate |f|/|∇f| where it is well below
/// the tolerance (its error is second order), else the distance to surfacepoint(q).
fn chord_error(
    surface: &mut dyn Surface,
    q: DVec3,
    tolerance: f64,
    scale: f64,
    sp_tol: &SurfacePointTolerance,
) -> f64 {
    let vg = surface.value_gradient(q);
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
