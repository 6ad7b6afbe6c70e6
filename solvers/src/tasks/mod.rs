//! The tasks, on top of the machinery: `param` and `deform` (planar maps, sharing
//! [`map_task`]), `authalic` (disk area-preserving maps), the Newton [`system`] of a run, and
//! the [`catalogue`] of every solver of every task. Nothing below this wing names a task
//! (the book's Architecture page, "The layers").

pub mod authalic;
pub mod catalogue;
pub mod deform;
pub mod map_task;
pub mod param;
mod solver_error;
pub mod system;
mod task;

pub use solver_error::SolverError;
pub use task::{validate_for, Task, UnknownTask};
