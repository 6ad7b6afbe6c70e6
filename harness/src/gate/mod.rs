//! The regression gate: baselines written from a run folder and the comparison against them.

pub mod check;
