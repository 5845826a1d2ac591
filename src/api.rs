//! The library's documented entry points, re-exported at the crate root: [`check`] a `.surf`
//! source, [`Checked::compile`] one of its surfaces into a [`Function`] that gives value and
//! gradient, [`Checked::mesh`] its mesh blocks, and [`write_mesh`] meshes in any [`Format`];
//! [`check_with`] and [`check_file`] take a file's path (for its imports) and constants set
//! from outside, as `surfc mesh FILE -D NAME=VALUE` does. The stages behind them (parser,
//! checker, compiler, evaluator, marcher) are internal; the Python package (`python/`) stands
//! on these functions.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use glam::DVec3;

use crate::diag;
use crate::eval::Engine;
use crate::pipeline::build::Builder;
use crate::sema::program::{Program, SurfaceId, SurfaceRef};
use crate::span::SourceMap;
use crate::surface::Surface;
use crate::surface::compiled::CompiledSurface;

pub use crate::diag::{Diagnostic, Severity};
pub use crate::mesh::quality::{MeshReport, MeshStats};
pub use crate::mesh::write::Format;
pub use crate::mesh::{Mesh, NamedMesh};
pub use crate::pipeline::Meshed;

/// A source with errors, or a mesh that could not be completed: every diagnostic, and the
/// source (with the files it imports) they point into.
#[derive(Clone, Debug)]
pub struct Errors {
    /// The diagnostics, errors and warnings, in the order they were found.
    pub diagnostics: Vec<Diagnostic>,
    files: SourceMap,
}

impl Errors {
    /// The diagnostics as a person reads them (codespan's rendering, without colour), with
    /// `file_name` as the file's name.
    ///
    /// ```
    /// let errors = surfc::check("surface s = x + qq;").unwrap_err();
    /// let text = errors.render("bad.surf");
    /// assert!(text.contains("bad.surf:1:17"), "{text}");
    /// ```
    pub fn render(&self, file_name: &str) -> String {
        diag::render_map(
            &self.diagnostics,
            &self.files.with_root_name(file_name),
            false,
        )
    }

    /// The diagnostics as rendered, each file under the name it was given: the path of
    /// [`check_file`], [`CheckOptions::name`] or [`CheckOptions::path`], else `<stdin>`.
    pub fn rendered(&self) -> String {
        diag::render_map(&self.diagnostics, &self.files, false)
    }

    /// The diagnostics as the JSON text of `surfc mesh --json`'s `errors` list: an array of
    /// `{code, severity, message, file, line, column, help, notes, labels}` (docs/cli.md).
    ///
    /// ```
    /// let errors = surfc::check("surface s = x + qq;").unwrap_err();
    /// assert!(errors.json().starts_with(r#"[{"code":"E0101","severity":"error""#));
    /// ```
    pub fn json(&self) -> String {
        let entries: Vec<diag::json::ErrorJson> = self
            .diagnostics
            .iter()
            .map(|d| diag::json::ErrorJson::from_diagnostic(d, &self.files))
            .collect();
        serde_json::to_string(&entries).unwrap_or_default()
    }
}

impl std::fmt::Display for Errors {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let errors: Vec<&Diagnostic> = self.diagnostics.iter().filter(|d| d.is_error()).collect();
        match errors.first() {
            Some(first) if errors.len() > 1 => write!(
                f,
                "{}: {} (and {} more errors)",
                first.code,
                first.message,
                errors.len() - 1
            ),
            Some(first) => write!(f, "{}: {}", first.code, first.message),
            None => f.write_str("no errors"),
        }
    }
}

impl std::error::Error for Errors {}

/// A `.surf` source that parsed and checked without errors.
#[derive(Debug)]
pub struct Checked {
    source: String,
    files: SourceMap,
    program: Program,
    warnings: Vec<Diagnostic>,
}

/// Parses and checks a `.surf` source: the checked program, or every diagnostic of it. Its
/// `import`s are read relative to the current directory.
///
/// ```
/// let checked = surfc::check("surface ball = x^2 + y^2 + z^2 - 1;")?;
/// assert_eq!(checked.surfaces(), ["ball"]);
///
/// let errors = surfc::check("surface s = x + qq;").unwrap_err();
/// assert_eq!(errors.diagnostics[0].code, "E0101");
/// # Ok::<(), surfc::Errors>(())
/// ```
pub fn check(source: &str) -> Result<Checked, Errors> {
    check_with(source, &CheckOptions::default())
}

