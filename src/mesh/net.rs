//! Coherent nets oriented as one. Meshes written to one file that share a polygon (its
//! vertices bit-identical, docs/language.md) join along its edges; each mesh is oriented by its
//! own ∇f, which may point the other way from its neighbour's (the G2 set's closure: its ∇f
//! points into the cylinder it closes). Where an edge is in exactly two triangles of two
//! different meshes, the two must use it in opposite directions; a mesh whose shared edges
//! mostly say otherwise is flipped (triangles reversed, normals and sides negated), the first
//! mesh of each net in file order keeping its own orientation. Edges in four triangles
//! (surfaces crossing, Sect. 3.9) join nothing: each surface there stays consistent in itself.

use std::collections::{BTreeMap, HashMap};

use super::Mesh;

/// Orients every net of `meshes` as one, in place; whether each mesh was flipped.
pub fn orient(meshes: &mut [&mut Mesh]) -> Vec<bool> {
    let flips = flips(meshes);
    for (mesh, &flip) in meshes.iter_mut().zip(&flips) {
        if flip {
            for t in &mut mesh.triangles {
                t.swap(1, 2);
            }
            for n in &mut mesh.normals {
                *n = -*n;
            }
            for side in &mut mesh.sides {
                side.normal = -side.normal;
            }
        }
    }
    flips
}

/// Which meshes to flip: a walk over the graph of meshes joined by shared edges, each join
/// deciding by the majority of its edges whether the two meshes agree.
fn flips(meshes: &[&mut Mesh]) -> Vec<bool> {
    // One mesh joins nothing (and the fine sphere's 4 M edge uses need not be looked at).
    if meshes.len() < 2 {
        return vec![false; meshes.len()];
    }
    // File-wide vertex ids, and for each id whether more than one mesh uses it: only edges
    // between such vertices can be used by two meshes, so only those are collected.
    let mut ids: HashMap<[u64; 3], u32> = HashMap::new();
    let mut shared: Vec<(usize, bool)> = Vec::new();
    let locals: Vec<Vec<u32>> = meshes
        .iter()
        .enumerate()
        .map(|(m, mesh)| {
            mesh.vertices
                .iter()
                .map(|v| {
                    let next = ids.len() as u32;
                    let id = *ids.entry(v.to_array().map(f64::to_bits)).or_insert(next);
                    if id == next {
                        shared.push((m, false));
                    } else if shared[id as usize].0 != m {
                        shared[id as usize].1 = true;
                    }
                    id
                })
                .collect()
        })
        .collect();
    // Every use of an undirected edge between shared vertices: (lo, hi, mesh, lo → hi);
    // sorted, the uses of one edge are adjacent.
    let mut uses: Vec<(u32, u32, usize, bool)> = Vec::new();
    for (m, (mesh, local)) in meshes.iter().zip(&locals).enumerate() {
        for t in &mesh.triangles {
            for k in 0..3 {
                let (Some(&a), Some(&b)) =
                    (local.get(t[k] as usize), local.get(t[(k + 1) % 3] as usize))
                else {
                    continue;
                };
                if shared[a as usize].1 && shared[b as usize].1 {
                    uses.push((a.min(b), a.max(b), m, a < b));
                }
            }
        }
    }
    uses.sort_unstable();
    // Per pair of meshes: edges used in opposite directions (agree) less those used in the
    // same direction (disagree). A BTreeMap, so that the walk below is deterministic.
    let mut votes: BTreeMap<(usize, usize), i64> = BTreeMap::new();
    for u in uses.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        if let &[(_, _, i, fi), (_, _, j, fj)] = u
            && i != j
        {
            *votes.entry((i.min(j), i.max(j))).or_insert(0) += if fi != fj { 1 } else { -1 };
        }
    }
    let mut neighbours: Vec<Vec<(usize, bool)>> = vec![Vec::new(); meshes.len()];
    for (&(i, j), &v) in &votes {
        if v != 0 {
            neighbours[i].push((j, v < 0));
            neighbours[j].push((i, v < 0));
        }
    }
    let mut flip: Vec<Option<bool>> = vec![None; meshes.len()];
    for root in 0..meshes.len() {
        if flip[root].is_some() {
            continue;
        }
        flip[root] = Some(false);
        let mut stack = vec![root];
        while let Some(i) = stack.pop() {
            let fi = flip[i].unwrap_or(false);
            for &(j, opposed) in &neighbours[i] {
                if flip[j].is_none() {
                    flip[j] = Some(fi ^ opposed);
                    stack.push(j);
                }
            }
        }
    }
    flip.into_iter().map(|f| f.unwrap_or(false)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// Two triangles on either side of the edge (0,0,0)–(1,0,0); `b_up` orients the second
    /// one with the first (its edge the other way round) or against it.
    fn pair(b_up: bool) -> (Mesh, Mesh) {
        let a = Mesh {
            vertices: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
            normals: vec![DVec3::Z; 3],
            triangles: vec![[0, 1, 2]],
            sides: Vec::new(),
        };
        let b = Mesh {
            vertices: vec![DVec3::X, DVec3::ZERO, DVec3::NEG_Y],
            normals: vec![if b_up { DVec3::Z } else { DVec3::NEG_Z }; 3],
            triangles: vec![if b_up { [0, 1, 2] } else { [1, 0, 2] }],
            sides: Vec::new(),
        };
        (a, b)
    }

    #[test]
    fn a_mesh_against_its_neighbour_is_flipped_and_one_with_it_is_not() {
        for b_up in [true, false] {
            let (mut a, mut b) = pair(b_up);
            let flipped = orient(&mut [&mut a, &mut b]);
            assert_eq!(flipped, vec![false, !b_up]);
            // After orienting, b walks the shared edge from X (its vertex 0) to the origin
            // (its vertex 1), a the other way, and b's normals agree with a's.
            let t = b.triangles[0];
            assert!((0..3).any(|k| t[k] == 0 && t[(k + 1) % 3] == 1), "{t:?}");
            assert_eq!(b.normals[0], DVec3::Z);
        }
    }

    #[test]
    fn crossing_surfaces_are_left_alone() {
        // The edge (0,0,0)–(1,0,0) in four triangles: mesh a in the plane z = 0 on both sides
        // of it, mesh b in the plane y = 0 on both sides, b oriented "against" a's winding.
        let mut a = Mesh {
            vertices: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::NEG_Y],
            normals: vec![DVec3::Z; 4],
            triangles: vec![[0, 1, 2], [1, 0, 3]],
            sides: Vec::new(),
        };
        let mut b = Mesh {
            vertices: vec![DVec3::ZERO, DVec3::X, DVec3::Z, DVec3::NEG_Z],
            normals: vec![DVec3::Y; 4],
            triangles: vec![[1, 0, 2], [0, 1, 3]],
            sides: Vec::new(),
        };
        let before = (a.clone(), b.clone());
        assert_eq!(orient(&mut [&mut a, &mut b]), vec![false, false]);
        assert_eq!((a, b), before);
    }
}
