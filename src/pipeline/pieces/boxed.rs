//! Slabs of a component in a box (docs/pieces.md, *In a box*): the planes cut it along curves
//! that end on the box's faces, and the march makes its border points on the faces as its
//! fronts reach them, so two slabs would not share them. Here every curve the slabs end at is
//! traced first: the cut curves (surface ∩ plane, clipped to the box) and the border curves
//! (surface ∩ box face, clipped to each slab), meeting at *corners* — points on two planes
//! (a cut and a face, or two faces along a box edge), found by Newton along the line of the
//! two and again from a grid point, so that every curve that ends there finds the same bits
//! (the planes and the slabs are traced on the pool's threads, each on a fresh oracle). Each
//! slab's curves chain into closed polygons, which it marches as a component from a start
//! point's slab does (the first as front, the rest as bounds), in its part of the box two
//! steps larger: the polygons bound it. The join holds the mesh to the survey's boundary
//! loops and Euler characteristic, every boundary edge on the box's faces.

use glam::DVec3;
use rayon::prelude::*;

use super::{
    CROSS_SINE, MIN_LOOP, NoCut, Placed, Slabs, Survey, cut_into_slabs, local_step, near_all,
    slab_inputs,
};
use crate::march::{MarchInput, MarchSettings};
use crate::mesh::Mesh;
use crate::solve::curve::{self, nearest_on_segment};
use crate::solve::tolerance::CurveTolerance;
use crate::surface::{Fork, NativeSurface, Surface, ValueGrad};
use crate::survey::sizing::Sizing;

/// A curve the slabs end at: its points in order (for an open one, from corner to corner).
#[derive(Clone, Debug)]
struct Piece {
    points: Vec<DVec3>,
    closed: bool,
}

/// Newton along a corner's line stops at a step below this (× step).
const CORNER_STEP: f64 = 1e-13;
const CORNER_ITERATIONS: usize = 60;
/// A corner's Newton starts again from its first answer rounded to this fraction (a power of
/// two, × the step's power of two): curves that reach a corner from either side find the
/// same bits without asking one another (unless their first answers straddle a grid line,
/// about once in 10⁹; then the polygons do not chain and the component is marched whole).
const CORNER_GRID: i32 = 24;

/// The point of the surface on the line where the two coordinates `fixed` are held, nearest
/// `guess`: Newton along the line's free coordinate, then again from that rounded to a grid
/// (`CORNER_GRID`), so that every curve ending there gets the same point. None where Newton
/// fails or leaves the box.
fn corner(
    s: &mut dyn Surface,
    fixed: [(usize, f64); 2],
    guess: DVec3,
    step: f64,
    bbox: (DVec3, DVec3),
) -> Option<DVec3> {
    let free = 3 - fixed[0].0 - fixed[1].0;
    let mut p = guess;
    for (axis, value) in fixed {
        p[axis] = value;
    }
    let newton = |s: &mut dyn Surface, mut p: DVec3| -> Option<DVec3> {
        for _ in 0..CORNER_ITERATIONS {
            let vg = s.value_gradient(p);
            let d = vg.gradient[free];
            if !(vg.value.is_finite() && d.is_finite() && d != 0.0) {
                return None;
            }
            let du = vg.value / d;
            p[free] -= du;
            if du.abs() <= CORNER_STEP * step {
                return Some(p);
            }
        }
        None
    };
    let mut p = newton(s, p)?;
    let grid = 2f64.powi(step.log2().floor() as i32 - CORNER_GRID);
    p[free] = (p[free] / grid).round() * grid;
    let p = newton(s, p)?;
    let (lo, hi) = bbox;
    (lo[free]..=hi[free]).contains(&p[free]).then_some(p)
}

/// The plane `p[axis] = at` as a surface.
fn plane(axis: usize, at: f64) -> NativeSurface<impl FnMut(DVec3) -> ValueGrad> {
    let mut e = DVec3::ZERO;
    e[axis] = 1.0;
    NativeSurface(move |p: DVec3| ValueGrad {
        value: p[axis] - at,
        gradient: e,
    })
}

