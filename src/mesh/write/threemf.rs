//! 3MF: named meshes → one 3D Manufacturing Format package (a zip of XML parts: content
//! types, the relationship to the model, and `3D/3dmodel.model`). Each mesh with triangles
//! is one `object` of type `model` named after the mesh, with its own vertices (3MF objects
//! share none), and one build item; a mesh without triangles is left out (3MF has no empty
//! objects). The model's `unit` is the coordinates' ([`Unit`], millimetres by default, the
//! format's own default). Coordinates in Rust's shortest round-trip form (3MF numbers are
//! decimal text), so they read back exactly. The package is deflated, with every entry dated
//! 1980-01-01 so that the bytes depend only on the meshes.
//!
//! Every entry is a plain zip entry, without zip64 records: the readers slicers build on
//! (miniz in PrusaSlicer, libzip, lib3mf) refuse the zip crate's large-file entries, whose
//! central directory carries two zip64 records. A model part of 4 GiB or more, which a plain
//! entry cannot hold, is refused ([`InvalidMesh::TooLarge`]).

use std::fmt::Write as _;
use std::io::{self, Cursor, Write};
use std::sync::atomic::{AtomicU64, Ordering};

use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime, ZipWriter};

use super::{Format, InvalidMesh, NamedMesh, Unit, WriteOptions, xml_escape};

/// The path of the model part inside the package.
pub const MODEL_PATH: &str = "3D/3dmodel.model";

const CONTENT_TYPES: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">
<Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>
<Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/>
</Types>
"#;

const RELATIONSHIPS: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">
<Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>
</Relationships>
"#;

/// Writes the meshes as one 3MF package (see the module comment), in millimetres (the
/// default [`Unit`]).
pub fn write_3mf(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    Format::ThreeMf.write_with(out, meshes, &WriteOptions::default())
}

/// The most bytes a plain (not zip64) zip entry holds.
const ENTRY_LIMIT: u64 = u32::MAX as u64 - 1;

/// The fewest bytes of model text a vertex and a triangle take (`<vertex x="0.0" y="0.0"
/// z="0.0"/>` and `<triangle v1="0" v2="0" v3="0"/>`, each with its newline).
const VERTEX_BYTES_MIN: u64 = 34;
const TRIANGLE_BYTES_MIN: u64 = 33;

pub(super) fn write(
    out: &mut dyn Write,
    meshes: &[NamedMesh],
    options: &WriteOptions,
) -> io::Result<()> {
    let too_large = |count| InvalidMesh::TooLarge {
        format: Format::ThreeMf,
        what: "bytes of model text",
        count,
        limit: ENTRY_LIMIT,
    };
    // Refused at once when even the shortest text of every vertex and triangle is too long.
    let least: u64 = meshes
        .iter()
        .filter(|m| !m.mesh.triangles.is_empty())
        .map(|m| {
            VERTEX_BYTES_MIN * m.mesh.vertices.len() as u64
                + TRIANGLE_BYTES_MIN * m.mesh.triangles.len() as u64
        })
        .sum();
    if least > ENTRY_LIMIT {
        return Err(too_large(least).into());
    }
    // A zip's central directory points back into the file, so the package is put together
    // in memory (compressed) and then written out.
    let mut zip = ZipWriter::new(Cursor::new(Vec::new()));
    let options_zip = SimpleFileOptions::default()
        .compression_method(CompressionMethod::Deflated)
        .last_modified_time(DateTime::default());
    for (path, text) in [
        ("[Content_Types].xml", CONTENT_TYPES),
        ("_rels/.rels", RELATIONSHIPS),
    ] {
        zip.start_file(path, options_zip)
            .map_err(io::Error::other)?;
        zip.write_all(text.as_bytes())?;
    }
    zip.start_file(MODEL_PATH, options_zip)
        .map_err(io::Error::other)?;
    let mut model = Limited {
        inner: &mut zip,
        written: 0,
        counted: 0,
        counter: options.written,
    };
    write_model(&mut model, meshes, options.unit)?;
    model.count();
    let bytes = zip.finish().map_err(io::Error::other)?.into_inner();
    out.write_all(&bytes)
}

/// The model part's writer: stops with [`InvalidMesh::TooLarge`] before the text passes
/// what a plain zip entry holds (the zip crate would stop it with a bare message), and adds
/// what it wrote to the progress counter a batch at a time.
struct Limited<'a, W: Write> {
    inner: &'a mut W,
    written: u64,
    /// How much of `written` the counter has.
    counted: u64,
    counter: Option<&'a AtomicU64>,
}

impl<W: Write> Limited<'_, W> {
    fn count(&mut self) {
        if let Some(counter) = self.counter {
            counter.fetch_add(self.written - self.counted, Ordering::Relaxed);
        }
        self.counted = self.written;
    }
}

impl<W: Write> Write for Limited<'_, W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let total = self.written + buf.len() as u64;
        if total > ENTRY_LIMIT {
            return Err(InvalidMesh::TooLarge {
                format: Format::ThreeMf,
                what: "bytes of model text (at least)",
                count: total,
                limit: ENTRY_LIMIT,
            }
            .into());
        }
        let n = self.inner.write(buf)?;
        self.written += n as u64;
        if self.written - self.counted >= 1 << 16 {
            self.count();
        }
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

/// The model part: one object per mesh with triangles, one build item per object.
fn write_model(out: &mut dyn Write, meshes: &[NamedMesh], unit: Unit) -> io::Result<()> {
    writeln!(out, r#"<?xml version="1.0" encoding="UTF-8"?>"#)?;
    writeln!(
        out,
        r#"<model unit="{}" xml:lang="en-US" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02">"#,
        unit.threemf_name()
    )?;
    writeln!(out, r#"<metadata name="Application">surfc</metadata>"#)?;
    writeln!(out, "<resources>")?;
    let drawn: Vec<&NamedMesh> = meshes
        .iter()
        .filter(|m| !m.mesh.triangles.is_empty())
        .collect();
    let mut line = String::with_capacity(128);
    for (k, named) in drawn.iter().enumerate() {
        let name = xml_escape(named.name);
        writeln!(out, r#"<object id="{}" type="model" name="{name}">"#, k + 1)?;
        writeln!(out, "<mesh>\n<vertices>")?;
        for v in &named.mesh.vertices {
            line.clear();
            let _ = writeln!(
                line,
                r#"<vertex x="{:?}" y="{:?}" z="{:?}"/>"#,
                v.x, v.y, v.z
            );
            out.write_all(line.as_bytes())?;
        }
        writeln!(out, "</vertices>\n<triangles>")?;
        for [a, b, c] in &named.mesh.triangles {
            line.clear();
            let _ = writeln!(line, r#"<triangle v1="{a}" v2="{b}" v3="{c}"/>"#);
            out.write_all(line.as_bytes())?;
        }
        writeln!(out, "</triangles>\n</mesh>\n</object>")?;
    }
    writeln!(out, "</resources>\n<build>")?;
    for k in 0..drawn.len() {
        writeln!(out, r#"<item objectid="{}"/>"#, k + 1)?;
    }
    writeln!(out, "</build>\n</model>")?;
    Ok(())
}
