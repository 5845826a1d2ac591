//! Value types shared by the stages: intervals and interval gradients (the bounds of the
//! component search and the crease survey), f and ∇f at a point, and the surface oracle's
//! trait that every numerical stage asks. Imports nothing of the crate, so any stage may use
//! it without an import running back up the data flow (docs/ARCHITECTURE.md).

pub mod interval;
pub mod interval_grad;
pub mod oracle;

pub use interval::Interval;
pub use interval_grad::IntervalGrad;
pub use oracle::{Fault, Surface, ValueGrad};
