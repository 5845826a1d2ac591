//! Mesh blocks on surfaces with creases (`crease_net`): which blocks are meshed piece by
//! piece, and the diagnostics when that fails. docs/creases.md has the rules:
//! - a block with a `box` (and no `front` or `bounds`) is meshed crease by crease in the box;
//!   with a `start` too, only the connected part of that mesh nearest the start is kept;
//! - a block with a `start` and no `box` gets a box from interval bounds (`derived_box`) when
//!   the surface is bounded, and is then meshed as above;
//! - any other block is marched as before, and its mesh is then checked: a triangle across a
//!   crease is an error that asks for a `box`.

use std::collections::HashSet;

use glam::DVec3;
use serde::Serialize;

use super::build::Builder;
use super::components::{Marching, SearchError, SearchSettings};
use super::crease_net::{self, CreaseError, CreaseSettings, CreasedMesh};
use crate::compile::CompileError;
use crate::diag::{Diagnostic, messages};
use crate::mesh::Mesh;
use crate::mesh::bits::BitsHash;
use crate::mesh::progress::Counts;
use crate::sema::program::MeshDef;
use crate::surface::Surface;
use crate::surface::{BranchFork, Fork};
use crate::survey::cells::{Candidates, surface_cells};
use crate::survey::spine::Creased;

/// What a mesh made crease by crease (`pipeline::crease_net`) has of its creases.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct CreaseCounts {
    /// Crease curves traced in the box (closed loops and corner-to-corner curves).
    pub creases: usize,
    /// Corners where three pieces meet.
    pub corners: usize,
    /// Vertices of the mesh on a crease polygon (corners included), each once.
    pub crease_vertices: usize,
}

const HELP: &str = "give the mesh a `box` that holds the whole surface (and no `front`): a surface with creases is then meshed piece by piece up to its creases";

/// The creased form of the block's surface, or None when its spine has no switch.
pub(crate) fn creased_of(
    builder: &Builder,
    def: &MeshDef,
) -> Result<Option<Creased>, Result<CompileError, Diagnostic>> {
    let Some((spine, branches)) = builder.creased(&def.surface, def.step).map_err(Ok)? else {
        return Ok(None);
    };
    Creased::new(spine, branches).map(Some).map_err(|e| {
        Err(messages::mesh_failed(
            &def.name,
            def.span,
            &e.to_string(),
            None,
        ))
    })
}

/// Meshes a block crease by crease in its box (see the module documentation).
pub(super) fn mesh(
    creased: &mut Creased,
    whole: &mut dyn Surface,
    fork: &Fork<'_>,
    branches: &BranchFork<'_>,
    def: &MeshDef,
    bbox: (DVec3, DVec3),
    progress: &Counts,
) -> Result<CreasedMesh, Diagnostic> {
    let marching = Marching {
        step: def.step,
        max_triangles: def.max_triangles,
        tolerance: def.tolerance,
        uniform: def.uniform,
    };
    let mut out = crease_net::mesh_creased(
        creased,
        whole,
        Some(fork),
        Some(branches),
        marching,
        bbox,
        &super::build::march_settings(def),
        &SearchSettings::default(),
        &CreaseSettings::default(),
        Some(progress),
    )
    .map_err(|e| failed(def, &e))?;
    if let Some(start) = def.start {
        out.mesh = part_nearest(&out.mesh, start);
    }
    Ok(out)
}

/// The crease counts of `--json` for a mesh made crease by crease: creases and corners as
/// traced, and the mesh's vertices that lie on a crease polygon (with a `start`, only the
/// part kept has its vertices counted).
pub(super) fn counts(out: &CreasedMesh) -> CreaseCounts {
    let bits = |p: &DVec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    let in_mesh: HashSet<[u64; 3], BitsHash> = out.mesh.vertices.iter().map(bits).collect();
    let on_creases: HashSet<[u64; 3], BitsHash> = out
        .polygons
        .iter()
        .flatten()
        .map(bits)
        .filter(|b| in_mesh.contains(b))
        .collect();
    CreaseCounts {
        creases: out.creases,
        corners: out.corners,
        crease_vertices: on_creases.len(),
    }
}

