//! Real meshes for the output tests, made once per process through the library: the CAD part
//! of `examples/plate.surf` (a plate with holes, a boss and a fillet: sharp edges, curved
//! faces), the whole torus of `examples/torus.surf` (its `torus` block: smooth, closed), and
//! a box (flat faces, sharp edges and corners).

use std::sync::OnceLock;

use surfc::eval::Engine;
use surfc::mesh::NamedMesh;
use surfc::pipeline::{Meshed, mesh_program};

/// The blocks `only` names (all when empty) of `source`, meshed.
fn mesh(source: &str, only: &[&str]) -> Vec<Meshed> {
    let (_, checked, diags) = surfc::pipeline::load::analyse(source);
    let Some((_, program)) = checked else {
        panic!("the source checks: {diags:?}");
    };
    let blocks: Vec<_> = program
        .meshes
        .iter()
        .filter(|m| only.is_empty() || only.contains(&m.name.as_str()))
        .collect();
    assert!(!blocks.is_empty(), "no block {only:?}");
    mesh_program(&program, source, &blocks, true, Engine::default()).expect("meshed")
}

/// `examples/plate.surf`, meshed.
pub fn plate() -> &'static [Meshed] {
    static MESHED: OnceLock<Vec<Meshed>> = OnceLock::new();
    MESHED.get_or_init(|| mesh(include_str!("../../examples/plate.surf"), &[]))
}

/// The `torus` block of `examples/torus.surf` (the whole torus from a start point), meshed.
pub fn torus() -> &'static [Meshed] {
    static MESHED: OnceLock<Vec<Meshed>> = OnceLock::new();
    MESHED.get_or_init(|| mesh(include_str!("../../examples/torus.surf"), &["torus"]))
}

/// A 2 × 1 × 0.5 box, meshed crease by crease.
pub const BOX: &str = "surface b = box((0, 0, 0), (2, 1, 0.5));\n\
                       mesh b = b { step: 0.25; box: (-1, -1, -1) .. (3, 2, 1.5); }\n";

/// [`BOX`], meshed.
pub fn cube() -> &'static [Meshed] {
    static MESHED: OnceLock<Vec<Meshed>> = OnceLock::new();
    MESHED.get_or_init(|| mesh(BOX, &[]))
}

/// The meshes as the writers take them.
pub fn named(meshed: &[Meshed]) -> Vec<NamedMesh<'_>> {
    surfc::pipeline::named(meshed)
}
