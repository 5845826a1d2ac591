//! Creases that die out. Where the two faces of a crease become one sheet — past the ends of
//! the concave crease between the offsets of two solids flush on a face, both rounded solids
//! are the shared face — the crease ends at a point where its faces' normals meet, and the
//! faces go on as one sheet. Each such end is a corner of its crease (`Tracer::dying_end`).
//! A crease both of whose ends die is closed by a seam through the sheet the faces share
//! (`Tracer::close_dying_creases`): the section of form i's sheet by the plane through both
//! ends along the crease's direction at its last end, on which both forms vanish; each face's
//! loop is the crease and the seam, and each face is marched up to the seam. A seam that
//! leaves the shared sheet, or a dying end without a partner, is refused where it dies.

use crate::survey::spine::Creased;
use glam::DVec3;

use super::{Corner, Seam, Traced, Tracer, sine};
use crate::pipeline::crease_net::CreaseError;
use crate::survey::faces::{self, Leaving};

/// How far past a stuck point (in steps) the two forms must be one sheet for the crease to
/// die there: beyond the walk's last halvings, within the shared face.
const BEYOND: [f64; 3] = [0.02, 0.05, 0.1];

/// Two forms are one sheet at a point when the other's distance is below `coincide` steps
/// (`FaceSettings`) and their normals are parallel to this sine (as `survey::faces::relate`
/// asks).
const PARALLEL: f64 = 1e-7;

/// The seam is traced in steps of this fraction of the step before resampling.
const SEAM_STEP: f64 = 0.25;

impl Tracer<'_> {
    /// The corner where the crease of forms i and j, stuck at p walking along t with their
    /// normals nearly parallel, dies out: a little farther along t the two forms are one
    /// sheet. None when they are not.
    pub(in crate::pipeline::crease_net) fn dying_end(
        &mut self,
        i: usize,
        j: usize,
        p: DVec3,
        t: DVec3,
    ) -> Result<Option<usize>, CreaseError> {
        for beyond in BEYOND {
            let Some(q) = faces::onto(self.c, i, p + beyond * self.step * t, self.step) else {
                return Ok(None);
            };
            if !self.one_sheet(i, j, q) {
                return Ok(None);
            }
        }
        if !self.inside(p) {
            return Err(CreaseError::LeavesBox { at: p });
        }
        if crate::trace::enabled() {
            eprintln!("creases: the crease of {i} and {j} dies out at {p}");
        }
        self.corners.push(Corner {
            at: p,
            // The crease that ends here; the seam is not traced from it (`close_dying_creases`).
            leaving: vec![Leaving {
                faces: [(i, DVec3::ZERO), (j, DVec3::ZERO)],
                direction: -t,
                at: p,
            }],
            hand_over: false,
            tangent: None,
            dying: Some((i, j, t)),
        });
        Ok(Some(self.corners.len() - 1))
    }

    /// Closes every crease whose two ends die out by a seam through the sheet its faces
    /// share, from its last end to its first (so the faces lie on the same sides of both).
    /// A dying end of any other crease is refused there.
    pub(in crate::pipeline::crease_net) fn close_dying_creases(
        &mut self,
    ) -> Result<(), CreaseError> {
        let mut seams = Vec::new();
        let mut closed = vec![false; self.corners.len()];
        for k in 0..self.traced.len() {
            let Some((first, last)) = self.traced[k].ends else {
                continue;
            };
            let (Some((i, j, _)), Some((_, _, toward))) =
                (self.corners[first].dying, self.corners[last].dying)
            else {
                continue;
            };
            if first == last || self.traced[k].forms != (i, j) {
                continue;
            }
            let (from, to) = (self.corners[last].at, self.corners[first].at);
            let Some((points, plane)) = self.seam_between(i, j, from, toward, to) else {
                return Err(CreaseError::Tangent {
                    at: from,
                    sine: 0.0,
                });
            };
            let sides = self.sides(&self.traced[k].clone())?;
            seams.push(Traced {
                forms: (i, j),
                points,
                ends: Some((last, first)),
                seam: Some(Seam { plane, sides }),
            });
            closed[first] = true;
            closed[last] = true;
        }
        if let Some(c) =
            (0..self.corners.len()).find(|&c| self.corners[c].dying.is_some() && !closed[c])
        {
            return Err(CreaseError::Tangent {
                at: self.corners[c].at,
                sine: 0.0,
            });
        }
        self.traced.extend(seams);
        Ok(())
    }

    /// The seam from `from` to `to` on the sheet forms i and j share: form i's sheet cut by
    /// the plane through both points along `toward` at `from`. Its points and the plane, or
    /// None where the cut leaves the shared sheet or meets another face.
    fn seam_between(
        &mut self,
        i: usize,
        j: usize,
        from: DVec3,
        toward: DVec3,
        to: DVec3,
    ) -> Option<(Vec<DVec3>, (DVec3, DVec3))> {
        let normal = (to - from).cross(toward).normalize_or_zero();
        if normal == DVec3::ZERO {
            return None;
        }
        let plane = (from, normal);
        let h = SEAM_STEP * self.step;
        let (ci, cj) = (self.c.class(i), self.c.class(j));
        let mut points = vec![from];
        let mut x = from;
        let mut dir = toward;
        let most = (4.0 * self.bbox.0.distance(self.bbox.1) / h) as usize + 16;
        for _ in 0..most {
            if x.distance(to) <= 1.5 * h && points.len() > 1 {
                points.push(to);
                return Some((points, plane));
            }
            let mut along = self.c.form(i, x).gradient.cross(normal).normalize_or_zero();
            if along.dot(dir) < 0.0 {
                along = -along;
            }
            if along == DVec3::ZERO || along.dot(dir) < 0.5 {
                return None;
            }
            let y = x + h * along;
            let q = self.on_seam(i, plane, y, along)?;
            let classes = self.classes_at(q);
            if !self.one_sheet(i, j, q) || classes.iter().any(|&c| c != ci && c != cj) {
                return None;
            }
            points.push(q);
            (x, dir) = (q, along);
        }
        None
    }

    /// The point of form i's sheet in `plane` near y, in the plane through y normal to m
    /// (`seam_point`), or None.
    pub(in crate::pipeline::crease_net) fn on_seam(
        &mut self,
        i: usize,
        plane: (DVec3, DVec3),
        y: DVec3,
        m: DVec3,
    ) -> Option<DVec3> {
        seam_point(self.c, i, plane, y, m, self.step)
    }

    /// Forms i and j are one sheet at q (on form i's).
    fn one_sheet(&mut self, i: usize, j: usize, q: DVec3) -> bool {
        let (a, b) = (self.c.form(i, q), self.c.form(j, q));
        let nb = b.gradient.length();
        nb > 0.0
            && b.value.abs() <= self.s.faces.coincide * self.step * nb
            && a.gradient.dot(b.gradient) > 0.0
            && sine(a.gradient, b.gradient) <= PARALLEL
    }
}

/// The point of form i's sheet in `plane` (origin, normal) near y, in the plane through y
/// normal to m (`faces::solve3` on the three), or None.
pub(in crate::pipeline::crease_net) fn seam_point(
    c: &mut Creased,
    i: usize,
    (origin, normal): (DVec3, DVec3),
    y: DVec3,
    m: DVec3,
    step: f64,
) -> Option<DVec3> {
    faces::solve3(y, step, |q| {
        let a = c.form(i, q);
        let scale = a.gradient.length() * m.length();
        (
            [a.gradient, normal, m],
            DVec3::new(a.value, normal.dot(q - origin), m.dot(q - y)),
            scale,
        )
    })
}
