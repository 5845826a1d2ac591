//! The local step h(p) ≤ step (docs/marcher.md): how long the marcher's edges may be at a point
//! of the surface, from its curvature (the chord error stays within the tolerance, the normal
//! turns little per edge), its thickness (the nearest other sheet along ±n, so that a tube, a
//! plate, a neck or a gap gets several triangles across) and from caps that the verification
//! of a failed mesh sets near the places that failed. Grading (a size grows by at most a
//! fixed factor per edge) is applied by the caller from a point's parent; caps are graded
//! here. Knows the surface only through the oracle; every threshold is a named setting.
//!
//! Input: a surface point with its frame. Output: h in [`SizingSettings::min_size`·step, step],
//! and whether the floor cut a smaller wish (a feature too small for the step).

use glam::DVec3;

use super::free_cells::FreeCells;
use crate::solve::SurfacePoint;
use crate::surface::{Surface, ValueGrad};

/// Settings of the sizing field. Lengths are relative to the step; `Default` gives the values
/// the tests were run with (docs/marcher.md has the evidence).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SizingSettings {
    /// Curvature: h ≤ √(`chord_factor`·ρ·tolerance) for the smallest curvature radius ρ.
    /// An equilateral triangle of side h on a sphere of radius ρ has its centroid h²/(6ρ)
    /// inside; the marcher's edges reach 1.2 h (Step 3's split gap), so 4 keeps the centroid
    /// within ≈ 0.96·tolerance. Default 4.
    pub chord_factor: f64,
    /// Curvature: h ≤ `max_turn`·ρ, so the normal turns by at most this many radians along
    /// an edge (≥ 12 edges around a small tube whatever the tolerance). Default 0.5.
    pub max_turn: f64,
    /// Step of the one-sided differences of the unit normal that measure the curvature,
    /// relative to the step. Default 1e-4 (truncation ~1e-4·κ'·step, rounding ~1e-12/step).
    pub curvature_probe: f64,
    /// Thickness: h ≤ `thickness_fraction`·t for the distance t to the nearest other sheet
    /// along ±n. Default 0.4: a tube gets ≈ 8 edges around, a plate's rim ≈ 4, and two
    /// sheets a distance t apart are never within the near distance (1.0·h) of each other.
    pub thickness_fraction: f64,
    /// Rays along ±n are followed to `probe_reach`·step. A sheet farther than
    /// step/thickness_fraction (2.5 step) cannot bind; the rest of the reach is the margin
    /// that lets the points made from this one skip the probe (see `inherit`). Default 5.
    pub probe_reach: f64,
    /// Samples along a ray start at `probe_max`·reach and advance by the linear distance
    /// estimate |f|/|∇f| times this, between `probe_min` and `probe_max` (relative to the
    /// reach); a first sample nearer to another sheet than to p (estimate below 0.7 t)
    /// restarts the ray densely from `probe_min`. Default 0.8.
    pub probe_advance: f64,
    /// See `probe_advance`. Default 1/64.
    pub probe_min: f64,
    /// See `probe_advance`. Default 1/4.
    pub probe_max: f64,
    /// A point made from a parent at distance d skips the probes when the parent's rays were
    /// free for the binding distance plus d, its curvature bound is above the step even for
    /// half its curvature radius, and the normal turned from parent to point by at most
    /// `inherit`·d/ρ: then it has the parent's size info, less d. Default 1.5. 0 turns
    /// inheritance off.
    pub inherit: f64,
    /// Grading: a point's h is at most its parent's h + `grading`·distance, and a cap of
    /// size s at c bounds h(p) by s + `grading`·|p − c|. Default 0.2.
    pub grading: f64,
    /// The floor of h, relative to the step: smaller wishes are cut to it and reported.
    /// Default 1/256.
    pub min_size: f64,
    /// Regrading (`Sizing::regrading_caps`): a point is made too coarse when its h is more
    /// than 1/(1 − `regrade_margin`) times the field graded both ways. Default 0.2.
    pub regrade_margin: f64,
    /// A march with more than this share of its points made too coarse is made again with
    /// the field graded both ways. Default 0.01; 1 turns regrading off.
    pub regrade_share: f64,
    /// The most marches made again to grade the field both ways. Default 3.
    pub regrade_rounds: u32,
}

impl Default for SizingSettings {
    fn default() -> Self {
        SizingSettings {
            chord_factor: 4.0,
            max_turn: 0.5,
            curvature_probe: 1e-4,
            thickness_fraction: 0.4,
            probe_reach: 5.0,
            probe_advance: 0.8,
            probe_min: 1.0 / 64.0,
            probe_max: 0.25,
            inherit: 1.5,
            grading: 0.2,
            min_size: 1.0 / 256.0,
            regrade_margin: 0.2,
            regrade_share: 0.01,
            regrade_rounds: 3,
        }
    }
}

/// A bound on h near a place where a mesh failed its verification.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cap {
    pub at: DVec3,
    pub size: f64,
}

