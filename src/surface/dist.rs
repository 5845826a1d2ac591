//! Distance surfaces (docs/language.md, `dist`): the normal form of a surface, f(x) = the oriented
//! distance from x to the surface, computed through foot points (`solve::foot`). The value is
//! ±|x − q|, the gradient the unit normal at the foot point q (not differentiated through the
//! iterations: that normal *is* the gradient of the distance function wherever the foot
//! point is unique).
//!
//! Failure is reported through the `Surface` contract: value and gradient NaN, and the first
//! failure kept as the surface's `fault` (its query point and the typed error's words), which
//! the component search and the march ask after each step to stop at once with that place.
//! Direct callers who want the reason use `foot`, which returns the typed error.
//!
//! Warm start: each surface remembers its last query and foot point. `ImplicitDist` starts a
//! query within `warm_radius · scale` of the last one from the last foot point (and its
//! curvature), but only if that foot point was regular (x well inside the tubular
//! neighbourhood, see `FootTolerance::warm_min_eigenvalue`); a failed warm search is repeated
//! cold, and both are followed by the global phase of `solve::foot`, so a warm start that lands
//! on another local foot point (another side of a quartic cylinder) is corrected. `PatchDist` runs Newton from
//! the last (u, v) first and then from the pre-search seeds, so a warm start only saves work.
//! Answers depend on the order of queries only at the level of the convergence tolerance, and
//! that order is itself deterministic.
//!
//! `SolidDist` is the distance to a surface with creases (a solid written with `box`,
//! `union`, `difference`, `min`, `max`, `abs`), whose nearest point may lie on a face, a
//! crease or a corner (`solve::solid`); it is built instead of `ImplicitDist` where the
//! measured surface has a spine. Its warm start is only the first search radius (the last
//! foot's distance), so its answers do not depend on the order of queries beyond the
//! convergence tolerance.
//! The algorithms, regions and conventions are described in `docs/implicitization.md`.

use glam::DVec3;

use super::{Fault, Patch, Surface, ValueGrad};
use crate::eval::Interval;
use crate::solve::foot::{
    Curvature, Foot, FootError, PatchFoot, PatchFootError, PatchGrid, foot_point,
    foot_point_hinted, patch_foot,
};
use crate::solve::solid::{Pieces, SolidFoot, SolidFootError, SolidScratch, solid_foot_in};
use crate::solve::tolerance::{FootTolerance, PatchFootTolerance, SolidFootTolerance};

/// What a NaN-reporting surface returns.
const FAILED: ValueGrad = ValueGrad {
    value: f64::NAN,
    gradient: DVec3::NAN,
};

/// A distance is 1-Lipschitz: over a box it lies within the half-diagonal of its value at
/// the centre. None when the centre has no foot point: the bound is then unknown and the
/// caller splits the cell, so the centre's failure is not kept as the surface's fault (its
/// slot `fault`; a foot-point search from a box corner far from a product of balls may
/// diverge where the mesh never asks for a value).
fn lipschitz_bound<S: Surface>(
    d: &mut S,
    fault: fn(&mut S) -> &mut Option<Fault>,
    lo: DVec3,
    hi: DVec3,
) -> Option<Interval> {
    let kept = fault(d).clone();
    let centre = d.value((lo + hi) * 0.5);
    *fault(d) = kept;
    let r = (hi - lo).length() * 0.5;
    // Outward by a few ulps of the ends, and by the foot point's convergence error
    // (relative to the distance, far below the half-diagonal of a cell).
    let slack = 1e-9 * (centre.abs() + r);
    centre
        .is_finite()
        .then(|| Interval::new(centre - r - slack, centre + r + slack))
}

/// Keeps the first failure of a distance surface's queries as its fault.
fn keep_fault(fault: &mut Option<Fault>, at: DVec3, error: &dyn std::fmt::Display) {
    if fault.is_none() {
        *fault = Some(Fault {
            at,
            reason: error.to_string(),
        });
    }
}

