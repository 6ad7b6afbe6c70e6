//! Where a config's batch keeps what outlives its run folder: the history database and the
//! reference stores, resolved against the config's folder.

use super::config::LoadedConfig;
use std::path::{Path, PathBuf};

/// The database when neither the config (`history = "PATH"`) nor `--history` names one:
/// relative to the current directory, like the default run folder `reports/<name>`.
pub const DEFAULT_PATH: &str = "reports/history.sqlite";

/// The database a config names: its `history` key relative to the config's folder (as every
/// path of a config), else [`DEFAULT_PATH`] relative to the current directory.
pub fn resolve_path(key: Option<&Path>, config_dir: &Path) -> PathBuf {
    match key {
        Some(p) => config_dir.join(p),
        None => PathBuf::from(DEFAULT_PATH),
    }
}

/// The file name of a reference store.
pub const REFERENCES_FILE: &str = "references.json";

/// Where references are read and written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Stores {
    /// Read only: the committed store beside the registry.
    pub seed: Option<PathBuf>,
    /// Read, and where computed references are added when `persist`.
    pub store: PathBuf,
    /// Computed references are written to `store` (off with `--no-history`).
    pub persist: bool,
    /// A missing reference is computed (the config's `compute_references`, default true).
    pub compute: bool,
}

impl Stores {
    /// The config's stores: `references.json` beside its registry, and its `references` key
    /// (relative to the config's folder) or `references.json` beside the config's history
    /// database (`history`, default `reports/history.sqlite`).
    pub fn of(cfg: &LoadedConfig) -> Stores {
        let seed = cfg.registry_path().and_then(|r| Some(r.parent()?.join(REFERENCES_FILE)));
        let store = match &cfg.config.references {
            Some(p) => cfg.dir.join(p),
            None => {
                let history = resolve_path(cfg.config.history.as_deref(), &cfg.dir);
                history.parent().unwrap_or(Path::new("")).join(REFERENCES_FILE)
            }
        };
        Stores { seed, store, persist: true, compute: cfg.config.compute_references.unwrap_or(true) }
    }
}
