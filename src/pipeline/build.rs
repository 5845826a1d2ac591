//! From the checked program to what the numeric half consumes: surface oracles (compiled
//! tapes with their `dist` children) and curve polygons. Curves are sampled once per
//! (curve, step, box) and cached, so meshes that use the same curve get bit-identical
//! polygon vertices and form one coherent net in the written file.

use std::collections::BTreeMap;

use glam::DVec3;

use crate::compile::{self, CompileError};
use crate::diag::{Diagnostic, messages};
use crate::eval::Engine;
use crate::eval::Interval;
use crate::march::MarchSettings;
use crate::sema::program::{CurveId, CurveKind, Program, SurfaceRef};
use crate::solve::curve::{self, CurveError, Polygon};
use crate::solve::solid::Pieces;
use crate::solve::tolerance::{
    FootTolerance, PatchFootTolerance, SolidFootTolerance, SurfacePointTolerance,
};
use crate::span::Span;
use crate::surface::compiled::{self, CompiledSurface};
use crate::surface::{Fault, ImplicitDist, PatchDist, SolidDist, Surface, ValueGrad};
use crate::survey::spine::{Form, MAX_FORMS};
use crate::values::interval;

/// Why a surface or curve could not be built.
#[derive(Debug, thiserror::Error)]
pub(crate) enum BuildError {
    #[error(transparent)]
    Compile(#[from] CompileError),
    #[error("curve `{name}`: {source}")]
    Curve {
        curve: CurveId,
        name: String,
        source: CurveError,
    },
}

/// A spine and its branch surfaces (`survey::spine`).
pub(crate) type Spined = (crate::survey::spine::Spine, Vec<Box<dyn Surface>>);

/// An axis-aligned box (lo, hi).
pub(crate) type Bbox = Option<(DVec3, DVec3)>;

/// The cache key of a sampled curve: its id, the step's bits and the box's bits.
type CurveKey = (CurveId, u64, Option<[u64; 6]>);

/// Builds surfaces and curves of one program, caching sampled curves.
pub(crate) struct Builder<'p> {
    program: &'p Program,
    /// The engine of every surface built.
    engine: Engine,
    curves: BTreeMap<CurveKey, Polygon>,
}

impl<'p> Builder<'p> {
    pub(crate) fn new(program: &'p Program, engine: Engine) -> Self {
        Builder {
            program,
            engine,
            curves: BTreeMap::new(),
        }
    }

    /// The engine of every surface built.
    pub(crate) fn engine(&self) -> Engine {
        self.engine
    }

    /// The oracle of a surface: its compiled tape, `dist(S)` children as foot-point distance
    /// surfaces over S's own compiled tape (or patch), built recursively, at most
    /// `MAX_DIST_DEPTH` deep. `scale` (the mesh step) is the length the foot-point tolerances
    /// are relative to.
    pub(crate) fn surface(
        &self,
        r: &SurfaceRef,
        scale: f64,
    ) -> Result<CompiledSurface, CompileError> {
        self.surface_in(r, scale, &mut Vec::new())
    }

    /// [`Builder::surface`] inside the `dist`s that `outer` names (outermost first).
    fn surface_in(
        &self,
        r: &SurfaceRef,
        scale: f64,
        outer: &mut Vec<String>,
    ) -> Result<CompiledSurface, CompileError> {
        let mut surface = compiled::compile_surface(self.program, r, &mut |target| {
            self.dist_child(target, scale, outer)
        })?;
        surface.set_engine(self.engine);
        Ok(surface)
    }

    /// The spine and branch surfaces of a surface with creases (`survey::spine`), or None
    /// when it has none.
    pub(crate) fn creased(
        &self,
        r: &SurfaceRef,
        scale: f64,
    ) -> Result<Option<Spined>, CompileError> {
        self.spine_in(r, scale, &mut Vec::new())
    }

    /// [`creased`](Self::creased) inside the `dist` surfaces named in `outer`.
    fn spine_in(
        &self,
        r: &SurfaceRef,
        scale: f64,
        outer: &mut Vec<String>,
    ) -> Result<Option<Spined>, CompileError> {
        let found = compiled::compile_spine(self.program, r, &mut |target| {
            self.dist_child(target, scale, outer)
        })?;
        let Some((spine, branches)) = found else {
            return Ok(None);
        };
        let branches = branches
            .into_iter()
            .map(|mut b| {
                b.set_engine(self.engine);
                Box::new(b) as Box<dyn Surface>
            })
            .collect();
        Ok(Some((spine, branches)))
    }

