//! The regression gate: baselines written from a run folder and the comparison against them
//! (`check`), the comparison of two run folders (`compare`), and the rules they share.

pub mod check;
pub mod compare;
pub mod rules;
