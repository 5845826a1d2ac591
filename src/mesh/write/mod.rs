//! Mesh files: named meshes → the bytes of one OBJ, OFF, binary STL, binary PLY, GLB, 3MF,
//! gmsh MSH or VTK VTU file.
//!
//! Every writer takes all meshes of a file at once and never panics: a mesh that cannot be
//! written (a non-finite coordinate, an index past the vertex list, a normal list of the wrong
//! length) is an [`InvalidMesh`] error before the first byte is written. Output is a pure
//! function of the meshes: same meshes, same bytes. Files are written atomically by
//! [`write_mesh_file`] (temporary file in the target's directory, then rename), so a failure
//! leaves an existing file as it was. The formats and their precision are described in
//! `docs/formats.md`. Beyond the meshes, [`WriteOptions`] say the unit of the coordinates
//! (for the formats that record one: 3MF, GLB) and where to count the bytes written (for a
//! progress bar). Files being written are known to [`remove_temporary_files`], which a
//! signal handler calls so that an interrupted write leaves nothing behind.

mod glb;
mod msh;
mod obj;
mod off;
mod ply;
mod split;
mod stl;
pub mod target;
mod text;
mod threemf;
mod vtu;

use std::collections::HashMap;
use std::fmt;
use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;

use super::bits::BitsHash;

use super::{Mesh, NamedMesh};

pub use glb::{ROOT_NODE as GLB_ROOT_NODE, write_glb};
pub use msh::write_msh;
pub use obj::write_obj;
pub use off::write_off;
pub use ply::write_ply;
pub use stl::write_stl;
pub use threemf::{MODEL_PATH as THREEMF_MODEL_PATH, write_3mf};
pub use vtu::write_vtu;

/// A mesh file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Format {
    /// Wavefront OBJ, text: one `o` object and `g` group per mesh, shared positions, one
    /// normal per position.
    Obj,
    /// Binary STL, f32 triangles with facet normals, no names.
    Stl,
    /// Binary little-endian PLY, f64 positions and normals, one merged vertex list.
    Ply,
    /// OFF, text: one merged vertex list with shared positions, no normals or names.
    Off,
    /// glTF 2.0 binary: one named node and mesh per mesh, f32 positions and normals, Y up
    /// through the root node's rotation.
    Glb,
    /// 3MF (3D Manufacturing Format): a zip package, one named object per mesh.
    ThreeMf,
    /// gmsh MSH 4.1, text: one named physical group per mesh, shared nodes.
    Msh,
    /// VTK XML unstructured grid, text: shared points, the mesh's index as cell data `block`.
    Vtu,
}

impl Format {
    /// Every format, in the order of the command line's help.
    pub const ALL: [Format; 8] = [
        Format::Obj,
        Format::Stl,
        Format::Ply,
        Format::Off,
        Format::Glb,
        Format::ThreeMf,
        Format::Msh,
        Format::Vtu,
    ];