/// Where a source given as text comes from, and the constants set from outside: the
/// options of [`check_with`].
#[derive(Clone, Debug, Default)]
pub struct CheckOptions {
    /// The name diagnostics give the source. None (the default): its path, else `<stdin>`.
    pub name: Option<String>,
    /// The file the source was read from: diagnostics name it, and its `import`s are
    /// relative to its directory. None (the default): the source is `<stdin>`, its imports
    /// relative to the current directory.
    pub path: Option<PathBuf>,
    /// Constants of the source set to numbers, as `surfc mesh -D NAME=VALUE` sets them:
    /// each replaces the `const` of that name (whose definition is still checked). A name
    /// that is no constant of the source is diagnostic E0701, which lists the constants.
    pub defines: Vec<(String, f64)>,
}

/// [`check`] with the source's path and constants set from outside.
///
/// ```
/// let options = surfc::CheckOptions {
///     defines: vec![("r".to_owned(), 2.0)],
///     ..Default::default()
/// };
/// let checked = surfc::check_with("const r = 1; surface ball = x^2 + y^2 + z^2 - r^2;", &options)?;
/// assert_eq!(checked.compile("ball")?.value([2.0, 0.0, 0.0]), 0.0);
///
/// let unknown = surfc::CheckOptions { defines: vec![("q".to_owned(), 2.0)], ..Default::default() };
/// let errors = surfc::check_with("const r = 1; surface s = sphere(r);", &unknown).unwrap_err();
/// assert_eq!(errors.diagnostics[0].code, "E0701");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn check_with(source: &str, options: &CheckOptions) -> Result<Checked, Errors> {
    let name = match (&options.name, &options.path) {
        (Some(name), _) => name.clone(),
        (None, Some(path)) => path.display().to_string(),
        (None, None) => crate::pipeline::load::STDIN_NAME.to_owned(),
    };
    let (files, checked, diagnostics) = crate::pipeline::load::analyse_file(
        &name,
        options.path.as_deref(),
        source,
        &options.defines,
    );
    match checked {
        Some((_, program)) if !diag::has_errors(&diagnostics) => Ok(Checked {
            source: source.to_owned(),
            files,
            program,
            warnings: diagnostics,
        }),
        _ => Err(Errors { diagnostics, files }),
    }
}

/// Why [`check_file`] gave no checked program.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    /// The file could not be read.
    #[error("cannot read `{}`: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: io::Error,
    },
    /// The file (or a file it imports) has errors; a file that is not UTF-8 text is one too
    /// (diagnostic E0009).
    #[error(transparent)]
    Errors(#[from] Errors),
}

/// Reads the `.surf` file at `path` and checks it, with its imports (relative to its
/// directory) and the constants `defines` set from outside: what `surfc check FILE -D …`
/// does.
///
/// ```no_run
/// let checked = surfc::check_file("examples/torus.surf", &[])?;
/// let meshes = checked.mesh()?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn check_file(path: impl AsRef<Path>, defines: &[(String, f64)]) -> Result<Checked, FileError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| FileError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let name = path.display().to_string();
    let source = match crate::syntax::source_text(&bytes) {
        Ok(text) => text,
        Err(diagnostic) => {
            return Err(FileError::Errors(Errors {
                diagnostics: vec![diagnostic],
                files: SourceMap::single(&name, &String::from_utf8_lossy(&bytes)),
            }));
        }
    };
    let options = CheckOptions {
        name: Some(name),
        path: Some(path.to_path_buf()),
        defines: defines.to_vec(),
    };
    Ok(check_with(source, &options)?)
}

impl Checked {
    /// The warnings of the source (it has no errors).
    pub fn warnings(&self) -> &[Diagnostic] {
        &self.warnings
    }

    /// The names of the `surface` definitions, in source order.
    pub fn surfaces(&self) -> Vec<&str> {
        self.program
            .surfaces
            .iter()
            .map(|s| s.name.as_str())
            .collect()
    }

    /// The names and values of the `const` definitions (the source's and its imports'),
    /// after the constants set from outside.
    pub fn constants(&self) -> Vec<(&str, f64)> {
        self.program
            .constants
            .iter()
            .map(|c| (c.name.as_str(), c.value))
            .collect()
    }

    /// The warnings as rendered (empty without warnings), as [`Errors::rendered`] renders.
    pub fn rendered_warnings(&self) -> String {
        if self.warnings.is_empty() {
            return String::new();
        }
        diag::render_map(&self.warnings, &self.files, false)
    }

    /// The names of the `mesh` blocks, in source order.
    pub fn mesh_blocks(&self) -> Vec<&str> {
        self.program
            .meshes
            .iter()
            .map(|m| m.name.as_str())
            .collect()
    }

