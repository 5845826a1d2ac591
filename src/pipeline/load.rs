//! Parsing and checking a `.surf` source with the files it imports and the constants set
//! from outside (`-D NAME=VALUE`): every file read, the AST and the program, and every
//! diagnostic. Reading files and printing are the caller's.

use std::path::{Path, PathBuf};

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
    let analysis = analyse_inputs(name, path, source, defines);
    (analysis.map, analysis.checked, analysis.diagnostics)
}

/// What [`analyse_inputs`] found: [`analyse_file`]'s results and the files the source
/// depends on.
#[derive(Debug)]
pub struct Analysis {
    /// Every file read, the root first.
    pub map: SourceMap,
    /// The AST and the program, if everything parsed.
    pub checked: Option<(ast::File, Program)>,
    /// Every diagnostic, errors and warnings.
    pub diagnostics: Vec<Diagnostic>,
    /// Every file an `import` named (transitively), read or not: with the root, the files
    /// whose change changes the result (`surfc watch` waits on them).
    pub imports: Vec<PathBuf>,
}

/// [`analyse_file`], and the files the source imports.
pub fn analyse_inputs(
    name: &str,
    path: Option<&Path>,
    source: &str,
    defines: &[(String, f64)],
) -> Analysis {
    let parsed = syntax::imports::parse_with_imports(name, path, source);
    let mut diagnostics = parsed.diagnostics;
    let Some(file) = parsed.file else {
        return Analysis {
            map: parsed.map,
            checked: None,
            diagnostics,
            imports: parsed.imports,
        };
    };
    let options = sema::Options {
        defines: defines.to_vec(),
        imported_from: Some(parsed.imported_from),
    };
    let (program, more) = sema::check_with(&file, &options);
    diagnostics.extend(more);
    Analysis {
        map: parsed.map,
        checked: Some((file, program)),
        diagnostics,
        imports: parsed.imports,
    }
}
