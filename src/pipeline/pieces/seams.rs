//! The seams of joined slabs, polished (docs/pieces.md, *The seams*). Each slab's quality
//! stage keeps its cut polygons' vertices where the cut put them, and the slab whose fronts
//! arrive at a cut polygon close against it as against any fixed bound: the joined mesh's
//! smallest angles and most of its vertices of valence 4 and 8 are there (the fine torus in
//! eight slabs: its smallest angle 33.5° within two steps of a cut, 38.0° beyond four; 12 of
//! its 13 vertices of valence 4 or 8 within four steps of one). Once the slabs are one mesh,
//! the triangles within `RINGS` rings of a cut vertex go through the quality stage again as
//! one patch (`march::improve_patch`), the cut vertices free, the patch's rim and
//! the points on the box fixed, and the patch is verified; it is kept only if its
//! verification passes, and the join's checks run on the result either way.
//!
//! Only where the block asks for a `radius_ratio` above the default: at the default aim the
//! seams meet it already (the join holds them to 30° and to the mean), and polishing them
//! cost the fine sphere 14 % of its time for a mean radius ratio no higher.

use glam::DVec3;

use crate::march::{self, MarchInput, MarchSettings, Patch};
use crate::mesh::Mesh;
use crate::surface::Fork;

/// Vertices this many rings or fewer from a cut vertex move with it (rings 0 ..= RINGS); the
/// patch is their triangles. The fronts that arrive at a cut close against it over two to
/// six rows: at `radius_ratio: 0.995` the fine torus's smallest angle rose from 33.5° to
/// 34.8° with 2 rings and to 35.7° (as far from the cuts) with 4; the three cylinders in their
/// box at step 0.1 made 31.5° four steps from a cut with 4 rings, 34.0° with 6 (at the box's
/// edges, as in two slabs), and 8 changed nothing more.
const RINGS: u32 = 6;

/// The aim the patch is polished towards, whatever the block's: the patch's mean radius ratio
/// is above most aims already (rows that start from a cut polygon on one side), and the
/// stage does nothing for an aim its mesh meets; its worst triangles are what is to mend.
const SEAM_AIM: f64 = 1.0;

/// The seams polished.
pub(super) struct Polished {
    pub mesh: Mesh,
    /// The cut polygons' vertices, and every vertex of the patch that may have moved (where
    /// the join's angle check looks).
    pub on: Vec<bool>,
    /// The farthest a vertex of the polished patch lies from the nearest plane, along the
    /// axis; None where the seams are as joined.
    pub reach: Option<f64>,
}

