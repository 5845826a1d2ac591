//! Parallel pieces (docs/pieces.md, issues 14 and 41): one large component marched
//! from a start point is cut along planes into slabs, the cut curves (surface ∩ plane) are
//! traced once and shared as polygons between the two slabs they separate (the paper's
//! coherent nets, Sects. 3.9 and 3.11), and each slab is marched on its own thread of the
//! rayon pool. The slabs are joined by their bit-identical polygon vertices into one mesh.
//!
//! 1. Survey: a coarse march (`COARSE` × the step, no quality stage) from the same start
//!    gives the component's extent, area and topology. Its area over √3/4·step² estimates
//!    the triangle count; below `MarchSettings::pieces_above` the component is marched
//!    whole. Otherwise it is cut into n = ⌈estimate / piece_triangles⌉ slabs rounded up to a
//!    power of two (2 ..= `pieces_max`: 2, 4 or 8 threads share them evenly), of equal width
//!    along the longest axis of its extent. n depends only on the surface and the settings,
//!    never on the number of threads.
//! 2. Cuts: for each plane, the coarse mesh's section (closed polylines) seeds one trace per
//!    loop (`solve::curve::intersection_with`, the plane as second surface), sampled at the
//!    smallest local step along the loop. A plane is taken only if every loop closes, follows
//!    its coarse loop (each within half a coarse step of the other), crosses the plane at 30°
//!    or more (`CROSS_SINE`), has at least `MIN_LOOP` vertices, and stays a coarse step away
//!    from the plane's other loops. (Where the survey fails at `COARSE` steps, it is made
//!    at half that.) Else the plane is shifted (`SHIFTS` of the slab width), then the next
//!    axis is tried, then half as many slabs, then the component is marched whole. The
//!    planes of an axis are cut on the pool's threads, each on a fresh oracle. A component
//!    in a box (`boxed`) has its cut curves end on the box's faces, and its slabs' border
//!    curves on the faces traced too: every slab is bounded by closed polygons.
//! 3. Pieces: slab k marches with the loops of its upper plane as traced (the traced
//!    direction ∇f × e_axis has the side below the plane on its left) and those of its lower
//!    plane reversed, the first as front, the rest as bounds; each on a fresh oracle from the
//!    fork, so its mesh is the same whichever thread runs it. Every piece is verified by the
//!    marcher as usual.
//! 4. Join: every vertex of a piece lies in its slab (and box), the joined mesh is oriented,
//!    closed but on the box's faces, one component, with the coarse mesh's Euler
//!    characteristic and boundary loops, no two triangles near a
//!    plane cross, and no triangle at a cut polygon is below `CUT_ANGLE` (unless the mesh
//!    has a smaller angle away from the cuts too: the cut must not be the worst place).
//!    Anything else, or any failure on the way, marches the component whole
//!    (as before this stage): a cut is an optimisation and never decides what the mesh is.
//!
//! Deterministic: planes, loops, pieces and the join follow fixed orders; results are taken
//! in slab order.

mod boxed;
mod seams;

use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use super::crease_net::merge_at;
use crate::march::settings::DEFAULT_QUALITY_RATIO;
use crate::march::{self, Held, MarchError, MarchInput, MarchSettings, Marched, Start};
use crate::mesh::Mesh;
use crate::mesh::check::intersecting_pairs_across;
use crate::mesh::quality::{self, Quality};
use crate::mesh::topology::{Topology, topology};
use crate::solve::SurfacePoint;
use crate::solve::curve::{self, CurveError, nearest_on_segment};
use crate::solve::surfacepoint::tangent_frame;
use crate::solve::tolerance::CurveTolerance;
use crate::surface::Fork;
use crate::surface::{NativeSurface, Surface, ValueGrad};
use crate::survey::sizing::{Sizing, SizingSettings};

/// The coarse survey marches at this many steps.
pub const COARSE: f64 = 8.0;
/// The coarse survey stops (and nothing is cut) above this many triangles.
const COARSE_LIMIT: u64 = 200_000;
/// A cut loop must cross its plane at 30° or more: |n × e_axis| ≥ 0.5 at every vertex. Near
/// a tangent contact the fronts on either side would leave their slab.
pub const CROSS_SINE: f64 = 0.5;
/// The fewest vertices of a cut loop (a tiny loop is refused).
pub const MIN_LOOP: usize = 8;
/// Positions tried for a plane, as fractions of the slab width from its place.
const SHIFTS: [f64; 5] = [0.0, 0.1, -0.1, 0.2, -0.2];
/// A piece's vertex may be this far (× step) beyond its slab's planes (the cut vertices lie
/// on the planes to rounding).
const SLAB_MARGIN: f64 = 1e-6;
/// The quality bar at the cut polygons (docs/quality.md, degrees): a triangle there below it,
/// and below every triangle away from the cuts, refuses the cut.
pub const CUT_ANGLE: f64 = 30.0;
/// The quality stage's aim (`MarchSettings::quality_ratio`), or the default aim where it is
/// higher, less this is the least mean radius ratio the joined slabs may have: the default
/// aim 0.975 is docs/quality.md's bar of 0.97 with this margin. (A higher aim is what the
/// stage strives for, not a bar: held to it, the sphere's slabs at step 0.03 with
/// `radius_ratio: 1` were refused at 0.9926 and the whole march made 0.9844.)
const RATIO_MARGIN: f64 = 0.005;
/// A slab may make this many times the triangles the survey's area in it estimates, plus
/// `SLAB_SHARE_MIN`, before its march is stopped (and the component marched whole).
const SLAB_SHARE: f64 = 4.0;
const SLAB_SHARE_MIN: u64 = 20_000;
/// Above the default aim a component is cut into slabs of a `ROUNDER_SLABS`th of
/// `MarchSettings::piece_triangles`: rows that start from a cut polygon are the march's most
/// regular, and the more of the surface lies near one, the rounder its triangles (the fine
/// torus at `radius_ratio: 0.995`: 3.3 % of its vertices of a valence other than 6 and a mean
/// radius ratio of 0.9937 in 8 slabs, 15 % and 0.9877 in 2). Not at the default aim: there
/// the seams are not polished, and the sphere at step 0.03 made 0.9862 in 4 slabs against
/// 0.9877 in 2.
const ROUNDER_SLABS: u64 = 4;
/// Triangles within this many steps of a plane are checked for crossings across pieces.
const BAND: f64 = 3.0;