/// The wall of `bbox` that p lies on exactly, other than `except`'s axis: (axis, value).
fn wall_of(p: DVec3, bbox: (DVec3, DVec3), except: usize) -> Option<(usize, f64)> {
    (0..3).filter(|&k| k != except).find_map(|k| {
        if p[k] == bbox.0[k] {
            Some((k, bbox.0[k]))
        } else if p[k] == bbox.1[k] {
            Some((k, bbox.1[k]))
        } else {
            None
        }
    })
}

/// The boxed component's slabs, or None where it is small enough to march whole.
pub(super) fn plan(
    fork: &Fork<'_>,
    input: &MarchInput,
    settings: &MarchSettings,
) -> Result<Option<Slabs>, NoCut> {
    let Some(bbox) = input.bbox else {
        return Ok(None);
    };
    let step = input.step;
    cut_into_slabs(
        fork,
        input,
        settings,
        |topo| topo.non_manifold_edges.is_empty() && topo.misoriented_edges.is_empty(),
        |s, survey, sizing, axis, at| cut(s, survey, axis, at, step, settings, sizing, bbox),
        |survey, topo, sizing, axis, cuts| {
            slabs(
                fork,
                survey,
                &topo.boundary_edges,
                axis,
                &cuts,
                input,
                settings,
                sizing,
                bbox,
            )
        },
    )
}

/// The curves where the plane `p[axis] = at` cuts the surface in the box, traced from the
/// survey's section and checked as for a component out of a box, each open one from corner
/// to corner, oriented along ∇f × e_axis (the side below the plane on its left).
// The oracle, the survey, the plane, what the curves are sampled for, the box.
#[allow(clippy::too_many_arguments)]
fn cut(
    s: &mut dyn Surface,
    survey: &Survey,
    axis: usize,
    at: f64,
    step: f64,
    settings: &MarchSettings,
    sizing: &Sizing,
    bbox: (DVec3, DVec3),
) -> Result<Vec<Piece>, NoCut> {
    let refuse = |why| NoCut::Plane { axis, at, why };
    let sections = section(&survey.mesh, axis, at);
    if sections.is_empty() {
        return Err(refuse("the plane misses the surface"));
    }
    let mut e = DVec3::ZERO;
    e[axis] = 1.0;
    let mut pieces = Vec::with_capacity(sections.len());
    for (coarse, coarse_closed) in &sections {
        let seed = coarse[coarse.len() / 2];
        let piece = trace(
            s,
            &mut plane(axis, at),
            seed,
            step,
            settings,
            sizing,
            bbox,
            (axis, at),
        )
        .ok_or(refuse("a cut curve could not be traced to the box"))?;
        for (i, &p) in piece.points.iter().enumerate() {
            let g = s.value_gradient(p).gradient.normalize_or_zero();
            let sine = g.cross(e).length();
            if sine.is_nan() || sine < CROSS_SINE {
                return Err(refuse("the surface meets the plane at less than 30°"));
            }
            // Where it ends on a face, it crosses the face at 30° or more too.
            if !piece.closed && (i == 0 || i + 1 == piece.points.len()) {
                let Some((k, _)) = wall_of(p, bbox, axis) else {
                    return Err(refuse("a cut curve ends away from the box"));
                };
                let t = g.cross(e).normalize_or_zero();
                if t[k].abs() < CROSS_SINE {
                    return Err(refuse("a cut curve meets the box at less than 30°"));
                }
            }
        }
        if piece.points.len() < if piece.closed { MIN_LOOP } else { 3 } {
            return Err(refuse("a cut curve is tiny"));
        }
        let reach = 0.5 * survey.step;
        if !near_all(&piece.points, coarse, *coarse_closed, reach)
            || !near_all(coarse, &piece.points, piece.closed, reach)
        {
            return Err(refuse(
                "a traced cut curve does not follow its coarse section",
            ));
        }
        if pieces.iter().any(|other: &Piece| {
            other
                .points
                .iter()
                .any(|p| piece.points.iter().any(|q| p.distance(*q) < survey.step))
        }) {
            return Err(refuse("two cut curves come closer than a coarse step"));
        }
        pieces.push(piece);
    }
    Ok(pieces)
}

