//! Binary STL: named meshes → one binary STL file. STL knows only f32 triangles: each carries
//! its geometric normal (unit, oriented by the winding; zero for a degenerate triangle) and
//! its three corners rounded to f32. No names, no shared vertices.

use std::io::{self, Write};

use super::{Format, NamedMesh, facet_normal};

/// The 80-byte header. It must not begin with `solid`, which readers take for ASCII STL.
const HEADER: &[u8; 80] =
    b"binary STL written by surfc                                                     ";

/// Writes the meshes as one binary STL file (see the module comment).
pub fn write_stl(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    super::checked(Format::Stl, out, meshes, write)
}

pub(super) fn write(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    let count: usize = meshes.iter().map(|m| m.mesh.triangles.len()).sum();
    out.write_all(HEADER)?;
    // `validate` bounded the count by u32::MAX.
    out.write_all(&u32::try_from(count).unwrap_or(u32::MAX).to_le_bytes())?;
    let mut record = [0u8; 50];
    for named in meshes {
        let mesh = named.mesh;
        for &tri in &mesh.triangles {
            let normal = facet_normal(mesh, tri);
            let corners = tri.map(|i| mesh.vertices[i as usize]);
            let values = std::iter::once(normal).chain(corners);
            for (k, v) in values.enumerate() {
                for (j, x) in v.to_array().into_iter().enumerate() {
                    let at = 12 * k + 4 * j;
                    record[at..at + 4].copy_from_slice(&(x as f32).to_le_bytes());
                }
            }
            // bytes 48..50: the attribute byte count, zero.
            out.write_all(&record)?;
        }
    }
    Ok(())
}
