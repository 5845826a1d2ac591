//! `surfc mesh FILE [-o OUT] [--only NAME]... [--format F] [--json] [--quiet]`: every selected
//! mesh block is built (surface oracle, curve polygons), marched and reported; then all of
//! them go into one file, written atomically. If any mesh fails, nothing is written.

use std::path::PathBuf;
use std::time::Instant;

use clap::ValueEnum;
use glam::DVec3;
use serde::Serialize;

use super::build::{self, BuildError, Builder};
use super::load::{Loaded, load, stderr_color};
use super::{ColorMode, EXIT_INPUT, EXIT_USAGE, EngineChoice};
use crate::diag::{self, Diagnostic, messages};
use crate::eval::Engine;
use crate::march::{self, MarchError, MarchInput, MarchSettings, Start};
use crate::mesh::quality::MeshReport;
use crate::mesh::summary::{MeshSummary, Progress, format_summary};
use crate::mesh::write::{Format, target, write_mesh_file};
use crate::mesh::{Mesh, NamedMesh, net};
use crate::sema::program::{MeshDef, Program, SurfaceRef};

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MeshFormat {
    Obj,
    Stl,
    Ply,
    Off,
    Glb,
}

impl From<MeshFormat> for Format {
    fn from(f: MeshFormat) -> Format {
        match f {
            MeshFormat::Obj => Format::Obj,
            MeshFormat::Stl => Format::Stl,
            MeshFormat::Ply => Format::Ply,
            MeshFormat::Off => Format::Off,
            MeshFormat::Glb => Format::Glb,
        }
    }
}

#[derive(clap::Args, Debug)]
pub struct MeshArgs {
    pub file: PathBuf,
    /// Output file; the format follows its extension. Default: `<file stem>.<format>` here.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Mesh only the named mesh blocks (repeatable).
    #[arg(long = "only", value_name = "NAME")]
    pub only: Vec<String>,
    /// Output format (default: from OUT's extension, else obj).
    #[arg(long, value_enum)]
    pub format: Option<MeshFormat>,
    /// Print one JSON report object on stdout.
    #[arg(long)]
    pub json: bool,
    /// No progress bar and no summary table on stderr.
    #[arg(long, short)]
    pub quiet: bool,
    /// How surfaces are evaluated: machine code compiled from the tape, or the interpreter.
    #[arg(long, value_enum, default_value_t = EngineChoice::Native)]
    pub engine: EngineChoice,
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
    /// Whether the mesh was flipped against its ∇f to agree with the net it joins.
    flipped: bool,
    seconds: f64,
}

/// A mesh block that was meshed.
#[derive(Clone, Debug)]
pub struct Meshed {
    pub name: String,
    pub surface: String,
    pub step: f64,
    /// The block's `box`, if it has one.
    pub bbox: Option<(DVec3, DVec3)>,
    pub mesh: Mesh,
    pub report: MeshReport,
    /// Whether the mesh is oriented against its ∇f, to agree with the meshes it shares a
    /// polygon with (`mesh::net`).
    pub flipped: bool,
    pub seconds: f64,
}

pub fn run(args: MeshArgs, color: ColorMode) -> u8 {
    let started = Instant::now();
    let format = match Format::choose(args.format.map(Format::from), args.output.as_deref()) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("error: {e}");
            return EXIT_USAGE;
        }
    };
    let loaded = match load(&args.file, color) {
        Ok(l) => l,
        Err(code) => return code,
    };
    let selected = match select(&loaded, &args.only) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| format.default_output(&args.file));
    // Before meshing, so that the user does not wait for a refusal (a FIFO is not opened).
    if let Err(e) = target::check_output(&output, &args.file) {
        eprintln!("error: {e}");
        return EXIT_USAGE;
    }
    let meshed = match mesh_blocks(&loaded, &selected, color, args.quiet, args.engine.into()) {
        Ok(m) => m,
        Err(code) => return code,
    };

    if let Err(e) = write_mesh_file(&output, format, &named(&meshed)) {
        eprintln!("error: {e}");
        return EXIT_USAGE;
    }

    if args.json {
        let meshes: Vec<MeshJson> = meshed
            .iter()
            .map(|m| MeshJson {
                name: &m.name,
                surface: &m.surface,
                step: m.step,
                report: m.report.clone(),
                flipped: m.flipped,
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
            return code;
        }
    }
    if !args.quiet {
        let rows: Vec<MeshSummary> = meshed
            .iter()
            .map(|m| MeshSummary {
                name: &m.name,
                triangles: m.report.triangles,
                seconds: m.seconds,
                boundary_loops: m.report.boundary_loops,
                non_manifold_edges: m.report.non_manifold_edges,
            })
            .collect();
        eprint!("{}", format_summary(&rows));
        eprintln!("wrote {}", output.display());
    }
    0
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
pub(crate) fn select<'a>(loaded: &'a Loaded, only: &[String]) -> Result<Vec<&'a MeshDef>, u8> {
    let meshes = &loaded.program.meshes;
    if meshes.is_empty() {
        eprintln!(
            "error: `{}` has no mesh block; add one, e.g. `mesh m = S {{ step: 0.1; start: (1, 0, 0); }}`",
            loaded.path.display()
        );
        return Err(EXIT_INPUT);
    }
    for name in only {
        if !meshes.iter().any(|m| &m.name == name) {
            let known: Vec<&str> = meshes.iter().map(|m| m.name.as_str()).collect();
            eprintln!(
                "error: `{}` has no mesh block `{name}`; its mesh blocks are: {}",
                loaded.path.display(),
                known.join(", ")
            );
            return Err(EXIT_USAGE);
        }
    }
    Ok(meshes
        .iter()
        .filter(|m| only.is_empty() || only.contains(&m.name))
        .collect())
}

