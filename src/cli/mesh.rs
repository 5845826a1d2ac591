//! `surfc mesh FILE [-o OUT] [--only NAME]... [--format F] [--json] [--stats] [--quiet]
//! [--threads N]`:
//! every selected mesh block is built (surface oracle, curve polygons), marched and reported;
//! then all of them go into one file, written atomically, or to standard output (`-o -`).
//! If any mesh fails, nothing is written.

use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::AtomicU64;
use std::time::Instant;

use clap::ValueEnum;
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::build::{self, BuildError, Builder};
use super::creases;
use super::load::{Loaded, input_name, is_stdin, load_reported, stderr_color};
use super::report::{CODE_INPUT, CODE_IO, CODE_USAGE, Failure};
use super::{ColorMode, EXIT_INPUT, EXIT_USAGE, EngineChoice};
use crate::diag::{self, Diagnostic, messages};
use crate::eval::Engine;
use crate::march::{MarchError, MarchInput, MarchSettings, PolygonRole, Start};
use crate::mesh::quality::MeshReport;
use crate::mesh::summary::{
    MeshSummary, Progress, estimate_triangles, format_stats, format_summary,
};
use crate::mesh::topology::Topology;
use crate::mesh::write::{Format, target, write_mesh_file};
use crate::mesh::{Mesh, NamedMesh, net};
use crate::sema::program::{MeshDef, Program, SurfaceRef};
use crate::solve::surface_point_near;
use crate::surface::compiled::CompiledSurface;
use crate::survey::components::{self, Marching, SearchError, SearchSettings};
use crate::survey::pieces;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MeshFormat {
    Obj,
    Stl,
    Ply,
    Off,
    Glb,
    #[value(name = "3mf")]
    ThreeMf,
    Msh,
    Vtu,
}

impl From<MeshFormat> for Format {
    fn from(f: MeshFormat) -> Format {
        match f {
            MeshFormat::Obj => Format::Obj,
            MeshFormat::Stl => Format::Stl,
            MeshFormat::Ply => Format::Ply,
            MeshFormat::Off => Format::Off,
            MeshFormat::Glb => Format::Glb,
            MeshFormat::ThreeMf => Format::ThreeMf,
            MeshFormat::Msh => Format::Msh,
            MeshFormat::Vtu => Format::Vtu,
        }
    }
}

#[derive(clap::Args, Debug)]
pub struct MeshArgs {
    /// The .surf file; `-` reads standard input.
    pub file: PathBuf,
    /// Output file; the format follows its extension. `-` writes to standard output (then
    /// `--format` is required). Default: `<file stem>.<format>` here.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Mesh only the named mesh blocks (repeatable).
    #[arg(long = "only", value_name = "NAME")]
    pub only: Vec<String>,
    /// Output format (default: from OUT's extension, else obj).
    #[arg(long, value_enum)]
    pub format: Option<MeshFormat>,
    /// Print one JSON report object on stdout (on failure: `{"errors": [...]}`).
    #[arg(long)]
    pub json: bool,
    /// Print a table of shape statistics on stderr: angle percentiles, radius ratios, edges.
    #[arg(long)]
    pub stats: bool,
    /// No progress bar and no summary table on stderr.
    #[arg(long, short)]
    pub quiet: bool,
    /// How surfaces are evaluated: machine code compiled from the tape, or the interpreter.
    #[arg(long, value_enum, default_value_t = EngineChoice::Native)]
    pub engine: EngineChoice,
    /// Set a constant of the file: `-D NAME=VALUE` (repeatable).
    #[command(flatten)]
    pub defines: super::load::DefineArgs,
    /// Threads to mesh with (default: every core). The output is the same bytes for any N.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    pub threads: Option<u16>,
}

/// The `--json` report (DESIGN.md §3); structs keep the keys in the documented order.
#[derive(Serialize)]
struct Json<'a> {
    meshes: Vec<MeshJson<'a>>,
    seconds: f64,
}

/// One mesh of the `--json` report (DESIGN.md §3).
#[derive(Serialize)]
struct MeshJson<'a> {
    name: &'a str,
    surface: &'a str,
    step: f64,
    #[serde(flatten)]
    report: MeshReport,
    max_chord_error: f64,
    warnings: &'a [String],
    /// Whether the mesh was flipped against its ∇f to agree with the net it joins.
    flipped: bool,
    /// The creases of a mesh made crease by crease, else null.
    creases: Option<CreaseCounts>,
    /// Slabs marched on separate threads (`survey::pieces`); left out when 1.
    #[serde(skip_serializing_if = "is_one")]
    pieces: usize,
    seconds: f64,
}

fn is_one(n: &usize) -> bool {
    *n == 1
}

/// What a mesh made crease by crease (`survey::creases`) has of its creases.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct CreaseCounts {
    /// Crease curves traced in the box (closed loops and corner-to-corner curves).
    pub creases: usize,
    /// Corners where three pieces meet.
    pub corners: usize,
    /// Vertices of the mesh on a crease polygon (corners included), each once.
    pub crease_vertices: usize,
}

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
    /// Slabs the component was cut into and marched on separate threads (`survey::pieces`);
    /// 1 when it was marched whole.
    pub pieces: usize,
    /// Wall-clock time to build and mesh the block, in seconds.
    pub seconds: f64,
}