/// A component marched whole or in pieces.
#[derive(Clone, Debug, PartialEq)]
pub struct Pieced {
    pub marched: Marched,
    /// Slabs marched: 1 when the component was marched whole.
    pub pieces: usize,
    /// The cut polygons, each shared by two slabs (as traced: the slab below on its left).
    pub cuts: Vec<Vec<DVec3>>,
    /// The axis cut across (0, 1, 2 for x, y, z) and the planes' positions along it.
    pub planes: Option<(usize, Vec<f64>)>,
    /// The joined mesh's topology and shape statistics as the join checked them (None when
    /// marched whole): the report takes them rather than computing them again.
    pub measured: Option<(Topology, Quality)>,
}

/// Why a component was marched whole; only for the trace.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NoCut {
    #[error("no fresh oracle of the surface")]
    Fork,
    #[error("the coarse survey failed: {0}")]
    Coarse(MarchError),
    #[error("the coarse survey is not one closed surface")]
    CoarseOpen,
    #[error("the coarse section at {at} along axis {axis} does not close into loops")]
    Section { axis: usize, at: f64 },
    #[error("no plane across axis {axis} near {at} can be cut reliably: {why}")]
    Plane {
        axis: usize,
        at: f64,
        why: &'static str,
    },
    #[error("a cut curve could not be traced: {0}")]
    Trace(CurveError),
    #[error("piece {piece}: {source}")]
    Piece { piece: usize, source: MarchError },
    #[error("piece {piece} reaches {at}, beyond its slab")]
    Slab { piece: usize, at: DVec3 },
    #[error("the pieces do not join into one closed surface: {0}")]
    Joined(&'static str),
    #[error(
        "a triangle at a cut polygon has a smallest angle of {degrees:.2}°, below 30° and below every triangle away from the cuts"
    )]
    Angle { degrees: f64 },
    #[error("the slabs' mean radius ratio {mean:.4} is below {bar:.4}")]
    Ratio { mean: f64, bar: f64 },
    #[error("the pieces have {total} triangles, more than the limit {limit}")]
    Limit { total: u64, limit: u64 },
}

/// What was cut at one plane: its position and what the cut made (the loops as traced).
#[derive(Clone, Debug)]
pub(super) struct Placed<T> {
    pub at: f64,
    pub loops: T,
}

/// The cut of one plane of a component that is not in a box: closed loops.
type Cut = Placed<Vec<Vec<DVec3>>>;

/// Marches `input` as `march::march_verified` does; a large component from a start point
/// (no bounds, not uniform, in a box or not) with a `fork` is cut into slabs marched on the rayon pool
/// as the module documentation says. Errors are those of the whole march: a component that
/// cannot be cut, or whose pieces fail, is marched whole.
pub fn march(
    surface: &mut dyn Surface,
    fork: Option<&Fork<'_>>,
    input: &MarchInput,
    settings: &MarchSettings,
    progress: Option<&AtomicU64>,
) -> Result<Pieced, MarchError> {
    let trace = crate::trace::enabled();
    let eligible = matches!(input.start, Start::Point(_))
        && input.bounds.is_empty()
        && !input.uniform
        && settings.pieces_max >= 2;
    if let (Some(fork), true) = (fork, eligible) {
        let started = std::time::Instant::now();
        let planned = if input.bbox.is_some() {
            boxed::plan(fork, input, settings)
        } else {
            plan(fork, input, settings)
        };
        let pieced = planned.and_then(|p| match p {
            Some(slabs) => {
                if trace {
                    eprintln!(
                        "pieces: survey and cuts {:.3} s",
                        started.elapsed().as_secs_f64()
                    );
                }
                march_slabs(fork, input, settings, &slabs, progress).map(Some)
            }
            None => Ok(None),
        });
        match pieced {
            Ok(Some(pieced)) => {
                if trace {
                    eprintln!(
                        "pieces: {} piece(s) across axis {} at {:?}, {} cut loop(s), {} triangles, {:.3} s",
                        pieced.pieces,
                        pieced.planes.as_ref().map_or(0, |p| p.0),
                        pieced.planes.as_ref().map_or(&[][..], |p| &p.1[..]),
                        pieced.cuts.len(),
                        pieced.marched.mesh.triangles.len(),
                        started.elapsed().as_secs_f64()
                    );
                }
                if let Some(p) = progress {
                    p.store(
                        pieced.marched.mesh.triangles.len() as u64,
                        Ordering::Relaxed,
                    );
                }
                return Ok(pieced);
            }
            Ok(None) => {}
            Err(why) => {
                // The slabs that were marched are thrown away: the count starts again with
                // the whole march (nothing else of the block is counted yet).
                if let Some(p) = progress {
                    p.store(0, Ordering::Relaxed);
                }
                if trace {
                    eprintln!(
                        "pieces: marched whole: {why} ({:.3} s)",
                        started.elapsed().as_secs_f64()
                    );
                }
            }
        }
    }
    let marched = march::march_verified(surface, fork, input, settings, progress)?;
    Ok(Pieced {
        marched,
        pieces: 1,
        cuts: Vec::new(),
        planes: None,
        measured: None,
    })
}

/// The coarse survey and the cuts of a component that is not in a box: None when it is
/// small enough to march whole, else its slabs.
fn plan(
    fork: &Fork<'_>,
    input: &MarchInput,
    settings: &MarchSettings,
) -> Result<Option<Slabs>, NoCut> {
    cut_into_slabs(
        fork,
        input,
        settings,
        |topo| topo.is_closed_and_oriented(),
        |s, survey, sizing, axis, at| {
            cut(
                s,
                &survey.mesh,
                survey.step,
                axis,
                at,
                input.step,
                settings,
                sizing,
            )
        },
        |survey, _, _, axis, cuts| Ok(slabs(input, settings, survey, axis, &cuts)),
    )
}

