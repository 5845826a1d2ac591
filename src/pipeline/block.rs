//! One mesh block from its checked definition to its mesh and report: the strategy the block
//! asks for (a front, a start point, the component search in a box, the crease net, parallel
//! pieces), the diagnostics when it cannot be completed, and the orientation of the nets the
//! blocks form as one (docs/ARCHITECTURE.md).

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use super::build::{self, BuildError, Builder, march_settings};
use super::components::{self, Marching, SearchError, SearchSettings};
use super::creased::{self as creases, CreaseCounts};
use super::pieces;
use crate::diag::{self, Diagnostic, messages};
use crate::eval::Engine;
use crate::march::{MarchError, MarchInput, PolygonRole, Start};
use crate::mesh::progress::{Bars, Counts, estimate_triangles};
use crate::mesh::quality::{MeshReport, Quality};
use crate::mesh::topology::Topology;
use crate::mesh::{Mesh, NamedMesh, net};
use crate::sema::program::{MeshDef, Program, SurfaceRef};
use crate::solve::surface_point_near;
use crate::surface::compiled::CompiledSurface;

/// A mesh block that was meshed.
#[derive(Clone, Debug)]
pub struct Meshed {
    /// The mesh block's name.
    pub name: String,
    /// The name of the surface it meshes, or the text of its expression.
    pub surface: String,
    /// The block's `step`.
    pub step: f64,
    /// The block's `box`, if it has one.
    pub bbox: Option<(DVec3, DVec3)>,
    /// The triangles.
    pub mesh: Mesh,
    /// Topology and quality of the triangles (the figures of `surfc mesh --json`).
    pub report: MeshReport,
    /// The largest distance from a triangle's centroid or edge midpoint to the surface.
    pub max_chord_error: f64,
    /// What the user should know: components smaller than the step, regions where no seed
    /// converged, features cut at the floor of the local step (also printed on stderr).
    pub warnings: Vec<String>,
    /// Whether the mesh is oriented against its ∇f, to agree with the meshes it shares a
    /// polygon with (`mesh::net`).
    pub flipped: bool,
    /// The creases, when the mesh was made crease by crease.
    pub creases: Option<CreaseCounts>,
    /// Slabs the component was cut into and marched on separate threads (`pipeline::pieces`);
    /// 1 when it was marched whole.
    pub pieces: usize,
    /// Wall-clock time to build and mesh the block, in seconds.
    pub seconds: f64,
}

/// The meshes as the writers and the renderer take them.
pub fn named(meshed: &[Meshed]) -> Vec<NamedMesh<'_>> {
    meshed
        .iter()
        .map(|m| NamedMesh {
            name: &m.name,
            mesh: &m.mesh,
        })
        .collect()
}

/// Parses, checks and meshes every mesh block of `source`: the library form of
/// `surfc mesh`, for tests and embedders. Err holds every diagnostic of the file, or the one
/// that says why a mesh could not be completed.
pub fn mesh_source(source: &str) -> Result<Vec<Meshed>, Vec<Diagnostic>> {
    mesh_source_with(source, Engine::default())
}

/// [`mesh_source`] with the surfaces evaluated by `engine`.
pub fn mesh_source_with(source: &str, engine: Engine) -> Result<Vec<Meshed>, Vec<Diagnostic>> {
    let (_, checked, diags) = super::load::analyse(source);
    match checked {
        Some((_, program)) if !diag::has_errors(&diags) => {
            mesh_checked(&program, source, engine).map_err(|d| vec![d])
        }
        _ => Err(diags),
    }
}

/// Meshes every block of a checked `program` (its `source` names anonymous surfaces): for
/// callers that change the program first (the fuzzer caps `max_triangles`).
pub fn mesh_checked(
    program: &Program,
    source: &str,
    engine: Engine,
) -> Result<Vec<Meshed>, Diagnostic> {
    let blocks: Vec<&MeshDef> = program.meshes.iter().collect();
    mesh_program(program, source, &blocks, true, engine)
}