pub fn run(args: MeshArgs, color: ColorMode) -> u8 {
    let json = args.json;
    // Every parallel part (blocks, the verification's crossing check, the report) runs on
    // this pool; 0 asks rayon for one thread per core.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.map_or(0, usize::from))
        .build();
    let result = match pool {
        Ok(pool) => pool.install(|| mesh_command(args, color)),
        Err(e) => Err(Failure::usage(format!("cannot start the threads: {e}"))),
    };
    match result {
        Ok(()) => 0,
        Err(failure) => failure.finish(json),
    }
}

/// Where the mesh file goes.
enum Output {
    File(PathBuf),
    Stdout,
}

/// The output and its format, from `-o` and `--format`; a usage error where they do not say
/// enough or disagree.
fn choose_output(args: &MeshArgs) -> Result<(Output, Format), Failure> {
    let explicit = args.format.map(Format::from);
    match args.output.as_deref() {
        Some(out) if is_stdin(out) => {
            if args.json {
                return Err(Failure::usage(
                    "`-o -` and `--json` both write to standard output; write the mesh to a file, or leave out `--json`".into(),
                ));
            }
            match explicit {
                Some(format) => Ok((Output::Stdout, format)),
                None => Err(Failure::usage(
                    "`-o -` writes to standard output, which has no extension: name the format with `--format obj|stl|ply|off|glb|3mf|msh|vtu`".into(),
                )),
            }
        }
        output => {
            let format =
                Format::choose(explicit, output).map_err(|e| Failure::usage(e.to_string()))?;
            let path = match output {
                Some(path) => path.to_path_buf(),
                None if is_stdin(&args.file) => {
                    return Err(Failure::usage(
                        "reading standard input, `mesh` has no file name to name its output after: give `-o OUT` (or `-o -` with `--format`)".into(),
                    ));
                }
                None => format.default_output(&args.file),
            };
            Ok((Output::File(path), format))
        }
    }
}

fn mesh_command(args: MeshArgs, color: ColorMode) -> Result<(), Failure> {
    let started = Instant::now();
    let (output, format) = choose_output(&args)?;
    let loaded = load_reported(&args.file, color, &args.defines)?;
    let selected = select(&loaded, &args.only)?;
    // Before meshing, so that the user does not wait for a refusal (a FIFO is not opened).
    if let Output::File(path) = &output {
        target::check_output(path, &args.file).map_err(|e| Failure::io(e.to_string(), path))?;
    }
    let meshed = mesh_blocks(&loaded, &selected, color, args.quiet, args.engine.into())?;
    for m in &meshed {
        for w in &m.warnings {
            eprintln!("warning: mesh `{}`: {w}", m.name);
        }
    }

    let meshes = named(&meshed);
    let written = match &output {
        Output::File(path) => write_mesh_file(path, format, &meshes)
            .map(|()| path.display().to_string())
            .map_err(|e| Failure::io(e.to_string(), e.path())),
        Output::Stdout => write_stdout(format, &meshes).map(|()| "standard output".to_owned()),
    }?;

    if args.json {
        let meshes: Vec<MeshJson> = meshed
            .iter()
            .map(|m| MeshJson {
                name: &m.name,
                surface: &m.surface,
                step: m.step,
                report: m.report.clone(),
                max_chord_error: m.max_chord_error,
                warnings: &m.warnings,
                flipped: m.flipped,
                creases: m.creases,
                pieces: m.pieces,
                seconds: m.seconds,
            })
            .collect();
        let json = Json {
            meshes,
            seconds: started.elapsed().as_secs_f64(),
        };
        let code = super::print_stdout(&format!(
            "{}\n",
            serde_json::to_string(&json).unwrap_or_default()
        ));
        if code != 0 {
            return Err(Failure {
                exit: code,
                errors: Vec::new(),
            });
        }
    }
    if args.stats {
        let rows: Vec<(&str, &MeshReport)> = meshed
            .iter()
            .map(|m| (m.name.as_str(), &m.report))
            .collect();
        eprint!("{}", format_stats(&rows));
    }
    if !args.quiet {
        let rows: Vec<MeshSummary> = meshed
            .iter()
            .map(|m| MeshSummary {
                name: &m.name,
                triangles: m.report.triangles,
                components: m.report.components,
                seconds: m.seconds,
                boundary_loops: m.report.boundary_loops,
                non_manifold_edges: m.report.non_manifold_edges,
            })
            .collect();
        eprint!("{}", format_summary(&rows));
        eprintln!("wrote {written}");
    }
    Ok(())
}

