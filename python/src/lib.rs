//! `surfc._surfc`, the extension module under the Python package `surfc` (docs/python.md):
//! checking and meshing through the library API (`surfc::check_with`, `surfc::check_file`,
//! `Checked::mesh`), with the GIL released while it works. It hands back plain data — names,
//! the arrays' bytes, the reports as JSON text — and `surfc/__init__.py` makes the Python
//! objects of it (numpy arrays, dicts, `SurfcError`). No command line is parsed here.

use std::path::PathBuf;

use pyo3::exceptions::{PyException, PyFileNotFoundError, PyOSError, PyPermissionError};
use pyo3::prelude::*;
use pyo3::types::PyByteArray;

pyo3::create_exception!(
    _surfc,
    Failure,
    PyException,
    "The source has errors, or a mesh could not be completed: args are the rendered \
     diagnostics and their JSON text (a list as in `surfc mesh --json`'s `errors`)."
);

/// Where a source comes from: its text (named `<source>`), or a file to read.
enum Input {
    Text(String),
    File(PathBuf),
}

/// Why nothing came back: the source's diagnostics, or a file that cannot be read.
enum Error {
    Diagnostics { rendered: String, json: String },
    Read(surfc::FileError),
}

impl From<Error> for PyErr {
    fn from(error: Error) -> PyErr {
        match error {
            Error::Diagnostics { rendered, json } => Failure::new_err((rendered, json)),
            Error::Read(e) => {
                let message = e.to_string();
                match e {
                    surfc::FileError::Read { source, .. } => match source.kind() {
                        std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
                        std::io::ErrorKind::PermissionDenied => PyPermissionError::new_err(message),
                        _ => PyOSError::new_err(message),
                    },
                    surfc::FileError::Errors(errors) => diagnostics(&errors).into(),
                }
            }
        }
    }
}

fn diagnostics(errors: &surfc::Errors) -> Error {
    Error::Diagnostics {
        rendered: errors.rendered(),
        json: errors.json(),
    }
}

/// The name a source given as text goes by in diagnostics.
const SOURCE_NAME: &str = "<source>";

fn input(source: Option<String>, path: Option<PathBuf>) -> PyResult<Input> {
    match (source, path) {
        (Some(text), None) => Ok(Input::Text(text)),
        (None, Some(path)) => Ok(Input::File(path)),
        _ => Err(pyo3::exceptions::PyTypeError::new_err(
            "give the source's text or a path, not both",
        )),
    }
}

fn checked(input: &Input, defines: &[(String, f64)]) -> Result<surfc::Checked, Error> {
    match input {
        Input::Text(text) => {
            let options = surfc::CheckOptions {
                name: Some(SOURCE_NAME.to_owned()),
                path: None,
                defines: defines.to_vec(),
            };
            surfc::check_with(text, &options).map_err(|e| diagnostics(&e))
        }
        Input::File(path) => surfc::check_file(path, defines).map_err(Error::Read),
    }
}

/// What `check` gives: the surfaces, the mesh blocks, the constants (after `defines`) and
/// the rendered warnings (empty if none).
type CheckResult = (Vec<String>, Vec<String>, Vec<(String, f64)>, String);

/// Parses and checks a source (the text `source`, or the file `path` with its imports
/// relative to it) with the constants `defines` set: `(surfaces, mesh blocks, constants,
/// warnings)`. Raises `Failure` with the diagnostics, an `OSError` if the file cannot be read.
#[pyfunction]
#[pyo3(signature = (source=None, path=None, defines=Vec::new()))]
fn check(
    py: Python<'_>,
    source: Option<String>,
    path: Option<PathBuf>,
    defines: Vec<(String, f64)>,
) -> PyResult<CheckResult> {
    let input = input(source, path)?;
    let result = py.detach(|| {
        checked(&input, &defines).map(|c| {
            (
                c.surfaces().into_iter().map(str::to_owned).collect(),
                c.mesh_blocks().into_iter().map(str::to_owned).collect(),
                c.constants()
                    .into_iter()
                    .map(|(name, value)| (name.to_owned(), value))
                    .collect(),
                c.rendered_warnings(),
            )
        })
    });
    Ok(result?)
}

/// One meshed block as Python gets it: the name, the vertices (n × 3 float64), the unit
/// normals (n × 3 float64) and the triangles (m × 3 uint32) as bytes in the machine's byte
/// order, row by row, and the block's `--json` report as JSON text.
type Block = (
    String,
    Py<PyByteArray>,
    Py<PyByteArray>,
    Py<PyByteArray>,
    String,
);

/// Checks and meshes every mesh block of a source (as `check` takes it), in source order,
/// as `surfc mesh` does; the GIL is released while it meshes. Raises `Failure` with the
/// diagnostics (of the source, or of the first block that could not be completed).
#[pyfunction]
#[pyo3(signature = (source=None, path=None, defines=Vec::new()))]
fn mesh(
    py: Python<'_>,
    source: Option<String>,
    path: Option<PathBuf>,
    defines: Vec<(String, f64)>,
) -> PyResult<Vec<Block>> {
    let input = input(source, path)?;
    let meshed = py.detach(|| {
        let checked = checked(&input, &defines)?;
        checked.mesh().map_err(|e| diagnostics(&e))
    })?;
    let bytes =
        |values: &mut dyn Iterator<Item = [u8; 8]>| -> Vec<u8> { values.flatten().collect() };
    Ok(meshed
        .iter()
        .map(|m| {
            let vertices = bytes(
                &mut m
                    .mesh
                    .vertices
                    .iter()
                    .flat_map(|v| v.to_array())
                    .map(f64::to_ne_bytes),
            );
            let normals = bytes(
                &mut m
                    .mesh
                    .normals
                    .iter()
                    .flat_map(|v| v.to_array())
                    .map(f64::to_ne_bytes),
            );
            let triangles: Vec<u8> = m
                .mesh
                .triangles
                .iter()
                .flatten()
                .flat_map(|i| i.to_ne_bytes())
                .collect();
            (
                m.name.clone(),
                PyByteArray::new(py, &vertices).unbind(),
                PyByteArray::new(py, &normals).unbind(),
                PyByteArray::new(py, &triangles).unbind(),
                m.json_text(),
            )
        })
        .collect())
}

/// The extension module.
#[pymodule]
fn _surfc(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(check, m)?)?;
    m.add_function(wrap_pyfunction!(mesh, m)?)?;
    m.add("Failure", m.py().get_type::<Failure>())?;
    m.add("SURFC_VERSION", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
