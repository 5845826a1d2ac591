//! Reading, parsing and checking one `.surf` file (with the files it imports) for a command,
//! with the constants `-D NAME=VALUE` sets: every diagnostic (warnings too) goes to stderr;
//! the checked program comes back only if there is no error.

use std::io::{IsTerminal, Read};
use std::path::{Path, PathBuf};

use crate::diag;
use crate::pipeline::load::analyse_inputs;
use crate::sema::program::Program;
use crate::span::SourceMap;
use crate::syntax::{self, ast};

use super::ColorMode;
use super::report::Failure;

/// A file that parsed and checked without errors.
// The mesh, eval and bytecode commands read the fields; until they land, `check` does not.
#[allow(dead_code)]
#[derive(Debug)]
pub(crate) struct Loaded {
    pub path: PathBuf,
    /// The root file's text.
    pub source: String,
    /// The root file and the files it imports: what the program's spans point into.
    pub map: SourceMap,
    pub ast: ast::File,
    pub program: Program,
}

/// Whether diagnostics on stderr are coloured.
pub(crate) fn stderr_color(color: ColorMode) -> bool {
    match color {
        ColorMode::Always => true,
        ColorMode::Never => false,
        ColorMode::Auto => std::io::stderr().is_terminal(),
    }
}

pub(crate) use crate::pipeline::load::STDIN_NAME;

/// Whether a FILE argument means standard input (`-`).
pub(crate) fn is_stdin(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// The name of an input in messages: its path, or `<stdin>`.
pub(crate) fn input_name(path: &Path) -> String {
    if is_stdin(path) {
        STDIN_NAME.to_owned()
    } else {
        path.display().to_string()
    }
}

/// Reads a file (or standard input, for `-`) as text. A missing or unreadable file is an I/O
/// failure (exit 2); a file that is not UTF-8 is a diagnostic (E0009, exit 1).
pub(crate) fn read_source(path: &Path, color: ColorMode) -> Result<String, Failure> {
    let bytes = if is_stdin(path) {
        let mut bytes = Vec::new();
        std::io::stdin()
            .lock()
            .read_to_end(&mut bytes)
            .map(|_| bytes)
    } else {
        std::fs::read(path)
    };
    let bytes =
        bytes.map_err(|e| Failure::io(format!("cannot read `{}`: {e}", input_name(path)), path))?;
    match syntax::source_text(&bytes) {
        Ok(s) => Ok(s.to_string()),
        Err(d) => {
            let lossy = String::from_utf8_lossy(&bytes);
            Err(Failure::diagnostics(
                &[d],
                &input_name(path),
                &lossy,
                stderr_color(color),
            ))
        }
    }
}

/// [`read_source`] for commands that need only the exit code.
pub(crate) fn read(path: &Path, color: ColorMode) -> Result<String, u8> {
    read_source(path, color).map_err(|f| f.exit)
}

/// `-D NAME=VALUE` (repeatable) of the commands that read a `.surf` file.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct DefineArgs {
    /// Set the constant NAME of the file to the number VALUE (repeatable; each name once).
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
    pub define: Vec<(String, f64)>,
}

/// `NAME=VALUE` with a name as the language spells it and a finite decimal number.
fn parse_define(text: &str) -> Result<(String, f64), String> {
    let usage = "expected NAME=VALUE with a number VALUE, e.g. `-D r=2`";
    let Some((name, value)) = text.split_once('=') else {
        return Err(format!("`{text}`: no `=`; {usage}"));
    };
    let is_name = name
        .chars()
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !is_name {
        return Err(format!("`{name}` is not a name; {usage}"));
    }
    // Only what a number literal may hold (with a sign): no `inf`, `nan` or hex.
    let numeric = value
        .chars()
        .all(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '+' | '-'));
    match value.parse::<f64>() {
        Ok(v) if numeric && v.is_finite() => Ok((name.to_string(), v)),
        _ => Err(format!("`{value}` is not a finite number; {usage}")),
    }
}

/// A `-D` name given twice is a usage error (exit 2): which of two values was meant is not
/// for surfc to guess.
fn check_defines(defines: &[(String, f64)], path: &Path) -> Result<(), Failure> {
    for (k, (name, _)) in defines.iter().enumerate() {
        if defines[..k].iter().any(|(n, _)| n == name) {
            return Err(Failure::new(
                super::EXIT_USAGE,
                super::report::CODE_USAGE,
                format!("`-D {name}=…` is given twice; give each constant once"),
                Some(path),
            ));
        }
    }
    Ok(())
}

/// Reads, parses and checks `path` (`-`: standard input) with its imports and the `-D`
/// values, printing every diagnostic to stderr. Err if the file cannot be read or a `-D` is
/// given twice (exit 2), or it has errors (exit 1).
pub(crate) fn load_reported(
    path: &Path,
    color: ColorMode,
    defines: &DefineArgs,
) -> Result<Loaded, Failure> {
    load_with_imports(path, color, defines).0
}

/// An input file of a build and the bytes the build read of it (None: it could not be
/// read, e.g. an import not there): what `surfc watch` compares a file with after a save.
pub(crate) type ReadFile = (PathBuf, Option<Vec<u8>>);

/// [`load_reported`], and every file the build depends on, the root first, each with what
/// was read of it: the root and every file it imports (found or not).
pub(crate) fn load_with_imports(
    path: &Path,
    color: ColorMode,
    defines: &DefineArgs,
) -> (Result<Loaded, Failure>, Vec<ReadFile>) {
    // Read again where the build kept nothing of it (it could not be read, or it is no text):
    // as close to the build's reading as the file can be had.
    let reread = |p: &Path| std::fs::read(p).ok();
    if let Err(failure) = check_defines(&defines.define, path) {
        return (Err(failure), vec![(path.to_path_buf(), reread(path))]);
    }
    let source = match read_source(path, color) {
        Ok(source) => source,
        Err(failure) => return (Err(failure), vec![(path.to_path_buf(), reread(path))]),
    };
    let name = input_name(path);
    let file = (!is_stdin(path)).then_some(path);
    let analysis = analyse_inputs(&name, file, &source, &defines.define);
    let mut read = vec![(path.to_path_buf(), Some(source.clone().into_bytes()))];
    for import in analysis.imports {
        let shown = import.display().to_string();
        let text = match analysis
            .map
            .files()
            .iter()
            .skip(1)
            .find(|f| f.name == shown)
        {
            Some(f) => Some(f.text.clone().into_bytes()),
            None => reread(&import),
        };
        read.push((import, text));
    }
    let (map, diags) = (analysis.map, analysis.diagnostics);
    let loaded = match analysis.checked {
        Some((ast, program)) if !diag::has_errors(&diags) => {
            if !diags.is_empty() {
                diag::emit_stderr_map(&diags, &map, stderr_color(color));
            }
            Ok(Loaded {
                path: path.to_path_buf(),
                source,
                map,
                ast,
                program,
            })
        }
        _ => Err(Failure::diagnostics_map(&diags, &map, stderr_color(color))),
    };
    (loaded, read)
}

/// [`load_reported`] for commands that need only the exit code.
pub(crate) fn load(path: &Path, color: ColorMode, defines: &DefineArgs) -> Result<Loaded, u8> {
    load_reported(path, color, defines).map_err(|f| f.exit)
}
