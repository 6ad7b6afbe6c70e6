//! The `authalic` task: disk area-preserving parameterization by minimizing the normalized
//! authalic energy of Liu & Yueh ("Authalic energy minimization",
//! docs/src/design/methods.md).
//!
//! Unknowns (Eq. 7): interior image coordinates `f_I^1, f_I^2` and the boundary angles
//! `theta`, the boundary staying on the unit circle. The variable vector is laid out as in the
//! paper, `z = [f_I^1; f_I^2; theta]`. The source mesh is scaled to total area `pi`, the area
//! of the unit disk, so that the paper's area ratio `|f(tau)| / |tau|` (Eq. 45) is 1 for an
//! area-preserving map; the normalized energy itself does not depend on this scale.
//!
//! Image areas are signed (positive for the faces' orientation), which makes the stretch
//! energy `E_S = sum |f(tau)|^2 / |tau|` a polynomial and its gradient exact everywhere.

pub mod aem;
pub(crate) mod iterate;
pub(crate) mod problem;
pub mod sem;
mod solve;

pub use iterate::AUTHALIC_COLUMNS;
pub use problem::{
    default_stop, AreaMetrics, AuthalicError, AuthalicOutcome, AuthalicProblem, AuthalicSettings, FoldGuard, Terms,
    AUTHALIC_ENERGY,
};
pub use solve::{authalic_start, solve_authalic, solve_authalic_from};

#[cfg(test)]
mod tests;