    /// Compiles the surface called `name` into a function of (x, y, z) with its gradient
    /// (machine code where the platform allows, else the bytecode interpreter).
    ///
    /// ```
    /// let checked = surfc::check("surface ball = x^2 + y^2 + z^2 - 4;")?;
    /// let mut ball = checked.compile("ball")?;
    /// assert_eq!(ball.value([2.0, 0.0, 0.0]), 0.0);
    /// assert_eq!(ball.value_gradient([1.0, 2.0, 0.0]), (1.0, [2.0, 4.0, 0.0]));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn compile(&self, name: &str) -> Result<Function, CompileError> {
        let Some(index) = self.program.surfaces.iter().position(|s| s.name == name) else {
            return Err(CompileError::UnknownSurface {
                name: name.to_owned(),
                known: self.surfaces().join(", "),
            });
        };
        let id = SurfaceId(u32::try_from(index).unwrap_or(u32::MAX));
        let builder = Builder::new(&self.program, Engine::default());
        // Foot-point tolerances of `dist` children are relative to a unit length here, as
        // in `surfc eval`: there is no mesh step.
        let surface = builder.surface(&SurfaceRef::Surface(id), 1.0)?;
        Ok(Function { surface })
    }

    /// Meshes every mesh block, in source order, as `surfc mesh` does: each with its
    /// report (topology, quality). Err holds the diagnostic of the first block that could
    /// not be completed.
    ///
    /// ```
    /// let source = "surface ball = x^2 + y^2 + z^2 - 1;\n\
    ///               mesh ball = ball { step: 0.3; start: (1, 0, 0); }\n";
    /// let meshes = surfc::check(source)?.mesh()?;
    /// let report = &meshes[0].report;
    /// assert_eq!((report.boundary_edges, report.euler_characteristic), (0, 2));
    /// # Ok::<(), surfc::Errors>(())
    /// ```
    pub fn mesh(&self) -> Result<Vec<Meshed>, Errors> {
        crate::pipeline::mesh_checked(&self.program, &self.source, Engine::default()).map_err(
            |diagnostic| Errors {
                diagnostics: vec![diagnostic],
                files: self.files.clone(),
            },
        )
    }
}

/// A surface compiled by [`Checked::compile`]: f(x, y, z) and its gradient.
pub struct Function {
    surface: CompiledSurface,
}

impl Function {
    /// f(p).
    pub fn value(&mut self, p: [f64; 3]) -> f64 {
        self.surface.value(DVec3::from_array(p))
    }

    /// f(p) and ∇f(p).
    pub fn value_gradient(&mut self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let vg = self.surface.value_gradient(DVec3::from_array(p));
        (vg.value, vg.gradient.to_array())
    }
}

impl std::fmt::Debug for Function {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Function").finish_non_exhaustive()
    }
}

/// Why [`Checked::compile`] could not compile a surface.
#[derive(Debug, thiserror::Error)]
pub enum CompileError {
    /// The source defines no surface of that name.
    #[error("no surface `{name}`; the source defines: {known}")]
    UnknownSurface {
        /// The name asked for.
        name: String,
        /// The surfaces the source defines, comma-separated.
        known: String,
    },
    /// The compiler could not compile the surface.
    #[error(transparent)]
    Compile(#[from] crate::compile::CompileError),
}

/// The meshes of [`Checked::mesh`] as [`write_mesh`] takes them: each with its block's name.
pub fn named(meshed: &[Meshed]) -> Vec<NamedMesh<'_>> {
    crate::pipeline::named(meshed)
}

/// Writes meshes in `format` as one file's bytes: one named object, group, node or region
/// per mesh where the format has names (see `docs/formats.md`). A mesh that the format
/// cannot hold (a non-finite coordinate, an index past its vertices) is refused before the
/// first byte, as an [`io::ErrorKind::InvalidData`] error.
///
/// ```
/// let source = "surface ball = x^2 + y^2 + z^2 - 1;\n\
///               mesh ball = ball { step: 0.3; start: (1, 0, 0); }\n";
/// let meshes = surfc::check(source)?.mesh()?;
/// let mut obj = Vec::new();
/// surfc::write_mesh(&mut obj, surfc::Format::Obj, &surfc::named(&meshes))?;
/// let text = String::from_utf8(obj)?;
/// assert!(text.contains("\no ball\ng ball\n"));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn write_mesh(out: &mut dyn Write, format: Format, meshes: &[NamedMesh]) -> io::Result<()> {
    format.write(out, meshes)
}
