//! `surfc mesh FILE [-o OUT] [--only NAME]... [--format F] [--unit U] [--json] [--stats]
//! [--quiet] [--threads N]`:
//! every selected mesh block is built (surface oracle, curve polygons), marched and reported;
//! then all of them go into one file, written atomically, or to standard output (`-o -`).
//! If any mesh fails, nothing is written.

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use clap::ValueEnum;
use serde::Serialize;

use super::load::{Loaded, input_name, is_stdin, load_reported, stderr_color};
use super::report::{CODE_INPUT, CODE_IO, CODE_USAGE, Failure};
use super::{ColorMode, EXIT_INPUT, EXIT_USAGE, EngineChoice};
use crate::eval::Engine;
use crate::mesh::NamedMesh;
use crate::mesh::progress::Bars;
use crate::mesh::quality::MeshReport;
use crate::mesh::summary::{MeshSummary, format_stats, format_summary};
use crate::mesh::write::{Format, Unit, WriteOptions, target, write_mesh_file_with};
use crate::pipeline::report::BlockJson;
use crate::pipeline::{Meshed, mesh_program, named};
use crate::sema::program::MeshDef;

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

/// The unit of a file's lengths (`--unit`; docs/formats.md, *Units*).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum UnitChoice {
    /// Micrometres.
    Um,
    /// Millimetres.
    #[default]
    Mm,
    /// Centimetres.
    Cm,
    /// Metres.
    M,
    /// Inches.
    #[value(name = "in")]
    Inch,
    /// Feet.
    Ft,
}

impl From<UnitChoice> for Unit {
    fn from(u: UnitChoice) -> Unit {
        match u {
            UnitChoice::Um => Unit::Micron,
            UnitChoice::Mm => Unit::Millimetre,
            UnitChoice::Cm => Unit::Centimetre,
            UnitChoice::M => Unit::Metre,
            UnitChoice::Inch => Unit::Inch,
            UnitChoice::Ft => Unit::Foot,
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
    /// The unit of the file's lengths, recorded by the formats that have one: 3MF's `unit`,
    /// GLB's scale to metres. The other formats hold the numbers as they are.
    #[arg(long, value_enum, default_value_t = UnitChoice::Mm)]
    pub unit: UnitChoice,
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

/// The `--json` report (docs/cli.md); structs keep the keys in the documented order.
#[derive(Serialize)]
struct Json<'a> {
    meshes: Vec<BlockJson<'a>>,
    seconds: f64,
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
pub(crate) enum Output {
    File(PathBuf),
    Stdout,
}

/// The output and its format, from `-o` and `--format`; a usage error where they do not say
/// enough or disagree.
pub(crate) fn choose_output(args: &MeshArgs) -> Result<(Output, Format), Failure> {
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
    let (meshed, written) = mesh_and_write(&loaded, &args, &output, format, color)?;
    if args.json {
        print_json(&meshed, started)?;
    }
    if args.stats {
        print_stats(&meshed);
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

/// Meshes the blocks of a loaded file that `--only` selects and writes them to `output`
/// (the warnings on stderr): the meshes, and where they went (the path, or `standard
/// output`). Nothing is written if a block fails; a file is written atomically.
pub(crate) fn mesh_and_write(
    loaded: &Loaded,
    args: &MeshArgs,
    output: &Output,
    format: Format,
    color: ColorMode,
) -> Result<(Vec<Meshed>, String), Failure> {
    let selected = select(loaded, &args.only)?;
    // Before meshing, so that the user does not wait for a refusal (a FIFO is not opened).
    if let Output::File(path) = output {
        target::check_output(path, &args.file).map_err(|e| Failure::io(e.to_string(), path))?;
    }
    let meshed = mesh_blocks(loaded, &selected, color, args.quiet, args.engine.into())?;
    for m in &meshed {
        for w in &m.warnings {
            eprintln!("warning: mesh `{}`: {w}", m.name);
        }
    }

    let meshes = named(&meshed);
    let unit = Unit::from(args.unit);
    let written = match output {
        Output::File(path) => {
            let line = Bars::new(args.quiet).writing(&path.display().to_string());
            let options = WriteOptions {
                unit,
                written: Some(line.count()),
            };
            let result = write_mesh_file_with(path, format, &meshes, &options);
            line.finish();
            result
                .map(|()| path.display().to_string())
                .map_err(|e| Failure::io(e.to_string(), e.path()))
        }
        Output::Stdout => {
            write_stdout(format, unit, &meshes).map(|()| "standard output".to_owned())
        }
    }?;
    Ok((meshed, written))
}

/// Prints the `--json` report of the meshes on stdout, one line; `started` is when the
/// command (or the rebuild) began. Err only if stdout cannot take it.
pub(crate) fn print_json(meshed: &[Meshed], started: Instant) -> Result<(), Failure> {
    let json = Json {
        meshes: meshed.iter().map(Meshed::json).collect(),
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
    Ok(())
}

/// Prints the `--stats` table of the meshes on stderr.
pub(crate) fn print_stats(meshed: &[Meshed]) {
    let rows: Vec<(&str, &MeshReport)> = meshed
        .iter()
        .map(|m| (m.name.as_str(), &m.report))
        .collect();
    eprint!("{}", format_stats(&rows));
}

/// Writes the meshes to standard output (`-o -`). A reader that stops early is no error, as
/// for every command that prints; a mesh no format can write is refused before the first
/// byte.
fn write_stdout(format: Format, unit: Unit, meshes: &[NamedMesh]) -> Result<(), Failure> {
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let options = WriteOptions {
        unit,
        written: None,
    };
    match format
        .write_with(&mut out, meshes, &options)
        .and_then(|()| out.flush())
    {
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