    fn dist_child(
        &self,
        target: &SurfaceRef,
        scale: f64,
        outer: &mut Vec<String>,
    ) -> Result<Box<dyn Surface>, CompileError> {
        compile::enter_dist(self.program, target, outer)?;
        let foot = FootTolerance {
            scale,
            ..FootTolerance::default()
        };
        let child: Box<dyn Surface> = match target {
            SurfaceRef::Patch(id) => Box::new(PatchDist::with_tolerance(
                Box::new(compiled::compile_patch(self.program, *id)?),
                PatchFootTolerance {
                    foot,
                    ..PatchFootTolerance::default()
                },
            )),
            // A surface with creases (a solid): the nearest point may be on a face, a crease
            // or a corner (`solve::solid`).
            other => match self.spine_pieces(other, scale, outer)? {
                Some(pieces) => Box::new(SolidDist::with_tolerance(
                    Box::new(pieces),
                    SolidFootTolerance {
                        foot,
                        ..SolidFootTolerance::default()
                    },
                )),
                None => Box::new(ImplicitDist::with_tolerance(
                    Box::new(self.surface_in(other, scale, outer)?),
                    foot,
                )),
            },
        };
        outer.pop();
        Ok(child)
    }

    /// The forms of a surface with creases as `solve::solid` reads them, or None when it has
    /// no spine (or more forms than `MAX_FORMS`: then its distance is the smooth one's, and
    /// a sharp edge it meets is refused where the mesh needs it).
    fn spine_pieces(
        &self,
        r: &SurfaceRef,
        scale: f64,
        outer: &mut Vec<String>,
    ) -> Result<Option<SpinePieces>, CompileError> {
        let Some((spine, branches)) = self.spine_in(r, scale, outer)? else {
            return Ok(None);
        };
        let Ok(forms) = spine.forms(MAX_FORMS) else {
            return Ok(None);
        };
        let whole = self.surface_in(r, scale, outer)?;
        Ok(Some(SpinePieces::new(whole, forms, branches)))
    }

    /// The polygon of curve `id` sampled at `step` (clipped by `bbox` where the curve is
    /// traced), as computed before for the same key. Circles are not yet projected: see
    /// `polygon_on`.
    pub(crate) fn curve(
        &mut self,
        id: CurveId,
        step: f64,
        bbox: Bbox,
    ) -> Result<Polygon, BuildError> {
        let key = (
            id,
            step.to_bits(),
            bbox.map(|(lo, hi)| [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z].map(f64::to_bits)),
        );
        if let Some(p) = self.curves.get(&key) {
            return Ok(p.clone());
        }
        let program = self.program;
        let def = &program.curves[id.index()];
        let fail = |source| BuildError::Curve {
            curve: id,
            name: def.name.clone(),
            source,
        };
        let polygon = match &def.kind {
            CurveKind::Intersection {
                first,
                second,
                near,
            } => {
                let mut s1 = self.surface(first, step)?;
                let mut s2 = self.surface(second, step)?;
                curve::intersection(&mut s1, &mut s2, *near, step, bbox).map_err(fail)?
            }
            CurveKind::Circle {
                center,
                normal,
                radius,
                segments,
            } => match segments {
                Some(n) => curve::circle_segments(*center, *normal, *radius, *n as usize),
                None => curve::circle(*center, *normal, *radius, step),
            }
            .map_err(fail)?,
            CurveKind::Boundary(patch) => {
                let mut patch = compiled::compile_patch(self.program, *patch)?;
                curve::boundary(&mut patch, step).map_err(fail)?
            }
            CurveKind::Reverse(inner) => curve::reverse(&self.curve(*inner, step, bbox)?),
        };
        self.curves.insert(key, polygon.clone());
        Ok(polygon)
    }

