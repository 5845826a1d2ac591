//! What the marcher learns about a surface before and while it marches (docs/ARCHITECTURE.md,
//! docs/marcher.md), asked of the surface oracle and knowing nothing of syntax: where the
//! surface can be at all in a box (interval bounds over octree cells, and their clusters),
//! how small its features are (the local step), and where it is not smooth (the crease forms
//! of its spine, and sharp edges hidden from them). Each is a module of its own; the marcher
//! and the pipeline's drivers take their answers as inputs. Imports nothing above `march`.

pub mod cells;
pub mod clusters;
pub mod faces;
pub mod free_cells;
pub mod gradient_jump;
pub mod sizing;
pub mod spine;
