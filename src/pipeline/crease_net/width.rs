//! How wide the faces beside a crease are. A face narrower than the step between two creases
//! (a plate's rim, the wall of a hole through a thin plate, a rib's top) would be held by
//! polygons spaced by the step and marched with triangles as long as the step across a strip
//! narrower than them: slivers. The width, measured across the face from points of each
//! crease, caps the local step there (`survey::sizing::Cap`, graded away from it), so that
//! the crease's polygon and the face's march are both spaced by it.
//!
//! The cap is the width divided into whole rows of equilateral triangles (a row is √3/2 of
//! its edge high), at least `MIN_ROWS` of them: a strip between two creases fits its
//! triangles only when its width is a whole number of rows and its two creases' vertices are
//! in phase (`pair.rs`). Capping at the width itself gave 1.15 rows (a strip of slivers and
//! right triangles). With the creases in phase, four rows at least on a strip (a face whose
//! far side is a crease running beside this one; two on a face narrowing into a corner
//! between creases at an angle, whose width falls to nothing there): the runs of the
//! generated CAD parts below the quality bars (docs/quality.md, *CAD parts*) went from 452 to
//! 29 of 1 200 (of the 452 meshed again, 22 stayed below with four rows, 116 with three and
//! 385 with two), for 52 % more triangles over the sweep (nearly all at and above the
//! smallest feature, where faces are strips: the ends of a strip, where it meets a crease
//! across it, cost the same whatever its length, and more rows make the strip's middle,
//! where the phase puts whole rows, more of it). Without the phase, three
//! rows had given more triangles below 30° than two. Faces up to `REACH` steps wide are
//! measured, as a strip 1.3 steps wide is as ill-fitting as one 0.9 wide. The crease is
//! measured about every quarter step; between two points that are capped, caps every half
//! of the smaller size continue the bound along the crease, or it would rise by the
//! grading between them (a hole's rim spaced a fifth wider than its wall's rows).
//!
//! Across the face: from a point p of the crease, along d = ±n × t (n the face's normal, t
//! the crease's tangent), points p + s·d projected onto the face's form stay on the surface
//! (|f| ≈ 0) until the face ends at its next crease, where f leaves 0 (another face cut it
//! off, or another part of the solid covers it). Of ±d, the side where the face goes on.

use glam::DVec3;

use rayon::prelude::*;

use super::pair::FineIndex;
use super::trace::{Traced, Tracer};
use crate::surface::BranchFork;
use crate::survey::sizing::Cap;

/// The face's end is looked for at these fractions of the step (eighths), then bisected.
const PROBES: usize = 8;
/// Faces up to this many steps wide cap the local step (module documentation).
const REACH: f64 = 3.0;
/// The height of a row of equilateral triangles, as a fraction of their edge.
const ROW: f64 = 0.866_025_403_784_438_6;
/// The fewest rows a strip between creases is divided into (module documentation).
const MIN_ROWS: f64 = 4.0;
/// The fewest rows across a face narrowing between creases at an angle: a wedge, whose
/// width falls to nothing at the corner, where rows do not fit anyway and four of them gave
/// triangles of 26° where a pyramid's four faces meet.
const MIN_ROWS_WEDGE: f64 = 2.0;
const BISECT: usize = 5;
/// The probes are first looked at every `STRIDE`th (half a step): most faces are wider than
/// `REACH` steps, and a probe is six evaluations (the plate of issue 41 spent a fifth of its
/// time here, probing every eighth of a step).
const STRIDE: usize = 4;
/// Points of a crease measured from: about every quarter step.
const SPACING: f64 = 0.25;
/// A projected point is on the face while |f| is below this fraction of the step (times
/// |∇f|): the face's end is found to about that over the sine of the crease's angle.
const ON: f64 = 1e-4;
/// How far out along a face's normal (a fraction of the step, above `ON`) f must be positive.
const OUT: f64 = 1e-3;

