//! VTU: named meshes → one VTK XML unstructured grid, ASCII. Points are the positions shared
//! across meshes (bit-identical positions written once, so a coherent net stays one), as
//! Float64 in Rust's shortest round-trip form; cells are triangles (VTK type 5) in the order
//! of the meshes, with the cell data `block`: the index (0, 1, …) of the mesh a triangle
//! belongs to. The names of the blocks are in an XML comment before the grid, in block order.

use std::fmt::Write as _;
use std::io::{self, Write};

use super::{Format, NamedMesh, SharedPositions, xml_escape};

/// VTK's cell type of a triangle.
const VTK_TRIANGLE: u8 = 5;

/// Writes the meshes as one VTU file (see the module comment).
pub fn write_vtu(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    super::checked(Format::Vtu, out, meshes, write)
}

pub(super) fn write(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    let shared = SharedPositions::new(meshes);
    let cells: usize = meshes.iter().map(|m| m.mesh.triangles.len()).sum();
    writeln!(out, "<?xml version=\"1.0\"?>")?;
    writeln!(
        out,
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">"
    )?;
    for (k, named) in meshes.iter().enumerate() {
        // `--` may not appear inside a comment.
        let name = xml_escape(named.name).replace("--", "-&#45;");
        writeln!(out, "<!-- block {k}: {name} -->")?;
    }
    writeln!(out, "<UnstructuredGrid>")?;
    writeln!(
        out,
        "<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{cells}\">",
        shared.positions.len()
    )?;
    let mut line = String::with_capacity(96);
    writeln!(
        out,
        "<Points>\n<DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"ascii\">"
    )?;
    for p in &shared.positions {
        line.clear();
        let _ = writeln!(line, "{:?} {:?} {:?}", p.x, p.y, p.z);
        out.write_all(line.as_bytes())?;
    }
    writeln!(out, "</DataArray>\n</Points>")?;

    writeln!(out, "<Cells>")?;
    writeln!(
        out,
        "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">"
    )?;
    for (named, index) in meshes.iter().zip(&shared.index) {
        for tri in &named.mesh.triangles {
            let [a, b, c] = tri.map(|i| index[i as usize]);
            line.clear();
            let _ = writeln!(line, "{a} {b} {c}");
            out.write_all(line.as_bytes())?;
        }
    }
    writeln!(out, "</DataArray>")?;
    writeln!(
        out,
        "<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">"
    )?;
    repeat_lines(out, cells, |k, line| {
        let _ = write!(line, "{}", 3 * (k as u64 + 1));
    })?;
    writeln!(out, "</DataArray>")?;
    writeln!(
        out,
        "<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">"
    )?;
    repeat_lines(out, cells, |_, line| {
        let _ = write!(line, "{VTK_TRIANGLE}");
    })?;
    writeln!(out, "</DataArray>\n</Cells>")?;

    writeln!(out, "<CellData Scalars=\"block\">")?;
    writeln!(
        out,
        "<DataArray type=\"Int32\" Name=\"block\" format=\"ascii\">"
    )?;
    for (k, named) in meshes.iter().enumerate() {
        repeat_lines(out, named.mesh.triangles.len(), |_, line| {
            let _ = write!(line, "{k}");
        })?;
    }
    writeln!(out, "</DataArray>\n</CellData>")?;
    writeln!(out, "</Piece>\n</UnstructuredGrid>\n</VTKFile>")?;
    Ok(())
}

/// Writes `count` values, sixteen to a line, each made by `value(k, line)`.
fn repeat_lines(
    out: &mut dyn Write,
    count: usize,
    mut value: impl FnMut(usize, &mut String),
) -> io::Result<()> {
    let mut line = String::with_capacity(128);
    for start in (0..count).step_by(16) {
        line.clear();
        for k in start..count.min(start + 16) {
            if k > start {
                line.push(' ');
            }
            value(k, &mut line);
        }
        line.push('\n');
        out.write_all(line.as_bytes())?;
    }
    Ok(())
}