    /// The file extension, lower case and without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Obj => "obj",
            Format::Stl => "stl",
            Format::Ply => "ply",
            Format::Off => "off",
            Format::Glb => "glb",
            Format::ThreeMf => "3mf",
            Format::Msh => "msh",
            Format::Vtu => "vtu",
        }
    }

    /// The format an extension names (case-insensitive, without the dot).
    pub fn from_extension(extension: &str) -> Option<Format> {
        Format::ALL
            .into_iter()
            .find(|f| f.extension().eq_ignore_ascii_case(extension))
    }

    /// The format of a file path, by its extension.
    pub fn from_path(path: &Path) -> Result<Format, FormatError> {
        let extension = path.extension().map(|e| e.to_string_lossy().into_owned());
        match extension.as_deref().and_then(Format::from_extension) {
            Some(format) => Ok(format),
            None => Err(FormatError::UnknownExtension {
                path: path.to_path_buf(),
                extension,
            }),
        }
    }

    /// The format to write: the explicit choice if there is one (it must agree with the
    /// output's extension when that names a format), else the output's extension, else OBJ.
    pub fn choose(explicit: Option<Format>, output: Option<&Path>) -> Result<Format, FormatError> {
        let by_extension = output.map(Format::from_path);
        match (explicit, by_extension) {
            (Some(explicit), Some(Ok(implied))) if explicit != implied => {
                Err(FormatError::Mismatch {
                    path: output.map(Path::to_path_buf).unwrap_or_default(),
                    explicit,
                    implied,
                })
            }
            (Some(explicit), _) => Ok(explicit),
            (None, Some(result)) => result,
            (None, None) => Ok(Format::Obj),
        }
    }

    /// `<stem of input>.<extension>` in the current directory: the default output of
    /// `surfc mesh FILE`.
    pub fn default_output(self, input: &Path) -> PathBuf {
        let stem = input.file_stem().unwrap_or(input.as_os_str());
        let mut path = PathBuf::from(stem);
        path.set_extension(self.extension());
        path
    }

    /// Writes the meshes in this format, with the default [`WriteOptions`].
    pub fn write(self, out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
        self.write_with(out, meshes, &WriteOptions::default())
    }

    /// Writes the meshes in this format as `options` say.
    pub fn write_with(
        self,
        out: &mut dyn Write,
        meshes: &[NamedMesh],
        options: &WriteOptions,
    ) -> io::Result<()> {
        validate(meshes, self)?;
        self.write_unchecked(out, meshes, options)
    }

    /// Whether the format stores coordinates as f32 (so that they must fit).
    fn stores_f32(self) -> bool {
        matches!(self, Format::Stl | Format::Glb)
    }

    /// Whether the format stores vertex normals (so that they must be valid).
    fn stores_normals(self) -> bool {
        matches!(self, Format::Obj | Format::Ply | Format::Glb)
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.extension())
    }
}

impl FromStr for Format {
    type Err = FormatError;
    fn from_str(s: &str) -> Result<Format, FormatError> {
        Format::from_extension(s).ok_or_else(|| FormatError::UnknownName(s.to_owned()))
    }
}

/// The length unit of a `.surf` file's coordinates, for the formats that record one: 3MF's
/// `unit` attribute and GLB's scale to metres (glTF's unit). The other formats hold bare
/// numbers. The default is the millimetre, 3MF's own default and what slicers assume of STL
/// files (docs/formats.md, *Units*).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Unit {
    Micron,
    #[default]
    Millimetre,
    Centimetre,
    Metre,
    Inch,
    Foot,
}

impl Unit {
    /// Every unit, smallest first: the units of 3MF.
    pub const ALL: [Unit; 6] = [
        Unit::Micron,
        Unit::Millimetre,
        Unit::Centimetre,
        Unit::Inch,
        Unit::Foot,
        Unit::Metre,
    ];

    /// The length of one unit in metres.
    pub fn metres(self) -> f64 {
        match self {
            Unit::Micron => 1e-6,
            Unit::Millimetre => 1e-3,
            Unit::Centimetre => 1e-2,
            Unit::Metre => 1.0,
            Unit::Inch => 0.0254,
            Unit::Foot => 0.3048,
        }
    }

    /// The name of the unit in a 3MF model's `unit` attribute.
    pub fn threemf_name(self) -> &'static str {
        match self {
            Unit::Micron => "micron",
            Unit::Millimetre => "millimeter",
            Unit::Centimetre => "centimeter",
            Unit::Metre => "meter",
            Unit::Inch => "inch",
            Unit::Foot => "foot",
        }
    }

    /// The unit a 3MF `unit` attribute names.
    pub fn from_threemf_name(name: &str) -> Option<Unit> {
        Unit::ALL.into_iter().find(|u| u.threemf_name() == name)
    }

    /// The short name of the command line's `--unit`: `um`, `mm`, `cm`, `m`, `in`, `ft`.
    pub fn symbol(self) -> &'static str {
        match self {
            Unit::Micron => "um",
            Unit::Millimetre => "mm",
            Unit::Centimetre => "cm",
            Unit::Metre => "m",
            Unit::Inch => "in",
            Unit::Foot => "ft",
        }
    }
}

