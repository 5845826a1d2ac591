//! The crease search and tracing of `crease_net`: the octree cells where two forms may meet,
//! seeds on them, each crease walked both ways to its corners or round, corners solved and
//! asked which creases leave them (`survey::faces`), creases that no seed found traced from
//! their corners, and each crease resampled at the local step of both its pieces.

use std::collections::{HashMap, HashSet};
use std::rc::Rc;

use glam::{DMat3, DVec3};

use super::pair::Wanted;
use super::{CreaseError, CreaseSettings};
use crate::eval::Interval;
use crate::solve::SurfacePoint;
use crate::solve::curve::{ArcLength, min_norm_step};
use crate::solve::surfacepoint::tangent_frame;
use crate::surface::{Surface, ValueGrad};
use crate::survey::faces::{self, Crossing, FaceSettings, Junction, Leaving, Scale};
use crate::survey::sizing::Sizing;
use crate::survey::spine::{Creased, Spine};

/// A cell of the crease search's octree: its box, the spine pruned over it (or over the
/// cell it was split from) and that spine's forms, once known.
type Cell = (DVec3, DVec3, Rc<Spine>, Option<Rc<Vec<usize>>>);

mod dying;
pub(super) use dying::seam_point;
mod tangent;

/// A traced crease: the forms it was traced on (i, j), its points along ∇Lᵢ × ∇Lⱼ, and the
/// corners at its ends.
#[derive(Clone)]
pub(super) struct Traced {
    pub forms: (usize, usize),
    pub points: Vec<DVec3>,
    /// Corner ids at the first and last point; None for a closed crease.
    pub ends: Option<(usize, usize)>,
    /// A seam through a sheet both forms share (`dying`): the plane (a point, its normal)
    /// that cuts it out of form i's sheet, and the faces' sides, those of the crease it
    /// continues. None for a crease.
    pub seam: Option<Seam>,
}

/// How a seam between dying ends lies: the plane it is cut by and its faces' sides.
#[derive(Clone, Copy, Debug)]
pub(super) struct Seam {
    pub plane: (DVec3, DVec3),
    pub sides: (bool, bool),
}

/// A corner: where it is and the creases that leave it.
pub(super) struct Corner {
    pub at: DVec3,
    pub leaving: Vec<Leaving>,
    /// A hand-over (two creases of the same two faces, see `Tracer::hand_over`), which a
    /// walk along the faces meets without an event: it stops there all the same.
    pub hand_over: bool,
    /// Where the two faces of its creases touch and cross (`Tracer::tangent_crossing`):
    /// their common normal (∇f's way). Each face meets such a corner in two sectors, and
    /// its loops are chained there by the turn around this normal (`join::chain`).
    pub tangent: Option<DVec3>,
    /// Where a crease of forms (i, j) dies out (`Tracer::dying_end`): the forms and the
    /// direction the crease would go on, into the sheet they share.
    pub dying: Option<(usize, usize, DVec3)>,
}

/// Normals closer than this sine (0.6°) are tangent to a stuck walk: a form with one of its
/// forms' normals may stand in for it (`Tracer::hand_over`), and a walk stuck with its two
/// forms' normals that close ends where its faces become tangent. Far below any crease
/// angle traced, far above the crease's turn over the last halvings.
pub(super) const TANGENT: f64 = 1e-2;

/// What the walk met where the active faces changed.
enum Event {
    /// A junction the crease passes through (ties of operands inside the solid).
    Through(DVec3),
    /// A corner: its id.
    Corner(usize),
}

/// An octree leaf where two forms or more may meet: its box and those forms.
pub(super) type Leaf = (DVec3, DVec3, Vec<usize>);

/// The state of one crease search.
pub(super) struct Tracer<'a> {
    pub c: &'a mut Creased,
    pub step: f64,
    pub bbox: (DVec3, DVec3),
    pub s: CreaseSettings,
    pub corners: Vec<Corner>,
    pub traced: Vec<Traced>,
    /// Tracing points with their forms, by cell of side `covered · step`.
    near: HashMap<[i64; 3], Vec<(DVec3, usize, usize)>>,
    /// Pairs of forms found to be one sheet with opposite sides, or one the other's shadow
    /// (`faces::Relation`), smaller id first: never a third face of a crease of the other.
    opposite: HashSet<(usize, usize)>,
}

/// How many traced points of a crease are asked for the side its faces lie on.
const PROBES: usize = 8;

impl<'a> Tracer<'a> {
    pub fn new(c: &'a mut Creased, step: f64, bbox: (DVec3, DVec3), s: CreaseSettings) -> Self {
        Tracer {
            c,
            step,
            bbox,
            s,
            corners: Vec::new(),
            traced: Vec::new(),
            near: HashMap::new(),
            opposite: HashSet::new(),
        }
    }

    fn faces(&self) -> FaceSettings {
        self.s.faces
    }

    fn scale(&self) -> Scale {
        Scale {
            step: self.step,
            tie: self.s.tie,
        }
    }

    fn inside(&self, p: DVec3) -> bool {
        let (lo, hi) = self.bbox;
        p.cmpge(lo).all() && p.cmple(hi).all()
    }

