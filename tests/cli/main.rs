//! The `surfc` binary: its commands, exit codes and reports, pipelines, output safety,
//! interruptions, the progress lines, bounded work, thread-count determinism, and the
//! README's own commands.
//!
//! One test binary (tests/README.md says which root holds what); the helpers of all roots are
//! `tests/common/`.

#[path = "../common/mod.rs"]
mod common;

mod bounded_work;
mod cad_parts;
mod cad_sweep;
mod cli_compose;
mod csg_cli;
mod eval_cli;
mod interrupt;
mod mesh_cli;
mod output_safety;
mod progress;
mod readme;
mod threads;
mod watch;