/// A box for a block on a surface with creases that has a `start` and no `box`: the cells of
/// an octree over ±`DERIVED_REACH` that the interval bound keeps, narrowed a few times, with a
/// step's margin. None when the surface reaches that far (unbounded) or cannot bound itself;
/// then the block is marched as before and checked.
pub(super) fn derived_box(whole: &mut dyn Surface, step: f64) -> Option<(DVec3, DVec3)> {
    let (mut lo, mut hi) = (DVec3::splat(-DERIVED_REACH), DVec3::splat(DERIVED_REACH));
    for round in 0..8 {
        let leaf = (hi - lo).max_element() / 16.0;
        let Candidates {
            cells, truncated, ..
        } = surface_cells(whole, lo, hi, leaf.max(step), 100_000);
        if truncated || cells.is_empty() {
            return None;
        }
        let (a, b) = cells
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), c| {
                (a.min(c.lo), b.max(c.hi))
            });
        // Reaching the outer faces: the surface may go on beyond them.
        if round == 0 && (a.cmple(lo).any() || b.cmpge(hi).any()) {
            return None;
        }
        (lo, hi) = (a, b);
        if leaf <= step {
            break;
        }
    }
    Some((lo - DVec3::splat(step), hi + DVec3::splat(step)))
}

/// How far from the origin a surface with creases and no `box` is searched for its extent.
const DERIVED_REACH: f64 = 1e3;

/// Checks a mesh marched without the crease search: no triangle across a crease.
pub(super) fn check(creased: &mut Creased, def: &MeshDef, mesh: &Mesh) -> Result<(), Diagnostic> {
    crease_net::check_one_piece_each(creased, mesh, def.step, &CreaseSettings::default())
        .map_err(|e| failed(def, &e))
}

fn failed(def: &MeshDef, e: &CreaseError) -> Diagnostic {
    let help = match e {
        CreaseError::MissedCrease { .. } | CreaseError::LeavesBox { .. } => Some(HELP),
        CreaseError::Tangent { .. } | CreaseError::SingularCorner { .. } => Some(
            "move or resize a part a little (apart, or into each other): where pieces touch or meet more than three at a point, the crease has no direction",
        ),
        CreaseError::PartlyOneSheet { .. } => Some(
            "operands that are one sheet on part of a face and cross elsewhere (solids flush on a face, rounded by `offset`) could not all be told apart here: let one stand a little inside the other's outline, or round with `smooth_union`",
        ),
        CreaseError::LeftPiece { .. } | CreaseError::Lost { .. } => {
            Some("a smaller `step` lets the crease search see smaller features")
        }
        CreaseError::March { source, .. }
        | CreaseError::Search(SearchError::March { source, .. }) => {
            super::block::march_help(source)
        }
        _ => None,
    };
    messages::mesh_failed(&def.name, def.span, &e.to_string(), help)
}

/// The edge-connected part of `mesh` that holds the vertex nearest `start`.
fn part_nearest(mesh: &Mesh, start: DVec3) -> Mesh {
    let Some(first) = (0..mesh.vertices.len()).min_by(|&a, &b| {
        let (da, db) = (
            mesh.vertices[a].distance_squared(start),
            mesh.vertices[b].distance_squared(start),
        );
        da.total_cmp(&db)
    }) else {
        return mesh.clone();
    };
    // Union-find over vertices joined by triangles.
    let mut parent: Vec<usize> = (0..mesh.vertices.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for t in &mesh.triangles {
        let a = root(&mut parent, t[0] as usize);
        for &k in &t[1..] {
            let b = root(&mut parent, k as usize);
            parent[b] = a;
        }
    }
    let keep = root(&mut parent, first);
    let mut index = vec![u32::MAX; mesh.vertices.len()];
    let mut out = Mesh::default();
    for t in &mesh.triangles {
        if root(&mut parent, t[0] as usize) != keep {
            continue;
        }
        let t = t.map(|k| {
            let k = k as usize;
            if index[k] == u32::MAX {
                index[k] = out.vertices.len() as u32;
                out.vertices.push(mesh.vertices[k]);
                out.normals.push(mesh.normals[k]);
            }
            index[k]
        });
        out.triangles.push(t);
    }
    out.sides = mesh
        .sides
        .iter()
        .filter(|s| index.get(s.vertex as usize).is_some_and(|&k| k != u32::MAX))
        .map(|s| crate::mesh::Side {
            vertex: index[s.vertex as usize],
            normal: s.normal,
        })
        .collect();
    // Sorted by vertex, as `Mesh::sides` are (the kept vertices are renumbered in order of use).
    out.sides.sort_by_key(|s| s.vertex);
    out
}