/// The survey (whose topology `accepts` must take, one component), then the planes of n slabs
/// across the first axis where `cut` takes them all, and `slabs` of what it cut (given the
/// survey's topology too); where no axis takes
/// them (one meets the surface at a grazing angle wherever it is shifted: more planes, more
/// such places) or `slabs` refuses them, half as many slabs, down to two. The slabs get the
/// survey's Euler characteristic and boundary loops to be held to.
pub(super) fn cut_into_slabs<T: Send>(
    fork: &Fork<'_>,
    input: &MarchInput,
    settings: &MarchSettings,
    accepts: impl Fn(&Topology) -> bool,
    cut: impl Fn(&mut dyn Surface, &Survey, &Sizing, usize, f64) -> Result<T, NoCut> + Sync,
    slabs: impl Fn(&Survey, &Topology, &Sizing, usize, Vec<Placed<T>>) -> Result<Slabs, NoCut>,
) -> Result<Option<Slabs>, NoCut> {
    let step = input.step;
    let mut s = fork().ok_or(NoCut::Fork)?;
    let survey = survey(&mut s, input, settings)?;
    let Some(mut n) = survey.slabs(settings) else {
        return Ok(None);
    };
    let topo = topology(&survey.mesh);
    if !accepts(&topo) || topo.components != 1 {
        return Err(NoCut::CoarseOpen);
    }
    let (lo, extent, axes) = survey.axes();
    let tolerance = input.tolerance.unwrap_or(settings.tolerance * step);
    let sizing = Sizing::of_mesh(step, tolerance, false, settings.sizing);
    let mut last = NoCut::Fork;
    loop {
        let found = planes(n, &axes, lo, extent, &mut last, |axis, bases, width| {
            in_parallel(fork, bases, width, |s, at| {
                cut(s, &survey, &sizing, axis, at)
            })
        });
        if let Some((axis, cuts)) = found {
            match slabs(&survey, &topo, &sizing, axis, cuts) {
                Ok(mut slabs) => {
                    slabs.chi = topo.euler_characteristic;
                    slabs.boundary_loops = topo.boundary_loops.len();
                    return Ok(Some(slabs));
                }
                Err(e) => last = e,
            }
        }
        if n <= 2 {
            return Err(last);
        }
        n = (n / 2).max(2);
    }
}

/// The coarse survey of a component (docs/pieces.md, *When a component is cut*).
pub(super) struct Survey {
    pub mesh: Mesh,
    /// The step it was marched at.
    pub step: f64,
    /// The area of an equilateral triangle of the (fine) step.
    pub triangle: f64,
    /// The triangles the fine march will make, as the survey's area estimates them.
    pub estimate: f64,
}

impl Survey {
    /// How many slabs to cut the component into: None below `pieces_above`, else
    /// ⌈estimate / piece_triangles⌉ rounded up to a power of two, 2 ..= `pieces_max`.
    pub fn slabs(&self, settings: &MarchSettings) -> Option<usize> {
        // A NaN area (a survey vertex not finite) cuts nothing either.
        if self.estimate.is_nan() || self.estimate <= settings.pieces_above as f64 {
            return None;
        }
        // Rounder triangles asked for: slabs ROUNDER_SLABS times smaller (their seams are
        // polished then, `seams`).
        let per_slab = if settings.above_default_aim() {
            settings.piece_triangles / ROUNDER_SLABS
        } else {
            settings.piece_triangles
        };
        Some(
            ((self.estimate / per_slab.max(1) as f64).ceil() as usize)
                .next_power_of_two()
                .clamp(2, settings.pieces_max.max(2) as usize),
        )
    }

    /// The survey's lowest corner, extent, and the axes from the longest extent.
    pub fn axes(&self) -> (DVec3, DVec3, [usize; 3]) {
        let (lo, hi) = self.mesh.vertices.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), &v| (lo.min(v), hi.max(v)),
        );
        let extent = hi - lo;
        let mut axes = [0usize, 1, 2];
        axes.sort_by(|&a, &b| extent[b].total_cmp(&extent[a]));
        (lo, extent, axes)
    }

    /// Each slab's triangles as the survey's area in it estimates them (a triangle in the
    /// slab of its centroid), for the slabs between the planes at `planes` across `axis`.
    pub fn estimates(&self, axis: usize, planes: &[f64]) -> Vec<f64> {
        let mesh = &self.mesh;
        let mut estimates = vec![0.0; planes.len() + 1];
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|k| mesh.vertices[k as usize]);
            let centre = (a[axis] + b[axis] + c[axis]) / 3.0;
            let slab = planes.partition_point(|&at| at < centre);
            estimates[slab] += 0.5 * (b - a).cross(c - a).length() / self.triangle;
        }
        estimates
    }
}