/// The joined `mesh` with its seams polished; `on` marks the cut polygons' vertices (and
/// in a box the border polygons', which lie on the box and stay). The mesh as joined where
/// no oracle can be made or the patch's verification refuses it.
pub(super) fn polish(
    fork: &Fork<'_>,
    input: &MarchInput,
    settings: &MarchSettings,
    mesh: Mesh,
    on: Vec<bool>,
    bbox: Option<(DVec3, DVec3)>,
    (axis, planes): (usize, &[f64]),
) -> Polished {
    let unchanged = |mesh, on| Polished {
        mesh,
        on,
        reach: None,
    };
    if settings.quality_angle <= 0.0 || !settings.above_default_aim() {
        return unchanged(mesh, on);
    }
    let Some(mut surface) = fork() else {
        return unchanged(mesh, on);
    };
    let n = mesh.vertices.len();
    // Rings from the cut vertices: a pass over the triangles a ring.
    let mut ring = vec![u32::MAX; n];
    for (k, &o) in on.iter().enumerate() {
        if o {
            ring[k] = 0;
        }
    }
    for r in 0..RINGS {
        for t in &mesh.triangles {
            if t.iter().any(|&k| ring[k as usize] == r) {
                for &k in t {
                    ring[k as usize] = ring[k as usize].min(r + 1);
                }
            }
        }
    }
    let free: Vec<bool> = (0..n)
        .map(|k| ring[k] <= RINGS && !super::on_box(mesh.vertices[k], bbox))
        .collect();
    let (patch_tris, rest): (Vec<[u32; 3]>, Vec<[u32; 3]>) = mesh
        .triangles
        .iter()
        .partition(|t| t.iter().any(|&k| free[k as usize]));
    if patch_tris.is_empty() {
        return unchanged(mesh, on);
    }
    // The patch's vertices: the fixed ones (its rim, points on the box) first, then the free
    // ones, each in the joined mesh's order.
    let mut in_patch = vec![false; n];
    for &k in patch_tris.iter().flatten() {
        in_patch[k as usize] = true;
    }
    let order: Vec<u32> = (0..n as u32)
        .filter(|&k| in_patch[k as usize] && !free[k as usize])
        .chain((0..n as u32).filter(|&k| free[k as usize]))
        .collect();
    let fixed = order.iter().take_while(|&&k| !free[k as usize]).count();
    let mut local = vec![u32::MAX; n];
    for (i, &k) in order.iter().enumerate() {
        local[k as usize] = i as u32;
    }
    // The local step each vertex was made with, as its edges measure it (the march makes
    // them that long): the patch's rim and cuts would cost the sizing's curvature probes.
    let mut lengths = vec![(0.0, 0u32); order.len()];
    for t in &patch_tris {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            let d = mesh.vertices[a as usize].distance(mesh.vertices[b as usize]);
            for k in [a, b] {
                let l = &mut lengths[local[k as usize] as usize];
                *l = (l.0 + d, l.1 + 1);
            }
        }
    }
    let patch = Patch {
        mesh: Mesh {
            vertices: order.iter().map(|&k| mesh.vertices[k as usize]).collect(),
            normals: order.iter().map(|&k| mesh.normals[k as usize]).collect(),
            triangles: patch_tris
                .iter()
                .map(|t| t.map(|k| local[k as usize]))
                .collect(),
            sides: Vec::new(),
        },
        fixed,
        // (A vertex in no triangle, which a cut polygon's need not be in, keeps the step.)
        h: lengths
            .iter()
            .map(|&(sum, n)| if n > 0 { sum / n as f64 } else { input.step })
            .collect(),
    };
    let patch_input = MarchInput {
        bbox,
        ..input.clone()
    };
    let patch_settings = MarchSettings {
        quality_ratio: SEAM_AIM,
        ..*settings
    };
    let Some(polished) = march::improve_patch(
        &mut surface,
        Some(fork),
        patch,
        &patch_input,
        &patch_settings,
    ) else {
        if crate::trace::enabled() {
            eprintln!(
                "pieces: the seams' patch ({} triangles) was refused by its verification: the seams as joined",
                patch_tris.len()
            );
        }
        return unchanged(mesh, on);
    };
    if crate::trace::enabled() {
        eprintln!(
            "pieces: the seams polished: {} triangles in the patch, {} after",
            patch_tris.len(),
            polished.triangles.len()
        );
    }
    // The joined mesh's vertices that were not free, in order, then the patch's free ones
    // (moved, added, some removed); the triangles away from the patch, then the patch's.
    let mut new_index = vec![u32::MAX; n];
    let mut out = Mesh {
        vertices: Vec::with_capacity(n),
        normals: Vec::with_capacity(n),
        triangles: Vec::with_capacity(mesh.triangles.len()),
        sides: Vec::new(),
    };
    let mut out_on = Vec::with_capacity(n);
    for k in 0..n {
        if !free[k] {
            new_index[k] = out.vertices.len() as u32;
            out.vertices.push(mesh.vertices[k]);
            out.normals.push(mesh.normals[k]);
            out_on.push(on[k]);
        }
    }
    let base = out.vertices.len() as u32;
    let of_patch = |i: u32| {
        if (i as usize) < fixed {
            new_index[order[i as usize] as usize]
        } else {
            base + i - fixed as u32
        }
    };
    out.vertices.extend_from_slice(&polished.vertices[fixed..]);
    out.normals.extend_from_slice(&polished.normals[fixed..]);
    out_on.resize(out.vertices.len(), true);
    let dist = |v: DVec3| {
        planes
            .iter()
            .map(|&at| (v[axis] - at).abs())
            .fold(f64::INFINITY, f64::min)
    };
    let reach = polished
        .vertices
        .iter()
        .map(|&v| dist(v))
        .fold(0.0, f64::max);
    out.triangles
        .extend(rest.iter().map(|t| t.map(|k| new_index[k as usize])));
    out.triangles
        .extend(polished.triangles.iter().map(|t| t.map(of_patch)));
    Polished {
        mesh: out,
        on: out_on,
        reach: Some(reach),
    }
}
