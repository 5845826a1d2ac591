//! OBJ: named meshes → Wavefront OBJ text. One `o NAME` object per mesh; positions shared
//! across meshes (`v`, bit-identical positions written once), one normal per mesh vertex
//! (`vn`), faces `f v//vn` with 1-based indices. Numbers in Rust's shortest round-trip form.

use std::fmt::Write as _;
use std::io::{self, Write};

use super::{Format, NamedMesh, SharedPositions, header_name};

/// Writes the meshes as one OBJ file (see the module comment).
pub fn write_obj(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    super::checked(Format::Obj, out, meshes, write)
}

pub(super) fn write(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    let shared = SharedPositions::new(meshes);
    let mut line = String::with_capacity(128);
    let names: Vec<String> = meshes.iter().map(|m| header_name(m.name)).collect();
    writeln!(out, "# surfc: {}", names.join(", "))?;
    // All positions first: an object may use positions first written for an earlier one.
    for p in &shared.positions {
        line.clear();
        // `{:?}` is the shortest text that parses back to the same f64 (`2.0`, `1e-7`).
        let _ = writeln!(line, "v {:?} {:?} {:?}", p.x, p.y, p.z);
        out.write_all(line.as_bytes())?;
    }
    let mut normal_base = 1u64;
    for ((named, index), name) in meshes.iter().zip(&shared.index).zip(&names) {
        writeln!(out, "o {name}")?;
        for n in &named.mesh.normals {
            line.clear();
            let _ = writeln!(line, "vn {:?} {:?} {:?}", n.x, n.y, n.z);
            out.write_all(line.as_bytes())?;
        }
        for tri in &named.mesh.triangles {
            line.clear();
            line.push('f');
            for &i in tri {
                let v = u64::from(index[i as usize]) + 1;
                let n = u64::from(i) + normal_base;
                let _ = write!(line, " {v}//{n}");
            }
            line.push('\n');
            out.write_all(line.as_bytes())?;
        }
        normal_base += named.mesh.normals.len() as u64;
    }
    Ok(())
}
