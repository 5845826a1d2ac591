//! Vertices split at sharp edges, for the formats that store a normal per vertex (GLB, OBJ,
//! PLY): a mesh with sides (`Mesh::sides`, the normals of the smooth pieces that meet at a
//! vertex on a crease) becomes one in which such a vertex is one vertex per side its
//! triangles use, each with that side's normal, so that readers shade each face of a sharp
//! edge by its own normal instead of rounding the edge. Each triangle at such a vertex takes
//! the side whose normal is nearest its geometric normal (the triangle lies on one smooth
//! piece; the sides differ by the crease's angle). The first side used keeps the vertex's
//! index, the others are appended in the order the triangles first use them, so the result
//! is a function of the mesh. A mesh without sides is passed through as it is, borrowed:
//! smooth surfaces are written exactly as they were before sides existed.

use std::borrow::Cow;
use std::collections::HashMap;

use glam::DVec3;

use super::super::Mesh;
use crate::mesh::bits::BitsHash;

/// A mesh as a writer that stores a normal per vertex sees it.
pub(super) struct Split<'a> {
    pub vertices: Cow<'a, [DVec3]>,
    pub normals: Cow<'a, [DVec3]>,
    pub triangles: Cow<'a, [[u32; 3]]>,
    /// Per vertex, whether it is one side of a vertex on a crease (it carries one piece's
    /// normal and must not be merged with another vertex at its position); empty when the
    /// mesh has no sides.
    pub side: Vec<bool>,
}

/// The mesh with its vertices on creases split by side (see the module comment). `validate`
/// has checked that the sides name vertices of the mesh.
pub(super) fn split(mesh: &Mesh) -> Split<'_> {
    if mesh.sides.is_empty() {
        return Split {
            vertices: Cow::Borrowed(&mesh.vertices),
            normals: Cow::Borrowed(&mesh.normals),
            triangles: Cow::Borrowed(&mesh.triangles),
            side: Vec::new(),
        };
    }
    // Each vertex's side normals, in the order given.
    let mut sides: HashMap<u32, Vec<DVec3>, BitsHash> = HashMap::default();
    for s in &mesh.sides {
        sides.entry(s.vertex).or_default().push(s.normal);
    }
    let mut vertices = mesh.vertices.clone();
    let mut normals = mesh.normals.clone();
    let mut triangles = mesh.triangles.clone();
    let mut side = vec![false; vertices.len()];
    // (vertex, side) → the vertex of the split mesh that carries it.
    let mut taken: HashMap<(u32, usize), u32, BitsHash> = HashMap::default();
    for tri in &mut triangles {
        if !tri.iter().any(|v| sides.contains_key(v)) {
            continue;
        }
        let [a, b, c] = tri.map(|v| mesh.vertices[v as usize]);
        let mut facing = (b - a).cross(c - a);
        if facing == DVec3::ZERO {
            // A degenerate triangle: its vertices' normals say where it faces.
            facing = tri.iter().map(|&v| mesh.normals[v as usize]).sum();
        }
        for v in tri.iter_mut() {
            let Some(choices) = sides.get(v) else {
                continue;
            };
            let nearest = (0..choices.len())
                .max_by(|&i, &j| {
                    facing
                        .dot(choices[i])
                        .total_cmp(&facing.dot(choices[j]))
                        // Ties go to the first side.
                        .then(j.cmp(&i))
                })
                .unwrap_or(0);
            let vertex = *v;
            *v = *taken.entry((vertex, nearest)).or_insert_with(|| {
                let k = vertex as usize;
                if side[k] {
                    // The vertex carries another side already: a new vertex for this one.
                    vertices.push(mesh.vertices[k]);
                    normals.push(choices[nearest]);
                    side.push(true);
                    u32::try_from(vertices.len() - 1).unwrap_or(u32::MAX)
                } else {
                    normals[k] = choices[nearest];
                    side[k] = true;
                    vertex
                }
            });
        }
    }
    Split {
        vertices: Cow::Owned(vertices),
        normals: Cow::Owned(normals),
        triangles: Cow::Owned(triangles),
        side,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Side;

    /// Two faces of a box meeting at the edge x = 0, z = 0 (the top z = 0 for x < 0, the side
    /// x = 0 for z < 0), with the edge's two vertices shared and their sides given.
    fn edge() -> Mesh {
        let vertices = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(-1.0, 1.0, 0.0),
            DVec3::new(0.0, 0.0, -1.0),
            DVec3::new(0.0, 1.0, -1.0),
        ];
        let bisector = DVec3::new(1.0, 0.0, 1.0).normalize();
        Mesh {
            normals: vec![bisector, bisector, DVec3::Z, DVec3::Z, DVec3::X, DVec3::X],
            vertices,
            // Counter-clockwise seen from outside (+z on top, +x on the side).
            triangles: vec![[0, 1, 3], [0, 3, 2], [0, 4, 5], [0, 5, 1]],
            sides: [0, 1]
                .into_iter()
                .flat_map(|vertex| [DVec3::Z, DVec3::X].map(|normal| Side { vertex, normal }))
                .collect(),
        }
    }

    #[test]
    fn each_face_of_a_sharp_edge_gets_its_own_normal() {
        let mesh = edge();
        let split = split(&mesh);
        assert_eq!(split.vertices.len(), 8);
        for tri in split.triangles.iter() {
            let [a, b, c] = tri.map(|v| split.vertices[v as usize]);
            let facing = (b - a).cross(c - a).normalize();
            for &v in tri {
                assert_eq!(split.normals[v as usize], facing, "{tri:?}");
            }
        }
        // The top keeps the edge's indices (it uses them first), the side gets new ones.
        assert_eq!(split.triangles[0], [0, 1, 3]);
        assert_eq!(split.triangles[2], [6, 4, 5]);
        assert_eq!(split.triangles[3], [6, 5, 7]);
        assert_eq!(
            split.side,
            vec![true, true, false, false, false, false, true, true]
        );
    }

    #[test]
    fn a_mesh_without_sides_is_borrowed_as_it_is() {
        let mut mesh = edge();
        mesh.sides.clear();
        let split = split(&mesh);
        assert!(matches!(split.vertices, Cow::Borrowed(_)));
        assert!(matches!(split.normals, Cow::Borrowed(_)));
        assert!(split.side.is_empty());
    }
}
