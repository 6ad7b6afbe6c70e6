//! From a config and the dataset registry to the runs of a batch.

pub mod config;
pub mod handles;
pub mod names;
pub mod registry;