/// The coarse march from the component's start (in its box, where it has one) at `COARSE`
/// steps, and where the surface has features too small for that (the survey fails), at half
/// of it; no quality stage, no regrading: only its area, extent and sections count.
fn survey(
    s: &mut dyn Surface,
    input: &MarchInput,
    settings: &MarchSettings,
) -> Result<Survey, NoCut> {
    let coarse_input = MarchInput {
        step: COARSE * input.step,
        start: input.start.clone(),
        bounds: Vec::new(),
        bbox: input.bbox,
        max_triangles: Some(COARSE_LIMIT),
        tolerance: None,
        uniform: false,
        expected_triangles: None,
    };
    let coarse_settings = MarchSettings {
        quality_angle: 0.0,
        sizing: SizingSettings {
            regrade_share: 1.0,
            ..settings.sizing
        },
        ..*settings
    };
    let (mesh, step) = match march::march_verified(s, None, &coarse_input, &coarse_settings, None) {
        Ok(m) => (m.mesh, coarse_input.step),
        Err(_) => {
            let finer = MarchInput {
                step: 0.5 * COARSE * input.step,
                ..coarse_input
            };
            let m = march::march_verified(s, None, &finer, &coarse_settings, None)
                .map_err(NoCut::Coarse)?;
            (m.mesh, finer.step)
        }
    };
    let area: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|k| mesh.vertices[k as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    let triangle = 0.25 * 3f64.sqrt() * input.step * input.step;
    Ok(Survey {
        mesh,
        step,
        triangle,
        estimate: area / triangle,
    })
}

/// The n - 1 planes of n slabs across the first of `axes` where `place` takes them all (it
/// gets the axis, the planes' places and the slabs' width, and cuts each plane at its place
/// or `shifted`), with what it made of each; None (and why the last axis failed in `last`)
/// where no axis takes them.
fn planes<T>(
    n: usize,
    axes: &[usize; 3],
    lo: DVec3,
    extent: DVec3,
    last: &mut NoCut,
    mut place: impl FnMut(usize, &[f64], f64) -> Result<Vec<Placed<T>>, NoCut>,
) -> Option<(usize, Vec<Placed<T>>)> {
    for &axis in axes {
        let width = extent[axis] / n as f64;
        let bases: Vec<f64> = (1..n).map(|k| lo[axis] + k as f64 * width).collect();
        match place(axis, &bases, width) {
            Ok(cuts) => return Some((axis, cuts)),
            Err(e) => *last = e,
        }
    }
    None
}

/// The planes at `bases` (each `shifted`) on the pool's threads, each on a fresh oracle: what
/// one finds does not depend on which thread ran it or what ran before. The first refusal in
/// the planes' order where one is refused.
fn in_parallel<T: Send>(
    fork: &Fork<'_>,
    bases: &[f64],
    width: f64,
    cut: impl Fn(&mut dyn Surface, f64) -> Result<T, NoCut> + Sync,
) -> Result<Vec<Placed<T>>, NoCut> {
    let placed: Vec<Result<Placed<T>, NoCut>> = bases
        .par_iter()
        .map(|&base| {
            let mut s = fork().ok_or(NoCut::Fork)?;
            shifted(base, width, |at| cut(&mut *s, at))
        })
        .collect();
    placed.into_iter().collect()
}

/// The plane at `base`, or moved by `SHIFTS` of the slabs' `width`, where `cut` first takes
/// it; else the last refusal.
fn shifted<T>(
    base: f64,
    width: f64,
    mut cut: impl FnMut(f64) -> Result<T, NoCut>,
) -> Result<Placed<T>, NoCut> {
    let mut last = NoCut::Fork;
    for shift in SHIFTS {
        let at = base + shift * width;
        match cut(at) {
            Ok(loops) => return Ok(Placed { at, loops }),
            Err(e) => last = e,
        }
    }
    Err(last)
}

/// The plane's cut loops, traced from the coarse section and checked as the module
/// documentation says.
// The survey (oracle, mesh and its step), the plane, and what the loops are sampled for.
#[allow(clippy::too_many_arguments)]
fn cut(
    s: &mut dyn Surface,
    coarse: &Mesh,
    coarse_step: f64,
    axis: usize,
    at: f64,
    step: f64,
    settings: &MarchSettings,
    sizing: &Sizing,
) -> Result<Vec<Vec<DVec3>>, NoCut> {
    let refuse = |why| NoCut::Plane { axis, at, why };
    let sections = section(coarse, axis, at).ok_or(NoCut::Section { axis, at })?;
    if sections.is_empty() {
        return Err(refuse("the plane misses the surface"));
    }
    let mut e = DVec3::ZERO;
    e[axis] = 1.0;
    let mut plane = NativeSurface(move |p: DVec3| ValueGrad {
        value: p[axis] - at,
        gradient: e,
    });
    let tol = CurveTolerance::default();
    let reach = 0.5 * coarse_step;
    let mut loops: Vec<Vec<DVec3>> = Vec::with_capacity(sections.len());
    for coarse_loop in &sections {
        let seed = coarse_loop[0];
        let mut h = step;
        let mut traced = Vec::new();
        // At the step, then (where the local step is smaller along the loop) at the smallest
        // local step along it.
        for _ in 0..2 {
            let polygon = curve::intersection_with(s, &mut plane, seed, h, None, &tol)
                .map_err(NoCut::Trace)?;
            if !polygon.closed {
                return Err(refuse("a cut curve does not close"));
            }
            traced = polygon.points;
            let local = traced
                .iter()
                .map(|&p| local_step(s, sizing, p))
                .fold(step, f64::min);
            if local >= 0.98 * h {
                break;
            }
            if local < 1.25 * settings.polygon_edge_min * step {
                return Err(refuse("the local step along a cut curve is too small"));
            }
            h = local;
        }
        if traced.len() < MIN_LOOP {
            return Err(refuse("a cut loop is tiny"));
        }
        for &p in &traced {
            let g = s.value_gradient(p).gradient;
            let sine = g.normalize_or_zero().cross(e).length();
            if sine.is_nan() || sine < CROSS_SINE {
                return Err(refuse("the surface meets the plane at less than 30°"));
            }
        }
        if !near_all(&traced, coarse_loop, true, reach)
            || !near_all(coarse_loop, &traced, true, reach)
        {
            return Err(refuse("a traced loop does not follow its coarse section"));
        }
        loops.push(traced);
    }
    for (i, a) in loops.iter().enumerate() {
        for b in &loops[i + 1..] {
            let near = a
                .iter()
                .any(|p| b.iter().any(|q| p.distance(*q) < coarse_step));
            if near {
                return Err(refuse("two cut loops come closer than a coarse step"));
            }
        }
    }
    Ok(loops)
}

/// The local step at a point on the surface.
pub(super) fn local_step(s: &mut dyn Surface, sizing: &Sizing, p: DVec3) -> f64 {
    let normal = s.value_gradient(p).gradient.normalize_or_zero();
    if normal == DVec3::ZERO {
        return 0.0;
    }
    let (t1, t2) = tangent_frame(normal);
    let sp = SurfacePoint {
        point: p,
        normal,
        t1,
        t2,
    };
    sizing.size(s, &sp, None, None).h
}

/// Every point of `a` within `reach` of the polyline `b` (closed: its last point joined to
/// its first). The closed case's traced loops against the survey's sections, and the boxed
/// case's cut curves, which may end on the box's faces.
pub(super) fn near_all(a: &[DVec3], b: &[DVec3], closed: bool, reach: f64) -> bool {
    let segments = b.len().saturating_sub(usize::from(!closed));
    // Each point's search starts at the segment the point before was near: the two lines
    // run alike, so it is usually the first looked at (every segment may still be).
    let mut last = 0;
    a.iter().all(|&p| {
        b.len() == 1 && b[0].distance(p) <= reach
            || (last..segments).chain(0..last).any(|i| {
                let (u, v) = (b[i], b[(i + 1) % b.len()]);
                let near = (u + nearest_on_segment(p, u, v) * (v - u)).distance(p) <= reach;
                if near {
                    last = i;
                }
                near
            })
    })
}

/// The section of a closed, oriented mesh with the plane `p[axis] = at`: closed polylines,
/// one point on each edge from a vertex below to one at or above the plane; None where the
/// segments do not chain into loops.
fn section(mesh: &Mesh, axis: usize, at: f64) -> Option<Vec<Vec<DVec3>>> {
    let above = |k: u32| mesh.vertices[k as usize][axis] >= at;
    // Per crossed triangle: the edge where the section leaves it (walking its edges in
    // order, from above to below) → the edge where it enters (below to above). In a closed,
    // oriented mesh each crossed edge enters one triangle and leaves its neighbour.
    let mut next: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
    let mut order = Vec::new();
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    for t in &mesh.triangles {
        let (mut leave, mut enter) = (None, None);
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            match (above(a), above(b)) {
                (true, false) => leave = Some(key(a, b)),
                (false, true) => enter = Some(key(a, b)),
                _ => {}
            }
        }
        if let (Some(l), Some(e)) = (leave, enter) {
            if next.insert(l, e).is_some() {
                return None;
            }
            order.push(l);
        }
    }
    let point = |(a, b): (u32, u32)| {
        let (p, q) = (mesh.vertices[a as usize], mesh.vertices[b as usize]);
        let w = (at - p[axis]) / (q[axis] - p[axis]);
        p.lerp(q, w)
    };
    let mut done: HashSet<(u32, u32)> = HashSet::new();
    let mut loops = Vec::new();
    for first in order {
        if done.contains(&first) {
            continue;
        }
        let mut ring = Vec::new();
        let mut e = first;
        loop {
            done.insert(e);
            ring.push(point(e));
            e = *next.get(&e)?;
            if e == first {
                break;
            }
            if done.contains(&e) {
                return None;
            }
        }
        loops.push(ring);
    }
    Some(loops)
}

