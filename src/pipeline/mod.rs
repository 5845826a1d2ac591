//! The library's driver (docs/ARCHITECTURE.md): load a `.surf` source, check it, compile its
//! surfaces, and mesh each mesh block with the strategy it asks for — a start point, a front,
//! the component search in a box, the crease net of a surface with sharp edges, parallel
//! pieces of a large component — then verify and report. The library API (`api.rs`) and the
//! command line (`cli/`) both stand on it; it knows nothing of arguments, terminals or
//! printing.

pub mod block;
pub mod build;
pub mod components;
pub mod crease_net;
pub mod creased;
pub mod load;
pub mod pieces;
pub mod report;

pub use block::{Meshed, mesh_checked, mesh_program, mesh_source, mesh_source_with, named};
pub use build::march_settings;
pub use creased::CreaseCounts;
