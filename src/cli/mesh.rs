//! `surfc mesh FILE [-o OUT] [--only NAME]... [--format F] [--json] [--quiet]`.

use std::path::PathBuf;

use clap::ValueEnum;

use super::ColorMode;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MeshFormat {
    Obj,
    Stl,
    Ply,
    Off,
    Glb,
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
}

pub fn run(_args: MeshArgs, _color: ColorMode) -> u8 {
    super::not_yet("mesh")
}
