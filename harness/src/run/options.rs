//! How to run a batch: the `run` flags the batch runner takes.

use crate::plan::select::Shard;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

/// How to run a batch (the `run` flags).
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Reuse finished runs of a previous batch in the same folder with the same key.
    pub resume: bool,
    /// Runs at once (worker threads); default: the machine's cores.
    pub jobs: Option<usize>,
    pub shard: Option<Shard>,
    /// With a shard plan (`--shard-plan`): the runs of `shard`, instead of every N-th run.
    pub shard_runs: Option<std::collections::BTreeSet<String>>,
    /// Delete the results of another batch in the output folder instead of refusing it.
    pub force: bool,
    /// Set (by Ctrl-C) to stop: running runs are abandoned, no new run starts.
    pub interrupt: Arc<AtomicBool>,
}