/// The slabs of a component that is not in a box: between the cuts, the upper plane's
/// loops as traced (the slab below them), the lower plane's reversed (module doc 3).
fn slabs(
    input: &MarchInput,
    settings: &MarchSettings,
    survey: &Survey,
    axis: usize,
    cuts: &[Cut],
) -> Slabs {
    let n = cuts.len() + 1;
    let planes: Vec<f64> = cuts.iter().map(|c| c.at).collect();
    let estimates = survey.estimates(axis, &planes);
    let polygons = (0..n)
        .map(|k| {
            let mut loops: Vec<Vec<DVec3>> = Vec::new();
            if let Some(c) = cuts.get(k) {
                loops.extend(c.loops.iter().cloned());
            }
            if k > 0 {
                loops.extend(cuts[k - 1].loops.iter().map(|l| {
                    let mut r = l.clone();
                    r.reverse();
                    r
                }));
            }
            loops
        })
        .collect();
    Slabs {
        axis,
        planes,
        inputs: slab_inputs(input, settings, polygons, &estimates),
        shared: cuts
            .iter()
            .flat_map(|c| c.loops.iter().flatten().copied())
            .collect(),
        cuts: cuts.iter().flat_map(|c| c.loops.iter().cloned()).collect(),
        chi: 0,
        boundary_loops: 0,
        bbox: None,
    }
}

/// Each slab's march from its polygons, the first as front and the others as bounds, with
/// its share of triangles (`SLAB_SHARE`): a slab that marches far beyond it (its front got
/// past a cut it should have stopped at, and goes round the surface again) is stopped early,
/// and the component is then marched whole, as for any failed piece.
pub(super) fn slab_inputs(
    input: &MarchInput,
    settings: &MarchSettings,
    polygons: Vec<Vec<Vec<DVec3>>>,
    estimates: &[f64],
) -> Vec<MarchInput> {
    let limit = input.max_triangles.unwrap_or(settings.max_triangles);
    polygons
        .into_iter()
        .zip(estimates)
        .map(|(mut loops, &estimate)| {
            let front = loops.remove(0);
            let share = (SLAB_SHARE * estimate) as u64 + SLAB_SHARE_MIN;
            MarchInput {
                step: input.step,
                start: Start::Front(front),
                bounds: loops,
                bbox: None,
                max_triangles: Some(share.min(limit)),
                tolerance: input.tolerance,
                uniform: false,
                // The area's estimate itself (the fine sphere's end slabs make 1.2 times it,
                // and grow once). Reserved for more, its one thread had more page faults,
                // not fewer: 54 k at 1.5 times, 59 k at twice, 43 k at once, 49 k without.
                expected_triangles: Some((estimate as u64).min(share.min(limit))),
            }
        })
        .collect()
}

/// Slabs to march and what their join is held to.
pub(super) struct Slabs {
    /// The axis cut across and the planes' positions along it, increasing.
    pub axis: usize,
    pub planes: Vec<f64>,
    /// Each slab's march.
    pub inputs: Vec<MarchInput>,
    /// The polygon vertices two slabs may share (bit for bit) and where the join's angle
    /// check looks: the cut polygons', and in a box the border polygons' too.
    pub shared: Vec<DVec3>,
    /// The cut polygons, for `Pieced::cuts`.
    pub cuts: Vec<Vec<DVec3>>,
    /// The joined mesh's Euler characteristic and boundary loops: the survey's.
    pub chi: i64,
    pub boundary_loops: usize,
    /// The box every vertex lies in, for a component in one: its boundary edges lie on the
    /// box's faces.
    pub bbox: Option<(DVec3, DVec3)>,
}