/// Meshes the blocks in order, with a progress bar on a terminal unless `quiet`, and
/// orients the nets they form as one.
pub fn mesh_program(
    program: &Program,
    source: &str,
    blocks: &[&MeshDef],
    quiet: bool,
    engine: Engine,
) -> Result<Vec<Meshed>, Diagnostic> {
    // Blocks on the threads of the pool, each with its own builder: surfaces are not shared
    // between threads, and a curve used by two blocks is sampled by each to the same bits
    // (sampling is a function of the curve, the step and the box). Results are taken in
    // file order, the first failure in file order is the error: the same for any number of
    // threads.
    let bars = Bars::new(quiet);
    let results: Vec<Result<Meshed, Diagnostic>> = blocks
        .par_iter()
        .map(|def| {
            let mut builder = Builder::new(program, engine);
            let estimate = def
                .bbox
                .and_then(|(lo, hi)| estimate_triangles(def.step, lo, hi));
            let line = bars.block(&def.name, estimate);
            let result = mesh_block(program, source, &mut builder, def, line.count());
            line.finish();
            result
        })
        .collect();
    let mut meshed = results
        .into_iter()
        .collect::<Result<Vec<Meshed>, Diagnostic>>()?;
    // The meshes go into one file: where they share a polygon, they are one net.
    let flips = net::orient(&mut meshed.iter_mut().map(|m| &mut m.mesh).collect::<Vec<_>>());
    for (m, flipped) in meshed.iter_mut().zip(flips) {
        m.flipped = flipped;
    }
    Ok(meshed)
}

fn mesh_block(
    program: &Program,
    source: &str,
    builder: &mut Builder,
    def: &MeshDef,
    progress: &Counts,
) -> Result<Meshed, Diagnostic> {
    let started = Instant::now();
    let build_failed = |e: BuildError| {
        let curve = match &e {
            BuildError::Curve { curve, .. } => Some(program.curves[curve.index()].span),
            BuildError::Compile(c) => {
                if let Some(d) = build::limit_diagnostic(c) {
                    return d.secondary(def.span, "in this mesh block");
                }
                None
            }
        };
        messages::mesh_build_failed(&def.name, def.span, &e, curve)
    };
    let mut surface = builder
        .surface(&def.surface, def.step)
        .map_err(|e| build_failed(e.into()))?;
    // A fresh oracle of the surface for each march of the component search, built on the
    // thread that marches (surface::Fork).
    let engine = builder.engine();
    let fork = || {
        Builder::new(program, engine)
            .surface(&def.surface, def.step)
            .ok()
            .map(|s| Box::new(s) as Box<dyn crate::surface::Surface>)
    };
    // Fresh oracles of the spine's branches, for the smooth pieces marched on the pool.
    let branches = || {
        Builder::new(program, engine)
            .creased(&def.surface, def.step)
            .ok()
            .flatten()
            .map(|(_, branches)| branches)
    };
    let mut creased = creases::creased_of(builder, def).map_err(|e| match e {
        Ok(c) => build_failed(c.into()),
        Err(d) => d,
    })?;
    let crease_box = match (&creased, def.bbox, def.start) {
        (Some(_), None, Some(_)) => creases::derived_box(&mut surface, def.step),
        _ => def.bbox,
    };
    if let (Some(c), Some(bbox), None, true) = (
        creased.as_mut(),
        crease_box,
        def.front,
        def.bounds.is_empty(),
    ) {
        let out = creases::mesh(c, &mut surface, &fork, &branches, def, bbox, progress)?;
        if out.mesh.triangles.is_empty() && def.start.is_none() {
            return Err(nothing_in_box(def, &mut surface, bbox, &out.warnings));
        }
        let counts = creases::counts(&out);
        let mut meshed = finish(
            program,
            source,
            def,
            &mut surface,
            (out.mesh, None),
            out.max_chord_error,
            out.warnings,
            started,
        );
        meshed.creases = Some(counts);
        return Ok(meshed);
    }
    let mut bounds = Vec::with_capacity(def.bounds.len());
    for &b in &def.bounds {
        bounds.push(
            builder
                .polygon_on(b, def.step, def.bbox, &mut surface)
                .map_err(build_failed)?
                .points,
        );
    }
    let failed = |e: &MarchError| {
        let d = messages::mesh_failed(&def.name, def.span, &e.to_string(), march_help(e));
        // A polygon too coarse for the surface: the curve it was sampled from (a cut
        // polygon of `pieces` has none).
        let curve = match e {
            MarchError::CoarsePolygon(c) => match c.polygon {
                PolygonRole::Front => def.front,
                PolygonRole::Bound(i) => def.bounds.get(i).copied(),
            },
            _ => None,
        };
        match curve {
            Some(c) => d.secondary(
                program.curves[c.index()].span,
                "the polygon is sampled from this curve",
            ),
            None => d,
        }
    };
    let settings = march_settings(def);
    let mut warnings = Vec::new();
    let start = match (def.front, def.start, def.bbox) {
        (Some(front), _, _) => Start::Front(
            builder
                .polygon_on(front, def.step, def.bbox, &mut surface)
                .map_err(build_failed)?
                .points,
        ),
        (None, Some(p), _) => {
            let sp = surface_point_near(&mut surface, p, def.step, &settings.surface_point)
                .map_err(|e| {
                    messages::mesh_failed(&def.name, def.span, &e.to_string(), Some(START_HELP))
                })?;
            Start::Point(sp.point)
        }
        (None, None, Some(bbox)) if bounds.is_empty() => {
            let marching = Marching {
                step: def.step,
                max_triangles: def.max_triangles,
                tolerance: def.tolerance,
                uniform: def.uniform,
            };
            let found = components::mesh_components_forked(
                &mut surface,
                &fork,
                marching,
                bbox,
                &settings,
                &SearchSettings::default(),
                Some(progress),
            )
            .map_err(|e| match &e {
                SearchError::March { source, .. } => {
                    messages::mesh_failed(&def.name, def.span, &e.to_string(), march_help(source))
                }
                SearchError::Fault { .. } => {
                    messages::mesh_failed(&def.name, def.span, &e.to_string(), Some(FAULT_HELP))
                }
                SearchError::CellBudget { .. } => messages::mesh_failed(
                    &def.name,
                    def.span,
                    &e.to_string(),
                    Some("raise `max_triangles` if the surface is this large at this step; else a smaller `box` around the part to mesh"),
                ),
                _ => messages::mesh_failed(&def.name, def.span, &e.to_string(), None),
            })?;
            warnings.extend(found.warnings.iter().map(ToString::to_string));
            warnings.extend(found.march_warnings);
            if found.mesh.triangles.is_empty() {
                return Err(nothing_in_box(def, &mut surface, bbox, &warnings));
            }
            return Ok(finish(
                program,
                source,
                def,
                &mut surface,
                (found.mesh, None),
                found.max_chord_error,
                warnings,
                started,
            ));
        }
        // sema requires one of them; a program built elsewhere may not.
        (None, None, _) => {
            let why = if def.bbox.is_some() {
                "`bounds` need a `start` or a `front` to begin from"
            } else {
                "it has neither `start`, `front` nor `box`"
            };
            return Err(messages::mesh_failed(&def.name, def.span, why, None));
        }
    };
    let input = MarchInput {
        step: def.step,
        start,
        bounds,
        bbox: def.bbox,
        max_triangles: def.max_triangles,
        tolerance: def.tolerance,
        uniform: def.uniform,
        expected_triangles: None,
    };
    // A large component from a start point is marched in pieces on the pool's threads
    // (`pipeline::pieces`); not a surface with creases, whose pieces are its smooth forms.
    let fork: Option<&crate::surface::Fork<'_>> =
        if creased.is_none() { Some(&fork) } else { None };
    let pieced = pieces::march(
        &mut surface,
        fork,
        &input,
        &settings,
        Some(&progress.triangles),
    )
    .map_err(|e| failed(&e))?;
    let marched = pieced.marched;
    if let Some(c) = creased.as_mut() {
        creases::check(c, def, &marched.mesh)?;
    }
    warnings.extend(marched.warnings);
    let mut meshed = finish(
        program,
        source,
        def,
        &mut surface,
        (marched.mesh, pieced.measured),
        marched.max_chord_error,
        warnings,
        started,
    );
    meshed.pieces = pieced.pieces;
    Ok(meshed)
}