impl fmt::Display for Unit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.symbol())
    }
}

/// What a writer needs beyond the meshes. `Default`: millimetres, nothing counted.
#[derive(Clone, Copy, Debug, Default)]
pub struct WriteOptions<'a> {
    /// The unit of the coordinates (3MF and GLB record it; see [`Unit`]). Default: mm.
    pub unit: Unit,
    /// Where the bytes written so far are added up as they go (in batches), for a progress
    /// bar on another thread; for 3MF, whose package is put together in memory, the bytes
    /// of the model part as they are compressed. Default: none.
    pub written: Option<&'a AtomicU64>,
}

/// The output format could not be chosen: the user's command line is at fault.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum FormatError {
    #[error(
        "cannot tell the mesh format of `{}` from its extension{}; use .obj, .stl, .ply, .off, .glb, .3mf, .msh or .vtu, or --format",
        path.display(),
        extension.as_deref().map(|e| format!(" `.{e}`")).unwrap_or_default()
    )]
    UnknownExtension {
        path: PathBuf,
        extension: Option<String>,
    },
    #[error("unknown mesh format `{0}`; expected obj, stl, ply, off, glb, 3mf, msh or vtu")]
    UnknownName(String),
    #[error(
        "`{}` has the extension of {implied} but --format asks for {explicit}",
        path.display()
    )]
    Mismatch {
        path: PathBuf,
        explicit: Format,
        implied: Format,
    },
}

/// A mesh that no format can write: the mesh's producer is at fault. Names the mesh by its
/// name and the element by its index in that mesh.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum InvalidMesh {
    #[error("mesh `{mesh}`: vertex {vertex} has a non-finite coordinate ({position:?})")]
    NonFiniteVertex {
        mesh: String,
        vertex: u32,
        position: [f64; 3],
    },
    #[error(
        "mesh `{mesh}`: vertex {vertex} ({position:?}) lies outside the range of {format}'s 32-bit floats"
    )]
    OutOfF32Range {
        mesh: String,
        vertex: u32,
        position: [f64; 3],
        format: Format,
    },
    #[error("mesh `{mesh}`: the normal of vertex {vertex} is not finite ({normal:?})")]
    NonFiniteNormal {
        mesh: String,
        vertex: u32,
        normal: [f64; 3],
    },
    #[error("mesh `{mesh}` has {vertices} vertices but {normals} normals")]
    NormalCount {
        mesh: String,
        vertices: usize,
        normals: usize,
    },
    #[error("mesh `{mesh}`: a side names vertex {vertex}, but the mesh has {vertices} vertices")]
    SideOutOfRange {
        mesh: String,
        vertex: u32,
        vertices: usize,
    },
    #[error(
        "mesh `{mesh}`: triangle {triangle} uses vertex {index}, but the mesh has {vertices} vertices"
    )]
    IndexOutOfRange {
        mesh: String,
        triangle: usize,
        index: u32,
        vertices: usize,
    },
    #[error("the meshes have {count} {what}, more than {format} can hold ({limit})")]
    TooLarge {
        format: Format,
        what: &'static str,
        count: u64,
        limit: u64,
    },
}

impl From<InvalidMesh> for io::Error {
    fn from(e: InvalidMesh) -> io::Error {
        io::Error::new(io::ErrorKind::InvalidData, e)
    }
}

