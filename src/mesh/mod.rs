//! Mesh: the triangles the marcher produced — vertices, unit normals (from ∇f), triangles
//! oriented so that their normals agree with ∇f. Topology and quality reports and the file
//! writers live in submodules and see meshes only through this type.

pub mod bits;
pub mod check;
pub mod edges;
mod height_fields;
pub mod net;
pub mod progress;
pub mod quality;
pub mod topology;

use glam::DVec3;

/// A triangle mesh of one surface.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub vertices: Vec<DVec3>,
    /// Unit normal at each vertex, ∇f/|∇f|.
    pub normals: Vec<DVec3>,
    /// Vertex indices, counter-clockwise seen from the side ∇f points to.
    pub triangles: Vec<[u32; 3]>,
    /// Where the surface has a sharp edge: at each vertex on a crease, the unit normal of
    /// every smooth piece that meets there (∇ of that piece's function), two or more entries
    /// per such vertex, sorted by vertex; `normals` holds their normalised sum at that vertex
    /// (all a format with one normal per vertex can hold). Writers that split vertices at
    /// sharp edges (GLB, OBJ, PLY) give each triangle at such a vertex the side whose normal
    /// is nearest the triangle's own. Empty for a smooth surface.
    pub sides: Vec<Side>,
}

/// The normal of one smooth piece at a vertex where pieces meet on a crease.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Side {
    /// The vertex, an index into `Mesh::vertices`.
    pub vertex: u32,
    /// The piece's unit normal there.
    pub normal: DVec3,
}

/// A mesh with the name of its mesh block: what writers put into one file. Meshes written to
/// one file that share bit-identical vertices (the polygons of a shared curve) share those
/// vertices in the file, so that they form one coherent net.
#[derive(Clone, Copy, Debug)]
pub struct NamedMesh<'a> {
    /// The name written with the mesh (its mesh block's).
    pub name: &'a str,
    /// The triangles.
    pub mesh: &'a Mesh,
}

pub mod read;
pub mod render;
pub mod summary;
pub mod write;