/// Caps set before a march, with their tree built once for every march that shares them: a
/// crease net's pieces all start from the caps of its narrow faces (24 pieces on the CAD plate
/// of issue 41, each building the same tree of 4 400 caps, took 1.7 % of its instructions).
#[derive(Clone, Debug)]
pub struct PresetCaps {
    tree: CapTree,
    step: f64,
    floor: f64,
}

impl PresetCaps {
    /// `caps` for marches of `step` with `settings` (sizes below the floor raised to it).
    pub fn new(caps: impl IntoIterator<Item = Cap>, step: f64, settings: &SizingSettings) -> Self {
        let floor = settings.min_size * step;
        let caps = floored(caps, floor).collect();
        PresetCaps {
            tree: CapTree::new(settings.grading, caps, step),
            step,
            floor,
        }
    }

    /// No caps.
    pub fn none() -> Self {
        PresetCaps::new(Vec::new(), 1.0, &SizingSettings::default())
    }

    pub fn is_empty(&self) -> bool {
        self.tree.caps.is_empty()
    }
}

/// `caps` with sizes below `floor` raised to it.
fn floored(caps: impl IntoIterator<Item = Cap>, floor: f64) -> impl Iterator<Item = Cap> {
    caps.into_iter().map(move |c| Cap {
        at: c.at,
        size: c.size.max(floor),
    })
}

/// The local step of one mesh.
#[derive(Clone, Debug)]
pub struct Sizing {
    step: f64,
    tolerance: f64,
    uniform: bool,
    s: SizingSettings,
    caps: CapTree,
}

/// What the field says at a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Size {
    pub h: f64,
    /// The surface asked for less than the floor here.
    pub floored: bool,
    /// How far along ±n no other sheet was found (at most the reach).
    pub free: f64,
    /// The smallest curvature radius (infinite on a plane).
    pub rho: f64,
}

impl Sizing {
    /// The sizing of a mesh with `step` and `tolerance` (largest chord error, model units).
    pub fn new(step: f64, tolerance: f64, settings: SizingSettings) -> Self {
        Sizing {
            step,
            tolerance,
            uniform: false,
            s: settings,
            caps: CapTree::new(settings.grading, Vec::new(), step),
        }
    }

    /// The sizing of a mesh block: the paper's fixed step with `uniform`, else the local step
    /// with `tolerance`.
    pub fn of_mesh(step: f64, tolerance: f64, uniform: bool, settings: SizingSettings) -> Self {
        if uniform {
            Sizing::uniform(step)
        } else {
            Sizing::new(step, tolerance, settings)
        }
    }

    /// The paper's fixed step: h = step everywhere, nothing asked of the surface.
    pub fn uniform(step: f64) -> Self {
        Sizing {
            step,
            tolerance: f64::INFINITY,
            uniform: true,
            s: SizingSettings::default(),
            caps: CapTree::new(0.5, Vec::new(), step),
        }
    }

    pub fn is_uniform(&self) -> bool {
        self.uniform
    }

    pub fn step(&self) -> f64 {
        self.step
    }

    pub fn settings(&self) -> &SizingSettings {
        &self.s
    }

    /// The floor of h.
    pub fn floor(&self) -> f64 {
        self.s.min_size * self.step
    }

    /// Adds caps (from a failed verification); sizes below the floor are raised to it.
    pub fn add_caps(&mut self, caps: impl IntoIterator<Item = Cap>) {
        let mut all = std::mem::take(&mut self.caps.caps);
        all.extend(floored(caps, self.floor()));
        self.caps = CapTree::new(self.s.grading, all, self.step);
    }

    /// Adds `preset`'s caps: its tree as it is where this sizing has none yet and the tree was
    /// built for its step, floor and grading (what `add_caps` would build from the same caps:
    /// a query's bound is the least over the same caps, whatever the tree's order), else its
    /// caps one by one.
    pub fn add_preset(&mut self, preset: &PresetCaps) {
        if self.caps.caps.is_empty()
            && preset.step == self.step
            && preset.floor == self.floor()
            && preset.tree.grading == self.s.grading
        {
            self.caps = preset.tree.clone();
        } else {
            self.add_caps(preset.tree.caps.iter().copied());
        }
    }