/// Writing a mesh or picture file failed. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    #[error("cannot write `{}`: `{}` is not an existing directory", path.display(), dir.display())]
    MissingDirectory { path: PathBuf, dir: PathBuf },
    #[error("cannot write `{}`: cannot create a file in `{}`: {source}", path.display(), dir.display())]
    CreateTemporary {
        path: PathBuf,
        dir: PathBuf,
        source: io::Error,
    },
    #[error("cannot write `{}`: {source}", path.display())]
    Write { path: PathBuf, source: io::Error },
    #[error("cannot write `{}`: {source}", path.display())]
    InvalidMesh { path: PathBuf, source: InvalidMesh },
    #[error("cannot write `{}`: replacing it failed: {source}", path.display())]
    Replace { path: PathBuf, source: io::Error },
    #[error(
        "cannot write `{}`: it is the input file `{}`; choose another output with -o",
        path.display(),
        input.display()
    )]
    SameAsInput { path: PathBuf, input: PathBuf },
    #[error(
        "cannot write `{}`: permission denied: {} read-only and is not replaced",
        path.display(),
        if path == file { "the file is".to_string() } else { format!("its target `{}` is", file.display()) }
    )]
    ReadOnly { path: PathBuf, file: PathBuf },
    #[error("cannot write `{}`: it is a directory", path.display())]
    IsDirectory { path: PathBuf },
}

impl WriteError {
    /// The file that could not be written.
    pub fn path(&self) -> &Path {
        match self {
            WriteError::MissingDirectory { path, .. }
            | WriteError::CreateTemporary { path, .. }
            | WriteError::Write { path, .. }
            | WriteError::InvalidMesh { path, .. }
            | WriteError::Replace { path, .. }
            | WriteError::SameAsInput { path, .. }
            | WriteError::ReadOnly { path, .. }
            | WriteError::IsDirectory { path } => path,
        }
    }
}

/// Writes the meshes to `path` in `format`, atomically: the bytes go to a temporary file in
/// the same directory, which then replaces `path`; on any failure `path` is left as it was
/// and the temporary file is removed.
pub fn write_mesh_file(
    path: &Path,
    format: Format,
    meshes: &[NamedMesh],
) -> Result<(), WriteError> {
    write_mesh_file_with(path, format, meshes, &WriteOptions::default())
}

/// [`write_mesh_file`] as `options` say.
pub fn write_mesh_file_with(
    path: &Path,
    format: Format,
    meshes: &[NamedMesh],
    options: &WriteOptions,
) -> Result<(), WriteError> {
    validate(meshes, format).map_err(|source| WriteError::InvalidMesh {
        path: path.to_path_buf(),
        source,
    })?;
    write_atomic(path, |out| format.write_unchecked(out, meshes, options))
}

/// Writes a file atomically: `write` fills a temporary file in `path`'s directory, which then
/// replaces `path`. If `write` fails (or flushing, syncing or renaming does), `path` keeps its
/// old contents and the temporary file is removed. The new file gets the permissions of the
/// file it replaces, or the usual ones (0o666 less the umask) for a new file. What `path` is
/// decides how ([`target::resolve`]): a symlink is followed and its target replaced, a FIFO or
/// device is written in place, a read-only file or a directory is refused.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), WriteError> {
    let resolved = match target::resolve(path)? {
        target::Target::Replace(resolved) => resolved,
        target::Target::Direct(special) => return write_direct(path, &special, write),
    };
    let (user_path, path) = (path, resolved.as_path());
    let dir = match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(WriteError::MissingDirectory {
            path: user_path.to_path_buf(),
            dir,
        });
    }
    let prefix = format!(
        ".{}.",
        path.file_name().unwrap_or_default().to_string_lossy()
    );
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    // Temporary files are created owner-only; the result should look like any other file.
    let permissions = fs::metadata(path).ok().map(|m| m.permissions());
    #[cfg(unix)]
    let permissions = permissions.or_else(|| {
        use std::os::unix::fs::PermissionsExt;
        Some(fs::Permissions::from_mode(0o666))
    });
    // Known to `remove_temporary_files` from before the file exists until it is renamed or
    // removed (the guard drops last), so that a signal at any moment finds it.
    let mut pending = Pending::new();
    let temporary = builder
        .make_in(&dir, |path| {
            pending.set(path);
            let mut options = fs::OpenOptions::new();
            options.read(true).write(true).create_new(true);
            #[cfg(unix)]
            if let Some(permissions) = &permissions {
                use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
                options.mode(permissions.mode());
            }
            options.open(path)
        })
        .map_err(|source| WriteError::CreateTemporary {
            path: user_path.to_path_buf(),
            dir: dir.clone(),
            source,
        })?;
    let write_error = |source| WriteError::Write {
        path: user_path.to_path_buf(),
        source,
    };
    let mut out = BufWriter::new(temporary);
    write(&mut out).map_err(write_error)?;
    let temporary = out.into_inner().map_err(|e| write_error(e.into_error()))?;
    temporary.as_file().sync_all().map_err(write_error)?;
    temporary.persist(path).map_err(|e| WriteError::Replace {
        path: user_path.to_path_buf(),
        source: e.error,
    })?;
    Ok(())
}