    /// The octree leaves where f and at least two forms may be zero, with those forms. A
    /// spine without selectors is pruned cell by cell (`Spine::pruned`), so a cell holds
    /// only the forms that can be chosen in it; a lifted one bounds all its forms.
    pub fn cells(&mut self, whole: &mut dyn Surface) -> Result<Vec<Leaf>, CreaseError> {
        let leaf = self.s.leaf * self.step;
        let mut out = Vec::new();
        // A cell's children share its pruned spine and its forms: a child whose spine prunes
        // to the same terms has the same forms (`forms_of` is a function of the terms).
        let root = Rc::new(self.c.spine().clone());
        let mut stack: Vec<Cell> = vec![(self.bbox.0, self.bbox.1, root, None)];
        let mut visited = 0usize;
        while let Some((lo, hi, spine, spine_forms)) = stack.pop() {
            visited += 1;
            if visited > self.s.max_cells {
                return Err(CreaseError::CellLimit {
                    cells: self.s.max_cells,
                });
            }
            let (spine, forms) = if self.c.enumerated() {
                if !whole.bound(lo, hi).is_none_or(|i| i.contains(0.0)) {
                    continue;
                }
                let forms =
                    spine_forms.unwrap_or_else(|| Rc::new((0..self.c.form_count()).collect()));
                (spine, forms)
            } else {
                let c = &mut *self.c;
                let near_zero = |bound: Interval| bound.contains(0.0) || bound.is_empty();
                let Some((pruned, _)) =
                    spine.pruned_if(&mut |k| c.branch_bound(k, lo, hi), near_zero)
                else {
                    continue;
                };
                match spine_forms {
                    // The parent's spine had a choice (it was split), and so has this one.
                    Some(forms) if pruned == *spine => (spine, forms),
                    _ => {
                        if !pruned.has_choice() {
                            continue;
                        }
                        let forms =
                            self.c
                                .forms_of(&pruned)
                                .map_err(|_| CreaseError::TooManyForms {
                                    at: 0.5 * (lo + hi),
                                })?;
                        (Rc::new(pruned), Rc::new(forms))
                    }
                }
            };
            let zero: Vec<usize> = forms
                .iter()
                .copied()
                .filter(|&i| self.c.form_bound(i, lo, hi).is_none_or(|b| b.contains(0.0)))
                .collect();
            if zero.len() < 2 {
                continue;
            }
            let size = hi - lo;
            if size.max_element() <= leaf {
                out.push((lo, hi, zero));
                continue;
            }
            // Split the sides longer than the leaf in two; children pushed reversed so the
            // first is searched first.
            let mid = 0.5 * (lo + hi);
            let mut children = vec![(lo, hi)];
            for k in 0..3 {
                if size[k] > leaf {
                    children = children
                        .into_iter()
                        .flat_map(|(a, b)| {
                            let (mut a1, mut b0) = (b, a);
                            a1[k] = mid[k];
                            b0[k] = mid[k];
                            [(a, a1), (b0, b)]
                        })
                        .collect();
                }
            }
            stack.extend(
                children
                    .into_iter()
                    .rev()
                    .map(|(a, b)| (a, b, Rc::clone(&spine), Some(Rc::clone(&forms)))),
            );
        }
        Ok(out)
    }

    /// Form i and the function whose zero on it is the seam with form j
    /// (`Creased::seam`: form j, or the selector of a lifted choice).
    fn pair(&mut self, i: usize, j: usize, p: DVec3) -> (ValueGrad, ValueGrad) {
        self.c.seam(i, j, p)
    }

    /// The tie tolerance of the spine at a point where the gradients are about `g` long.
    fn eps(&self, g: f64) -> f64 {
        self.s.tie * self.step * g.max(f64::MIN_POSITIVE)
    }