/// Writes the meshes to standard output (`-o -`). A reader that stops early is no error, as
/// for every command that prints; a mesh no format can write is refused before the first
/// byte.
fn write_stdout(format: Format, meshes: &[NamedMesh]) -> Result<(), Failure> {
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    match format.write(&mut out, meshes).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::InvalidData => Err(Failure::new(
            EXIT_USAGE,
            CODE_IO,
            format!("cannot write the mesh: {e}"),
            None,
        )),
        Err(e) => Err(Failure::new(
            EXIT_USAGE,
            CODE_IO,
            format!("cannot write to standard output: {e}"),
            None,
        )),
    }
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

/// The mesh blocks to mesh, in file order: all, or those `--only` names. An unknown name is
/// a usage error that lists the known ones.
pub(crate) fn select<'a>(loaded: &'a Loaded, only: &[String]) -> Result<Vec<&'a MeshDef>, Failure> {
    let meshes = &loaded.program.meshes;
    let file = input_name(&loaded.path);
    if meshes.is_empty() {
        return Err(Failure::new(
            EXIT_INPUT,
            CODE_INPUT,
            format!(
                "`{file}` has no mesh block; add one, e.g. `mesh m = S {{ step: 0.1; start: (1, 0, 0); }}`"
            ),
            Some(&loaded.path),
        ));
    }
    for name in only {
        if !meshes.iter().any(|m| &m.name == name) {
            let known: Vec<&str> = meshes.iter().map(|m| m.name.as_str()).collect();
            return Err(Failure::new(
                EXIT_USAGE,
                CODE_USAGE,
                format!(
                    "`{file}` has no mesh block `{name}`; its mesh blocks are: {}",
                    known.join(", ")
                ),
                Some(&loaded.path),
            ));
        }
    }
    Ok(meshes
        .iter()
        .filter(|m| only.is_empty() || only.contains(&m.name))
        .collect())
}

/// Meshes the blocks in order; the first failure is reported as a diagnostic (exit 1).
/// The marcher's settings for a mesh block: the defaults, with what the block asks for.
pub(super) fn march_settings(def: &MeshDef) -> MarchSettings {
    let defaults = MarchSettings::default();
    MarchSettings {
        quality_ratio: def.radius_ratio.unwrap_or(defaults.quality_ratio),
        ..defaults
    }
}

pub(crate) fn mesh_blocks(
    loaded: &Loaded,
    blocks: &[&MeshDef],
    color: ColorMode,
    quiet: bool,
    engine: Engine,
) -> Result<Vec<Meshed>, Failure> {
    mesh_program(&loaded.program, &loaded.source, blocks, quiet, engine)
        .map_err(|d| Failure::diagnostics_map(&[d], &loaded.map, stderr_color(color)))
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
fn mesh_program(
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
    let results: Vec<Result<Meshed, Diagnostic>> = blocks
        .par_iter()
        .map(|def| {
            let mut builder = Builder::new(program, engine);
            let estimate = def
                .bbox
                .and_then(|(lo, hi)| estimate_triangles(def.step, lo, hi));
            let progress = Progress::start(&def.name, quiet, estimate);
            let result = mesh_block(program, source, &mut builder, def, progress.counter());
            progress.finish();
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
    progress: &AtomicU64,
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
        let out = creases::mesh(c, &mut surface, &fork, def, bbox)?;
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
            )
            .map_err(|e| match &e {
                SearchError::March { source, .. } => {
                    messages::mesh_failed(&def.name, def.span, &e.to_string(), march_help(source))
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
    };
    // A large component from a start point is marched in pieces on the pool's threads
    // (`survey::pieces`); not a surface with creases, whose pieces are its smooth forms.
    let fork: Option<&crate::surface::Fork<'_>> =
        if creased.is_none() { Some(&fork) } else { None };
    let pieced = pieces::march(&mut surface, fork, &input, &settings, Some(progress))
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
        (marched.mesh, pieced.topology),
        marched.max_chord_error,
        warnings,
        started,
    );
    meshed.pieces = pieced.pieces;
    Ok(meshed)
}

/// What the user may change when no surface point is found near `start`.
const START_HELP: &str = "move `start` nearer the surface, or give the mesh a `box` and no `start` to mesh every component in it";

/// The meshed block with its report; the mesh comes with its topology where the march
/// computed it already (the join of pieces).
#[allow(clippy::too_many_arguments)]
fn finish(
    program: &Program,
    source: &str,
    def: &MeshDef,
    surface: &mut CompiledSurface,
    (mesh, topology): (Mesh, Option<Topology>),
    max_chord_error: f64,
    warnings: Vec<String>,
    started: Instant,
) -> Meshed {
    let report = MeshReport::new(&mesh, surface, topology);
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
fn march_help(e: &MarchError) -> Option<&'static str> {
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
        MarchError::HiddenCrease { .. } => {
            "creases are traced where `min`, `max`, `abs` or a sharp boolean or primitive is reached from the outside of the formula through sums, constant factors and smooth booleans; one inside another function (`exp`, `sin`, a product) hides its edges: keep sharp parts outside such functions, or round the edge with a smooth boolean (docs/creases.md)"
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
