//! `surfc bytecode FILE SURFACE`: the compiled tape of a surface, one instruction a line.

use std::path::PathBuf;

use super::ColorMode;
use super::eval::{compile_failure, load_surface};
use crate::compile;
use crate::sema::program::SurfaceRef;

#[derive(clap::Args, Debug)]
pub struct BytecodeArgs {
    pub file: PathBuf,
    /// The name of a `surface` definition.
    pub surface: String,
}

pub fn run(args: BytecodeArgs, color: ColorMode) -> u8 {
    let (loaded, id) = match load_surface(
        &args.file,
        &args.surface,
        color,
        &super::load::DefineArgs::default(),
    ) {
        Ok(found) => found,
        Err(failure) => return failure.exit,
    };
    let lowered = match compile::lower_surface(&loaded.program, &SurfaceRef::Surface(id)) {
        Ok(l) => l,
        Err(e) => return compile_failure(&e, &loaded, color).exit,
    };
    super::print_stdout(&compile::listing(&loaded.program, &lowered))
}