    /// The regrading pass (docs/marcher.md, *Grading both ways*). Grading from a point's
    /// parent bounds how fast h grows away from a fine place but not how fast it falls
    /// towards one: a front coming from a coarse region meets a plate's rim or a neck with h
    /// falling by a factor of 2 or 3 within an edge, where no triangles are near-equilateral
    /// (the flat ellipsoid's rim: mean radius ratio 0.92). Given a finished march's points,
    /// the size the surface asked for at each (`wanted`) and the one each was made with
    /// (`made`): caps at the points that make the field graded both ways,
    /// h(p) ≤ wanted(q) + grading·|p − q| for every pair, if more than `regrade_share` of the
    /// points were made with over 1/(1 − `regrade_margin`) times that; else none (the march
    /// was graded enough and stands).
    pub fn regrading_caps(&self, points: &[DVec3], wanted: &[f64], made: &[f64]) -> Vec<Cap> {
        if self.uniform || self.s.regrade_share >= 1.0 {
            return Vec::new();
        }
        let caps: Vec<Cap> = points
            .iter()
            .zip(wanted)
            .filter(|&(_, &w)| w < self.step)
            .map(|(&at, &size)| Cap { at, size })
            .collect();
        let field = CapTree::new(self.s.grading, caps, self.step);
        let keep = 1.0 - self.s.regrade_margin;
        let steep = points
            .iter()
            .zip(made)
            .filter(|&(&p, &h)| field.bound(p, self.step) < keep * h)
            .count();
        if crate::trace::enabled() {
            eprintln!(
                "sizing: {steep} of {} point(s) made with a step over {:.2} times the field graded both ways",
                points.len(),
                1.0 / keep
            );
        }
        if (steep as f64) > self.s.regrade_share * points.len() as f64 {
            field.caps
        } else {
            Vec::new()
        }
    }

    /// Number of caps set so far.
    pub fn cap_count(&self) -> usize {
        self.caps.caps.len()
    }

    /// How far the thickness rays look from their point (model units).
    pub fn reach(&self) -> f64 {
        self.s.probe_reach * self.step
    }

    /// h at a surface point: the smallest of the step, the curvature and thickness bounds
    /// and the caps, cut at the floor. `parent`: the size, position and normal of the point
    /// this one was stepped from, whose probes it may inherit. `free`: cells for rays of
    /// [`Sizing::reach`] that may prove the thickness rays would find nothing (the same
    /// size, fewer evaluations).
    pub fn size(
        &self,
        surface: &mut dyn Surface,
        sp: &SurfacePoint,
        parent: Option<(&Size, DVec3, DVec3)>,
        free: Option<&mut FreeCells>,
    ) -> Size {
        if self.uniform {
            return Size {
                h: self.step,
                floored: false,
                free: f64::INFINITY,
                rho: f64::INFINITY,
            };
        }
        let caps = self.caps.bound(sp.point, self.step);
        let (free, rho) = match parent.and_then(|(ps, pp, pn)| self.inherited(sp, ps, pp, pn)) {
            Some(got) => got,
            None => {
                let proven = free.is_some_and(|cells| {
                    debug_assert_eq!(cells.reach(), self.reach());
                    cells.proves_free(surface, sp.point, sp.normal)
                });
                let free = if proven {
                    self.reach()
                } else {
                    self.thickness(surface, sp)
                };
                (free, self.curvature_radius(surface, sp))
            }
        };
        let h = self
            .step
            .min(caps)
            .min(self.curvature_size(rho))
            .min(self.s.thickness_fraction * free);
        let floor = self.floor();
        Size {
            h: h.max(floor),
            floored: h < floor,
            free,
            rho,
        }
    }

    /// The parent's free distance (less the way from it) and curvature radius, where they
    /// still say that neither binds here.
    fn inherited(
        &self,
        sp: &SurfacePoint,
        parent: &Size,
        at: DVec3,
        normal: DVec3,
    ) -> Option<(f64, f64)> {
        let d = at.distance(sp.point);
        let free = parent.free - d;
        let binding = self.step / self.s.thickness_fraction;
        let cos_turn = sp.normal.dot(normal).clamp(-1.0, 1.0);
        (self.s.inherit > 0.0
            && free >= binding
            && self.curvature_size(0.5 * parent.rho) >= self.step
            && turn_within(cos_turn, self.s.inherit * d / parent.rho))
        .then_some((free, parent.rho))
    }

    /// h allowed by a curvature radius ρ.
    fn curvature_size(&self, rho: f64) -> f64 {
        (self.s.chord_factor * rho * self.tolerance)
            .sqrt()
            .min(self.s.max_turn * rho)
    }

    /// The smallest curvature radius: the shape operator from one-sided differences of the
    /// unit normal along t1 and t2.
    fn curvature_radius(&self, surface: &mut dyn Surface, sp: &SurfacePoint) -> f64 {
        let e = self.s.curvature_probe * self.step;
        // The two probes in one call where the surface answers in batches.
        let probes = [sp.point + e * sp.t1, sp.point + e * sp.t2];
        let mut grads = [ValueGrad::default(); 2];
        if !surface.value_gradient_batch(&probes, &mut grads) {
            grads = probes.map(|q| surface.value_gradient(q));
        }
        let [n1, n2] = grads.map(|g| g.gradient.normalize_or_zero());
        if n1 == DVec3::ZERO || n2 == DVec3::ZERO || !(n1.is_finite() && n2.is_finite()) {
            // A singular neighbourhood: nothing to learn here, the verification judges.
            return f64::INFINITY;
        }
        let (d1, d2) = ((n1 - sp.normal) / e, (n2 - sp.normal) / e);
        let (a, d) = (d1.dot(sp.t1), d2.dot(sp.t2));
        let b = 0.5 * (d1.dot(sp.t2) + d2.dot(sp.t1));
        let mean = 0.5 * (a + d);
        let kappa = mean.abs() + (0.25 * (a - d) * (a - d) + b * b).sqrt();
        if !(kappa > 0.0 && kappa.is_finite()) {
            return f64::INFINITY;
        }
        1.0 / kappa
    }

