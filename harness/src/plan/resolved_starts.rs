//! The chained starts a batch has resolved ([`super::starts`]), kept with the plan
//! ([`super::Plan::starts`]): a memo by SD problem.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard};

/// A resolved start: its map (normalized frame), or why there is none.
pub type Resolved = Result<Arc<Vec<f64>>, String>;

/// Chained starts by their SD problem ([`memo_key`](super::starts::memo_key)).
#[derive(Clone, Default)]
pub struct Starts(Arc<Mutex<HashMap<String, Resolved>>>);

impl Starts {
    /// The memo, locked: resolving a start under the lock computes it once.
    pub fn lock(&self) -> MutexGuard<'_, HashMap<String, Resolved>> {
        // A panic while resolving leaves the memo as it was: take it as is.
        self.0.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

impl std::fmt::Debug for Starts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Starts({} resolved)", self.lock().len())
    }
}