/// Marches the slabs on the rayon pool and joins them (module doc 3, 4).
fn march_slabs(
    fork: &Fork<'_>,
    input: &MarchInput,
    settings: &MarchSettings,
    slabs: &Slabs,
    progress: Option<&AtomicU64>,
) -> Result<Pieced, NoCut> {
    let (axis, planes, chi) = (slabs.axis, &slabs.planes[..], slabs.chi);
    let n = planes.len() + 1;
    let limit = input.max_triangles.unwrap_or(settings.max_triangles);
    let marched = in_turn(&slabs.inputs, &outside_in(n), |piece, inp| {
        let mut s = fork().ok_or(NoCut::Fork)?;
        march::march_verified(&mut s, Some(fork), inp, settings, progress)
            .map_err(|source| NoCut::Piece { piece, source })
    });
    let mut marched = marched.into_iter().collect::<Result<Vec<_>, _>>()?;
    let joining = std::time::Instant::now();
    let margin = SLAB_MARGIN * input.step;
    for (piece, m) in marched.iter().enumerate() {
        let below = piece.checked_sub(1).map(|k| planes[k] - margin);
        let above = planes.get(piece).map(|&at| at + margin);
        let outside = |v: &DVec3| {
            below.is_some_and(|b| v[axis] < b)
                || above.is_some_and(|a| v[axis] > a)
                || slabs.bbox.is_some_and(|(lo, hi)| {
                    v.cmplt(lo - DVec3::splat(margin)).any()
                        || v.cmpgt(hi + DVec3::splat(margin)).any()
                })
        };
        if let Some(&at) = m.mesh.vertices.iter().find(|v| outside(v)) {
            return Err(NoCut::Slab { piece, at });
        }
    }
    let total: u64 = marched.iter().map(|m| m.mesh.triangles.len() as u64).sum();
    if total > limit {
        return Err(NoCut::Limit { total, limit });
    }
    let parts: Vec<Mesh> = marched
        .iter_mut()
        .map(|m| std::mem::take(&mut m.mesh))
        .collect();
    // Only the polygons' vertices looked up (`merge_at`): the only ones two slabs share, bit
    // for bit, since a polygon vertex is a mesh vertex with its coordinates (`merge`, which
    // hashes every vertex, took a fifth of a second on the fine sphere in one thread).
    let (mesh, on) = merge_at(&parts, &slabs.shared);
    // Where each slab's triangles end in the merged mesh (they come in slab order).
    let ends: Vec<usize> = (parts.iter())
        .scan(0, |end, part| {
            *end += part.triangles.len();
            Some(*end)
        })
        .collect();
    drop(parts);
    let seams::Polished { mesh, on, reach } =
        seams::polish(fork, input, settings, mesh, on, slabs.bbox, (axis, planes));
    // The topology and the checks after it need only the mesh: side by side on the pool.
    // The shape statistics are the report's (`Pieced::measured`).
    let (topo, (crossing, shapes, at_cuts)) = rayon::join(
        || topology(&mesh),
        || {
            let shapes = quality::quality(&mesh);
            let band = match reach {
                // Polished seams: crossings are looked for as far from the planes as they
                // reach, and a triangle's longest edge beyond (a triangle that crosses one
                // of the polished patch's has a corner there), between any two triangles.
                // (The statistics' longest edge is the longest edge, bit for bit.)
                Some(r) => Band {
                    reach: (BAND * input.step).max(r + shapes.max_edge),
                    slab_ends: None,
                },
                // Else only between two slabs: each slab's own crossings were checked by
                // its verification, and the merge moved no vertex. A slab lies on its side of
                // its planes to within `SLAB_MARGIN` steps (checked above), so two triangles
                // of two slabs that cross share a point within that of a plane, and each has
                // a corner at least as far towards the other slab as that point: within the
                // margin of the plane too (twice it here, for the rounding of the test). On
                // the fine sphere that is the triangles at the cut polygons, 30 000 of the
                // 147 000 within three steps of the planes checked before.
                None => Band {
                    reach: 2.0 * SLAB_MARGIN * input.step,
                    slab_ends: Some(&ends),
                },
            };
            let crossing = !band.pairs(&mesh, axis, planes).is_empty();
            let at_cuts = smallest_angle_where(&mesh, &on, true);
            (crossing, shapes, at_cuts)
        },
    );
    let on_the_box = |k: u32| on_box(mesh.vertices[k as usize], slabs.bbox);
    if !topo.non_manifold_edges.is_empty()
        || !topo.misoriented_edges.is_empty()
        || topo.degenerate_triangles > 0
        || topo
            .boundary_edges
            .iter()
            .any(|&[a, b]| !(on_the_box(a) && on_the_box(b)))
    {
        return Err(NoCut::Joined(
            "an edge is open away from the box, in more than two triangles or misoriented",
        ));
    }
    if topo.boundary_loops.len() != slabs.boundary_loops {
        return Err(NoCut::Joined("the boundary loops differ from the survey's"));
    }
    if topo.components != 1 {
        return Err(NoCut::Joined("more than one component"));
    }
    if topo.euler_characteristic != chi {
        return Err(NoCut::Joined(
            "the Euler characteristic differs from the survey's",
        ));
    }
    if crossing {
        return Err(NoCut::Joined("triangles of two pieces cross"));
    }
    // Away from the cuts only when a triangle at them is below the bar.
    if at_cuts < CUT_ANGLE && at_cuts < smallest_angle_where(&mesh, &on, false) {
        return Err(NoCut::Angle { degrees: at_cuts });
    }
    // Slabs whose fronts start from their cut polygons can end below the mean radius ratio
    // the whole march reaches (flat superquadrics cut across, `SURFC_SWEEP_PIECES=2000`:
    // 0.965 in three slabs where the whole makes 0.977): such a cut is not taken.
    if settings.quality_angle > 0.0 {
        let mean = shapes.radius_ratio_mean;
        let bar = settings.quality_ratio.min(DEFAULT_QUALITY_RATIO) - RATIO_MARGIN;
        if mean.is_nan() || mean < bar {
            return Err(NoCut::Ratio { mean, bar });
        }
    }
    if crate::trace::enabled() {
        eprintln!(
            "pieces: joined and checked in {:.3} s",
            joining.elapsed().as_secs_f64()
        );
    }
    let mut warnings = Vec::new();
    for m in &marched {
        for w in &m.warnings {
            if !warnings.contains(w) {
                warnings.push(w.clone());
            }
        }
    }
    Ok(Pieced {
        marched: Marched {
            mesh,
            max_chord_error: marched
                .iter()
                .map(|m| m.max_chord_error)
                .fold(0.0, f64::max),
            warnings,
            held: marched.iter().filter_map(|m| m.held).reduce(Held::and),
            refinements: marched.iter().map(|m| m.refinements).max().unwrap_or(0),
            peak_triangles: marched.iter().map(|m| m.peak_triangles).sum(),
        },
        pieces: n,
        cuts: slabs.cuts.clone(),
        planes: Some((axis, planes.to_vec())),
        measured: Some((topo, shapes)),
    })
}