/// `caps` of every crease of `traced`, in their order. A crease's caps are its own (the
/// others are only read), so with fresh oracles of the branches (`branches`) and more than
/// one thread, runs of creases of about equal length are measured side by side on the
/// pool, each on a copy of the surface on branches of its own (`Shape::on`): the same caps
/// for any number of threads. Where a copy cannot be made or meets a fault, all are
/// measured here, on `t`'s surface.
pub(super) fn all_caps(
    t: &mut Tracer<'_>,
    traced: &[Traced],
    index: &FineIndex,
    branches: Option<&BranchFork<'_>>,
) -> Vec<Cap> {
    let each = |t: &mut Tracer<'_>, run: &[Traced]| -> Vec<Cap> {
        run.iter()
            .flat_map(|tr| caps(t, tr, traced, index))
            .collect()
    };
    let threads = rayon::current_num_threads();
    let Some(fork) = branches.filter(|_| threads > 1 && traced.len() > 1) else {
        return each(t, traced);
    };
    // Four runs a thread (the creases differ in cost), cut where the points reach each
    // share of all of them.
    let total: usize = traced.iter().map(|tr| tr.points.len()).sum();
    let runs = (4 * threads).min(traced.len());
    let mut cuts = vec![0];
    let mut seen = 0;
    for (k, tr) in traced.iter().enumerate() {
        seen += tr.points.len();
        if seen * runs >= cuts.len() * total && k + 1 < traced.len() {
            cuts.push(k + 1);
        }
    }
    cuts.push(traced.len());
    cuts.dedup();
    let shape = t.c.shape();
    let (step, bbox, settings) = (t.step, t.bbox, t.s);
    let measured: Option<Vec<Vec<Cap>>> = cuts
        .par_windows(2)
        .map(|run| {
            let mut c = shape.on(fork()?)?;
            let out = each(
                &mut Tracer::new(&mut c, step, bbox, settings),
                &traced[run[0]..run[1]],
            );
            c.fault().is_none().then_some(out)
        })
        .collect();
    match measured {
        Some(runs) => runs.concat(),
        None => each(t, traced),
    }
}

/// Caps of the local step at points of `tr` where a face beside it is narrower than `REACH`
/// steps: its width divided into whole rows of triangles.
fn caps(t: &mut Tracer<'_>, tr: &Traced, traced: &[Traced], index: &FineIndex) -> Vec<Cap> {
    let (i, j) = tr.forms;
    let points = &tr.points;
    let mut out = Vec::new();
    let mut since = f64::INFINITY;
    // The point measured last, and the last capped point with its cap's size.
    let mut last_measured = usize::MAX;
    let mut previous: Option<(usize, f64)> = None;
    for k in 0..points.len() {
        if k > 0 {
            since += points[k].distance(points[k - 1]);
        }
        if since < SPACING * t.step && k + 1 < points.len() {
            continue;
        }
        since = 0.0;
        let before = points[k.saturating_sub(1)];
        let after = points[(k + 1).min(points.len() - 1)];
        let Some(tangent) = (after - before).try_normalize() else {
            continue;
        };
        let p = points[k];
        let size = [i, j]
            .into_iter()
            .filter_map(|form| {
                let (width, end) = across(t, form, p, tangent)?;
                // A strip takes `MIN_ROWS`; a face narrowing into a corner between two
                // creases at an angle (a pyramid's face at its apex), two.
                let strip = end.is_some_and(|q| index.beside(traced, q, tangent, t.step).is_some());
                let least = if strip { MIN_ROWS } else { MIN_ROWS_WEDGE };
                let rows = (width / (ROW * t.step)).ceil().max(least);
                Some(width / (rows * ROW))
            })
            .fold(f64::INFINITY, f64::min);
        if size.is_finite() {
            // Between this point and the last one measured, if that was capped too: caps
            // every half of the smaller size along the crease, so that the bound does not
            // rise by the grading between caps a quarter step apart (rims spaced up to a
            // fifth wider than their walls' rows between the measured points).
            if let Some((from, last)) = previous.filter(|(from, _)| *from == last_measured) {
                between(&points[from..=k], size.min(last), &mut out);
            }
            out.push(Cap { at: p, size });
            previous = Some((k, size));
        }
        last_measured = k;
    }
    out
}

/// Caps of `size` every half of it along the polyline `line` (its ends excluded).
fn between(line: &[DVec3], size: f64, out: &mut Vec<Cap>) {
    let every = 0.5 * size;
    let mut next = every;
    let mut walked = 0.0;
    for pair in line.windows(2) {
        let length = pair[0].distance(pair[1]);
        while next < walked + length {
            let at = pair[0].lerp(pair[1], (next - walked) / length);
            if at.distance(line[line.len() - 1]) > 0.25 * size {
                out.push(Cap { at, size });
            }
            next += every;
        }
        walked += length;
    }
}

