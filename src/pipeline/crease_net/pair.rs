//! Creases in phase across narrow faces. A face a few rows wide between two creases (a
//! plate's rim, the wall of a hole, a rib's top, a ring round a boss) marches into whole rows
//! of near-equilateral triangles only where the vertices of its two creases are in phase:
//! opposite one another for an even number of rows, staggered by half an edge for an odd
//! number. Resampled each on its own, the two creases meet out of phase wherever their local
//! steps or starting points differ, and the strip's middle takes the difference up with a
//! dislocation (a run of triangles of radius ratio 0.8–0.9; a hole's two rims start wherever
//! their traces began). So once a crease's polygon is made, each narrow face beside it is
//! walked across (`width::across`) from its vertices and its edges' midpoints, and the places
//! where the walks end on the crease at the far side are given to that crease, which is
//! resampled through them (`Tracer::resample`) if it is not made yet. Polygons are made in
//! the traced order, so the first crease of a chain of strips sets their phase.

use std::collections::HashMap;

use glam::DVec3;

use super::trace::{Traced, Tracer};
use super::width;
use crate::solve::curve::nearest_on_segment;

/// A walk's end counts as on a crease within this fraction of the step of its fine line.
const ON_CREASE: f64 = 0.05;
/// The two creases of a strip run side by side: |cos| of their tangents at least this.
const SIDE_BY_SIDE: f64 = 0.9;

/// The traced creases' fine segments by cell of side `step`, for the crease nearest a point.
pub(super) struct FineIndex {
    cell: f64,
    cells: HashMap<[i64; 3], Vec<(u32, u32)>>,
}

impl FineIndex {
    pub fn new(traced: &[Traced], step: f64) -> FineIndex {
        let mut cells: HashMap<[i64; 3], Vec<(u32, u32)>> = HashMap::new();
        for (c, tr) in traced.iter().enumerate() {
            let m = tr.points.len();
            let segments = if tr.ends.is_none() {
                m
            } else {
                m.saturating_sub(1)
            };
            for s in 0..segments {
                let mid = tr.points[s].lerp(tr.points[(s + 1) % m], 0.5);
                cells
                    .entry(key(mid, step))
                    .or_default()
                    .push((c as u32, s as u32));
            }
        }
        FineIndex { cell: step, cells }
    }

    /// The crease whose fine line passes through q (a walk's end across a face), if it runs
    /// beside the crease whose tangent is given: the face between them is a strip.
    pub fn beside(&self, traced: &[Traced], q: DVec3, tangent: DVec3, step: f64) -> Option<usize> {
        let (b, d, tb) = self.nearest(traced, q)?;
        (d <= ON_CREASE * step && tb.dot(tangent).abs() >= SIDE_BY_SIDE).then_some(b)
    }

    /// The crease whose fine line passes nearest q (within a cell or so): its index, the
    /// distance and the unit direction of the nearest segment.
    fn nearest(&self, traced: &[Traced], q: DVec3) -> Option<(usize, f64, DVec3)> {
        let k = key(q, self.cell);
        let mut best: Option<(usize, f64, DVec3)> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(list) = self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) else {
                        continue;
                    };
                    for &(c, s) in list {
                        let pts = &traced[c as usize].points;
                        let (a, b) = (pts[s as usize], pts[(s as usize + 1) % pts.len()]);
                        let d = q.distance(a.lerp(b, nearest_on_segment(q, a, b)));
                        if best.is_none_or(|(_, e, _)| d < e) {
                            best = Some((c as usize, d, (b - a).normalize_or_zero()));
                        }
                    }
                }
            }
        }
        best
    }
}

fn key(p: DVec3, cell: f64) -> [i64; 3] {
    let c = (p / cell).floor();
    [c.x as i64, c.y as i64, c.z as i64]
}

/// A place a crease is wanted to have a vertex at, and the edge length of the polygon that
/// asks for it (the rows fit that length).
#[derive(Clone, Copy, Debug)]
pub(super) struct Wanted {
    pub at: DVec3,
    pub edge: f64,
}

/// The places the creases across the narrow faces beside crease `a` (its polygon `poly`)
/// want vertices at, for those not made yet (`made`): (crease, place near it).
pub(super) fn across(
    t: &mut Tracer<'_>,
    traced: &[Traced],
    index: &FineIndex,
    a: usize,
    poly: &[DVec3],
    made: &[bool],
) -> Vec<(usize, Wanted)> {
    let tr = &traced[a];
    let n = poly.len();
    if tr.seam.is_some() || n < 2 {
        return Vec::new();
    }
    let closed = tr.ends.is_none();
    let (i, j) = tr.forms;
    let faces = [t.c.class(i), t.c.class(j)];
    // Stations: the inner vertices (an even number of rows puts the far crease's vertices
    // opposite them) and the edges' midpoints (an odd number): (point, tangent, edge, vertex).
    let mut stations: Vec<(DVec3, DVec3, f64, bool)> = Vec::with_capacity(2 * n);
    let edges = if closed { n } else { n - 1 };
    for e in 0..edges {
        let (p0, p1) = (poly[e], poly[(e + 1) % n]);
        if closed || e > 0 {
            let before = poly[(e + n - 1) % n];
            let edge = 0.5 * (p0.distance(before) + p0.distance(p1));
            stations.push((p0, p1 - before, edge, true));
        }
        stations.push((p0.lerp(p1, 0.5), p1 - p0, p0.distance(p1), false));
    }
    let mut out = Vec::new();
    for (p, tangent, edge, vertex) in stations {
        let Some(tangent) = tangent.try_normalize() else {
            continue;
        };
        for (form, face) in [(i, faces[0]), (j, faces[1])] {
            let Some((w, Some(q))) = width::across(t, form, p, tangent) else {
                continue;
            };
            let Some(rows) = width::rows(w, edge) else {
                continue;
            };
            if (rows % 2 == 0) != vertex {
                continue;
            }
            let Some(b) = index.beside(traced, q, tangent, t.step) else {
                continue;
            };
            if b == a || made[b] || traced[b].seam.is_some() {
                continue;
            }
            let (bi, bj) = traced[b].forms;
            if t.c.class(bi) == face || t.c.class(bj) == face {
                out.push((b, Wanted { at: q, edge }));
            }
        }
    }
    out
}