/// 0, n − 1, 1, n − 2, …: the order the threads take the slabs in. The slabs at the ends of
/// the axis cost the most, which the survey's areas do not tell (one thread; the end slabs
/// against the rest: the fine sphere 0.19–0.24 s against 0.14–0.21, the torus at step 0.01
/// 0.10 s against 0.04–0.11, genus 3 at 0.02 0.22–0.25 s against 0.15–0.21, at equal or
/// smaller areas); taken last, they left a thread idle (taken in slab-order halves, the fine
/// sphere's two threads ended up to 64 ms apart).
fn outside_in(n: usize) -> Vec<usize> {
    (0..n / 2)
        .flat_map(|k| [k, n - 1 - k])
        .chain((n % 2 == 1).then_some(n / 2))
        .collect()
}

/// `run` on every item on the rayon pool, the results in the items' order: each thread
/// takes the next item in `order` (every index once) when it is free, so the threads end
/// at most one item apart. A thread that waits inside an item (for work of its own it
/// spawned) and is handed a second taker meanwhile declines it: taking items there would
/// hold the first item's result until the queue is empty. What no taker took, the caller
/// runs.
fn in_turn<I: Sync, T: Send>(
    items: &[I],
    order: &[usize],
    run: impl Fn(usize, &I) -> T + Sync,
) -> Vec<T> {
    thread_local! {
        static TAKING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let done: Vec<std::sync::Mutex<Option<T>>> = items.iter().map(|_| Default::default()).collect();
    let take =
        |k: usize| *done[k].lock().unwrap_or_else(|e| e.into_inner()) = Some(run(k, &items[k]));
    let takers = rayon::current_num_threads().min(items.len());
    (0..takers).into_par_iter().for_each(|_| {
        if TAKING.with(|t| t.replace(true)) {
            return;
        }
        // Cleared however the loop ends (a panic included).
        struct Taken;
        impl Drop for Taken {
            fn drop(&mut self) {
                TAKING.with(|t| t.set(false));
            }
        }
        let _taken = Taken;
        while let Some(&k) = order.get(next.fetch_add(1, Ordering::Relaxed)) {
            take(k);
        }
    });
    // Whatever no taker took (each declined, all inside items of their own): here.
    while let Some(&k) = order.get(next.fetch_add(1, Ordering::Relaxed)) {
        take(k);
    }
    done.into_iter()
        .map(|d| {
            let d = d.into_inner().unwrap_or_else(|e| e.into_inner());
            d.expect("every item is taken once")
        })
        .collect()
}

/// Whether `v` lies on a face of `bbox` (bit for bit: the border curves keep the face's
/// coordinate exactly).
fn on_box(v: DVec3, bbox: Option<(DVec3, DVec3)>) -> bool {
    bbox.is_some_and(|(lo, hi)| v.cmpeq(lo).any() || v.cmpeq(hi).any())
}

/// The smallest angle (degrees) of the triangles with a corner on a cut polygon (`at_cut`)
/// or with none (`on` marks the cut polygons' vertices).
fn smallest_angle_where(mesh: &Mesh, on: &[bool], at_cut: bool) -> f64 {
    mesh.triangles
        .iter()
        .filter(|t| t.iter().any(|&k| on[k as usize]) == at_cut)
        .map(|t| {
            let [a, b, c] = t.map(|k| mesh.vertices[k as usize]);
            quality::smallest_angle(a, b, c)
        })
        .fold(f64::INFINITY, f64::min)
}

/// Where the slabs' crossings are looked for after the join: the triangles with a vertex
/// within `reach` of a plane, and, where `slab_ends` are given (where each slab's triangles
/// end in the mesh), only pairs of two slabs.
struct Band<'a> {
    reach: f64,
    slab_ends: Option<&'a [usize]>,
}

