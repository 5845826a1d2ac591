//! Binary PLY: named meshes → one binary little-endian PLY file. One merged vertex list of
//! `double x y z nx ny nz` (exact f64), faces as `list uchar int vertex_indices`. Vertices of
//! different meshes are merged only where position and normal are both bit-identical (PLY has
//! one normal per vertex, so a shared position with two normals stays two vertices), and a
//! vertex on a sharp edge is one vertex per side (`split`). Comment lines name each mesh and
//! its range of faces.

use std::collections::HashMap;
use std::io::{self, Write};

use super::split::{Split, split};
use super::{Format, NamedMesh, header_name};
use crate::mesh::bits::BitsHash;

/// Writes the meshes as one binary PLY file (see the module comment).
pub fn write_ply(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    super::checked(Format::Ply, out, meshes, write)
}

pub(super) fn write(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    let splits: Vec<Split> = meshes.iter().map(|m| split(m.mesh)).collect();
    // Merge vertices whose position and normal agree bit for bit; first appearance numbers them.
    let mut seen: HashMap<[u64; 6], u32, BitsHash> = HashMap::default();
    let mut order: Vec<(usize, usize)> = Vec::new();
    let index: Vec<Vec<u32>> = splits
        .iter()
        .enumerate()
        .map(|(m, mesh)| {
            mesh.vertices
                .iter()
                .zip(mesh.normals.iter())
                .enumerate()
                .map(|(v, (p, n))| {
                    let key = [p.x, p.y, p.z, n.x, n.y, n.z].map(f64::to_bits);
                    *seen.entry(key).or_insert_with(|| {
                        order.push((m, v));
                        u32::try_from(order.len() - 1).unwrap_or(u32::MAX)
                    })
                })
                .collect()
        })
        .collect();
    let faces: usize = meshes.iter().map(|m| m.mesh.triangles.len()).sum();

    let mut header =
        String::from("ply\nformat binary_little_endian 1.0\ncomment written by surfc\n");
    let mut first = 0usize;
    for named in meshes {
        let n = named.mesh.triangles.len();
        header.push_str(&format!(
            "comment mesh {} faces {}..{}\n",
            header_name(named.name),
            first,
            first + n
        ));
        first += n;
    }
    header.push_str(&format!("element vertex {}\n", order.len()));
    for p in ["x", "y", "z", "nx", "ny", "nz"] {
        header.push_str(&format!("property double {p}\n"));
    }
    header.push_str(&format!("element face {faces}\n"));
    header.push_str("property list uchar int vertex_indices\nend_header\n");
    out.write_all(header.as_bytes())?;

    let mut record = [0u8; 48];
    for &(m, v) in &order {
        let mesh = &splits[m];
        let (p, n) = (mesh.vertices[v], mesh.normals[v]);
        for (j, x) in [p.x, p.y, p.z, n.x, n.y, n.z].into_iter().enumerate() {
            record[8 * j..8 * j + 8].copy_from_slice(&x.to_le_bytes());
        }
        out.write_all(&record)?;
    }
    let mut face = [0u8; 13];
    face[0] = 3;
    for (mesh, index) in splits.iter().zip(&index) {
        for tri in mesh.triangles.iter() {
            for (j, &i) in tri.iter().enumerate() {
                // `validate` bounded vertex counts by i32::MAX, PLY's `int`.
                let i = i32::try_from(index[i as usize]).unwrap_or(i32::MAX);
                face[1 + 4 * j..5 + 4 * j].copy_from_slice(&i.to_le_bytes());
            }
            out.write_all(&face)?;
        }
    }
    Ok(())
}
