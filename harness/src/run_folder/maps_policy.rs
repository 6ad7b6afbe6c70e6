//! The `maps` policy: which final maps a run folder keeps (the config's `maps` key, and
//! `meta.json`'s). What it keeps of a folder is `keep.rs`'s.

use serde::{Deserialize, Serialize};

/// The `maps` config key.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Maps {
    /// Every finished run's map.
    All,
    /// Per (dataset, energy) the map of the best run ([`best_of_group`](super::keep::best_of_group)).
    #[default]
    Best,
    /// No maps (and no mesh copies): the report has no map plots.
    None,
}

impl Maps {
    pub fn as_str(self) -> &'static str {
        match self {
            Maps::All => "all",
            Maps::Best => "best",
            Maps::None => "none",
        }
    }
}