    /// The distance to the nearest other sheet along ±n (at most the reach). The two rays'
    /// samples are asked in pairs where the surface answers in batches (one call for two
    /// points); else one ray after the other, in the order the surface's answers may depend
    /// on. The same samples and values either way.
    fn thickness(&self, surface: &mut dyn Surface, sp: &SurfacePoint) -> f64 {
        let mut rays = [
            Probe::new(self, sp.normal, 1.0),
            Probe::new(self, -sp.normal, -1.0),
        ];
        let p = sp.point;
        let mut pair = [ValueGrad::default(); 2];
        while rays.iter().all(|r| r.found.is_none()) {
            let points = rays.map(|r| p + r.t * r.dir);
            if !surface.value_gradient_batch(&points, &mut pair) {
                break;
            }
            for (ray, vg) in rays.iter_mut().zip(pair) {
                self.probe(surface, p, ray, vg);
            }
        }
        let [plus, minus] = rays.map(|mut ray| self.follow(surface, p, &mut ray));
        plus.min(minus)
    }

    /// The distance along `dir` from `p` to the other sheet, as `probe` finds it (one ray).
    #[cfg(test)]
    fn other_sheet(&self, surface: &mut dyn Surface, p: DVec3, dir: DVec3, side: f64) -> f64 {
        self.follow(surface, p, &mut Probe::new(self, dir, side))
    }

    /// The ray sampled a point at a time from where it is until its distance is found.
    fn follow(&self, surface: &mut dyn Surface, p: DVec3, ray: &mut Probe) -> f64 {
        loop {
            if let Some(found) = ray.found {
                return found;
            }
            let vg = surface.value_gradient(p + ray.t * ray.dir);
            self.probe(surface, p, ray, vg);
        }
    }

    /// One sample `vg` of the ray at its `t`: the distance along `dir` from `p` (on the
    /// surface, `dir` = ±n, `side` the sign of f just off p that way) to where f first takes
    /// the other sign, or the reach, once known. Samples advance by the linear distance
    /// estimate, so a sheet passing close to the ray is sampled densely and one far from it
    /// is skipped quickly.
    fn probe(&self, surface: &mut dyn Surface, p: DVec3, ray: &mut Probe, vg: ValueGrad) {
        let reach = self.reach();
        let (lo, hi) = (self.s.probe_min * reach, self.s.probe_max * reach);
        if !vg.value.is_finite() {
            ray.found = Some(reach);
            return;
        }
        if vg.value * ray.side <= 0.0 {
            ray.found = Some(self.crossing(surface, p, ray.dir, ray.side, ray.t_prev, ray.t));
            return;
        }
        let g = vg.gradient.length();
        let estimate = if g > 0.0 && g.is_finite() {
            vg.value.abs() / g
        } else {
            hi
        };
        if !ray.dense && ray.t_prev == 0.0 && estimate < 0.7 * ray.t {
            // Something is nearer to the first sample than p is: a sheet the ray may have
            // entered and left again. Walk it densely from the start.
            ray.dense = true;
            ray.t = lo;
        } else {
            ray.t_prev = ray.t;
            ray.t += (self.s.probe_advance * estimate).clamp(lo, hi);
        }
        // Past the reach (or a NaN place): nothing there.
        if ray.t <= reach {
            return;
        }
        ray.found = Some(reach);
    }

    /// Bisection of the first sign change on (a, b] of the ray; a few halvings are enough for
    /// a size.
    fn crossing(
        &self,
        surface: &mut dyn Surface,
        p: DVec3,
        dir: DVec3,
        side: f64,
        mut a: f64,
        mut b: f64,
    ) -> f64 {
        for _ in 0..6 {
            let m = 0.5 * (a + b);
            if surface.value(p + m * dir) * side <= 0.0 {
                b = m;
            } else {
                a = m;
            }
        }
        0.5 * (a + b)
    }

    /// The graded size of a point whose parent (the point it was stepped from) has size
    /// `parent` at distance `distance`.
    pub fn graded(&self, own: f64, parent: f64, distance: f64) -> f64 {
        own.min(parent + self.s.grading * distance)
    }
}

/// A ray of `Sizing::thickness` along `dir` (f's sign just off the point that way is
/// `side`): the last sample's place and the next one's, whether it walks densely, and the
/// distance to the other sheet once found.
#[derive(Clone, Copy)]
struct Probe {
    dir: DVec3,
    side: f64,
    t_prev: f64,
    t: f64,
    dense: bool,
    found: Option<f64>,
}

