//! The regression gate: baselines written from a run folder and the comparison against them
//! (`check`), and the rules it shares with the comparison of two run folders.

pub mod check;
pub mod rules;