/// Meshes the blocks in order; the first failure is reported as a diagnostic (exit 1).
pub(crate) fn mesh_blocks(
    loaded: &Loaded,
    blocks: &[&MeshDef],
    color: ColorMode,
    quiet: bool,
    engine: Engine,
) -> Result<Vec<Meshed>, u8> {
    mesh_program(&loaded.program, &loaded.source, blocks, quiet, engine).map_err(|d| {
        diag::emit_stderr(
            &[d],
            &loaded.path.display().to_string(),
            &loaded.source,
            stderr_color(color),
        );
        EXIT_INPUT
    })
}

/// Parses, checks and meshes every mesh block of `source`: the library form of
/// `surfc mesh`, for tests and embedders. Err holds every diagnostic of the file, or the one
/// that says why a mesh could not be completed.
pub fn mesh_source(source: &str) -> Result<Vec<Meshed>, Vec<Diagnostic>> {
    mesh_source_with(source, Engine::default())
}

/// [`mesh_source`] with the surfaces evaluated by `engine`.
pub fn mesh_source_with(source: &str, engine: Engine) -> Result<Vec<Meshed>, Vec<Diagnostic>> {
    let (checked, diags) = super::load::analyse(source);
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

/// Meshes the blocks in order, with a progress spinner on a terminal unless `quiet`, and
/// orients the nets they form as one.
fn mesh_program(
    program: &Program,
    source: &str,
    blocks: &[&MeshDef],
    quiet: bool,
    engine: Engine,
) -> Result<Vec<Meshed>, Diagnostic> {
    let mut builder = Builder::new(program, engine);
    let mut meshed = blocks
        .iter()
        .map(|def| {
            let progress = Progress::start(&def.name, quiet);
            let result = mesh_block(program, source, &mut builder, def);
            progress.finish();
            result
        })
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
    let start = match (def.front, def.start) {
        (Some(front), _) => Start::Front(
            builder
                .polygon_on(front, def.step, def.bbox, &mut surface)
                .map_err(build_failed)?
                .points,
        ),
        (None, Some(p)) => Start::Point(p),
        // sema requires one of them; a program built elsewhere may not.
        (None, None) => {
            return Err(messages::mesh_failed(
                &def.name,
                def.span,
                "it has neither `start` nor `front`",
                None,
            ));
        }
    };
    let mut bounds = Vec::with_capacity(def.bounds.len());
    for &b in &def.bounds {
        bounds.push(
            builder
                .polygon_on(b, def.step, def.bbox, &mut surface)
                .map_err(build_failed)?
                .points,
        );
    }
    let input = MarchInput {
        step: def.step,
        start,
        bounds,
        bbox: def.bbox,
        max_triangles: def.max_triangles,
    };
    let mesh = march::march(&mut surface, &input, &MarchSettings::default())
        .map_err(|e| messages::mesh_failed(&def.name, def.span, &e.to_string(), march_help(&e)))?;
    let report = MeshReport::new(&mesh, &mut surface);
    Ok(Meshed {
        name: def.name.clone(),
        surface: surface_name(program, source, &def.surface),
        step: def.step,
        bbox: def.bbox,
        mesh,
        report,
        flipped: false,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// What the user may change when the marcher stops with `e`.
fn march_help(e: &MarchError) -> Option<&'static str> {
    Some(match e {
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
        MarchError::NewPoint { .. } | MarchError::Stalled { .. } => {
            "a smaller `step` may get past small features or a singular point; a `box` can keep the mesh away from it"
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
