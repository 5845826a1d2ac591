//! How wide the faces beside a crease are. A face narrower than the step between two creases
//! (a plate's rim, the wall of a hole through a thin plate, a rib's top) would be held by
//! polygons spaced by the step and marched with triangles as long as the step across a strip
//! narrower than them: slivers. The width, measured across the face from points of each
//! crease, caps the local step there (`survey::sizing::Cap`, graded away from it), so that
//! the crease's polygon and the face's march are both spaced by it.
//!
//! The cap is the width divided into whole rows of equilateral triangles (a row is √3/2 of
//! its edge high), at least `MIN_ROWS` of them: a strip between two creases fits its
//! triangles only when its width is a whole number of rows. Capping at the width itself
//! gave 1.15 rows (a strip of slivers and right triangles), and one row would need the two
//! creases' vertices staggered by half an edge, which their separate resampling does not
//! give; two rows fit whatever the phase, the middle row of free vertices taking it up.
//! Faces up to `REACH` steps wide are measured, as a strip 1.3 steps wide is as ill-fitting
//! as one 0.9 wide. On the generated CAD parts' meshes below the quality bars (docs/quality.md,
//! *Strips between creases*) the mean radius ratio went from 0.955 to 0.967 at the smallest
//! feature and from 0.938 to 0.956 at 2½ times it, for 15 % more triangles; three rows
//! at least gave 0.971 and 0.951, with more triangles below 30° where the grading from the
//! strip's small step to the step is steep.
//!
//! Across the face: from a point p of the crease, along d = ±n × t (n the face's normal, t
//! the crease's tangent), points p + s·d projected onto the face's form stay on the surface
//! (|f| ≈ 0) until the face ends at its next crease, where f leaves 0 (another face cut it
//! off, or another part of the solid covers it). Of ±d, the side where the face goes on.

use glam::DVec3;

use super::trace::{Traced, Tracer};
use crate::survey::sizing::Cap;

/// The face's end is looked for at these fractions of the step (eighths), then bisected.
const PROBES: usize = 8;
/// Faces up to this many steps wide cap the local step (module documentation).
const REACH: f64 = 3.0;
/// The height of a row of equilateral triangles, as a fraction of their edge.
const ROW: f64 = 0.866_025_403_784_438_6;
/// The fewest rows a strip between creases is divided into (module documentation).
const MIN_ROWS: f64 = 2.0;
const BISECT: usize = 5;
/// Points of a crease measured from: about every quarter step.
const SPACING: f64 = 0.25;
/// A projected point is on the face while |f| is below this fraction of the step (times
/// |∇f|): the face's end is found to about that over the sine of the crease's angle.
const ON: f64 = 1e-4;

/// Caps of the local step at points of `tr` where a face beside it is narrower than `REACH`
/// steps: its width divided into whole rows of triangles.
pub(super) fn caps(t: &mut Tracer<'_>, tr: &Traced) -> Vec<Cap> {
    let (i, j) = tr.forms;
    let points = &tr.points;
    let mut out = Vec::new();
    let mut since = f64::INFINITY;
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
        let narrowest = [i, j]
            .into_iter()
            .filter_map(|form| width(t, form, p, tangent))
            .fold(f64::INFINITY, f64::min);
        if narrowest < REACH * t.step {
            let rows = (narrowest / (ROW * t.step)).ceil().max(MIN_ROWS);
            out.push(Cap {
                at: p,
                size: narrowest / (rows * ROW),
            });
        }
    }
    out
}

/// The width of face `form` beside the crease point p with tangent t, if the face is
/// narrower than `REACH` steps there.
fn width(t: &mut Tracer<'_>, form: usize, p: DVec3, tangent: DVec3) -> Option<f64> {
    let normal = t.c.form(form, p).gradient.try_normalize()?;
    let across = normal.cross(tangent).try_normalize()?;
    let probe = t.step / PROBES as f64;
    // The side the face lies on: the face goes on a short way along it.
    let side = [across, -across]
        .into_iter()
        .find(|&d| on_face(t, form, p + 0.5 * probe * d))?;
    let mut inside = 0.5 * probe;
    for k in 1..=(PROBES as f64 * REACH) as usize {
        let s = k as f64 * probe;
        if on_face(t, form, p + s * side) {
            inside = s;
            continue;
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
        return Some(0.5 * (inside + outside));
    }
    None
}

/// Whether q, projected onto the zero set of `form`, lies on the surface: f is 0 there.
fn on_face(t: &mut Tracer<'_>, form: usize, mut q: DVec3) -> bool {
    for _ in 0..3 {
        let l = t.c.form(form, q);
        let g2 = l.gradient.length_squared();
        if !(g2 > 0.0 && l.value.is_finite()) {
            return false;
        }
        q -= l.gradient * (l.value / g2);
    }
    let f = t.c.whole(q);
    f.value.is_finite() && f.value.abs() <= ON * t.step * f.gradient.length()
}