/// Samples per axis of the grid over an empty box whose values `nothing_in_box` reports.
const EMPTY_BOX_SAMPLES: usize = 17;

/// The error of a block whose box held nothing to mesh (E0605), with the range of f over the
/// box: its interval bound and the values on a grid of `EMPTY_BOX_SAMPLES`³ points.
fn nothing_in_box(
    def: &MeshDef,
    surface: &mut CompiledSurface,
    (lo, hi): (DVec3, DVec3),
    warnings: &[String],
) -> Diagnostic {
    use crate::surface::Surface;
    let bound = surface
        .bound(lo, hi)
        .filter(|b| !b.is_empty())
        .map(|b| (b.lo, b.hi));
    let n = EMPTY_BOX_SAMPLES;
    let mut sampled: Option<(f64, f64)> = None;
    let mut undefined = 0;
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let t = DVec3::new(i as f64, j as f64, k as f64) / (n - 1) as f64;
                let v = surface.value(lo + (hi - lo) * t);
                if v.is_nan() {
                    undefined += 1;
                    continue;
                }
                sampled = Some(sampled.map_or((v, v), |(a, b)| (a.min(v), b.max(v))));
            }
        }
    }
    let range = messages::Range {
        bound,
        sampled,
        samples: n * n * n,
        undefined,
    };
    messages::empty_box(
        &def.name,
        def.span,
        (lo.to_array(), hi.to_array()),
        range,
        warnings,
    )
}

/// What the user may change where a `dist` found no foot point.
const FAULT_HELP: &str = "`dist` and `offset` need the nearest point of their surface at every point the mesh asks about; a sharp edge or corner inside a function (`exp`, `sin`, a product) is not seen as one: write solids with `box`, the booleans, `min`, `max` and `abs` outside other functions (docs/implicitization.md), or keep the `box` away from that place";

