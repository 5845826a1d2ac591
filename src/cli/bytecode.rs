//! `surfc bytecode FILE SURFACE`: the compiled tape of a surface, one instruction a line.

use std::path::PathBuf;

use super::ColorMode;

#[derive(clap::Args, Debug)]
pub struct BytecodeArgs {
    pub file: PathBuf,
    /// The name of a `surface` definition.
    pub surface: String,
}

pub fn run(_args: BytecodeArgs, _color: ColorMode) -> u8 {
    super::not_yet("bytecode")
}
