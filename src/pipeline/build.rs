//! From the checked program to what the numeric half consumes: surface oracles (compiled
//! tapes with their `dist` children) and curve polygons. Curves are sampled once per
//! (curve, step, box) and cached, so meshes that use the same curve get bit-identical
//! polygon vertices and form one coherent net in the written file.

use std::collections::BTreeMap;

use glam::DVec3;

use crate::compile::{self, CompileError};
use crate::diag::{Diagnostic, messages};
use crate::eval::Engine;
use crate::march::MarchSettings;
use crate::sema::program::{CurveId, CurveKind, Program, SurfaceRef};
use crate::solve::curve::{self, CurveError, Polygon};
use crate::solve::tolerance::{FootTolerance, PatchFootTolerance, SurfacePointTolerance};
use crate::span::Span;
use crate::surface::compiled::{self, CompiledSurface};
use crate::surface::{ImplicitDist, PatchDist, Surface};

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
        let mut outer = Vec::new();
        let found = compiled::compile_spine(self.program, r, &mut |target| {
            self.dist_child(target, scale, &mut outer)
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
            other => Box::new(ImplicitDist::with_tolerance(
                Box::new(self.surface_in(other, scale, outer)?),
                foot,
            )),
        };
        outer.pop();
        Ok(child)
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