/// What the user may change when no surface point is found near `start`.
const START_HELP: &str = "move `start` nearer the surface, or give the mesh a `box` and no `start` to mesh every component in it";

/// The meshed block with its report; the mesh comes with its topology and shape statistics
/// where the march computed them already (the join of pieces).
#[allow(clippy::too_many_arguments)]
fn finish(
    program: &Program,
    source: &str,
    def: &MeshDef,
    surface: &mut CompiledSurface,
    (mesh, measured): (Mesh, Option<(Topology, Quality)>),
    max_chord_error: f64,
    warnings: Vec<String>,
    started: Instant,
) -> Meshed {
    let report = MeshReport::new(&mesh, surface, measured);
    Meshed {
        name: def.name.clone(),
        surface: surface_name(program, source, &def.surface),
        step: def.step,
        bbox: def.bbox,
        mesh,
        report,
        max_chord_error,
        warnings,
        flipped: false,
        creases: None,
        pieces: 1,
        seconds: started.elapsed().as_secs_f64(),
    }
}

/// What the user may change when the marcher stops with `e`.
pub(super) fn march_help(e: &MarchError) -> Option<&'static str> {
    Some(match e {
        MarchError::Refining { source, .. } => return march_help(source),
        MarchError::TooManyTriangles { .. } => {
            "raise `max_triangles` if the surface is this large at this step; else look where the front was last advanced: a smaller `step` there, or a `box` around the part to mesh"
        }
        MarchError::Unbounded { .. } => {
            "add a `box` around the part to mesh (a closed surface this large needs one too); if a `front` or `bounds` polygon should close the mesh, it may be walked the wrong way (see `reverse`)"
        }
        MarchError::Overlapping { .. } => {
            "two sheets of the surface come closer there than the step: use a smaller `step`, or a `box` that keeps the mesh away from that place"
        }
        MarchError::Start { .. } | MarchError::StartOutsideBox { .. } => {
            "move `start` nearer the surface (and inside the `box`)"
        }
        MarchError::NoSignChange { .. } => {
            "surfc meshes the boundary between f < 0 and f > 0: write the surface so that f changes sign on it (`g`, not `g^2` or `abs(g)`); a cusp or a crossing cannot be marched through, so keep it out of the `box`"
        }
        MarchError::CoarsePolygon(_) => {
            "the curve's polygon is sampled at `step`: a smaller `step` (at most twice the local step named here), or `segments:` for a circle; a larger `tolerance` lets the local step grow where it comes from the surface's curvature"
        }
        MarchError::Unverified { .. } => {
            "without `uniform: true` the local step refines there; else a smaller `step` (or, for a coarse but right mesh, a larger `tolerance`); `SURFC_TRACE=1` shows each refinement"
        }
        MarchError::NewPoint { .. } | MarchError::Stalled { .. } => {
            "a smaller `step` may get past small features or a singular point; a `box` can keep the mesh away from it"
        }
        MarchError::Fault { .. } => FAULT_HELP,
        MarchError::UniformMisses { .. } | MarchError::UniformTopology { .. } => {
            "`uniform: true` keeps the step everywhere: a smaller `step` resolves the feature; without `uniform` the local step refines there"
        }
        MarchError::HiddenCrease { .. } => {
            "creases are traced where `min`, `max`, `abs` or a sharp boolean or primitive is reached from the outside of the formula through sums, constant factors and smooth booleans; one inside another function (`exp`, `sin`, a product) hides its edges: keep sharp parts outside such functions, or round the edge with a smooth boolean (docs/creases.md). Inside `dist` and `offset` a concave edge of the solid is such an edge: the offset of a `union` is traced where its operands cross, but not where they share a face plane or inside one operand"
        }
        MarchError::PolygonTooShort { .. }
        | MarchError::PolygonSpacing { .. }
        | MarchError::PolygonOffSurface { .. }
        | MarchError::PolygonGradient { .. } => {
            "a front or bound must lie on the mesh's surface, its vertices about `step` apart"
        }
        _ => return None,
    })
}

/// The name of a surface as the user wrote it: its name, or the text of an expression.
fn surface_name(program: &Program, source: &str, r: &SurfaceRef) -> String {
    match r {
        SurfaceRef::Surface(id) => program.surfaces[id.index()].name.clone(),
        SurfaceRef::Patch(id) => program.patches[id.index()].name.clone(),
        SurfaceRef::Anonymous(e) => source
            .get(e.span.range())
            .unwrap_or("<expression>")
            .to_string(),
    }
}