    /// The polygon of curve `id` as a front or bound of a mesh of `surface`: a circle's
    /// vertices are projected onto the surface (docs/language.md); intersection curves and patch
    /// boundaries already lie on their surfaces and are used as sampled, so that every mesh
    /// that shares them shares their vertices exactly.
    pub(crate) fn polygon_on(
        &mut self,
        id: CurveId,
        step: f64,
        bbox: Bbox,
        surface: &mut dyn Surface,
    ) -> Result<Polygon, BuildError> {
        let polygon = self.curve(id, step, bbox)?;
        if self.is_circle(id) {
            let name = self.program.curves[id.index()].name.clone();
            return curve::project_onto(surface, &polygon, step, &SurfacePointTolerance::default())
                .map_err(|source| BuildError::Curve {
                    curve: id,
                    name,
                    source,
                });
        }
        Ok(polygon)
    }

    /// Whether the curve is a circle, possibly reversed.
    fn is_circle(&self, id: CurveId) -> bool {
        match &self.program.curves[id.index()].kind {
            CurveKind::Circle { .. } => true,
            CurveKind::Reverse(inner) => self.is_circle(*inner),
            _ => false,
        }
    }
}

/// A surface with creases as the foot points of `solve::solid` read it: f's own tape, its
/// forms (the smooth pieces, `survey::spine`) and the compiled branches. A form is evaluated
/// from the branches it uses alone.
struct SpinePieces {
    whole: CompiledSurface,
    forms: Vec<Form>,
    branches: Vec<Box<dyn Surface>>,
    /// The branches each form uses (a nonzero coefficient), with the coefficient.
    uses: Vec<Vec<(usize, f64)>>,
    /// Each branch's bound over the box `bounds_of` (its ends' bits), once computed.
    bounds: Vec<Option<Option<Interval>>>,
    bounds_of: Option<[u64; 6]>,
    /// Whether each form is affine: every branch it uses is (its interval partials over a
    /// box of ±`AFFINE_REACH` are points).
    affine_forms: Vec<bool>,
}

/// The half-width of the box over which a branch's interval partials decide whether it is
/// affine (a product of two coordinates has partials that are no points over it; the
/// partials of an affine tape are points over any box, up to their outward rounding).
const AFFINE_REACH: f64 = 1e6;
/// Partials whose interval over that box is this narrow, relative to their size, are points
/// widened by rounding (a few ulps a constant factor). A nonlinear term that passes has a
/// curvature below 1e-18 over the box: the planes' closed forms are exact to rounding there.
const AFFINE_WIDTH: f64 = 1e-12;

impl SpinePieces {
    fn new(whole: CompiledSurface, forms: Vec<Form>, mut branches: Vec<Box<dyn Surface>>) -> Self {
        let n = branches.len();
        let reach = DVec3::splat(AFFINE_REACH);
        let affine: Vec<bool> = branches
            .iter_mut()
            .map(|b| {
                b.bound_gradient(-reach, reach, [true; 3]).is_some_and(|g| {
                    g.defined
                        && g.d.iter().all(|i| {
                            i.lo.is_finite()
                                && i.hi.is_finite()
                                && i.hi - i.lo <= AFFINE_WIDTH * i.lo.abs().max(i.hi.abs())
                        })
                })
            })
            .collect();
        let uses: Vec<Vec<(usize, f64)>> = forms.iter().map(|f| f.terms.clone()).collect();
        let affine_forms = uses
            .iter()
            .map(|u: &Vec<(usize, f64)>| u.iter().all(|&(k, _)| affine[k]))
            .collect();
        SpinePieces {
            whole,
            forms,
            branches,
            uses,
            bounds: vec![None; n],
            bounds_of: None,
            affine_forms,
        }
    }

    /// Form i's constant term.
    fn constant(&self, i: usize) -> f64 {
        self.forms[i].constant
    }
}

impl Pieces for SpinePieces {
    fn count(&self) -> usize {
        self.forms.len()
    }

    fn whole(&mut self, p: DVec3) -> ValueGrad {
        self.whole.value_gradient(p)
    }

    fn whole_value(&mut self, p: DVec3) -> f64 {
        self.whole.value(p)
    }

    fn form_values(&mut self, p: DVec3, values: &mut Vec<f64>) {
        let branches: Vec<f64> = self.branches.iter_mut().map(|b| b.value(p)).collect();
        values.clear();
        values.extend(self.forms.iter().map(|f| f.value(&branches)));
    }

