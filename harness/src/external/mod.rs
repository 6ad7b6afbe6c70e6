//! Solvers outside the catalogue, in any language: the harness starts them as processes on a
//! problem folder and judges what they write with its own code.

pub mod child;
pub mod confine;
pub mod execute;
pub mod probe;
pub mod processes;
pub mod protocol;
pub mod records;
pub mod sandbox;
