//! mapbench's harness as a library: the binary (`main.rs`) is its CLI edge, and the fuzz
//! targets (`fuzz/`) drive the same readers the CLI uses.

pub mod check;
pub mod config;
pub mod export;
pub mod fuzzing;
pub mod handles;
pub mod mapfile;
pub mod merge;
pub mod names;
pub mod output;
pub mod progress;
pub mod registry;
pub mod report;
pub mod resume;
pub mod runner;