/// Surface ∩ `other` (a plane p[on.0] = on.1) traced from `seed` inside `bbox`, at the step
/// and again at the smallest local step along it where that is smaller: closed, or open
/// with both ends moved onto corners (the plane and the wall of `bbox` it left by). The
/// points keep the plane's coordinate exactly. None where the trace fails.
// The oracle, the plane, where to start, what the curve is sampled for, the box, the plane's
// coordinate.
#[allow(clippy::too_many_arguments)]
fn trace(
    s: &mut dyn Surface,
    other: &mut dyn Surface,
    seed: DVec3,
    step: f64,
    settings: &MarchSettings,
    sizing: &Sizing,
    bbox: (DVec3, DVec3),
    on: (usize, f64),
) -> Option<Piece> {
    let tol = CurveTolerance::default();
    // Along the plane's own axis the clip box reaches a step either side of the plane: the
    // trace lies in the plane (to rounding) and must not be taken for leaving through it.
    let mut inner = bbox;
    inner.0[on.0] = on.1 - step;
    inner.1[on.0] = on.1 + step;
    let mut h = step;
    let mut polygon = None;
    for _ in 0..2 {
        let traced = curve::intersection_with(s, other, seed, h, Some(inner), &tol).ok()?;
        let local = traced
            .points
            .iter()
            .map(|&p| local_step(s, sizing, p))
            .fold(step, f64::min);
        polygon = Some(traced);
        if local >= 0.98 * h {
            break;
        }
        if local < 1.25 * settings.polygon_edge_min * step {
            return None;
        }
        h = local;
    }
    let polygon = polygon?;
    let mut points = polygon.points;
    for p in &mut points {
        p[on.0] = on.1;
    }
    if !polygon.closed {
        let last = points.len() - 1;
        for i in [0, last] {
            let wall = wall_of(points[i], inner, on.0)?;
            points[i] = corner(s, [on, wall], points[i], step, bbox)?;
        }
        if points[0] == points[last] || points.windows(2).any(|w| w[0] == w[1]) {
            return None;
        }
    }
    Some(Piece {
        points,
        closed: polygon.closed,
    })
}

/// The section of the survey (a mesh with boundary) with the plane `p[axis] = at`:
/// polylines through the crossed edges (a point on each), open ones from boundary edge to
/// boundary edge, with whether they close.
fn section(mesh: &Mesh, axis: usize, at: f64) -> Vec<(Vec<DVec3>, bool)> {
    use std::collections::BTreeMap;
    let above = |k: u32| mesh.vertices[k as usize][axis] >= at;
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    // Each crossed edge's crossed triangles' other crossed edges.
    let mut links: BTreeMap<(u32, u32), Vec<(u32, u32)>> = BTreeMap::new();
    for t in &mesh.triangles {
        let crossed: Vec<(u32, u32)> = (0..3)
            .map(|k| (t[k], t[(k + 1) % 3]))
            .filter(|&(a, b)| above(a) != above(b))
            .map(|(a, b)| key(a, b))
            .collect();
        if let [x, y] = crossed[..] {
            links.entry(x).or_default().push(y);
            links.entry(y).or_default().push(x);
        }
    }
    let point = |(a, b): (u32, u32)| {
        let (p, q) = (mesh.vertices[a as usize], mesh.vertices[b as usize]);
        let t = (at - p[axis]) / (q[axis] - p[axis]);
        p + t * (q - p)
    };
    let mut used: std::collections::BTreeSet<(u32, u32)> = Default::default();
    let mut out = Vec::new();
    // Open chains from their ends (edges in one crossed triangle), then closed ones.
    let ends: Vec<(u32, u32)> = links
        .iter()
        .filter(|(_, l)| l.len() == 1)
        .map(|(e, _)| *e)
        .collect();
    let starts = ends.iter().chain(links.keys()).copied().collect::<Vec<_>>();
    for start in starts {
        if used.contains(&start) {
            continue;
        }
        let mut chain = vec![point(start)];
        used.insert(start);
        let mut at_edge = start;
        let closed;
        loop {
            let next = links[&at_edge].iter().find(|e| !used.contains(e)).copied();
            match next {
                Some(e) => {
                    used.insert(e);
                    chain.push(point(e));
                    at_edge = e;
                }
                None => {
                    closed = links[&at_edge].len() == 2 && links[&at_edge].contains(&start);
                    break;
                }
            }
        }
        out.push((chain, closed));
    }
    out
}

