//! OBJ: named meshes → Wavefront OBJ text. Positions are shared across meshes (`v`,
//! bit-identical positions written once), each followed by its normal: one `vn` per `v`, in
//! the same order, so that readers that take normals as point data (meshio) find as many
//! normals as points. At a sharp edge a position is one `v` per side, each with its piece's
//! normal (`split`). Each mesh is `o NAME` and `g NAME` (trimesh splits on `o`, meshio on
//! `g`) with faces `f v//v`, 1-based. Numbers in Rust's shortest round-trip form.

use std::io::{self, Write};

use glam::DVec3;

use super::split::{Split, split};
use super::text::{write_lines, xyz};
use super::{Format, NamedMesh, SharedPositions, header_name};

/// Writes the meshes as one OBJ file (see the module comment).
pub fn write_obj(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    super::checked(Format::Obj, out, meshes, write)
}

pub(super) fn write(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    let splits: Vec<Split> = meshes.iter().map(|m| split(m.mesh)).collect();
    let shared = SharedPositions::of_split(&splits);
    let normals = shared_normals(&splits, &shared);
    let names: Vec<String> = meshes.iter().map(|m| header_name(m.name)).collect();
    writeln!(out, "# surfc: {}", names.join(", "))?;
    // All positions and normals first: an object may use positions first written for an
    // earlier one. Floats as `{:?}` writes them: the shortest text that parses back to the
    // same f64 (`2.0`, `1e-7`).
    write_lines(out, &shared.positions, |t, p| xyz(t, "v ", p.to_array()))?;
    write_lines(out, &normals, |t, n| xyz(t, "vn ", n.to_array()))?;
    for ((mesh, index), name) in splits.iter().zip(&shared.index).zip(&names) {
        writeln!(out, "o {name}")?;
        writeln!(out, "g {name}")?;
        write_lines(out, &mesh.triangles, |t, tri| {
            t.str("f");
            for &i in tri {
                let v = u64::from(index[i as usize]) + 1;
                t.str(" ");
                t.int(v);
                t.str("//");
                t.int(v);
            }
            t.str("\n");
        })?;
    }
    Ok(())
}

/// One normal per shared position: the mesh's own normal where one mesh uses the position
/// (or all that use it agree bit for bit); where meshes of different surfaces meet on a
/// shared polygon, the normalised sum of their normals (what a smooth-shading renderer would
/// compute there), or the first mesh's normal if they cancel.
fn shared_normals(meshes: &[Split], shared: &SharedPositions) -> Vec<DVec3> {
    let mut first: Vec<Option<DVec3>> = vec![None; shared.positions.len()];
    let mut sum = vec![DVec3::ZERO; shared.positions.len()];
    let mut differs = vec![false; shared.positions.len()];
    for (mesh, index) in meshes.iter().zip(&shared.index) {
        for (&k, &n) in index.iter().zip(mesh.normals.iter()) {
            let k = k as usize;
            match first[k] {
                None => first[k] = Some(n),
                Some(f) => {
                    differs[k] |= f.to_array().map(f64::to_bits) != n.to_array().map(f64::to_bits)
                }
            }
            sum[k] += n;
        }
    }
    first
        .into_iter()
        .zip(sum)
        .zip(differs)
        .map(|((first, sum), differs)| {
            // Every position belongs to some mesh; formats without normals never get here
            // without them (`validate` checks the count).
            let first = first.unwrap_or(DVec3::ZERO);
            if differs {
                sum.try_normalize().unwrap_or(first)
            } else {
                first
            }
        })
        .collect()
}
