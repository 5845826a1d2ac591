//! Parsing and checking a `.surf` source with the files it imports and the constants set
//! from outside (`-D NAME=VALUE`): every file read, the AST and the program, and every
//! diagnostic. Reading files and printing are the caller's.

use std::path::Path;

use crate::diag::Diagnostic;
use crate::sema::{self, program::Program};
use crate::span::SourceMap;
use crate::syntax::{self, ast};

/// The name standard input (and a source given as text) goes by in diagnostics.
pub const STDIN_NAME: &str = "<stdin>";

/// Parses and checks source text (its imports relative to the current directory); returns
/// every file read, the AST and the program (if the file parsed) and every diagnostic.
pub fn analyse(source: &str) -> (SourceMap, Option<(ast::File, Program)>, Vec<Diagnostic>) {
    analyse_file(STDIN_NAME, None, source, &[])
}

/// Parses `source` (named `name`, read from `path` if it is a file) with the files it
/// imports, and checks it with the `-D` values `defines`: every file read, the AST and the
/// program (if everything parsed), and every diagnostic.
pub fn analyse_file(
    name: &str,
    path: Option<&Path>,
    source: &str,
    defines: &[(String, f64)],
) -> (SourceMap, Option<(ast::File, Program)>, Vec<Diagnostic>) {
    let parsed = syntax::imports::parse_with_imports(name, path, source);
    let mut diags = parsed.diagnostics;
    let Some(file) = parsed.file else {
        return (parsed.map, None, diags);
    };
    let options = sema::Options {
        defines: defines.to_vec(),
        imported_from: Some(parsed.imported_from),
    };
    let (program, more) = sema::check_with(&file, &options);
    diags.extend(more);
    (parsed.map, Some((file, program)), diags)
}