impl Probe {
    fn new(sizing: &Sizing, dir: DVec3, side: f64) -> Probe {
        let reach = sizing.reach();
        let t = sizing.s.probe_max * reach;
        Probe {
            dir,
            side,
            t_prev: 0.0,
            t,
            // A reach below the first sample's place: nothing to sample.
            found: if t <= reach { None } else { Some(reach) },
            dense: false,
        }
    }
}

/// Caps in a kd-tree whose nodes know the box of their caps' centres and their smallest
/// size, so that a query visits only the nodes whose bound `size + grading·distance to the
/// box` can still beat the best found so far. The regrading pass sets a cap at every point of
/// a graded zone (tens of thousands on a plate's rim), where a grid of cells as wide as a
/// cap's reach would scan them all; no crate's kd-tree takes this additively weighted
/// distance.
#[derive(Clone, Debug)]
struct CapTree {
    /// Ordered so that each node's caps are `caps[start..end]`.
    caps: Vec<Cap>,
    nodes: Vec<CapNode>,
    grading: f64,
    /// Where no cap can bound h below the step (None without caps below it).
    unbound: Option<Unbound>,
}

/// The places where no cap's bound `size + grading·distance` can fall below a threshold (the
/// step, which every query of the marcher starts from): a grid over the caps' reach, a cell
/// marked where some cap's cube of reach meets it. A query with `best` at most the threshold
/// at a point of an unmarked cell (or off the grid) returns `best` at once, the answer the
/// tree gives: each cap's bound there is above the threshold by `REACH_MARGIN` of it, far
/// over the rounding of `size + grading·distance`. On the CAD plate of issue 41, 96 % of the
/// marches' queries (4 400 crease caps a piece) end here instead of walking the tree.
#[derive(Clone, Debug)]
struct Unbound {
    threshold: f64,
    lo: DVec3,
    inv_side: f64,
    dims: [usize; 3],
    marked: Vec<bool>,
}

/// A cap's reach below the threshold T is (T − size + `REACH_MARGIN`·T)/grading.
const REACH_MARGIN: f64 = 1e-6;
/// The most cells of an `Unbound` grid (a bool each); its cells are at least half the
/// largest reach wide, so that a cap marks a few hundred of them at most.
const UNBOUND_CELLS: f64 = 262_144.0;

impl Unbound {
    fn new(caps: &[Cap], grading: f64, threshold: f64) -> Option<Unbound> {
        if !(grading > 0.0 && grading.is_finite() && threshold > 0.0 && threshold.is_finite()) {
            return None;
        }
        let reach = |c: &Cap| (threshold - c.size + REACH_MARGIN * threshold) / grading;
        let binding: Vec<(DVec3, f64)> = caps
            .iter()
            .filter(|c| c.size < threshold && c.at.is_finite())
            .map(|c| (c.at, reach(c)))
            .collect();
        if binding.is_empty() {
            return None;
        }
        let (mut lo, mut hi, mut widest) = (DVec3::INFINITY, DVec3::NEG_INFINITY, 0.0f64);
        for &(at, r) in &binding {
            lo = lo.min(at - DVec3::splat(r));
            hi = hi.max(at + DVec3::splat(r));
            widest = widest.max(r);
        }
        let extent = hi - lo;
        let side = (0.5 * widest)
            .max((extent.x * extent.y * extent.z / UNBOUND_CELLS).cbrt())
            .max(extent.max_element() / 1024.0);
        if !(side > 0.0 && side.is_finite()) {
            return None;
        }
        let inv_side = 1.0 / side;
        let dims = extent.to_array().map(|e| (e * inv_side) as usize + 1);
        let mut out = Unbound {
            threshold,
            lo,
            inv_side,
            dims,
            marked: vec![false; dims[0] * dims[1] * dims[2]],
        };
        for &(at, r) in &binding {
            let (a, b) = (
                out.index3(at - DVec3::splat(r)),
                out.index3(at + DVec3::splat(r)),
            );
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    let row = (z * dims[1] + y) * dims[0];
                    out.marked[row + a[0]..=row + b[0]].fill(true);
                }
            }
        }
        Some(out)
    }

    /// The cell of p, clamped into the grid (for the corners of the caps' cubes, which lie
    /// in it).
    fn index3(&self, p: DVec3) -> [usize; 3] {
        let k = ((p - self.lo) * self.inv_side).to_array();
        std::array::from_fn(|i| (k[i].max(0.0) as usize).min(self.dims[i] - 1))
    }

    /// Whether a cap may bound h below the threshold at p: p in a marked cell, or not finite.
    fn may_bind(&self, p: DVec3) -> bool {
        if !p.is_finite() {
            return true;
        }
        let k = ((p - self.lo) * self.inv_side).to_array();
        if k.iter()
            .zip(&self.dims)
            .any(|(&k, &n)| !(k >= 0.0 && k < n as f64))
        {
            return false;
        }
        let [x, y, z] = k.map(|k| k as usize);
        self.marked[(z * self.dims[1] + y) * self.dims[0] + x]
    }
}

