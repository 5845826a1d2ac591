//! 3MF: named meshes → one 3D Manufacturing Format package (a zip of XML parts: content
//! types, the relationship to the model, and `3D/3dmodel.model`). Each mesh with triangles
//! is one `object` of type `model` named after the mesh, with its own vertices (3MF objects
//! share none), and one build item; a mesh without triangles is left out (3MF has no empty
//! objects). Units are millimetres, the format's default. Coordinates in Rust's shortest
//! round-trip form (3MF numbers are decimal text), so they read back exactly. The package is
//! deflated, with every entry dated 1980-01-01 so that the bytes depend only on the meshes.

use std::fmt::Write as _;
use std::io::{self, Cursor, Write};

use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime, ZipWriter};

use super::{Format, NamedMesh, xml_escape};

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

/// Writes the meshes as one 3MF package (see the module comment).
pub fn write_3mf(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    super::checked(Format::ThreeMf, out, meshes, write)
}

pub(super) fn write(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    // A zip's central directory points back into the file, so the package is put together
    // in memory (compressed) and then written out.
    let mut zip = ZipWriter::new(Cursor::new(Vec::new()));
    let options = SimpleFileOptions::default()
        .compression_method(CompressionMethod::Deflated)
        .last_modified_time(DateTime::default());
    for (path, text) in [
        ("[Content_Types].xml", CONTENT_TYPES),
        ("_rels/.rels", RELATIONSHIPS),
    ] {
        zip.start_file(path, options).map_err(io::Error::other)?;
        zip.write_all(text.as_bytes())?;
    }
    // Large models pass the 4 GiB of plain zip entries.
    zip.start_file(MODEL_PATH, options.large_file(true))
        .map_err(io::Error::other)?;
    write_model(&mut zip, meshes)?;
    let bytes = zip.finish().map_err(io::Error::other)?.into_inner();
    out.write_all(&bytes)
}

/// The model part: one object per mesh with triangles, one build item per object.
fn write_model(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    writeln!(out, r#"<?xml version="1.0" encoding="UTF-8"?>"#)?;
    writeln!(
        out,
        r#"<model unit="millimeter" xml:lang="en-US" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02">"#
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