/// The whole number of rows of equilateral triangles of edge `edge` across a face `width`
/// wide, if they fit it to a quarter of a row.
pub(super) fn rows(width: f64, edge: f64) -> Option<u32> {
    let rows = width / (ROW * edge);
    let whole = rows.round();
    (whole >= 1.0 && (rows - whole).abs() <= 0.25).then_some(whole as u32)
}

/// Across face `form` from the crease point p with tangent t: the face's width, if it is
/// narrower than `REACH` steps there, and the point of the form's zero set where it ends
/// (on the crease at its far side; None where Newton left the finite).
pub(super) fn across(
    t: &mut Tracer<'_>,
    form: usize,
    p: DVec3,
    tangent: DVec3,
) -> Option<(f64, Option<DVec3>)> {
    let normal = t.c.form(form, p).gradient.try_normalize()?;
    let across = normal.cross(tangent).try_normalize()?;
    let probe = t.step / PROBES as f64;
    // The side the face lies on: the face goes on a short way along it.
    let side = [across, -across]
        .into_iter()
        .find(|&d| on_face(t, form, p + 0.5 * probe * d))?;
    let mut inside = 0.5 * probe;
    let mut k = 0;
    let last = (PROBES as f64 * REACH) as usize;
    while k < last {
        // A stride of probes at a time: where the face goes on past the stride's last probe
        // (nearly always), the probes between are not looked at; where it does not, they
        // are, in order, and the first off the face is the one the probes one by one find
        // (unless the face leaves and comes back within the stride: a gap narrower than
        // half a step across it, whose far side is then taken for the same face).
        let far = (k + STRIDE).min(last);
        if on_face(t, form, p + far as f64 * probe * side) {
            inside = far as f64 * probe;
            k = far;
            continue;
        }
        let mut s = far as f64 * probe;
        for j in k + 1..far {
            let at = j as f64 * probe;
            if !on_face(t, form, p + at * side) {
                s = at;
                break;
            }
            inside = at;
        }
        // The face ends between `inside` and s.
        let mut outside = s;
        for _ in 0..BISECT {
            let mid = 0.5 * (inside + outside);
            if on_face(t, form, p + mid * side) {
                inside = mid;
            } else {
                outside = mid;
            }
        }
        let w = 0.5 * (inside + outside);
        return Some((w, onto_form(t, form, p + w * side)));
    }
    None
}

/// q moved onto the zero set of `form` by three Newton steps, if they stay finite.
fn onto_form(t: &mut Tracer<'_>, form: usize, mut q: DVec3) -> Option<DVec3> {
    for _ in 0..3 {
        let l = t.c.form(form, q);
        let g2 = l.gradient.length_squared();
        if !(g2 > 0.0 && l.value.is_finite()) {
            return None;
        }
        // On the zero set (a plane's form after one step): the steps left would move no
        // coordinate, unless one is a zero whose sign a step could flip (or an infinite
        // partial made the step NaN).
        if l.value == 0.0 && g2.is_finite() && !q.cmpeq(DVec3::ZERO).any() {
            break;
        }
        q -= l.gradient * (l.value / g2);
    }
    Some(q)
}

/// Whether q, projected onto the zero set of `form`, lies on the surface: f is 0 there, and
/// positive a little way out along the form's normal (`OUT`). Where two solids touch along a
/// plane they share (blocks stacked flush, the upper one overhanging) f is 0 on that plane
/// too, with the solid on both sides: no face. Measured into it, the overhang's underside,
/// a strip 0.21 wide beside the contact, was taken for a face 0.89 wide and not capped, where
/// the same part turned a quarter about x measured its width (0.20 of mean radius ratio
/// between the two and twice the triangles on some faces).
fn on_face(t: &mut Tracer<'_>, form: usize, q: DVec3) -> bool {
    let Some(q) = onto_form(t, form, q) else {
        return false;
    };
    let f = t.c.whole(q);
    if !(f.value.is_finite() && f.value.abs() <= ON * t.step * f.gradient.length()) {
        return false;
    }
    let Some(out) = t.c.form(form, q).gradient.try_normalize() else {
        return false;
    };
    t.c.whole(q + OUT * t.step * out).value > 0.0
}