/// The slabs between the cuts: each slab's border curves on the box's faces, chained with
/// its cut curves into closed polygons; the slabs on the pool's threads, each on a fresh
/// oracle.
// The oracles, the survey and its boundary edges, the cuts, the block, what the curves are
// sampled for, the box.
#[allow(clippy::too_many_arguments)]
fn slabs(
    fork: &Fork<'_>,
    survey: &Survey,
    boundary: &[[u32; 2]],
    axis: usize,
    cuts: &[Placed<Vec<Piece>>],
    input: &MarchInput,
    settings: &MarchSettings,
    sizing: &Sizing,
    bbox: (DVec3, DVec3),
) -> Result<Slabs, NoCut> {
    let step = input.step;
    let at: Vec<f64> = cuts.iter().map(|c| c.at).collect();
    let polygons: Vec<Result<Vec<Vec<DVec3>>, NoCut>> = (0..=cuts.len())
        .into_par_iter()
        .map(|k| {
            let mut s = fork().ok_or(NoCut::Fork)?;
            slab_polygons(
                &mut *s, survey, boundary, axis, cuts, k, step, settings, sizing, bbox,
            )
        })
        .collect();
    let polygons = polygons.into_iter().collect::<Result<Vec<_>, _>>()?;
    let mut shared: Vec<DVec3> = polygons.iter().flatten().flatten().copied().collect();
    shared.sort_by(|a, b| {
        a.to_array()
            .map(f64::to_bits)
            .cmp(&b.to_array().map(f64::to_bits))
    });
    shared.dedup();
    let estimates = survey.estimates(axis, &at);
    let mut inputs = slab_inputs(input, settings, polygons, &estimates);
    // Each slab in its box two steps larger all round: its polygons bound it, and a front
    // that got past them (a border curve the survey did not see) stops there, and the slab is
    // refused at once, rather than marching on round the surface to its share.
    for (k, inp) in inputs.iter_mut().enumerate() {
        let slab = slab_box(bbox, axis, &at, k);
        inp.bbox = Some((
            slab.0 - DVec3::splat(2.0 * step),
            slab.1 + DVec3::splat(2.0 * step),
        ));
    }
    Ok(Slabs {
        axis,
        planes: at,
        inputs,
        shared,
        cuts: cuts
            .iter()
            .flat_map(|c| c.loops.iter().map(|p| p.points.clone()))
            .collect(),
        chi: 0,
        boundary_loops: 0,
        bbox: Some(bbox),
    })
}

/// Slab k's part of the box: between the planes `at` across `axis`.
fn slab_box(bbox: (DVec3, DVec3), axis: usize, at: &[f64], k: usize) -> (DVec3, DVec3) {
    let mut slab = bbox;
    if k > 0 {
        slab.0[axis] = at[k - 1];
    }
    if k < at.len() {
        slab.1[axis] = at[k];
    }
    slab
}

