//! surfc compiles `.surf` files — surfaces written as implicit formulas, parametric patches
//! and their combinations — and triangulates them with E. Hartmann's marching method.
//!
//! The library API is small: [`check`] a source, then [`Checked::compile`] a surface into a
//! [`Function`] (value and gradient), or [`Checked::mesh`] its mesh blocks, and
//! [`write_mesh`] the meshes in any [`Format`] (OBJ, STL, PLY, OFF, GLB, 3MF, MSH, VTU).
//! [`check_with`] and [`check_file`] take a file's path (for its imports) and constants set
//! from outside, as `surfc mesh FILE -D NAME=VALUE` does; the Python package (`python/`)
//! stands on these.
//!
//! ```
//! let source = "
//!     surface torus = (x^2 + y^2 + z^2 + 1 - 0.35^2)^2 - 4 * (x^2 + y^2);
//!     mesh torus = torus { step: 0.1; start: (1, 0, 0.35); }
//! ";
//! let checked = surfc::check(source)?;
//! let meshes = checked.mesh()?;
//! // A closed torus: no boundary, Euler characteristic 0.
//! assert_eq!(meshes[0].report.boundary_edges, 0);
//! assert_eq!(meshes[0].report.euler_characteristic, 0);
//!
//! let mut glb = Vec::new();
//! surfc::write_mesh(&mut glb, surfc::Format::Glb, &surfc::named(&meshes))?;
//! assert_eq!(&glb[..4], b"glTF");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Inside, one module per stage of the data flow (docs/ARCHITECTURE.md): `syntax` (text → AST) →
//! `sema` (names, kinds, diagnostics) → `compile` (IR → tape) → `eval` (VM: value,
//! gradient) → `surface` (the oracle the marcher sees) → `solve` (surfacepoint, foot points,
//! curves) → `survey` (what the marcher learns of a surface before marching: intervals and
//! components, the local step, creases) → `march` (the marching method) → `mesh` (Mesh,
//! report, writers, readers, pictures). `diag` renders diagnostics; `cli` is the only module
//! that knows every stage. These modules are public for the project's own tests and
//! benchmarks, hidden from the documentation, and not a stable interface.
//!
//! The numeric half (`eval` onward) imports nothing from `syntax`, `sema` or `diag`.

#![warn(missing_docs)]

mod api;

pub use api::{
    CheckOptions, Checked, CompileError, Diagnostic, Errors, FileError, Format, Function, Mesh,
    MeshReport, MeshStats, Meshed, NamedMesh, Severity, check, check_file, check_with, named,
    write_mesh,
};

#[doc(hidden)]
pub mod cli;
#[doc(hidden)]
pub mod compile;
#[doc(hidden)]
pub mod diag;
#[doc(hidden)]
pub mod eval;
#[doc(hidden)]
pub mod march;
#[doc(hidden)]
pub mod mesh;
#[doc(hidden)]
pub mod pipeline;
#[doc(hidden)]
pub mod sema;
#[doc(hidden)]
pub mod solve;
#[doc(hidden)]
pub mod span;
#[doc(hidden)]
pub mod surface;
#[doc(hidden)]
pub mod survey;
#[doc(hidden)]
pub mod syntax;
#[doc(hidden)]
pub mod trace;
#[doc(hidden)]
pub mod values;

/// What the unit tests share (a seeded random sampler).
#[cfg(test)]
mod testing;