#[derive(Clone, Copy, Debug)]
struct CapNode {
    lo: DVec3,
    hi: DVec3,
    smallest: f64,
    start: u32,
    end: u32,
    /// The two children's indices; 0 for a leaf (the root is never a child).
    children: [u32; 2],
}

/// The most caps in a leaf.
const CAP_LEAF: usize = 8;

impl CapTree {
    /// The tree of `caps`, with the grid of where none binds below `threshold` (`Unbound`).
    fn new(grading: f64, mut caps: Vec<Cap>, threshold: f64) -> Self {
        let mut nodes = Vec::with_capacity(2 * caps.len() / CAP_LEAF + 1);
        if !caps.is_empty() {
            let n = caps.len();
            Self::build(&mut caps, 0, n, &mut nodes);
        }
        let unbound = Unbound::new(&caps, grading, threshold);
        CapTree {
            caps,
            nodes,
            grading,
            unbound,
        }
    }

    /// Builds the node of `caps[start..end]` (split at the median of its widest axis) and
    /// its subtree; returns its index.
    fn build(caps: &mut [Cap], start: usize, end: usize, nodes: &mut Vec<CapNode>) -> u32 {
        let part = &mut caps[start..end];
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        let mut smallest = f64::INFINITY;
        for c in part.iter() {
            lo = lo.min(c.at);
            hi = hi.max(c.at);
            smallest = smallest.min(c.size);
        }
        let index = nodes.len();
        nodes.push(CapNode {
            lo,
            hi,
            smallest,
            start: start as u32,
            end: end as u32,
            children: [0, 0],
        });
        if part.len() > CAP_LEAF {
            let axis = (hi - lo).max_position();
            let mid = part.len() / 2;
            part.select_nth_unstable_by(mid, |a, b| a.at[axis].total_cmp(&b.at[axis]));
            let left = Self::build(caps, start, start + mid, nodes);
            let right = Self::build(caps, start + mid, end, nodes);
            nodes[index].children = [left, right];
        }
        index as u32
    }

    /// The smallest graded bound `size + grading·|p − at|` of the caps, or `best` if none
    /// is below it.
    fn bound(&self, p: DVec3, mut best: f64) -> f64 {
        if self.nodes.is_empty() {
            return best;
        }
        if let Some(u) = &self.unbound
            && best <= u.threshold
            && !u.may_bind(p)
        {
            return best;
        }
        let below = |n: &CapNode| n.smallest + self.grading * p.clamp(n.lo, n.hi).distance(p);
        // Depth-first, nearer child first; the depth is at most log2(caps / CAP_LEAF) + 1.
        let mut stack = [(0u32, 0.0f64); 64];
        stack[0] = (0, below(&self.nodes[0]));
        let mut len = 1;
        while len > 0 {
            len -= 1;
            let (i, at_least) = stack[len];
            if at_least >= best {
                continue;
            }
            let node = &self.nodes[i as usize];
            if node.children[0] == 0 {
                for c in &self.caps[node.start as usize..node.end as usize] {
                    best = best.min(c.size + self.grading * c.at.distance(p));
                }
                continue;
            }
            let [a, b] = node.children.map(|k| (k, below(&self.nodes[k as usize])));
            let (near, far) = if a.1 <= b.1 { (a, b) } else { (b, a) };
            for next in [far, near] {
                if next.1 < best {
                    stack[len] = next;
                    len += 1;
                }
            }
        }
        best
    }
}

/// Whether an angle of cosine `c` is at most `limit` (radians): `c.acos() <= limit`, the
/// same answer, but without libm's `acos` (1 % of the fine sphere, once a new point) where
/// `c` is clear of cos(`limit`) by far more than either side's rounding. For 0 ≤ x ≤ 1,
/// 1 − x²/2 ≤ cos x ≤ 1 − x²/2 + x⁴/24; a cosine `TURN_BAND` above the upper bound is an
/// angle at least `TURN_BAND` below `limit` (|d acos / dc| ≥ 1), where acos is within an
/// ulp of π.
fn turn_within(c: f64, limit: f64) -> bool {
    if (0.0..=1.0).contains(&limit) {
        let x2 = limit * limit;
        let below = 1.0 - 0.5 * x2;
        let above = below + x2 * x2 / 24.0;
        if c > above + TURN_BAND {
            return true;
        }
        if c < below - TURN_BAND {
            return false;
        }
    }
    c.acos() <= limit
}