/// The temporary files of the writes under way, for [`remove_temporary_files`].
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// A temporary file's path in [`PENDING`] while its write is under way; out when dropped.
struct Pending(Option<PathBuf>);

impl Pending {
    fn new() -> Pending {
        Pending(None)
    }

    /// Records `path` (replacing a name tried before, which was taken).
    fn set(&mut self, path: &Path) {
        let mut pending = PENDING.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(old) = self.0.take() {
            pending.retain(|p| *p != old);
        }
        pending.push(path.to_path_buf());
        self.0 = Some(path.to_path_buf());
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if let Some(path) = self.0.take() {
            let mut pending = PENDING.lock().unwrap_or_else(|e| e.into_inner());
            pending.retain(|p| *p != path);
        }
    }
}

/// Removes the temporary files of the writes under way (each output keeps its old contents
/// or stays absent) and holds back new ones while the returned guard lives: a write that
/// has not yet created its temporary file waits. For a handler of SIGINT and SIGTERM, which
/// ends the process holding the guard, so that no write leaves a file behind: one under way
/// fails or has its file removed (one that got as far as its rename has written the whole
/// file), and none begins.
pub fn remove_temporary_files() -> HeldBack {
    let pending = PENDING.lock().unwrap_or_else(|e| e.into_inner());
    let removed = pending
        .iter()
        .filter(|path| fs::remove_file(path).is_ok())
        .count();
    HeldBack {
        _pending: pending,
        removed,
    }
}

/// What [`remove_temporary_files`] did; while it lives, no temporary file is created.
pub struct HeldBack {
    _pending: std::sync::MutexGuard<'static, Vec<PathBuf>>,
    removed: usize,
}

impl HeldBack {
    /// How many temporary files were removed.
    pub fn removed(&self) -> usize {
        self.removed
    }
}

/// Writes to a special file in place: no temporary file, no rename, nothing to sync.
fn write_direct(
    path: &Path,
    special: &Path,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), WriteError> {
    let write_error = |source| WriteError::Write {
        path: path.to_path_buf(),
        source,
    };
    let file = fs::OpenOptions::new()
        .write(true)
        .open(special)
        .map_err(write_error)?;
    let mut out = BufWriter::new(file);
    write(&mut out).map_err(write_error)?;
    out.flush().map_err(write_error)
}

impl Format {
    fn write_unchecked(
        self,
        out: &mut dyn Write,
        meshes: &[NamedMesh],
        options: &WriteOptions,
    ) -> io::Result<()> {
        if self == Format::ThreeMf {
            // The package is put together in memory; its writer counts the model part.
            return threemf::write(out, meshes, options);
        }
        let mut counted;
        let out: &mut dyn Write = match options.written {
            Some(written) => {
                counted = Counted::new(out, written);
                &mut counted
            }
            None => out,
        };
        match self {
            Format::Obj => obj::write(out, meshes),
            Format::Stl => stl::write(out, meshes),
            Format::Ply => ply::write(out, meshes),
            Format::Off => off::write(out, meshes),
            Format::Glb => glb::write(out, meshes, options.unit),
            Format::ThreeMf => threemf::write(out, meshes, options),
            Format::Msh => msh::write(out, meshes),
            Format::Vtu => vtu::write(out, meshes),
        }
    }
}

