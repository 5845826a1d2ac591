//! What the marcher learns about a surface before and while it marches (DESIGN.md §4a),
//! asked of the surface oracle and knowing nothing of syntax: where the surface can be at all
//! in a box (interval bounds, the component search), how small its features are (the local
//! step), and where it is not smooth (creases). Each is a module of its own; the marcher takes
//! their answers as inputs.

pub mod ahead;
pub mod components;
pub mod creases;
pub mod jump;
pub mod pieces;
pub mod sizing;
pub mod spine;
