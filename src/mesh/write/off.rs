//! OFF: named meshes → one OFF text file. All meshes merged into one vertex list with
//! bit-identical positions written once (0-based indices); OFF has no names and no normals.
//! Numbers in Rust's shortest round-trip form.

use std::fmt::Write as _;
use std::io::{self, Write};

use super::{Format, NamedMesh, SharedPositions};

/// Writes the meshes as one OFF file (see the module comment).
pub fn write_off(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    super::checked(Format::Off, out, meshes, write)
}

pub(super) fn write(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    let shared = SharedPositions::new(meshes);
    let faces: usize = meshes.iter().map(|m| m.mesh.triangles.len()).sum();
    writeln!(out, "OFF")?;
    writeln!(out, "{} {} 0", shared.positions.len(), faces)?;
    let mut line = String::with_capacity(96);
    for p in &shared.positions {
        line.clear();
        let _ = writeln!(line, "{:?} {:?} {:?}", p.x, p.y, p.z);
        out.write_all(line.as_bytes())?;
    }
    for (named, index) in meshes.iter().zip(&shared.index) {
        for tri in &named.mesh.triangles {
            line.clear();
            let [a, b, c] = tri.map(|i| index[i as usize]);
            let _ = writeln!(line, "3 {a} {b} {c}");
            out.write_all(line.as_bytes())?;
        }
    }
    Ok(())
}
