//! The local step h(p) ≤ step (DESIGN.md §4a): how long the marcher's edges may be at a point
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

use crate::solve::SurfacePoint;
use crate::surface::Surface;

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
        }
    }
}

/// A bound on h near a place where a mesh failed its verification.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cap {
    pub at: DVec3,
    pub size: f64,
}

/// The local step of one mesh.
#[derive(Clone, Debug)]
pub struct Sizing {
    step: f64,
    tolerance: f64,
    uniform: bool,
    s: SizingSettings,
    caps: CapGrid,
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
            caps: CapGrid::new(step, settings.grading, Vec::new()),
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
            caps: CapGrid::new(step, 0.5, Vec::new()),
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
        let floor = self.floor();
        let mut all = std::mem::take(&mut self.caps.caps);
        all.extend(caps.into_iter().map(|c| Cap {
            at: c.at,
            size: c.size.max(floor),
        }));
        self.caps = CapGrid::new(self.step, self.s.grading, all);
    }

    /// Number of caps set so far.
    pub fn cap_count(&self) -> usize {
        self.caps.caps.len()
    }

    /// h at a surface point: the smallest of the step, the curvature and thickness bounds
    /// and the caps, cut at the floor. `parent`: the size, position and normal of the point
    /// this one was stepped from, whose probes it may inherit.
    pub fn size(
        &self,
        surface: &mut dyn Surface,
        sp: &SurfacePoint,
        parent: Option<(&Size, DVec3, DVec3)>,
    ) -> Size {
        if self.uniform {
            return Size {
                h: self.step,
                floored: false,
                free: f64::INFINITY,
                rho: f64::INFINITY,
            };
        }
        let caps = self.caps.bound(sp.point);
        let (free, rho) = match parent.and_then(|(ps, pp, pn)| self.inherited(sp, ps, pp, pn)) {
            Some(got) => got,
            None => (
                self.thickness(surface, sp),
                self.curvature_radius(surface, sp),
            ),
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
        let turn = sp.normal.dot(normal).clamp(-1.0, 1.0).acos();
        (self.s.inherit > 0.0
            && free >= binding
            && self.curvature_size(0.5 * parent.rho) >= self.step
            && turn <= self.s.inherit * d / parent.rho)
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
        let unit = |surface: &mut dyn Surface, q: DVec3| {
            let g = surface.value_gradient(q).gradient;
            g.normalize_or_zero()
        };
        let n1 = unit(surface, sp.point + e * sp.t1);
        let n2 = unit(surface, sp.point + e * sp.t2);
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

    /// The distance to the nearest other sheet along ±n (at most the reach).
    fn thickness(&self, surface: &mut dyn Surface, sp: &SurfacePoint) -> f64 {
        self.other_sheet(surface, sp.point, sp.normal, 1.0)
            .min(self.other_sheet(surface, sp.point, -sp.normal, -1.0))
    }

    /// The distance along `dir` from `p` (on the surface, `dir` = ±n, `side` the sign of f
    /// just off p that way) to where f first takes the other sign, or the reach. Samples
    /// advance by the linear distance estimate, so a sheet passing close to the ray is
    /// sampled densely and one far from it is skipped quickly.
    fn other_sheet(&self, surface: &mut dyn Surface, p: DVec3, dir: DVec3, side: f64) -> f64 {
        let reach = self.s.probe_reach * self.step;
        let (lo, hi) = (self.s.probe_min * reach, self.s.probe_max * reach);
        let mut t_prev = 0.0;
        let mut t = hi;
        let mut dense = false;
        while t <= reach {
            let vg = surface.value_gradient(p + t * dir);
            if !vg.value.is_finite() {
                return reach;
            }
            if vg.value * side <= 0.0 {
                return self.crossing(surface, p, dir, side, t_prev, t);
            }
            let g = vg.gradient.length();
            let estimate = if g > 0.0 && g.is_finite() {
                vg.value.abs() / g
            } else {
                hi
            };
            if !dense && t_prev == 0.0 && estimate < 0.7 * t {
                // Something is nearer to the first sample than p is: a sheet the ray may
                // have entered and left again. Walk it densely from the start.
                dense = true;
                t = lo;
                continue;
            }
            t_prev = t;
            t += (self.s.probe_advance * estimate).clamp(lo, hi);
        }
        reach
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

/// Caps in a grid of cells as wide as a cap's reach (where its graded bound falls below the
/// step), each cap in every cell its reach overlaps, so a query reads one cell.
#[derive(Clone, Debug)]
struct CapGrid {
    caps: Vec<Cap>,
    grading: f64,
    inv_cell: f64,
    cells: std::collections::HashMap<[i64; 3], Vec<u32>>,
}

impl CapGrid {
    fn new(step: f64, grading: f64, caps: Vec<Cap>) -> Self {
        let cell = step / grading.max(1e-3);
        let inv_cell = 1.0 / cell;
        let mut cells: std::collections::HashMap<[i64; 3], Vec<u32>> = Default::default();
        for (i, c) in caps.iter().enumerate() {
            let lo = ((c.at - cell) * inv_cell).floor().as_i64vec3();
            let hi = ((c.at + cell) * inv_cell).floor().as_i64vec3();
            for x in lo.x..=hi.x {
                for y in lo.y..=hi.y {
                    for z in lo.z..=hi.z {
                        cells.entry([x, y, z]).or_default().push(i as u32);
                    }
                }
            }
        }
        CapGrid {
            caps,
            grading,
            inv_cell,
            cells,
        }
    }

    fn bound(&self, p: DVec3) -> f64 {
        if self.caps.is_empty() {
            return f64::INFINITY;
        }
        let k = (p * self.inv_cell).floor().as_i64vec3();
        self.cells
            .get(&[k.x, k.y, k.z])
            .map_or(f64::INFINITY, |list| {
                list.iter()
                    .map(|&i| {
                        let c = self.caps[i as usize];
                        c.size + self.grading * c.at.distance(p)
                    })
                    .fold(f64::INFINITY, f64::min)
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::tangent_frame;
    use crate::surface::{NativeSurface, ValueGrad};

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
        let size = sizing.size(&mut s, &at(p, DVec3::Z), None);
        assert!(size.h <= 0.4 * 0.1 * 1.1 && !size.floored, "{size:?}");
    }

    #[test]
    fn caps_are_graded_and_floored() {
        let mut sizing = Sizing::new(1.0, 0.1, SizingSettings::default());
        sizing.add_caps([Cap {
            at: DVec3::ZERO,
            size: 1e-9,
        }]);
        let floor = sizing.floor();
        assert!((sizing.caps.bound(DVec3::ZERO) - floor).abs() < 1e-15);
        let d = 0.5;
        let b = sizing.caps.bound(DVec3::new(d, 0.0, 0.0));
        let g = sizing.settings().grading;
        assert!((b - (floor + g * d)).abs() < 1e-12, "{b}");
        assert_eq!(sizing.caps.bound(DVec3::splat(10.0)), f64::INFINITY);
    }
}
