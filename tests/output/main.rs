//! The mesh files and pictures: every writer read back by independent readers (Rust crates and
//! Python's), the locked OBJ layout, and rendering.
//!
//! One test binary (tests/README.md says which root holds what); the helpers of all roots are
//! `tests/common/`.

#[path = "../common/mod.rs"]
mod common;
mod output_fixtures;

mod obj_snapshot;
mod parts;
mod python_readers;
mod render;
mod sharp_edges;
mod slicer;
mod writers;