/// A writer that adds the bytes passing through it to a shared counter, a batch at a time
/// (an atomic add per 64 KiB, not per write: PLY writes a record at a time).
struct Counted<'a> {
    inner: &'a mut dyn Write,
    counter: &'a AtomicU64,
    pending: u64,
}

/// Bytes gathered before they are added to the counter.
const COUNT_BATCH: u64 = 1 << 16;

impl<'a> Counted<'a> {
    fn new(inner: &'a mut dyn Write, counter: &'a AtomicU64) -> Counted<'a> {
        Counted {
            inner,
            counter,
            pending: 0,
        }
    }

    fn add(&mut self) {
        self.counter.fetch_add(self.pending, Ordering::Relaxed);
        self.pending = 0;
    }
}

impl Write for Counted<'_> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.pending += n as u64;
        if self.pending >= COUNT_BATCH {
            self.add();
        }
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.add();
        self.inner.flush()
    }
}

impl Drop for Counted<'_> {
    fn drop(&mut self) {
        self.add();
    }
}

/// Checks what every writer relies on: finite coordinates, indices inside the vertex list,
/// and (for formats that store them) one finite normal per vertex and sides that name
/// vertices of their mesh with finite normals.
pub fn validate(meshes: &[NamedMesh], format: Format) -> Result<(), InvalidMesh> {
    for named in meshes {
        let mesh = named.mesh;
        let name = || named.name.to_owned();
        for (i, v) in mesh.vertices.iter().enumerate() {
            if !v.is_finite() {
                return Err(InvalidMesh::NonFiniteVertex {
                    mesh: name(),
                    vertex: index_u32(i),
                    position: v.to_array(),
                });
            }
            if format.stores_f32() && v.abs().max_element() > f64::from(f32::MAX) {
                return Err(InvalidMesh::OutOfF32Range {
                    mesh: name(),
                    vertex: index_u32(i),
                    position: v.to_array(),
                    format,
                });
            }
        }
        if format.stores_normals() {
            if mesh.normals.len() != mesh.vertices.len() {
                return Err(InvalidMesh::NormalCount {
                    mesh: name(),
                    vertices: mesh.vertices.len(),
                    normals: mesh.normals.len(),
                });
            }
            for (i, n) in mesh.normals.iter().enumerate() {
                if !n.is_finite() {
                    return Err(InvalidMesh::NonFiniteNormal {
                        mesh: name(),
                        vertex: index_u32(i),
                        normal: n.to_array(),
                    });
                }
            }
            for side in &mesh.sides {
                if side.vertex as usize >= mesh.vertices.len() {
                    return Err(InvalidMesh::SideOutOfRange {
                        mesh: name(),
                        vertex: side.vertex,
                        vertices: mesh.vertices.len(),
                    });
                }
                if !side.normal.is_finite() {
                    return Err(InvalidMesh::NonFiniteNormal {
                        mesh: name(),
                        vertex: side.vertex,
                        normal: side.normal.to_array(),
                    });
                }
            }
        }
        for (t, tri) in mesh.triangles.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&i| i as usize >= mesh.vertices.len()) {
                return Err(InvalidMesh::IndexOutOfRange {
                    mesh: name(),
                    triangle: t,
                    index,
                    vertices: mesh.vertices.len(),
                });
            }
        }
    }
    // Every format indexes vertices (or counts triangles) with 32 bits; PLY's `int` is signed.
    let limit = match format {
        Format::Ply => i32::MAX as u64,
        _ => u64::from(u32::MAX),
    };
    let triangles: u64 = meshes.iter().map(|m| m.mesh.triangles.len() as u64).sum();
    // Formats with normals split the vertices on creases: at most one more vertex a side.
    let split = |m: &NamedMesh| {
        if format.stores_normals() {
            m.mesh.sides.len() as u64
        } else {
            0
        }
    };
    let vertices: u64 = meshes
        .iter()
        .map(|m| m.mesh.vertices.len() as u64 + split(m))
        .sum();
    for (what, count) in [("triangles", triangles), ("vertices", vertices)] {
        if count > limit {
            return Err(InvalidMesh::TooLarge {
                format,
                what,
                count,
                limit,
            });
        }
    }
    Ok(())
}

