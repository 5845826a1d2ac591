//! The command line (docs/cli.md), the only module that knows every stage. Each command
//! lives in its own file; exit codes: 0 success, 1 wrong input or a mesh that could not be
//! completed, 2 usage or I/O error, 128 + N when interrupted by signal N (130 for Ctrl-C).

use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};

mod bytecode;
mod check;
mod eval;
mod fmt;
pub(crate) mod load;
pub mod mesh;
mod render;
mod report;
mod signals;
mod watch;

/// Exit code: the input is wrong, or a mesh could not be completed.
pub const EXIT_INPUT: u8 = 1;
/// Exit code: usage or I/O error.
pub const EXIT_USAGE: u8 = 2;

#[derive(Parser, Debug)]
#[command(
    name = "surfc",
    version,
    about = "Compile .surf files and triangulate their surfaces"
)]
pub struct Cli {
    /// When to colour diagnostics.
    #[arg(long, global = true, value_enum, default_value_t = ColorMode::Auto)]
    pub color: ColorMode,
    #[command(subcommand)]
    pub command: Command,
}

/// How surfaces are evaluated (`--engine` of the commands that evaluate).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum EngineChoice {
    /// The surface's tape compiled to machine code.
    #[default]
    Native,
    /// The bytecode interpreter: the same values; gradients the same up to the sign of zero.
    Interpreter,
}

impl From<EngineChoice> for crate::eval::Engine {
    fn from(choice: EngineChoice) -> Self {
        match choice {
            EngineChoice::Native => crate::eval::Engine::Native,
            EngineChoice::Interpreter => crate::eval::Engine::Interpreter,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ColorMode {
    Auto,
    Always,
    Never,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Parse and check files; diagnostics on stderr.
    Check(check::CheckArgs),
    /// Print files in canonical formatting, check that they are, or rewrite them.
    Fmt(fmt::FmtArgs),
    /// Triangulate the mesh blocks of a file.
    Mesh(mesh::MeshArgs),
    /// Draw the meshes of a file into a PNG or SVG picture.
    Render(render::RenderArgs),
    /// Value and gradient of a surface at a point.
    Eval(eval::EvalArgs),
    /// The compiled program of a surface, one instruction a line.
    Bytecode(bytecode::BytecodeArgs),
    /// Mesh a file (and draw it, with --render) now and again at every save of it or of a
    /// file it imports, until Ctrl-C.
    ///
    /// Takes every option of `mesh`; FILE and OUT are files here (not `-`). One line per
    /// rebuild on stderr (with --json, one report per rebuild on stdout); a save with errors
    /// prints them and leaves the last good files in place. Ctrl-C ends it with exit 0.
    Watch(watch::WatchArgs),
}

/// Writes `text` to stdout; the exit code. A reader that stopped reading (`surfc bytecode …
/// | head`) is not an error; any other failure to write is reported, `EXIT_USAGE`.
pub(crate) fn print_stdout(text: &str) -> u8 {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Ok(()) => 0,
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => 0,
        Err(e) => {
            eprintln!("error: cannot write to standard output: {e}");
            EXIT_USAGE
        }
    }
}

/// Parses the process arguments and runs the command; SIGINT and SIGTERM remove the
/// temporary files of writes under way and exit 130 or 143 (`signals`).
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    signals::install();
    ExitCode::from(run(cli))
}

/// Runs a parsed command line; returns the exit code.
pub fn run(cli: Cli) -> u8 {
    let color = cli.color;
    match cli.command {
        Command::Check(args) => check::run(args, color),
        Command::Fmt(args) => fmt::run(args, color),
        Command::Mesh(args) => mesh::run(args, color),
        Command::Render(args) => render::run(args, color),
        Command::Eval(args) => eval::run(args, color),
        Command::Bytecode(args) => bytecode::run(args, color),
        Command::Watch(args) => watch::run(args, color),
    }
}
