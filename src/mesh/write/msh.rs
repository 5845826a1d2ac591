//! MSH: named meshes → gmsh's mesh format 4.1, ASCII. Each mesh is a surface entity (tag
//! 1, 2, …) in a physical group of the same tag named after the mesh, so that gmsh and meshio
//! keep the blocks apart by name. Nodes are the positions shared across meshes (bit-identical
//! positions written once, a coherent net stays one); a node belongs to the entity of the
//! first mesh that uses it. Elements are 3-node triangles (type 2), numbered 1, 2, … over all
//! meshes. Coordinates in Rust's shortest round-trip form, so they read back exactly.

use std::fmt::Write as _;
use std::io::{self, Write};

use glam::DVec3;

use super::{Format, NamedMesh, SharedPositions, header_name};

/// gmsh's element type of a 3-node triangle.
const TRIANGLE: u32 = 2;

/// Writes the meshes as one MSH 4.1 file (see the module comment).
pub fn write_msh(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    super::checked(Format::Msh, out, meshes, write)
}

pub(super) fn write(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    let shared = SharedPositions::new(meshes);
    writeln!(out, "$MeshFormat\n4.1 0 8\n$EndMeshFormat")?;

    writeln!(out, "$PhysicalNames\n{}", meshes.len())?;
    for (k, named) in meshes.iter().enumerate() {
        // Names are quoted: a quote inside one would end it early.
        let name = header_name(named.name).replace('"', "_");
        writeln!(out, "2 {} \"{name}\"", k + 1)?;
    }
    writeln!(out, "$EndPhysicalNames")?;

    writeln!(out, "$Entities\n0 0 {} 0", meshes.len())?;
    for (k, named) in meshes.iter().enumerate() {
        let (lo, hi) = bounds(&named.mesh.vertices);
        writeln!(
            out,
            "{} {:?} {:?} {:?} {:?} {:?} {:?} 1 {} 0",
            k + 1,
            lo.x,
            lo.y,
            lo.z,
            hi.x,
            hi.y,
            hi.z,
            k + 1
        )?;
    }
    writeln!(out, "$EndEntities")?;

    // Positions are numbered in order of first use, mesh by mesh: the nodes a mesh brings in
    // are one contiguous run, its entity's node block.
    let mut runs = Vec::with_capacity(meshes.len());
    let mut next = 0u64;
    for index in &shared.index {
        let end = index
            .iter()
            .map(|&i| u64::from(i) + 1)
            .max()
            .unwrap_or(0)
            .max(next);
        runs.push(next..end);
        next = end;
    }
    let nodes = shared.positions.len();
    let blocks = runs.iter().filter(|r| !r.is_empty()).count();
    writeln!(out, "$Nodes\n{blocks} {nodes} {} {nodes}", nodes.min(1))?;
    let mut line = String::with_capacity(96);
    for (k, run) in runs.iter().enumerate().filter(|(_, r)| !r.is_empty()) {
        writeln!(out, "2 {} 0 {}", k + 1, run.end - run.start)?;
        for tag in run.clone() {
            writeln!(out, "{}", tag + 1)?;
        }
        for tag in run.clone() {
            let p = shared.positions[tag as usize];
            line.clear();
            let _ = writeln!(line, "{:?} {:?} {:?}", p.x, p.y, p.z);
            out.write_all(line.as_bytes())?;
        }
    }
    writeln!(out, "$EndNodes")?;

    let elements: usize = meshes.iter().map(|m| m.mesh.triangles.len()).sum();
    let blocks = meshes
        .iter()
        .filter(|m| !m.mesh.triangles.is_empty())
        .count();
    writeln!(
        out,
        "$Elements\n{blocks} {elements} {} {elements}",
        elements.min(1)
    )?;
    let mut tag = 0u64;
    for (k, (named, index)) in meshes.iter().zip(&shared.index).enumerate() {
        let triangles = &named.mesh.triangles;
        if triangles.is_empty() {
            continue;
        }
        writeln!(out, "2 {} {TRIANGLE} {}", k + 1, triangles.len())?;
        for tri in triangles {
            tag += 1;
            let [a, b, c] = tri.map(|i| u64::from(index[i as usize]) + 1);
            line.clear();
            let _ = writeln!(line, "{tag} {a} {b} {c}");
            out.write_all(line.as_bytes())?;
        }
    }
    writeln!(out, "$EndElements")?;
    Ok(())
}

/// The bounding box of the vertices, or the origin for none.
fn bounds(vertices: &[DVec3]) -> (DVec3, DVec3) {
    if vertices.is_empty() {
        return (DVec3::ZERO, DVec3::ZERO);
    }
    vertices
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        })
}
