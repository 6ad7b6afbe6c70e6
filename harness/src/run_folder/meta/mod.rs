//! `meta.json` of a run folder: the typed schema ([`Meta`]), written and read only here.

pub use schema::{shown, MergedShard, Meta, MetaError, Stop, VERSION};

mod provenance;
mod schema;
#[cfg(test)]
mod tests;