/// The oriented distance to an implicit surface f = 0: negative where f < 0.
pub struct ImplicitDist {
    /// The surface whose distance this is.
    pub inner: Box<dyn Surface>,
    /// Foot-point settings; `tolerance.scale` should be the mesh step when it is known.
    pub tolerance: FootTolerance,
    warm: Option<(DVec3, DVec3, Option<Curvature>)>,
    /// The first query without a foot point.
    fault: Option<Fault>,
}

impl ImplicitDist {
    /// The distance to `inner` with the default tolerance (scale 1).
    pub fn new(inner: Box<dyn Surface>) -> Self {
        Self::with_tolerance(inner, FootTolerance::default())
    }

    pub fn with_tolerance(inner: Box<dyn Surface>, tolerance: FootTolerance) -> Self {
        ImplicitDist {
            inner,
            tolerance,
            warm: None,
            fault: None,
        }
    }

    /// The foot point of x, with the reason when there is none. Uses and updates the warm
    /// start.
    pub fn foot(&mut self, x: DVec3) -> Result<Foot, FootError> {
        let tol = self.tolerance;
        let warm = self
            .warm
            .filter(|(wx, _, _)| (x - *wx).length() <= tol.warm_radius * tol.scale);
        let result = match warm {
            Some((_, q, curvature)) => {
                foot_point_hinted(self.inner.as_mut(), x, Some(q), curvature, &tol)
                    .or_else(|_| foot_point(self.inner.as_mut(), x, None, &tol))
            }
            None => foot_point(self.inner.as_mut(), x, None, &tol),
        };
        self.warm = match &result {
            Ok(f) if f.min_eigenvalue >= tol.warm_min_eigenvalue => Some((x, f.point, f.curvature)),
            _ => None,
        };
        if let Err(e) = &result {
            keep_fault(&mut self.fault, x, e);
        }
        result
    }

    /// Forget the warm start (the next query starts cold).
    pub fn clear_warm_start(&mut self) {
        self.warm = None;
    }
}

impl Surface for ImplicitDist {
    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        match self.foot(p) {
            Ok(f) => ValueGrad {
                value: f.distance,
                gradient: f.normal,
            },
            Err(_) => FAILED,
        }
    }

    fn bound(&mut self, lo: DVec3, hi: DVec3) -> Option<Interval> {
        lipschitz_bound(self, |d| &mut d.fault, lo, hi)
    }

    fn fault(&self) -> Option<Fault> {
        self.fault.clone().or_else(|| self.inner.fault())
    }
}

/// The oriented distance to a parametric patch, extended beyond its declared domain:
/// (x − P)·n̂ at the foot point, n̂ = (Pu × Pv)/|Pu × Pv|.
pub struct PatchDist {
    /// The patch whose distance this is.
    pub patch: Box<dyn Patch>,
    /// Foot-point settings (pre-search grid and region, Newton, warm start).
    pub tolerance: PatchFootTolerance,
    /// Built on the first query.
    grid: Option<PatchGrid>,
    warm: Option<(DVec3, (f64, f64))>,
    /// The first query without a foot point.
    fault: Option<Fault>,
}

impl PatchDist {
    /// The distance to `patch` with the default tolerance (scale 1).
    pub fn new(patch: Box<dyn Patch>) -> Self {
        Self::with_tolerance(patch, PatchFootTolerance::default())
    }

    pub fn with_tolerance(patch: Box<dyn Patch>, tolerance: PatchFootTolerance) -> Self {
        PatchDist {
            patch,
            tolerance,
            grid: None,
            warm: None,
            fault: None,
        }
    }