    fn form(&mut self, i: usize, p: DVec3) -> ValueGrad {
        let mut out = ValueGrad {
            value: self.constant(i),
            gradient: DVec3::ZERO,
        };
        for &(k, c) in &self.uses[i] {
            let b = self.branches[k].value_gradient(p);
            out.value += c * b.value;
            out.gradient += c * b.gradient;
        }
        out
    }

    fn form_value(&mut self, i: usize, p: DVec3) -> f64 {
        let mut v = self.constant(i);
        for &(k, c) in &self.uses[i] {
            v += c * self.branches[k].value(p);
        }
        v
    }

    fn is_affine(&self, i: usize) -> bool {
        self.affine_forms[i]
    }

    fn fault(&self) -> Option<Fault> {
        self.whole
            .fault()
            .or_else(|| self.branches.iter().find_map(|b| b.fault()))
    }

    fn form_bound(&mut self, i: usize, lo: DVec3, hi: DVec3) -> Option<Interval> {
        let key = [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z].map(f64::to_bits);
        if self.bounds_of != Some(key) {
            self.bounds_of = Some(key);
            self.bounds.iter_mut().for_each(|b| *b = None);
        }
        let mut acc = Interval::point(self.constant(i));
        for &(k, c) in &self.uses[i] {
            let b = match self.bounds[k] {
                Some(b) => b,
                None => {
                    let b = self.branches[k].bound(lo, hi);
                    self.bounds[k] = Some(b);
                    b
                }
            }?;
            acc = interval::add(acc, interval::mul(b, Interval::point(c)));
        }
        Some(acc)
    }
}

/// The error a compile failure comes down to, through the `dist` children it was wrapped in,
/// with the span of the innermost `dist` call that led there (if any).
pub(crate) fn innermost(e: &CompileError) -> (&CompileError, Option<Span>) {
    let mut at = None;
    let mut e = e;
    while let CompileError::Child { span, source } = e {
        match source.downcast_ref::<CompileError>() {
            Some(inner) => {
                at = Some(*span);
                e = inner;
            }
            None => break,
        }
    }
    (e, at)
}

/// The diagnostic of a compile error that is the user's (a limit of docs/language.md "Limits" reached),
/// pointing at the call or `dist` at fault; None for errors that only a hand-built program
/// can cause.
pub(crate) fn limit_diagnostic(e: &CompileError) -> Option<Diagnostic> {
    match innermost(e) {
        (
            CompileError::TooLarge {
                nodes,
                limit,
                chain,
                span,
            },
            _,
        ) => Some(messages::surface_too_large(*span, *nodes, *limit, chain)),
        (CompileError::DistTooDeep { limit, chain }, Some(span)) => {
            Some(messages::dist_too_deep(span, *limit, chain))
        }
        _ => None,
    }
}

/// The marcher's settings for a mesh block: the defaults, with what the block asks for.
pub fn march_settings(def: &crate::sema::program::MeshDef) -> MarchSettings {
    let defaults = MarchSettings::default();
    MarchSettings {
        quality_ratio: def.radius_ratio.unwrap_or(defaults.quality_ratio),
        ..defaults
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The forms `solve::solid` gets for `dist(s)`: a turned box's six faces are planes (its
    /// closed forms, no global phase), a ball's are not.
    fn pieces_of(source: &str) -> SpinePieces {
        let (_, checked, diags) = crate::pipeline::load::analyse(source);
        let Some((_, program)) = checked else {
            panic!("{diags:?}");
        };
        let builder = Builder::new(&program, Engine::default());
        let s = SurfaceRef::Surface(crate::sema::program::SurfaceId(0));
        match builder.spine_pieces(&s, 1.0, &mut Vec::new()) {
            Ok(Some(p)) => p,
            _ => panic!("no spine"),
        }
    }

    #[test]
    fn planes_are_known_as_affine() {
        let turned = pieces_of(
            "surface s = rotate(box((-1, -1, -1), (1, 2, 3)), axis: (1, 2, 3), angle: 0.7);\n",
        );
        assert_eq!(turned.count(), 6);
        assert!((0..6).all(|i| turned.is_affine(i)));
        let balls = pieces_of("surface s = union(sphere(1), translate(sphere(1), (1, 0, 0)));\n");
        assert_eq!(balls.count(), 2);
        assert!((0..2).all(|i| !balls.is_affine(i)));
    }
}
