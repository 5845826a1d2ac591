//! Meshing through the library: the marcher on the paper's surfaces and generated ones, box
//! searches for components, creases, pieces, coherent nets, offsets of solids and the whole gallery, each mesh
//! checked by the one mesh checker against independent counts.
//!
//! One test binary (tests/README.md says which root holds what); the helpers of all roots are
//! `tests/common/`.

#[path = "../common/mod.rs"]
mod common;

mod coherent_net;
mod components;
mod creases;
mod crossings;
mod dist_gallery;
mod flush;
mod gallery;
mod march_box;
mod march_closed;
mod march_fronts;
mod march_repair;
mod march_robust;
mod march_sweep;
mod march_thin;
mod offsets;
mod pieces;
mod voxel_reference;
