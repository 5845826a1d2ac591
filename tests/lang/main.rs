//! The language and its evaluation: parsing, formatting and diagnostics, the compiler's tapes
//! against a reference interpreter, intervals, the solids, distance surfaces (to solids too), curves and the
//! surface-point solver.
//!
//! One test binary (tests/README.md says which root holds what); the helpers of all roots are
//! `tests/common/`.

#[path = "../common/mod.rs"]
mod common;

mod bytecode;
mod csg;
mod curves;
mod diagnostics;
mod dist;
mod eval_props;
mod fmt_roundtrip;
mod fuzz_regressions;
mod interval;
mod solid_dist;
mod surfacepoint;
mod syntax_props;