    /// The faces (classes) chosen at p, sorted.
    fn classes_at(&mut self, p: DVec3) -> Vec<usize> {
        let g = self.c.whole(p).gradient.length();
        let active = self.c.active(p, self.eps(g));
        let mut out: Vec<usize> = active.into_iter().map(|k| self.c.class(k)).collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Whether q lies on the crease of forms i and j: i and j are chosen there, and the faces
    /// chosen are theirs and no other. Forms chosen there that are one sheet with i or j are
    /// united with them first. (A form of a face may be one sheet with it over a part only,
    /// a smooth boolean's lifted piece saturating onto a plane: where it parts from the
    /// face, it is no longer chosen, and the crease is handed over, `hand_over`.)
    fn on_crease(&mut self, i: usize, j: usize, q: DVec3) -> bool {
        let g = self.c.whole(q).gradient.length();
        let active = self.c.active(q, self.eps(g));
        if !(active.contains(&i) && active.contains(&j)) {
            return false;
        }
        let (ci, cj) = (self.c.class(i), self.c.class(j));
        let scale = self.scale();
        let fs = self.faces();
        for &k in &active {
            let ck = self.c.class(k);
            if ck == ci || ck == cj {
                continue;
            }
            let gk = self.c.form(k, q).gradient;
            for f in [i, j] {
                // A lifted choice's other operand beside f (a box's next face, past the
                // edge the seam is) may still be one sheet with the other face.
                if self.c.by_selector(k, f) {
                    continue;
                }
                if self.opposite.contains(&(f.min(k), f.max(k))) {
                    break;
                }
                let gf = self.c.form(f, q).gradient;
                if sine(gk, gf) <= 1e-7 {
                    match faces::relate(self.c, f, k, q, &scale, &fs) {
                        faces::Relation::Same => self.c.unite(f, k),
                        // A shadow or the other side of a face is no third face.
                        faces::Relation::Opposite | faces::Relation::Shadow => {
                            self.opposite.insert((f.min(k), f.max(k)));
                        }
                        faces::Relation::Touching => continue,
                    }
                    break;
                }
            }
        }
        let (ci, cj) = (self.c.class(i), self.c.class(j));
        // A form that is the other side of one of the two faces (the inner face where two
        // solids meet) is no third face.
        let active: Vec<usize> = active
            .into_iter()
            .filter(|&k| !self.opposite.contains(&(i.min(k), i.max(k))))
            .filter(|&k| !self.opposite.contains(&(j.min(k), j.max(k))))
            .collect();
        let mut classes: Vec<usize> = active.into_iter().map(|k| self.c.class(k)).collect();
        classes.sort_unstable();
        classes.dedup();
        classes.len() == 2 && classes.contains(&ci) && classes.contains(&cj)
    }

    /// A crease point of forms i and j from the centre of the cell, if Newton lands near the
    /// cell, in the box, where both are chosen. Forms with parallel normals there are one
    /// face (united), opposite faces, or a tangential contact (an error where both are
    /// chosen).
    pub fn seed(
        &mut self,
        i: usize,
        j: usize,
        lo: DVec3,
        hi: DVec3,
    ) -> Result<Option<DVec3>, CreaseError> {
        let mut p = 0.5 * (lo + hi);
        let margin = hi - lo;
        let floor = 1e-13 * self.step;
        let mut converged = false;
        for _ in 0..40 {
            let (a, b) = self.pair(i, j, p);
            let delta = min_norm_step(a, b, 1e-9);
            if !delta.is_finite() {
                return Ok(None);
            }
            p -= delta;
            if !(p.cmpge(lo - margin).all() && p.cmple(hi + margin).all()) {
                return Ok(None);
            }
            if delta.length() <= floor.max(4.0 * f64::EPSILON * p.abs().max_element()) {
                converged = true;
                break;
            }
        }
        let (a, b) = self.pair(i, j, p);
        let g = a.gradient.length().max(b.gradient.length());
        let residual = a.value.abs().max(b.value.abs()) / g;
        if residual.is_nan() || residual > 1e-9 * self.step || !self.inside(p) {
            return Ok(None);
        }
        let classes = self.classes_at(p);
        let (ci, cj) = (self.c.class(i), self.c.class(j));
        if !(classes.contains(&ci) && classes.contains(&cj)) {
            return Ok(None);
        }
        let sine = sine(a.gradient, b.gradient);
        // Newton that stalls short of rounding with a small residual is slow where the
        // normals are nearly parallel (a contact, below), or its forms are noisy at the
        // last digits (a `dist` solved by foot points): there, with the normals far apart,
        // the point is a seed all the same, which the walk corrects.
        if sine < self.s.tangent_sine || (!converged && sine < TANGENT) {
            if !self.c.by_selector(i, j) {
                match faces::relate(self.c, i, j, p, &self.scale(), &self.faces()) {
                    faces::Relation::Same => {
                        self.c.unite(i, j);
                        return Ok(None);
                    }
                    faces::Relation::Opposite | faces::Relation::Shadow => return Ok(None),
                    faces::Relation::Touching => {}
                }
            }
            // Where the faces touch and cross, a corner the creases are traced from.
            if self.tangent_crossing(i, j, p)?.is_some() {
                return Ok(None);
            }
            return Err(CreaseError::Tangent { at: p, sine });
        }
        Ok(Some(p))
    }

    /// What a seed of forms i and j is: the crease it lies on (its two faces' forms), or
    /// nothing to trace (no surface, one smooth face, or next to a corner, where the creases
    /// are traced from along them).
    pub fn seed_crease(
        &mut self,
        i: usize,
        j: usize,
        p: DVec3,
    ) -> Result<Option<(usize, usize)>, CreaseError> {
        let t = self.tangent(i, j, p)?;
        let (scale, fs) = (self.scale(), self.faces());
        match faces::crossing(self.c, p, t, &scale, &fs)? {
            // In the order of the seed's forms where the faces are theirs, so the crease is
            // walked the way ∇Lᵢ × ∇Lⱼ points.
            Crossing::Crease { faces } if self.c.class(faces[0].0) == self.c.class(j) => {
                Ok(Some((faces[1].0, faces[0].0)))
            }
            Crossing::Crease { faces } => Ok(Some((faces[0].0, faces[1].0))),
            Crossing::None | Crossing::Smooth | Crossing::Corner => Ok(None),
        }
    }

    fn key(&self, p: DVec3) -> [i64; 3] {
        (p / (self.s.covered * self.step))
            .floor()
            .to_array()
            .map(|c| c as i64)
    }

    /// Whether a crease of the faces of i and j was traced, or a line of them found to be no
    /// crease, within `covered · step` of p.
    pub fn covered(&mut self, i: usize, j: usize, p: DVec3) -> bool {
        let k = self.key(p);
        let r = self.s.covered * self.step;
        let (ci, cj) = (self.c.class(i), self.c.class(j));
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let key = [k[0] + dx, k[1] + dy, k[2] + dz];
                    let Some(list) = self.near.get(&key) else {
                        continue;
                    };
                    for &(q, a, b) in list {
                        if q.distance(p) > r {
                            continue;
                        }
                        let (ca, cb) = (self.c.class(a), self.c.class(b));
                        if (ca == ci && cb == cj) || (ca == cj && cb == ci) {
                            return true;
                        }
                    }
                }
            }
        }
        false
    }

    /// Keeps a traced crease (found from `from`), and says so under `SURFC_TRACE`.
    pub fn keep(&mut self, tr: Traced, trace: bool, from: DVec3) {
        if trace {
            let (i, j) = tr.forms;
            eprintln!(
                "creases: forms {i} and {j} from {from}: {} points, ends {:?}",
                tr.points.len(),
                tr.ends
            );
        }
        let (i, j) = tr.forms;
        for &p in &tr.points {
            self.remember(p, i, j);
        }
        self.traced.push(tr);
    }

    /// Remembers that a crease of the faces of i and j, or a line of them that is none (one
    /// face going on, or no surface: the same along it up to the next junction), passes p.
    pub fn remember(&mut self, p: DVec3, i: usize, j: usize) {
        let k = self.key(p);
        self.near.entry(k).or_default().push((p, i, j));
    }

    fn tangent(&mut self, i: usize, j: usize, p: DVec3) -> Result<DVec3, CreaseError> {
        let (a, b) = self.pair(i, j, p);
        let c = a.gradient.cross(b.gradient);
        let s = sine(a.gradient, b.gradient);
        if s.is_nan() || s < self.s.tangent_sine {
            return Err(CreaseError::Tangent { at: p, sine: s });
        }
        Ok(c / c.length())
    }

    fn correct(&mut self, i: usize, j: usize, p0: DVec3, o: DVec3, m: DVec3) -> Option<DVec3> {
        faces::correct(self.c, i, j, p0, o, m, self.step)
    }

    /// The crease of forms i and j through `seed`, both ways, to its corners or round.
    pub fn trace(&mut self, i: usize, j: usize, seed: DVec3) -> Result<Traced, CreaseError> {
        let (forward, end) = self.walk(i, j, seed, 1.0, None)?;
        let Some(end) = end else {
            return Ok(Traced {
                forms: (i, j),
                points: forward,
                ends: None,
                seam: None,
            });
        };
        let (mut backward, start) = self.walk(i, j, seed, -1.0, None)?;
        let start = start.ok_or(CreaseError::Lost { at: seed })?;
        backward.reverse();
        backward.extend_from_slice(&forward[1..]);
        Ok(Traced {
            forms: (i, j),
            points: backward,
            ends: Some((start, end)),
            seam: None,
        })
    }

    /// Traces every crease that leaves a corner and was not traced yet (one shorter than a
    /// cell's reach, which no seed found), corners found on the way included.
    pub fn trace_from_corners(&mut self, trace: bool) -> Result<(), CreaseError> {
        let mut next = 0;
        while next < self.corners.len() {
            let leaving = self.corners[next].leaving.clone();
            let at = self.corners[next].at;
            for l in leaving {
                if self.known_leaving(next, &l) {
                    continue;
                }
                let (i, j) = (l.faces[0].0, l.faces[1].0);
                let t = self.tangent(i, j, l.at)?;
                let dir = if t.dot(l.direction) >= 0.0 { 1.0 } else { -1.0 };
                // At a tangent crossing the crease has no direction: the walk starts where
                // the crease leaving it was found, the corner before it.
                let start = if self.corners[next].tangent.is_some() {
                    l.at
                } else {
                    at
                };
                let (mut points, end) = self.walk(i, j, start, dir, Some(next))?;
                if start != at {
                    points.insert(0, at);
                }
                let end = end.ok_or(CreaseError::Lost { at })?;
                self.keep(
                    Traced {
                        forms: (i, j),
                        points,
                        ends: Some((next, end)),
                        seam: None,
                    },
                    trace,
                    at,
                );
            }
            next += 1;
        }
        Ok(())
    }

    /// Whether a crease traced already ends at corner `id` along `l`.
    fn known_leaving(&mut self, id: usize, l: &Leaving) -> bool {
        let (a, b) = (self.c.class(l.faces[0].0), self.c.class(l.faces[1].0));
        for k in 0..self.traced.len() {
            let Some((s, e)) = self.traced[k].ends else {
                continue;
            };
            let (i, j) = self.traced[k].forms;
            let (ci, cj) = (self.c.class(i), self.c.class(j));
            if !((ci == a && cj == b) || (ci == b && cj == a)) {
                continue;
            }
            let pts = &self.traced[k].points;
            let n = pts.len();
            let mut ends = Vec::new();
            if s == id && n >= 2 {
                ends.push((pts[0], pts[1]));
            }
            if e == id && n >= 2 {
                ends.push((pts[n - 1], pts[n - 2]));
            }
            // The crease leaving along l, of the corner's creases of these faces the one
            // nearest in direction (a tangent crossing has four, at any angle).
            let others: Vec<DVec3> = self.corners[id]
                .leaving
                .iter()
                .filter(|o| {
                    o.direction != l.direction
                        && same_faces(self.c, o.faces, l.faces[0].0, l.faces[1].0)
                })
                .map(|o| o.direction)
                .collect();
            if ends.iter().any(|&(v, w)| {
                let d = (w - v).normalize_or_zero();
                let along = d.dot(l.direction);
                along > 0.5 && others.iter().all(|o| d.dot(*o) < along)
            }) {
                return true;
            }
        }
        false
    }

    /// Walks from `seed` along dir·(∇Lᵢ × ∇Lⱼ): the points, and the corner id where it
    /// stopped (None: closed, back at the seed). `from` is the corner it starts at, if any.
    ///
    /// Each step is tried at the current length and halved until it lands on the crease about
    /// that far on with a tangent that turned little; before that, a step across a place
    /// where the faces change (another face chosen, or a form of another face crossing the
    /// crease) is an event: a corner ends the walk, a junction passed through continues it
    /// from the junction.
    fn walk(
        &mut self,
        i: usize,
        j: usize,
        seed: DVec3,
        dir: f64,
        from: Option<usize>,
    ) -> Result<(Vec<DVec3>, Option<usize>), CreaseError> {
        let h0 = self.s.trace * self.step;
        let mut points = vec![seed];
        let mut p = seed;
        let mut t = dir * self.tangent(i, j, p)?;
        let mut h = h0;
        // The junction the walk stands on (its start corner, or one it passed through): the
        // next event is looked for beyond it.
        let mut standing: Option<DVec3> = from.map(|id| self.corners[id].at);
        'walk: loop {
            if points.len() > self.s.max_points {
                return Err(CreaseError::TooLong {
                    at: seed,
                    points: points.len(),
                });
            }
            let mut halvings = 0;
            let q = loop {
                let y = p + h * t;
                let landed = self
                    .correct(i, j, y, y, t)
                    .filter(|q| (0.5 * h..=1.5 * h).contains(&q.distance(p)));
                // Where the step ends (on the crease, or where it would be when the correction
                // fails there: past a corner the crease has no continuation to land on).
                let end = landed.unwrap_or(y);
                let changed = landed.is_some_and(|q| !self.on_crease(i, j, q));
                if changed || self.crossed(i, j, p, end)? {
                    match self.event(i, j, p, end, standing)? {
                        Some(Event::Corner(id)) => {
                            points.push(self.corners[id].at);
                            return Ok((points, Some(id)));
                        }
                        Some(Event::Through(v)) => {
                            // Go on from the junction itself (on the surface), looking
                            // beyond it.
                            if v.distance(p) > 1e-9 * self.step {
                                points.push(v);
                            }
                            p = v;
                            t = dir * self.tangent(i, j, v)?;
                            standing = Some(v);
                            h = h0;
                            continue 'walk;
                        }
                        None => {}
                    }
                }
                // Another face chosen and no junction found: a shorter step.
                if let Some(q) = landed
                    && !changed
                    && self.accept(i, j, dir, t, q)
                {
                    break q;
                }
                halvings += 1;
                // Stuck: thirty halvings here, or a step as short (steps that short may
                // still land, creeping at rounding's pace).
                if halvings > 30 || h < h0 * (-30f64).exp2() {
                    let id = match self.hand_over(i, j, p, t)? {
                        Some(id) => id,
                        None => {
                            let (a, b) = self.pair(i, j, p);
                            let sine = sine(a.gradient, b.gradient);
                            if sine >= TANGENT {
                                return Err(CreaseError::Lost { at: p });
                            }
                            // Stuck where the two faces have become tangent: where they
                            // touch and cross (rods of one radius whose axes cross), a
                            // corner of four creases; anywhere else a tangent contact,
                            // which no smaller step passes.
                            match self.tangent_crossing(i, j, p)? {
                                Some(id) => id,
                                None => self
                                    .dying_end(i, j, p, t)?
                                    .ok_or(CreaseError::Tangent { at: p, sine })?,
                            }
                        }
                    };
                    let v = self.corners[id].at;
                    // The walk crept up to the parting in ever shorter steps, a tie's width
                    // off the face that goes on: those points give no direction.
                    while points.len() > 1
                        && points
                            .last()
                            .is_some_and(|l| l.distance(v) <= 1e-2 * self.step)
                    {
                        points.pop();
                    }
                    points.push(v);
                    return Ok((points, Some(id)));
                }
                h *= 0.5;
            };
            if !self.inside(q) {
                return Err(CreaseError::LeavesBox { at: q });
            }
            if let Some(id) = self.hand_over_between(i, j, p, q, standing) {
                points.push(self.corners[id].at);
                return Ok((points, Some(id)));
            }
            let seg = q - p;
            if points.len() >= 3 {
                let s = ((seed - p).dot(seg) / seg.length_squared()).clamp(0.0, 1.0);
                if (p + s * seg - seed).length() <= 0.5 * h {
                    return Ok((points, None));
                }
            }
            points.push(q);
            t = dir * self.tangent(i, j, q)?;
            p = q;
            h = (2.0 * h).min(h0);
            standing = None;
        }
    }

    /// Whether a step to q (on the crease) keeps the walk on one smooth curve: its tangent
    /// turned by at most 0.3 rad from t.
    fn accept(&mut self, i: usize, j: usize, dir: f64, t: DVec3, q: DVec3) -> bool {
        self.tangent(i, j, q)
            .is_ok_and(|nt| t.angle_between(dir * nt) <= 0.3)
    }

    /// Whether a form of another face, one that can be chosen near the segment p..q, changes
    /// sign along it: the faces around the crease may change there although the faces chosen
    /// on it do not (a concave corner, where the crease goes on inside the solid).
    fn crossed(&mut self, i: usize, j: usize, p: DVec3, q: DVec3) -> Result<bool, CreaseError> {
        let pad = DVec3::splat(1e-9 * self.step);
        let (lo, hi) = (p.min(q) - pad, p.max(q) + pad);
        let near = self
            .c
            .forms_near(lo, hi)
            .map_err(|_| CreaseError::TooManyForms { at: p })?;
        let (ci, cj) = (self.c.class(i), self.c.class(j));
        for k in near {
            let ck = self.c.class(k);
            if ck == ci || ck == cj {
                continue;
            }
            let (a, b) = (self.c.form(k, p), self.c.form(k, q).value);
            // A form zero at p: p is the junction the walk stands on.
            if a.value.abs() <= 1e-12 * self.step * a.gradient.length() {
                continue;
            }
            if (a.value > 0.0) != (b > 0.0) || b == 0.0 {
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// Where the crease of i and j, on its faces at p, meets another face before q: the
    /// point near p where a third form k is zero with them and all three are chosen (solved
    /// by Newton to rounding), asked which creases leave it. A junction at `standing` (where
    /// the walk starts) is not this event. None when no third form is chosen where it meets
    /// the crease (a form crossed it inside or outside the solid, or q is too far).
    fn event(
        &mut self,
        i: usize,
        j: usize,
        p: DVec3,
        q: DVec3,
        standing: Option<DVec3>,
    ) -> Result<Option<Event>, CreaseError> {
        let reach = 2.0 * p.distance(q) + 1e-9 * self.step;
        let (ci, cj) = (self.c.class(i), self.c.class(j));
        // The third forms: chosen at q (or tied at p) and of another face.
        let mut cands: Vec<usize> = Vec::new();
        for x in [q, p] {
            let g = self.c.whole(x).gradient.length();
            let eps = self.eps(g).max(1e-9 * self.step * g);
            for k in self.c.active(x, eps) {
                let ck = self.c.class(k);
                if ck != ci && ck != cj && !cands.contains(&k) {
                    cands.push(k);
                }
            }
        }
        let pad = DVec3::splat(1e-9 * self.step);
        if let Ok(near) = self.c.forms_near(p.min(q) - pad, p.max(q) + pad) {
            for k in near {
                let ck = self.c.class(k);
                if ck == ci || ck == cj || cands.contains(&k) {
                    continue;
                }
                let (a, b) = (self.c.form(k, p).value, self.c.form(k, q).value);
                if (a > 0.0) != (b > 0.0) || b == 0.0 || a == 0.0 {
                    cands.push(k);
                }
            }
        }
        let mut best: Option<(f64, DVec3)> = None;
        for &k in &cands {
            for start in [p, q] {
                let Some(v) = self.newton3([i, j, k], start) else {
                    continue;
                };
                let d = v.distance(p);
                if d > reach || standing.is_some_and(|s| s.distance(v) <= 1e-7 * self.step) {
                    continue;
                }
                let classes = self.classes_at(v);
                let ck = self.c.class(k);
                if ![ci, cj, ck].iter().all(|f| classes.contains(f)) {
                    continue;
                }
                if best.is_none_or(|b| d < b.0) {
                    best = Some((d, v));
                }
            }
        }
        let Some((_, v)) = best else {
            return Ok(None);
        };
        let merge = 1e-7 * self.step;
        if let Some(id) = self.corners.iter().position(|c| c.at.distance(v) <= merge) {
            return Ok(Some(Event::Corner(id)));
        }
        let (scale, fs) = (self.scale(), self.faces());
        match faces::junction(self.c, v, &scale, &fs)? {
            Junction::PassThrough => Ok(Some(Event::Through(v))),
            Junction::Corner(leaving) => {
                if !self.inside(v) {
                    return Err(CreaseError::LeavesBox { at: v });
                }
                self.corners.push(Corner {
                    at: v,
                    leaving,
                    hand_over: false,
                    tangent: None,
                    dying: None,
                });
                Ok(Some(Event::Corner(self.corners.len() - 1)))
            }
        }
    }

    /// Where the crease of i and j, lost at p, goes on as the crease of stand-ins of them:
    /// forms tied at p with i's (or j's) normal, from which i (or j) parts tangentially. A
    /// smooth boolean's piece saturates onto a face (the filleted L's lifted back face equals
    /// the back plane up to where the fillet begins, then bends away inside the solid): its
    /// crease with the top leaves the surface there, where the plane's goes on; a T's two
    /// lifted pieces along the bar's edge both part from its planes where the post begins.
    /// Each form is united with its stand-in as one face, and the hand-over point becomes a
    /// corner of two creases of the same two faces. None when no stand-ins go on.
    fn hand_over(
        &mut self,
        i: usize,
        j: usize,
        p: DVec3,
        t: DVec3,
    ) -> Result<Option<usize>, CreaseError> {
        let g = self.c.whole(p).gradient.length();
        let active = self.c.active(p, self.eps(g));
        // Each form's stand-ins: itself and the forms tied at p with its normal.
        let mut stand_ins = [vec![i], vec![j]];
        let own = [self.c.form(i, p).gradient, self.c.form(j, p).gradient];
        for &k in &active {
            if k == i || k == j {
                continue;
            }
            let gk = self.c.form(k, p).gradient;
            for (slot, gf) in own.into_iter().enumerate() {
                let other = [j, i][slot];
                if self.c.class(k) == self.c.class(other) || self.c.by_selector(k, other) {
                    continue;
                }
                // Tangent where they part.
                if gf.dot(gk) > 0.0 && sine(gf, gk) <= TANGENT {
                    stand_ins[slot].push(k);
                }
            }
        }
        let h0 = self.s.trace * self.step;
        let (scale, fs) = (self.scale(), self.faces());
        let pairs: Vec<(usize, usize)> = stand_ins[0]
            .iter()
            .flat_map(|&a| stand_ins[1].iter().map(move |&b| (a, b)))
            .filter(|&(a, b)| (a, b) != (i, j) && a != b)
            .collect();
        for (a, b) in pairs {
            let Some(v) = self.correct(a, b, p, p, t) else {
                continue;
            };
            if v.distance(p) > 1e-4 * self.step {
                continue;
            }
            // It goes on: a step along t lands on the crease of a and b, both chosen there.
            let mut h = h0;
            let mut next = None;
            for _ in 0..12 {
                let y = v + h * t;
                if let Some(q) = self
                    .correct(a, b, y, y, t)
                    .filter(|q| (0.5 * h..=1.5 * h).contains(&q.distance(v)))
                    && self.on_crease(a, b, q)
                {
                    next = Some(q);
                    break;
                }
                h *= 0.5;
            }
            let Some(q) = next else {
                continue;
            };
            let mut tq = self.tangent(a, b, q)?;
            if tq.dot(t) < 0.0 {
                tq = -tq;
            }
            let Crossing::Crease { faces } = faces::crossing(self.c, q, tq, &scale, &fs)? else {
                continue;
            };
            self.c.unite(i, a);
            self.c.unite(j, b);
            if !self.inside(v) {
                return Err(CreaseError::LeavesBox { at: v });
            }
            let ahead = Leaving {
                faces,
                direction: (q - v).normalize_or_zero(),
                at: q,
            };
            let behind = Leaving {
                direction: -t,
                at: v - h * t,
                ..ahead
            };
            if crate::trace::enabled() {
                eprintln!(
                    "creases: the crease of {i} and {j} goes on at {v} as the crease of {a} and {b}"
                );
            }
            self.corners.push(Corner {
                at: v,
                leaving: vec![behind, ahead],
                hand_over: true,
                tangent: None,
                dying: None,
            });
            return Ok(Some(self.corners.len() - 1));
        }
        Ok(None)
    }

    /// A hand-over corner of the faces of i and j on the segment p..q (other than where the
    /// walk stands): the walk along the faces' other forms passes it without an event.
    fn hand_over_between(
        &mut self,
        i: usize,
        j: usize,
        p: DVec3,
        q: DVec3,
        standing: Option<DVec3>,
    ) -> Option<usize> {
        let seg = q - p;
        let near = 1e-6 * self.step;
        (0..self.corners.len()).find(|&id| {
            let corner = &self.corners[id];
            if !corner.hand_over || standing.is_some_and(|s| s.distance(corner.at) <= near) {
                return false;
            }
            let s = ((corner.at - p).dot(seg) / seg.length_squared()).clamp(0.0, 1.0);
            // The corner lies on the crease, which bends away from the chord by up to its
            // curvature times the step squared.
            if (p + s * seg).distance(corner.at) > near.max(0.1 * seg.length()) {
                return false;
            }
            same_faces(self.c, corner.leaving[0].faces, i, j)
        })
    }

    /// The common zero of three forms near `start`: Newton on one of them and its seams with
    /// the other two, each form tried as that pivot in turn (two seams of one pivot may be
    /// one lifted choice's selector, which tells nothing apart). None when no pivot converges
    /// or the normals do not span space.
    fn newton3(&mut self, forms: [usize; 3], start: DVec3) -> Option<DVec3> {
        let [a, b, c] = forms;
        for [i, j, k] in [[a, b, c], [b, a, c], [c, a, b]] {
            if self.c.adjacent(i, j)
                && self.c.adjacent(i, k)
                && let Some(v) = self.newton3_on([i, j, k], start)
            {
                return Some(v);
            }
        }
        None
    }

    /// Newton on form i and its seams with j and k from `start`.
    fn newton3_on(&mut self, [i, j, k]: [usize; 3], start: DVec3) -> Option<DVec3> {
        let mut p = start;
        let mut last = f64::INFINITY;
        for _ in 0..60 {
            let (li, sj) = self.pair(i, j, p);
            let v = [li, sj, self.pair(i, k, p).1];
            let rows = DMat3::from_cols(v[0].gradient, v[1].gradient, v[2].gradient).transpose();
            let det = rows.determinant();
            let size: f64 = v.iter().map(|x| x.gradient.length()).product();
            if det.is_nan() || det.abs() <= 1e-9 * size {
                return None;
            }
            let delta = rows.inverse() * DVec3::new(v[0].value, v[1].value, v[2].value);
            if !delta.is_finite() || delta.length() > 4.0 * self.step {
                return None;
            }
            let len = delta.length();
            // Converged to rounding: a step no shorter than the last, once small.
            if len >= last && len <= 1e-12 * self.step.max(p.abs().max_element()) {
                return Some(p);
            }
            p -= delta;
            if len == 0.0 {
                return Some(p);
            }
            last = len;
        }
        None
    }

    /// The crease's polygon: vertices spaced by the local step of both pieces along it,
    /// graded as the marcher grades (neighbouring edges differ little, so the triangles on
    /// either side stay near-equilateral where the step changes: a fillet's fine spacing does
    /// not run on along the straight edges it joins), at least `min_edge` (the pieces'
    /// shortest polygon edge); the ends kept exactly. Where the crease across a narrow face
    /// wants vertices (`wanted`, places near the crease: `pair.rs`), they are vertices, kept
    /// half a local step apart, and the spans between them are filled at the local step; a
    /// closed crease then starts at the first of them.
    pub fn resample(
        &mut self,
        tr: &Traced,
        sizing: &Sizing,
        min_edge: f64,
        wanted: &[Wanted],
    ) -> Result<Vec<DVec3>, CreaseError> {
        let (i, j) = tr.forms;
        let closed = tr.ends.is_none();
        let started;
        let fine: &[DVec3] = match wanted.first() {
            Some(w) if closed && tr.seam.is_none() => match self.start_at(tr, w.at) {
                Some(s) => {
                    started = s;
                    &started
                }
                None => &tr.points,
            },
            _ => &tr.points,
        };
        let m = fine.len();
        let line = ArcLength::new(fine, closed).ok_or(CreaseError::Short {
            at: fine.first().copied().unwrap_or(DVec3::ZERO),
            length: 0.0,
        })?;
        let total = line.total();
        // The local step along the crease, on both pieces, every step or so (and at the
        // ends): (arc length, h).
        let floor = min_edge / 0.8;
        let every = ((self.step / (self.s.trace * self.step)).round() as usize).max(1);
        let mut samples: Vec<usize> = (0..m).step_by(every).collect();
        if samples.last() != Some(&(m - 1)) {
            samples.push(m - 1);
        }
        let mut field: Vec<(f64, f64)> = Vec::with_capacity(samples.len() + 1);
        for &k in &samples {
            let mut h = self.step;
            for f in [i, j] {
                let vg = self.c.form(f, fine[k]);
                let normal = vg.gradient.normalize_or_zero();
                if normal == DVec3::ZERO {
                    continue;
                }
                let (t1, t2) = tangent_frame(normal);
                let sp = SurfacePoint {
                    point: fine[k],
                    normal,
                    t1,
                    t2,
                };
                h = h.min(sizing.size(&mut self.c.piece(f), &sp, None, None).h);
            }
            field.push((line.at(k), (CREASE_SHARE * h).max(floor)));
        }
        if closed {
            // Round the loop: the first sample again at the end.
            field.push((total, field[0].1));
        }
        // Graded both ways: h(s) ≤ h(s') + g·|s − s'|.
        let g = sizing.settings().grading;
        for k in 1..field.len() {
            let (s0, h0) = field[k - 1];
            field[k].1 = field[k].1.min(h0 + g * (field[k].0 - s0));
        }
        for k in (0..field.len().saturating_sub(1)).rev() {
            let (s1, h1) = field[k + 1];
            field[k].1 = field[k].1.min(h1 + g * (s1 - field[k].0));
        }
        if closed {
            let first = field[0].1.min(field[field.len() - 1].1);
            field[0].1 = first;
            let last = field.len() - 1;
            field[last].1 = first;
        }
        // Vertices at equal steps of ∫ ds / h (h linear between samples).
        let mut count = vec![0.0; field.len()];
        for k in 1..field.len() {
            let (s0, h0) = field[k - 1];
            let (s1, h1) = field[k];
            count[k] = count[k - 1] + (s1 - s0) * 0.5 * (1.0 / h0 + 1.0 / h1);
        }
        let whole = count[count.len() - 1];
        let n = (whole.ceil() as usize).max(if closed { 3 } else { 1 });
        // The local step's floor keeps the edges at `min_edge` or longer; a crease between
        // two corners shorter than that is refused (the corners nearly coincide).
        if total / (n as f64) < min_edge.min(self.s.shortest * self.step) {
            return Err(CreaseError::Short {
                at: fine[0],
                length: total,
            });
        }
        let arc_at = |target: f64| {
            let k = count
                .partition_point(|&c| c < target)
                .clamp(1, count.len() - 1);
            let (c0, c1) = (count[k - 1], count[k]);
            let w = if c1 > c0 {
                (target - c0) / (c1 - c0)
            } else {
                0.0
            };
            field[k - 1].0 + w * (field[k].0 - field[k - 1].0)
        };
        // Places along less than half the crease set no phase worth the uneven spacing
        // they leave round them (a rim given a few places by the plate's edge beside it).
        let places = wanted.iter().map(|w| (line.nearest(w.at), w.edge));
        let counts = if wanted.len() * 2 < n {
            None
        } else {
            through(places, total, &field, &count, min_edge, self.step)
        };
        let counts =
            counts.unwrap_or_else(|| (1..n).map(|v| whole * v as f64 / n as f64).collect());
        let arcs = counts.into_iter().map(arc_at);
        match tr.seam {
            None => line.resample_at(arcs, |y, dir| self.correct(i, j, y, y, dir)),
            Some(seam) => line.resample_at(arcs, |y, dir| self.on_seam(i, seam.plane, y, dir)),
        }
        .map_err(|at| CreaseError::Lost { at })
    }

    /// A closed crease's fine line started at its point nearest w (on both forms).
    fn start_at(&mut self, tr: &Traced, w: DVec3) -> Option<Vec<DVec3>> {
        let fine = &tr.points;
        let m = fine.len();
        let line = ArcLength::new(fine, true)?;
        let (k, y, direction) = line.locate(line.nearest(w));
        let (i, j) = tr.forms;
        let start = self.correct(i, j, y, y, direction)?;
        let tiny = 1e-9 * self.step;
        let mut out = vec![start];
        out.extend(
            (1..=m)
                .map(|d| fine[(k + d) % m])
                .filter(|p| p.distance(start) > tiny),
        );
        Some(out)
    }

    /// On which side of the crease, walked as traced, each of its faces lies: for the form
    /// of each face (i, j), whether the face is on the left seen from where its gradient
    /// points. Asked of `survey::faces::crossing` at up to `PROBES` traced points (corners
    /// excepted): the answers that decide must agree, and one at least must decide.
    pub fn sides(&mut self, tr: &Traced) -> Result<(bool, bool), CreaseError> {
        if let Some(seam) = tr.seam {
            return Ok(seam.sides);
        }
        let (i, j) = tr.forms;
        let fine = &tr.points;
        let mut probes: Vec<(DVec3, DVec3)> = Vec::new();
        let inner = fine.len().saturating_sub(2).max(1);
        let every = inner.div_ceil(PROBES).max(1);
        for k in (1..fine.len().saturating_sub(1)).step_by(every) {
            probes.push((fine[k], fine[k + 1] - fine[k]));
        }
        if probes.is_empty() && fine.len() == 2 {
            // A crease of one tracing step (corner to corner): asked at its middle.
            let (a, b) = (fine[0], fine[1]);
            let m = a.lerp(b, 0.5);
            let d = (b - a).normalize_or_zero();
            if let Some(o) = self.correct(i, j, m, m, d) {
                probes.push((o, d));
            }
        }
        let mut found: Option<(bool, bool)> = None;
        let (scale, fs) = (self.scale(), self.faces());
        for (o, along) in probes {
            let mut t = self.tangent(i, j, o)?;
            if t.dot(along) < 0.0 {
                t = -t;
            }
            let Crossing::Crease { faces } = faces::crossing(self.c, o, t, &scale, &fs)? else {
                continue;
            };
            let mut left = [None, None];
            for (slot, f) in [i, j].into_iter().enumerate() {
                let cf = self.c.class(f);
                for (g, away) in faces {
                    if self.c.class(g) == cf {
                        let n = self.c.form(f, o).gradient.normalize_or_zero();
                        left[slot] = Some(away.dot(n.cross(t)) > 0.0);
                    }
                }
            }
            let [Some(li), Some(lj)] = left else {
                return Err(CreaseError::Sides { at: o });
            };
            if found.is_some_and(|f| f != (li, lj)) {
                return Err(CreaseError::Sides { at: o });
            }
            found = Some((li, lj));
        }
        found.ok_or(CreaseError::Sides {
            at: fine[fine.len() / 2],
        })
    }
}

/// Whether the crease between `faces` (as a corner's `Leaving` holds them) is one of the
/// faces of forms i and j.
pub(super) fn same_faces(c: &mut Creased, faces: [(usize, DVec3); 2], i: usize, j: usize) -> bool {
    let (a, b) = (c.class(faces[0].0), c.class(faces[1].0));
    let (ci, cj) = (c.class(i), c.class(j));
    (a == ci && b == cj) || (a == cj && b == ci)
}

/// |n1 × n2| of the unit normals (0 where a gradient vanishes).
pub(super) fn sine(g1: DVec3, g2: DVec3) -> f64 {
    let d = g1.length() * g2.length();
    if d > 0.0 {
        g1.cross(g2).length() / d
    } else {
        0.0
    }
}

/// A place asked for by a polygon whose edges are down to the local step over this (and up
/// to 1 + `SLACK` times it).
const FIT: f64 = 1.25;
/// A span between kept places takes edges up to 1 + this of the local step (∫ ds / h per
/// edge) rather than one more edge.
const SLACK: f64 = 0.1;

/// Crease vertices are spaced at this share of the local step: the pieces' triangles beside
/// a crease have their two other edges shorter than the step (the rows close against the
/// crease polygon as a bound), and at the full step the crease edge was the longest of its
/// triangle (median 1.045 of the mean of the other two on the CAD sweep's lattices; 0.93
/// brought it to 1.013, and the sweep's runs below the mean radius ratio of 0.97 from 19 to 6
/// of 1 200, for 7.6 % more triangles). The caps the polygon's vertices set on the pieces'
/// step undo the share (`crease_net::mesh_creased_once`): the pieces march at the step the
/// crease was spaced for, not at its shorter edges.
pub(super) const CREASE_SHARE: f64 = 0.93;

/// The inner vertices of a polygon through `places` (arc lengths along a line `total` long,
/// each with the edge length it was asked for), as counts of ∫ ds / h (`field`: arc length
/// and local step; `count`: the integral at its samples): each place kept where the edge it
/// was asked for fits the local step there (`FIT`, `SLACK`) and it is half its local step (and
/// `min_edge`) or more from the last kept one and from the end, and the spans between
/// filled with edges of equal ∫ ds / h, as few as keep them within `SLACK` of the local step,
/// no longer than `step` and no shorter than `min_edge`. None if no place is kept.
fn through(
    places: impl Iterator<Item = (f64, f64)>,
    total: f64,
    field: &[(f64, f64)],
    count: &[f64],
    min_edge: f64,
    step: f64,
) -> Option<Vec<f64>> {
    let sample = |s: f64| {
        let k = field
            .partition_point(|&(x, _)| x < s)
            .clamp(1, field.len() - 1);
        let (s0, s1) = (field[k - 1].0, field[k].0);
        let w = if s1 > s0 {
            ((s - s0) / (s1 - s0)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (
            count[k - 1] + w * (count[k] - count[k - 1]),
            field[k - 1].1 + w * (field[k].1 - field[k - 1].1),
        )
    };
    let mut places: Vec<(f64, f64)> = places.collect();
    places.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut anchors = vec![0.0];
    for (s, edge) in places {
        let h = sample(s).1;
        let apart = (0.5 * h).max(min_edge);
        let fits = edge <= (1.0 + SLACK) * h && h <= FIT * edge;
        if fits && s - anchors[anchors.len() - 1] >= apart && total - s >= apart {
            anchors.push(s);
        }
    }
    if anchors.len() == 1 {
        return None;
    }
    anchors.push(total);
    let mut out = Vec::new();
    for (k, pair) in anchors.windows(2).enumerate() {
        let (a, b) = (pair[0], pair[1]);
        let (ca, cb) = (sample(a).0, sample(b).0);
        let length = b - a;
        let edges = ((cb - ca - SLACK).ceil().max(1.0))
            .max((length / step).ceil())
            .min((length / min_edge).floor().max(1.0)) as usize;
        if k > 0 {
            out.push(ca);
        }
        out.extend((1..edges).map(|e| ca + (cb - ca) * e as f64 / edges as f64));
    }
    Some(out)
}