/// A vertex index that `validate` has bounded by `u32::MAX`.
fn index_u32(i: usize) -> u32 {
    u32::try_from(i).unwrap_or(u32::MAX)
}

/// The positions of all meshes of a file with bit-identical positions merged, so that meshes
/// sharing a polygon share its vertices in the file. Positions are numbered in order of first
/// appearance (mesh by mesh, vertex by vertex), which makes the result deterministic.
struct SharedPositions {
    /// The distinct positions, in order of first appearance.
    positions: Vec<DVec3>,
    /// For each mesh, the index in `positions` of each of its vertices.
    index: Vec<Vec<u32>>,
}

impl SharedPositions {
    fn new(meshes: &[NamedMesh]) -> SharedPositions {
        SharedPositions::build(meshes.iter().map(|m| (&m.mesh.vertices[..], None)))
    }

    /// The positions of meshes split at their sharp edges (`split`): a side vertex (one
    /// piece's normal at a vertex on a crease) is merged only with a vertex of the same
    /// position and normal, so that each face of the edge keeps its own; the other vertices
    /// as [`SharedPositions::new`] merges them.
    fn of_split(splits: &[split::Split]) -> SharedPositions {
        SharedPositions::build(
            splits
                .iter()
                .map(|s| (&s.vertices[..], Some((&s.normals[..], &s.side[..])))),
        )
    }

    fn build<'a>(
        meshes: impl Iterator<Item = (&'a [DVec3], Option<(&'a [DVec3], &'a [bool])>)>,
    ) -> SharedPositions {
        let mut positions = Vec::new();
        let mut seen: HashMap<[u64; 3], u32, BitsHash> = HashMap::default();
        // Side vertices, by position and normal; only meshes with sides have any.
        let mut seen_sides: HashMap<[u64; 6], u32, BitsHash> = HashMap::default();
        let index = meshes
            .map(|(vertices, sides)| {
                vertices
                    .iter()
                    .enumerate()
                    .map(|(k, v)| {
                        let key = [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
                        let fresh = || {
                            positions.push(*v);
                            index_u32(positions.len() - 1)
                        };
                        match sides {
                            Some((normals, side)) if side.get(k).copied().unwrap_or(false) => {
                                let n = normals[k];
                                let key = [
                                    key[0],
                                    key[1],
                                    key[2],
                                    n.x.to_bits(),
                                    n.y.to_bits(),
                                    n.z.to_bits(),
                                ];
                                *seen_sides.entry(key).or_insert_with(fresh)
                            }
                            _ => *seen.entry(key).or_insert_with(fresh),
                        }
                    })
                    .collect()
            })
            .collect();
        SharedPositions { positions, index }
    }
}

/// A mesh name as XML attribute or text: the five special characters as entities, control
/// characters (which XML 1.0 cannot hold) as `_`.
fn xml_escape(name: &str) -> String {
    let mut out = String::with_capacity(name.len());
    for c in name.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c if c.is_control() => out.push('_'),
            c => out.push(c),
        }
    }
    out
}

/// A mesh name made safe for line-based headers (OBJ, PLY comments): whitespace and control
/// characters become `_`, and an empty name becomes `mesh`.
fn header_name(name: &str) -> String {
    if name.is_empty() {
        return "mesh".to_owned();
    }
    name.chars()
        .map(|c| {
            if c.is_whitespace() || c.is_control() {
                '_'
            } else {
                c
            }
        })
        .collect()
}