    /// The foot point of x, with the reason when there is none. The previous query's (u, v)
    /// seeds the first Newton run when x is within `warm_radius · scale` of it; the grid seeds
    /// follow (see `solve::foot::patch_foot`), so the answer does not depend on the warm start
    /// beyond the convergence tolerance.
    pub fn foot(&mut self, x: DVec3) -> Result<PatchFoot, PatchFootError> {
        let tol = self.tolerance;
        let grid = match &mut self.grid {
            Some(grid) => grid,
            None => match PatchGrid::new(self.patch.as_mut(), &tol) {
                Ok(grid) => self.grid.insert(grid),
                Err(e) => {
                    keep_fault(&mut self.fault, x, &e);
                    return Err(e);
                }
            },
        };
        let warm = self
            .warm
            .filter(|(wx, _)| (x - *wx).length() <= tol.foot.warm_radius * tol.foot.scale)
            .map(|(_, uv)| uv);
        let result = patch_foot(self.patch.as_mut(), x, warm, grid, &tol);
        self.warm = result.as_ref().ok().map(|f| (x, (f.u, f.v)));
        if let Err(e) = &result {
            keep_fault(&mut self.fault, x, e);
        }
        result
    }

    /// Forget the warm start.
    pub fn clear_warm_start(&mut self) {
        self.warm = None;
    }
}

impl Surface for PatchDist {
    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        match self.foot(p) {
            Ok(f) => ValueGrad {
                value: f.distance,
                gradient: f.normal,
            },
            Err(_) => FAILED,
        }
    }

    fn bound(&mut self, lo: DVec3, hi: DVec3) -> Option<Interval> {
        lipschitz_bound(self, |d| &mut d.fault, lo, hi)
    }

    fn fault(&self) -> Option<Fault> {
        self.fault.clone()
    }
}

/// The oriented distance to a surface with creases — faces, creases and corners of a solid —
/// negative where f < 0 (`solve::solid`).
pub struct SolidDist {
    /// The surface's forms and f.
    pub pieces: Box<dyn Pieces>,
    /// Foot-point settings; `tolerance.foot.scale` should be the mesh step when it is known.
    pub tolerance: SolidFootTolerance,
    /// The last query and its foot point.
    warm: Option<(DVec3, DVec3)>,
    scratch: SolidScratch,
    /// The first query without a foot point.
    fault: Option<Fault>,
}

impl SolidDist {
    /// The distance to the surface of `pieces` with the default tolerance (scale 1).
    pub fn new(pieces: Box<dyn Pieces>) -> Self {
        Self::with_tolerance(pieces, SolidFootTolerance::default())
    }

    pub fn with_tolerance(pieces: Box<dyn Pieces>, tolerance: SolidFootTolerance) -> Self {
        SolidDist {
            pieces,
            tolerance,
            warm: None,
            scratch: SolidScratch::default(),
            fault: None,
        }
    }

    /// The foot point of x, with the reason when there is none. A query within
    /// `warm_radius · scale` of the last one starts its search radius at the last foot
    /// point's distance (a point of the surface), which changes only the work.
    pub fn foot(&mut self, x: DVec3) -> Result<SolidFoot, SolidFootError> {
        let tol = self.tolerance;
        let hint = self
            .warm
            .filter(|(wx, _)| (x - *wx).length() <= tol.foot.warm_radius * tol.foot.scale)
            .map(|(_, q)| q);
        let result = solid_foot_in(self.pieces.as_mut(), x, hint, &tol, &mut self.scratch);
        self.warm = result.as_ref().ok().map(|f| (x, f.point));
        if let Err(e) = &result {
            keep_fault(&mut self.fault, x, e);
        }
        result
    }

    /// Forget the warm start.
    pub fn clear_warm_start(&mut self) {
        self.warm = None;
    }
}

impl Surface for SolidDist {
    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        match self.foot(p) {
            Ok(f) => ValueGrad {
                value: f.distance,
                gradient: f.gradient,
            },
            Err(_) => FAILED,
        }
    }

    fn bound(&mut self, lo: DVec3, hi: DVec3) -> Option<Interval> {
        lipschitz_bound(self, |d| &mut d.fault, lo, hi)
    }

    fn fault(&self) -> Option<Fault> {
        self.fault.clone().or_else(|| self.pieces.fault())
    }
}
