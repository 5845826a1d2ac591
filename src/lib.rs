//! surfc: compiles `.surf` files and triangulates their surfaces with E. Hartmann's marching
//! method. One module per stage of the data flow of DESIGN.md §1:
//!
//! `syntax` (text → AST) → `sema` (names, kinds, diagnostics) → `compile` (IR → tape) →
//! `eval` (VM: value, gradient) → `surface` (the oracle the marcher sees) → `solve`
//! (surfacepoint, foot points, curves) → `survey` (what the marcher learns of a surface
//! before marching: intervals and components, the local step, creases) → `march` (the
//! marching method) → `mesh` (Mesh, report, writers, pictures). `diag` renders
//! diagnostics; `cli` is the only module that knows every stage.
//!
//! The numeric half (`eval` onward) imports nothing from `syntax`, `sema` or `diag`.

pub mod cli;
pub mod compile;
pub mod diag;
pub mod eval;
pub mod march;
pub mod mesh;
pub mod sema;
pub mod solve;
pub mod span;
pub mod surface;
pub mod survey;
pub mod syntax;