impl Band<'_> {
    /// The crossing pairs of the band's triangles, as numbered in the band.
    fn pairs(&self, mesh: &Mesh, axis: usize, planes: &[f64]) -> Vec<[u32; 2]> {
        let near: Vec<bool> = mesh
            .vertices
            .iter()
            .map(|v| planes.iter().any(|&at| (v[axis] - at).abs() <= self.reach))
            .collect();
        // Each vertex's index in the band, numbered as first met in triangle order (a
        // vector over the whole mesh's vertices, not a map: a map's lookups were half the
        // band's time on the fine sphere).
        const NONE: u32 = u32::MAX;
        let mut ids = vec![NONE; mesh.vertices.len()];
        let mut sub = Mesh::default();
        let mut groups = Vec::new();
        let mut slab = 0;
        for (i, t) in mesh.triangles.iter().enumerate() {
            if !t.iter().any(|&k| near[k as usize]) {
                continue;
            }
            let tri = t.map(|k| {
                let id = &mut ids[k as usize];
                if *id == NONE {
                    *id = sub.vertices.len() as u32;
                    sub.vertices.push(mesh.vertices[k as usize]);
                    sub.normals.push(mesh.normals[k as usize]);
                }
                *id
            });
            sub.triangles.push(tri);
            if let Some(ends) = self.slab_ends {
                while ends.get(slab).is_some_and(|&end| end <= i) {
                    slab += 1;
                }
                groups.push(slab as u32);
            }
        }
        intersecting_pairs_across(&sub, self.slab_ends.map(|_| &groups[..]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::crease_net::merge;

    /// `outside_in` is every slab once; `in_turn` runs every item once and gives the
    /// results in the items' order, whatever the order taken and the pool: one, two and
    /// three threads, and called again inside an item (the inner call's items run even
    /// where every taker declines, on a pool of one).
    #[test]
    fn in_turn_runs_every_item_once_and_keeps_their_order() {
        use std::sync::atomic::AtomicUsize;
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool");
            pool.install(|| {
                for n in [0usize, 1, 2, 5, 8] {
                    let items: Vec<usize> = (0..n).map(|k| 10 * k).collect();
                    let order = outside_in(n);
                    let mut sorted = order.clone();
                    sorted.sort_unstable();
                    assert_eq!(sorted, (0..n).collect::<Vec<_>>(), "every slab once");
                    let runs = AtomicUsize::new(0);
                    let got = in_turn(&items, &order, |k, &item| {
                        runs.fetch_add(1, Ordering::Relaxed);
                        let inner: Vec<usize> = in_turn(&[1, 2, 3], &[2, 0, 1], |j, &x| j + x);
                        (k, item, inner)
                    });
                    assert_eq!(runs.load(Ordering::Relaxed), n);
                    let expected: Vec<_> = (0..n).map(|k| (k, 10 * k, vec![1, 3, 5])).collect();
                    assert_eq!(got, expected, "{threads} thread(s), {n} items");
                }
            });
        }
    }

    /// The band of an unpolished join (every triangle with a corner within twice the margin
    /// m of the plane, pairs of two slabs only) finds a crossing exactly when one of the two
    /// slabs' triangles crosses one of the other's: random triangles up to `edge` long,
    /// slab 0's below y = m and slab 1's above y = −m, far from the plane as well as at it,
    /// against every pair searched over both. A band of m/2 fails it.
    #[test]
    fn the_band_of_two_slabs_finds_every_crossing_between_them() {
        let mut rnd = crate::testing::uniform(0x0dd_ba11_5eed);
        let (edge, margin) = (1.0, 0.3);
        let (mut crossed, mut apart) = (0, 0);
        for _ in 0..400 {
            let mut mesh = Mesh::default();
            let mut ends = Vec::new();
            for side in [-1.0, 1.0] {
                for _ in 0..12 {
                    // A corner from y = −5 (slab 0) or up to 5 (slab 1) to the margin on the
                    // other side; the others within an edge of it, on the same side.
                    let (x, r, s, z) = (rnd(), rnd() * rnd(), rnd(), rnd());
                    let a = DVec3::new(3.0 * x, side * 5.0 * r - side * margin * s, 3.0 * z);
                    let mut corner = || {
                        let d = DVec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * edge;
                        let p = a + d;
                        DVec3::new(
                            p.x,
                            if side * p.y < -margin {
                                -side * margin
                            } else {
                                p.y
                            },
                            p.z,
                        )
                    };
                    let (b, c) = (corner(), corner());
                    let k = mesh.vertices.len() as u32;
                    mesh.vertices.extend([a, b, c]);
                    mesh.normals.extend([DVec3::Y; 3]);
                    mesh.triangles.push([k, k + 1, k + 2]);
                }
                ends.push(mesh.triangles.len());
            }
            let across = |pairs: &[[u32; 2]]| pairs.iter().any(|&[i, j]| (i < 12) != (j < 12));
            let all = crate::mesh::check::intersecting_pairs_searched(&mesh);
            let band = Band {
                reach: 2.0 * margin,
                slab_ends: Some(&ends),
            };
            let found = !band.pairs(&mesh, 1, &[0.0]).is_empty();
            assert_eq!(found, across(&all), "{mesh:?}");
            if found {
                crossed += 1;
            } else {
                apart += 1;
            }
        }
        assert!(
            crossed > 20 && apart > 20,
            "{crossed} crossed, {apart} apart"
        );
    }

    /// Two caps over one cut loop (a hexagon in the plane y = 0) and a third slab over a
    /// second loop: `join` gives `merge`'s mesh, bit for bit, normals of the shared vertices
    /// included, and marks exactly the loops' vertices.
    #[test]
    fn the_join_is_the_merge_of_slabs_sharing_their_cut_polygons() {
        let ring = |y: f64, r: f64| -> Vec<DVec3> {
            (0..6)
                .map(|i| {
                    let a = i as f64 * std::f64::consts::TAU / 6.0;
                    DVec3::new(r * a.cos(), y, r * a.sin())
                })
                .collect()
        };
        let (lower, upper) = (ring(0.0, 1.0), ring(1.0, 0.8));
        // A slab: its own vertices, then the loops' (as a piece's polygons come first in a
        // march, but anywhere will do), triangles fanned from its first vertex.
        let slab = |own: Vec<DVec3>, loops: &[&Vec<DVec3>]| {
            let mut vertices = own;
            for l in loops {
                vertices.extend(l.iter().copied());
            }
            let normals: Vec<DVec3> = vertices
                .iter()
                .map(|v| DVec3::new(-0.0, v.y, v.x).normalize_or(DVec3::Y))
                .collect();
            let n = vertices.len() as u32;
            let triangles = (1..n - 1).map(|k| [0, k, k + 1]).collect();
            Mesh {
                vertices,
                normals,
                triangles,
                sides: Vec::new(),
            }
        };
        let parts = [
            slab(vec![DVec3::new(0.0, -1.0, 0.0)], &[&lower]),
            slab(
                vec![DVec3::new(0.1, 0.5, 0.2), DVec3::new(-0.2, 0.5, 0.1)],
                &[&upper, &lower],
            ),
            slab(vec![DVec3::new(0.0, 2.0, 0.0)], &[&upper]),
        ];
        let cuts = [
            Cut {
                at: 0.0,
                loops: vec![lower.clone()],
            },
            Cut {
                at: 1.0,
                loops: vec![upper.clone()],
            },
        ];
        let shared: Vec<DVec3> = cuts
            .iter()
            .flat_map(|c| c.loops.iter().flatten().copied())
            .collect();
        let (joined, on) = merge_at(&parts, &shared);
        let merged = merge(&parts);
        let bits = |vs: &[DVec3]| -> Vec<[u64; 3]> {
            vs.iter().map(|v| v.to_array().map(f64::to_bits)).collect()
        };
        assert_eq!(bits(&joined.vertices), bits(&merged.vertices));
        assert_eq!(bits(&joined.normals), bits(&merged.normals));
        assert_eq!(joined.triangles, merged.triangles);
        let loop_vertices: HashSet<[u64; 3]> =
            bits(&lower).into_iter().chain(bits(&upper)).collect();
        let expected: Vec<bool> = bits(&joined.vertices)
            .iter()
            .map(|b| loop_vertices.contains(b))
            .collect();
        assert_eq!(on, expected);
        assert_eq!(on.iter().filter(|&&o| o).count(), 12);
    }
}