/// The geometric normal of a triangle (unit length, oriented by the winding), or zero for a
/// degenerate triangle.
fn facet_normal(mesh: &Mesh, tri: [u32; 3]) -> DVec3 {
    let [a, b, c] = tri.map(|i| mesh.vertices[i as usize]);
    (b - a).cross(c - a).normalize_or_zero()
}

/// Shared entry point of the public writers: validation, then the format's own code.
fn checked(
    format: Format,
    out: &mut dyn Write,
    meshes: &[NamedMesh],
    write: fn(&mut dyn Write, &[NamedMesh]) -> io::Result<()>,
) -> io::Result<()> {
    validate(meshes, format)?;
    write(out, meshes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_follow_extensions_in_any_case() {
        for format in Format::ALL {
            let lower = PathBuf::from(format!("a/b.{}", format.extension()));
            let upper = PathBuf::from(format!("b.{}", format.extension().to_uppercase()));
            assert_eq!(Format::from_path(&lower), Ok(format));
            assert_eq!(Format::from_path(&upper), Ok(format));
            assert_eq!(format.extension().parse::<Format>(), Ok(format));
        }
        assert_eq!(
            Format::from_path(Path::new("x.mesh")),
            Err(FormatError::UnknownExtension {
                path: PathBuf::from("x.mesh"),
                extension: Some("mesh".into())
            })
        );
        assert!(matches!(
            Format::from_path(Path::new("noext")),
            Err(FormatError::UnknownExtension {
                extension: None,
                ..
            })
        ));
    }

    #[test]
    fn an_explicit_format_must_agree_with_the_extension() {
        let stl = Path::new("out.stl");
        let odd = Path::new("out.mesh");
        assert_eq!(Format::choose(None, None), Ok(Format::Obj));
        assert_eq!(Format::choose(None, Some(stl)), Ok(Format::Stl));
        assert_eq!(
            Format::choose(Some(Format::Stl), Some(stl)),
            Ok(Format::Stl)
        );
        assert_eq!(
            Format::choose(Some(Format::Ply), Some(odd)),
            Ok(Format::Ply)
        );
        assert_eq!(
            Format::choose(Some(Format::Obj), Some(stl)),
            Err(FormatError::Mismatch {
                path: stl.into(),
                explicit: Format::Obj,
                implied: Format::Stl
            })
        );
        assert!(Format::choose(None, Some(odd)).is_err());
        assert_eq!(
            Format::Glb.default_output(Path::new("examples/torus.surf")),
            PathBuf::from("torus.glb")
        );
    }

    #[test]
    fn shared_positions_merge_bit_identical_vertices_only() {
        let a = Mesh {
            vertices: vec![DVec3::ZERO, DVec3::X, DVec3::new(-0.0, 0.0, 0.0)],
            ..Mesh::default()
        };
        let b = Mesh {
            vertices: vec![DVec3::Y, DVec3::X, DVec3::ZERO],
            ..Mesh::default()
        };
        let named = [
            NamedMesh {
                name: "a",
                mesh: &a,
            },
            NamedMesh {
                name: "b",
                mesh: &b,
            },
        ];
        let shared = SharedPositions::new(&named);
        // -0.0 differs from 0.0 in its bits, so it stays a vertex of its own.
        assert_eq!(
            shared.positions,
            vec![DVec3::ZERO, DVec3::X, DVec3::new(-0.0, 0.0, 0.0), DVec3::Y]
        );
        assert_eq!(shared.index, vec![vec![0, 1, 2], vec![3, 1, 0]]);
    }

    #[test]
    fn header_names_have_no_whitespace() {
        assert_eq!(header_name("cap"), "cap");
        assert_eq!(header_name("a b\nc"), "a_b_c");
        assert_eq!(header_name(""), "mesh");
    }
}
