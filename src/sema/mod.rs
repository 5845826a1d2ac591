//! Semantic analysis: names, kinds, cycles and every check of the language; collects all
//! diagnostics of a file and produces the checked program the compiler lowers.

pub mod program;