/// Slab k's closed polygons: its cut curves (the upper plane's as traced, the lower's
/// reversed) and its border curves, traced from the survey's `boundary` edges on each face in
/// the slab (one trace a run of them), chained end to start.
// The oracle, the survey and its boundary, the cuts, the slab, what the curves are sampled
// for, the box.
#[allow(clippy::too_many_arguments)]
fn slab_polygons(
    s: &mut dyn Surface,
    survey: &Survey,
    boundary: &[[u32; 2]],
    axis: usize,
    cuts: &[Placed<Vec<Piece>>],
    k: usize,
    step: f64,
    settings: &MarchSettings,
    sizing: &Sizing,
    bbox: (DVec3, DVec3),
) -> Result<Vec<Vec<DVec3>>, NoCut> {
    let at: Vec<f64> = cuts.iter().map(|c| c.at).collect();
    let place = at.get(k).copied().unwrap_or(bbox.1[axis]);
    let refuse = |why| NoCut::Plane {
        axis,
        at: place,
        why,
    };
    let mesh = &survey.mesh;
    let slab = slab_box(bbox, axis, &at, k);
    let mut pieces: Vec<Piece> = Vec::new();
    if let Some(c) = cuts.get(k) {
        pieces.extend(c.loops.iter().cloned());
    }
    if k > 0 {
        pieces.extend(cuts[k - 1].loops.iter().map(|p| {
            let mut r = p.clone();
            r.points.reverse();
            r
        }));
    }
    for face_axis in 0..3 {
        for (side, wall) in [(-1.0, bbox.0[face_axis]), (1.0, bbox.1[face_axis])] {
            if face_axis == axis && !(slab.0[axis]..=slab.1[axis]).contains(&wall) {
                continue;
            }
            // A face across the axis is the slab's whole; on a face along it, the edges
            // whose midpoints are strictly between the slab's planes.
            let seeds: Vec<DVec3> = boundary
                .iter()
                .filter_map(|&[a, b]| {
                    let (p, q) = (mesh.vertices[a as usize], mesh.vertices[b as usize]);
                    let mid = 0.5 * (p + q);
                    (p[face_axis] == wall
                        && q[face_axis] == wall
                        && (face_axis == axis
                            || (mid[axis] > slab.0[axis] && mid[axis] < slab.1[axis])))
                        .then_some(mid)
                })
                .collect();
            let mut traced: Vec<Piece> = Vec::new();
            for seed in seeds {
                // A seed on a curve already traced from another.
                let on_traced = traced.iter().any(|t| {
                    t.points.windows(2).any(|w| {
                        let (u, v) = (w[0], w[1]);
                        (u + nearest_on_segment(seed, u, v) * (v - u)).distance(seed)
                            <= 0.5 * survey.step
                    })
                });
                if on_traced {
                    continue;
                }
                let mut piece = trace(
                    s,
                    &mut plane(face_axis, wall),
                    seed,
                    step,
                    settings,
                    sizing,
                    slab,
                    (face_axis, wall),
                )
                .ok_or(refuse("a border curve could not be traced"))?;
                // Traced along ∇f × e: the box's inside on its left on the upper face.
                if side < 0.0 {
                    piece.points.reverse();
                }
                traced.push(piece);
            }
            pieces.extend(traced);
        }
    }
    let loops = chain(pieces).ok_or(refuse("a slab's curves do not chain into closed polygons"))?;
    let (min, max) = (
        settings.polygon_edge_min * step,
        settings.polygon_edge_max * step,
    );
    for l in &loops {
        for i in 0..l.len() {
            let length = l[i].distance(l[(i + 1) % l.len()]);
            if !(length >= min && length <= max) {
                return Err(refuse("a slab's polygon has an edge too short or too long"));
            }
        }
    }
    if crate::trace::enabled() {
        for l in &loops {
            let (lo, hi) = l.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), &v| (lo.min(v), hi.max(v)),
            );
            eprintln!(
                "pieces: slab {k}: a polygon of {} vertices in {lo} .. {hi}",
                l.len()
            );
        }
    }
    Ok(loops)
}

/// The pieces chained into closed polygons: a closed piece is one; an open one goes on with
/// the piece that starts at its last point (a corner, bit for bit). None where a piece has
/// no follower or two.
fn chain(pieces: Vec<Piece>) -> Option<Vec<Vec<DVec3>>> {
    let bits = |p: DVec3| p.to_array().map(f64::to_bits);
    let mut loops = Vec::new();
    let mut open: Vec<Piece> = Vec::new();
    for p in pieces {
        if p.closed {
            loops.push(p.points);
        } else {
            open.push(p);
        }
    }
    let starts: Vec<[u64; 3]> = open.iter().map(|p| bits(p.points[0])).collect();
    if (1..starts.len()).any(|i| starts[..i].contains(&starts[i])) {
        return None;
    }
    let mut used = vec![false; open.len()];
    for first in 0..open.len() {
        if used[first] {
            continue;
        }
        let mut polygon = Vec::new();
        let mut at = first;
        loop {
            used[at] = true;
            let points = &open[at].points;
            polygon.extend_from_slice(&points[..points.len() - 1]);
            let end = bits(points[points.len() - 1]);
            let next = starts.iter().position(|&s| s == end)?;
            if next == first {
                break;
            }
            if used[next] {
                return None;
            }
            at = next;
        }
        loops.push(polygon);
    }
    Some(loops)
}