/// How far (in cosine) `turn_within` keeps from the bounds of cos(limit) before it trusts
/// them: far above the bounds' rounding (1e-16) and acos's (an ulp of π, 4e-16).
const TURN_BAND: f64 = 1e-9;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::tangent_frame;
    use crate::surface::{NativeSurface, ValueGrad};

    /// `turn_within` is `c.acos() <= limit` everywhere: cosines of random angles, the
    /// cosines a few ulps either side of cos(limit) itself, and the ends (±1, NaN, limits
    /// of 0, above 1 and negative). A band of 0 or a bound without its x⁴ term fails it.
    #[test]
    fn turn_within_is_the_acos_comparison() {
        let mut unit = crate::testing::uniform(0x2545_f491_4f6c_dd1d);
        let mut cases = Vec::new();
        for _ in 0..200_000 {
            let limit = 1.2 * unit() - 0.1;
            let c = (limit + 0.02 * (unit() - 0.5)).cos();
            cases.push((c, limit));
            let at = limit.cos();
            for k in -4i64..=4 {
                cases.push((f64::from_bits((at.to_bits() as i64 + k) as u64), limit));
            }
        }
        for c in [-1.0, 1.0, 0.0, f64::NAN, 1.0 - 1e-17] {
            for limit in [0.0, 1e-9, 0.5, 1.0, 1.5, -0.1, f64::NAN, f64::INFINITY] {
                cases.push((c, limit));
            }
        }
        for (c, limit) in cases {
            assert_eq!(turn_within(c, limit), c.acos() <= limit, "{c:e} {limit:e}");
        }
    }

    fn at(p: DVec3, n: DVec3) -> SurfacePoint {
        let (t1, t2) = tangent_frame(n);
        SurfacePoint {
            point: p,
            normal: n,
            t1,
            t2,
        }
    }

    #[test]
    fn sphere_curvature_bound_follows_the_chord_formula() {
        let r = 0.5;
        let mut s = NativeSurface(move |p: DVec3| ValueGrad {
            value: p.length_squared() - r * r,
            gradient: 2.0 * p,
        });
        let (step, tol) = (1.0, 0.01);
        let sizing = Sizing::new(step, tol, SizingSettings::default());
        let n = DVec3::new(1.0, 2.0, 2.0) / 3.0;
        let h = sizing.curvature_size(sizing.curvature_radius(&mut s, &at(r * n, n)));
        let expected = (4.0 * r * tol).sqrt().min(0.5 * r);
        assert!((h - expected).abs() < 1e-3 * expected, "{h} vs {expected}");
    }

    #[test]
    fn thickness_of_a_slab_is_found_on_both_sides() {
        // The slab |z| < 0.05 as f = z² − 0.05²: thickness 0.1 across; from the top sheet the
        // gap above is open.
        let mut s = NativeSurface(|p: DVec3| ValueGrad {
            value: p.z * p.z - 0.0025,
            gradient: DVec3::new(0.0, 0.0, 2.0 * p.z),
        });
        let sizing = Sizing::new(1.0, 0.1, SizingSettings::default());
        let p = DVec3::new(0.3, -0.2, 0.05);
        let t = sizing.other_sheet(&mut s, p, -DVec3::Z, -1.0);
        assert!((t - 0.1).abs() < 0.01, "{t}");
        assert_eq!(sizing.other_sheet(&mut s, p, DVec3::Z, 1.0), 5.0);
        let size = sizing.size(&mut s, &at(p, DVec3::Z), None, None);
        assert!(size.h <= 0.4 * 0.1 * 1.1 && !size.floored, "{size:?}");
    }

    /// A surface answering in batches (a point at a time underneath), counting its points.
    struct Batched<S>(S, usize);

    impl<S: Surface> Surface for Batched<S> {
        fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
            self.1 += 1;
            self.0.value_gradient(p)
        }

        fn value_gradient_batch(&mut self, points: &[DVec3], out: &mut [ValueGrad]) -> bool {
            for (o, &p) in out.iter_mut().zip(points) {
                *o = self.value_gradient(p);
            }
            true
        }
    }

    /// The thickness with the two rays sampled in pairs is the thickness one ray after the
    /// other, bit for bit and from as many samples: two sheets at random gaps (and a ray
    /// grazing a sphere), from random points and normals.
    #[test]
    fn rays_in_pairs_find_what_rays_one_by_one_find() {
        let mut unit = crate::testing::uniform(0x7f4a_7c15_9e37_79b9);
        let sizing = Sizing::new(0.1, 0.01, SizingSettings::default());
        for _ in 0..300 {
            let (gap, r) = (0.6 * unit(), 0.05 + 0.3 * unit());
            let c = DVec3::new(unit(), unit(), unit()) - 0.5;
            let f = move |p: DVec3| ValueGrad {
                value: (p.z * p.z - gap * gap) * ((p - c).length_squared() - r * r),
                gradient: DVec3::new(0.0, 0.0, 2.0 * p.z) * ((p - c).length_squared() - r * r)
                    + 2.0 * (p - c) * (p.z * p.z - gap * gap),
            };
            let p = DVec3::new(unit() - 0.5, unit() - 0.5, gap);
            let n = (DVec3::Z + 0.3 * (DVec3::new(unit(), unit(), unit()) - 0.5)).normalize();
            let (mut one, mut paired) =
                (Batched(NativeSurface(f), 0), Batched(NativeSurface(f), 0));
            let sequential = sizing
                .other_sheet(&mut one, p, n, 1.0)
                .min(sizing.other_sheet(&mut one, p, -n, -1.0));
            let both = sizing.thickness(&mut paired, &at(p, n));
            assert_eq!(
                both.to_bits(),
                sequential.to_bits(),
                "{p} {n} {gap} {c} {r}"
            );
            assert_eq!(paired.1, one.1);
        }
    }

    /// The kd-tree's bound is the smallest `size + grading·distance` over all caps, as a scan
    /// of every cap finds it, for caps of sizes over four orders of magnitude in clusters.
    #[test]
    fn cap_tree_bound_is_the_smallest_over_all_caps() {
        let mut unit = crate::testing::uniform(0x9E37_79B9_7F4A_7C15u64);
        let mut point = |scale: f64| DVec3::new(unit(), unit(), unit()) * scale;
        for n in [0, 1, 7, 9, 100, 3000] {
            let caps: Vec<Cap> = (0..n)
                .map(|i| Cap {
                    at: point(if i % 3 == 0 { 0.05 } else { 2.0 }),
                    size: 1e-4 * 10f64.powf(4.0 * (i % 17) as f64 / 16.0),
                })
                .collect();
            // The grid of unbound places at 0.7 is used by the queries from 0.7 and 0.3,
            // not by those from 1.5; a tree without it answers all three alike. At the
            // grading 5 the caps reach 0.14 at most, and most points are off them.
            for grading in [0.2, 5.0] {
                let tree = CapTree::new(grading, caps.clone(), 0.7);
                let mut plain = tree.clone();
                plain.unbound = None;
                let mut off = 0;
                for _ in 0..400 {
                    let p = point(2.5) - DVec3::splat(0.25);
                    off += usize::from(tree.unbound.as_ref().is_some_and(|u| !u.may_bind(p)));
                    for best in [0.7, 0.3, 1.5] {
                        let scan = caps
                            .iter()
                            .map(|c| c.size + grading * c.at.distance(p))
                            .fold(best, f64::min);
                        let found = tree.bound(p, best);
                        assert_eq!(found, scan, "{n} caps, at {p}, from {best}");
                        assert_eq!(plain.bound(p, best), scan, "{n} caps, at {p}, from {best}");
                    }
                }
                if n > 0 && grading > 1.0 {
                    assert!(off > 100, "{n} caps: {off} points off the caps' reach");
                }
            }
        }
    }

    /// A march whose h fell from the step to a tenth of it within one edge is regraded: the
    /// caps bound h near the fine points by their size plus the grading times the distance.
    /// One whose h rose and fell at the grading's rate is not.
    #[test]
    fn regrading_caps_only_where_h_falls_faster_than_the_grading() {
        let sizing = Sizing::new(1.0, 0.1, SizingSettings::default());
        let g = sizing.settings().grading;
        let points: Vec<DVec3> = (0..100)
            .map(|i| DVec3::new(0.1 * i as f64, 0.0, 0.0))
            .collect();
        // h graded around the fine point at x = 5 at the grading's rate, capped at the step.
        let graded: Vec<f64> = points
            .iter()
            .map(|p| (0.1 + g * (p.x - 5.0).abs()).min(1.0))
            .collect();
        assert!(sizing.regrading_caps(&points, &graded, &graded).is_empty());
        // The same fine place, but the march kept the step until it got there.
        let jump: Vec<f64> = points
            .iter()
            .map(|p| if (p.x - 5.0).abs() < 0.05 { 0.1 } else { 1.0 })
            .collect();
        let caps = sizing.regrading_caps(&points, &jump, &jump);
        assert_eq!(caps.len(), 1);
        assert_eq!((caps[0].at, caps[0].size), (DVec3::new(5.0, 0.0, 0.0), 0.1));
        let mut regraded = sizing.clone();
        regraded.add_caps(caps);
        for p in &points {
            let want = (0.1 + g * (p.x - 5.0).abs()).min(1.0);
            assert!((regraded.caps.bound(*p, 1.0) - want).abs() < 1e-12, "{p}");
        }
        // Uniform sizing is never regraded.
        assert!(
            Sizing::uniform(1.0)
                .regrading_caps(&points, &jump, &jump)
                .is_empty()
        );
    }

    #[test]
    fn caps_are_graded_and_floored() {
        let mut sizing = Sizing::new(1.0, 0.1, SizingSettings::default());
        sizing.add_caps([Cap {
            at: DVec3::ZERO,
            size: 1e-9,
        }]);
        let floor = sizing.floor();
        assert!((sizing.caps.bound(DVec3::ZERO, 1.0) - floor).abs() < 1e-15);
        let d = 0.5;
        let b = sizing.caps.bound(DVec3::new(d, 0.0, 0.0), 1.0);
        let g = sizing.settings().grading;
        assert!((b - (floor + g * d)).abs() < 1e-12, "{b}");
        assert_eq!(sizing.caps.bound(DVec3::splat(10.0), 1.0), 1.0);
    }
}
