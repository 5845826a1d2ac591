//! OFF: named meshes → one OFF text file. All meshes merged into one vertex list with
//! bit-identical positions written once (0-based indices); OFF has no names and no normals.
//! Numbers in Rust's shortest round-trip form.

use std::io::{self, Write};

use super::text::{write_lines, xyz};
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
    write_lines(out, &shared.positions, |t, p| xyz(t, "", p.to_array()))?;
    for (named, index) in meshes.iter().zip(&shared.index) {
        write_lines(out, &named.mesh.triangles, |t, tri| {
            t.str("3");
            for &i in tri {
                t.str(" ");
                t.int(u64::from(index[i as usize]));
            }
            t.str("\n");
        })?;
    }
    Ok(())
}
