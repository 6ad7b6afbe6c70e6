//! The fields of `meta.json`, one typed struct, written and read only here.
//!
//! Every field is optional on reading: folders written before a key existed (and the
//! partial files of tests and tools) still parse, and a reader decides what a missing key
//! means. The keys keep the names and order (sorted) they always had on disk.

use crate::calibration::Calibration;
use crate::hardware::Hardware;
use crate::run_folder::atomic::write_atomic;
use crate::run_folder::maps_policy::Maps;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use solvers::solver::StopSettings;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The schema this code writes. Files without a `version` key are of the same schema,
/// written before the key was added.
pub const VERSION: u32 = 1;

#[derive(Debug, thiserror::Error)]
pub enum MetaError {
    #[error("{}: cannot read", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: not a meta.json mapbench reads: {what}", path.display())]
    Parse { path: PathBuf, what: String },
    #[error(
        "{}: meta.json schema version {found}, but this mapbench reads up to version {VERSION}; \
         use a newer mapbench",
        path.display()
    )]
    Version { path: PathBuf, found: u32 },
    #[error("{}: cannot write: {what}", path.display())]
    Write { path: PathBuf, what: String },
    #[error("{}: the settings of the config: {what}", path.display())]
    Settings { path: PathBuf, what: String },
}

/// `meta.json`: the config as read and the resolved settings of each energy, provenance
/// (code version, git revision, machine, toolchain), the batch's runs and how it ran.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Meta {
    /// The reference workload's samples; `time_norm` divides by their median.
    pub calibration: Option<Calibration>,
    pub calibration_median_s: Option<f64>,
    pub calibration_spread: Option<f64>,
    /// The config as read (its TOML as JSON); `Null` when unknown.
    pub config: Value,
    /// The git revision of the folder holding the config (absent outside a checkout), and
    /// whether its tree is dirty: a config kept in the user's own repository.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub config_git_dirty: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub config_git_revision: Option<String>,
    pub config_path: Option<String>,
    pub cores: Option<usize>,
    pub crates: Option<String>,
    pub ended_unix: Option<u64>,
    /// The external solvers of the batch: name, command, version and, when their runs were
    /// skipped, why (`external::probe::Probe`); absent without any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub external: Option<Value>,
    /// The code's git revision, set when the binary was built, and whether its code
    /// differed from it (`git_diff`: a hash of the difference).
    pub git_dirty: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub git_diff: Option<String>,
    pub git_revision: Option<String>,
    /// The machine's fingerprint (`crate::hardware`); in a merged folder the shards' common
    /// one, absent when they differ (each shard's is in `merged_from`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hardware: Option<Hardware>,
    /// The history database the batch is in (`None`: not, or not yet).
    pub history: Option<String>,
    /// What became of the batch in the history, set once the batch is over: a
    /// `history::HistoryOutcome`, which the history reads (the layers above own its type).
    pub history_outcome: Option<Value>,
    pub host: Option<String>,
    pub interrupted: Option<bool>,
    pub jobs: Option<usize>,
    /// Newton systems of fewer than METIS_MIN_NODES vertices use AMD whatever this says.
    pub linear_ordering: Option<String>,
    pub mapbench_version: Option<String>,
    /// Which final maps the folder keeps; merge prunes by it.
    pub maps: Option<Maps>,
    /// The solvers whose maps `best` kept besides the best (`maps_keep`), when any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub maps_keep: Option<Vec<String>>,
    /// The solvers the config expects to leave problems unsolved (`expected_to_fail`), when
    /// any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expected_to_fail: Option<Vec<String>>,
    /// The shards a merged folder was made of; only merged folders have the key.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub merged_from: Option<Vec<MergedShard>>,
    pub meshes_dir: Option<String>,
    pub only: Option<Vec<String>>,
    /// The planned runs (`--only` applied), in the batch's order.
    pub plan: Option<Vec<String>>,
    /// The reference minimum of each (dataset, energy) group: `judge::reference::GroupReference`s.
    pub references: Option<Value>,
    pub repeat: Option<usize>,
    pub resume: Option<bool>,
    pub rustc: Option<String>,
    /// What each energy's runs resolve the config to.
    pub settings_per_energy: Option<BTreeMap<String, Value>>,
    pub shard: Option<String>,
    pub started_unix: Option<u64>,
    pub stop_per_energy: Option<BTreeMap<String, Stop>>,
    /// The convergence test's targets, loosest first (every energy's but those of
    /// `targets_per_energy`).
    pub targets: Option<Vec<f64>>,
    /// The energies that set their own targets (`[energy.<name>] targets`), loosest first.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub targets_per_energy: Option<BTreeMap<String, Vec<f64>>>,
    pub threads_per_run: Option<usize>,
    /// The schema number ([`VERSION`]); `None` in folders from before it was recorded.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub version: Option<u32>,
}

impl Meta {
    /// The batch's targets (none in a folder from before they were recorded).
    pub fn targets(&self) -> crate::convergence::Targets {
        let default = self.targets.clone().unwrap_or_default();
        crate::convergence::Targets::new(default, self.targets_per_energy.clone().unwrap_or_default())
    }
}

/// An energy's stop rules, as `stop_per_energy` records them.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Stop {
    pub energy_decrease_tol: Option<f64>,
    pub grad_tol: Option<f64>,
    pub max_iters: Option<usize>,
    /// The stationary ends (absent in folders from before them).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grad_floor: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stall_window: Option<usize>,
}

impl From<StopSettings> for Stop {
    fn from(s: StopSettings) -> Stop {
        Stop {
            energy_decrease_tol: Some(s.energy_decrease_tol),
            grad_tol: Some(s.grad_tol),
            max_iters: Some(s.max_iters),
            grad_floor: Some(s.grad_floor),
            stall_window: Some(s.stall_window),
        }
    }
}

/// One shard of a merged folder: where it was and how its batch ran.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MergedShard {
    pub calibration: Option<Calibration>,
    pub dir: String,
    pub ended_unix: Option<u64>,
    pub git_dirty: Option<bool>,
    pub git_revision: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hardware: Option<Hardware>,
    pub host: Option<String>,
    pub interrupted: Option<bool>,
    pub shard: Option<String>,
    pub started_unix: Option<u64>,
}

impl Meta {
    /// `folder/meta.json`, checked against the schema versions this code reads.
    pub fn read(folder: &Path) -> Result<Meta, MetaError> {
        let path = crate::run_folder::layout::meta_json(folder);
        let text = std::fs::read_to_string(&path).map_err(|source| MetaError::Read { path: path.clone(), source })?;
        Meta::parse(&path, &text)
    }

    /// `text`, the contents of `path`.
    pub fn parse(path: &Path, text: &str) -> Result<Meta, MetaError> {
        let value: Value =
            serde_json::from_str(text).map_err(|e| MetaError::Parse { path: path.into(), what: e.to_string() })?;
        // The version first: a newer schema may not parse as this one.
        if let Some(v) = value.get("version") {
            let found = v
                .as_u64()
                .and_then(|v| u32::try_from(v).ok())
                .ok_or_else(|| MetaError::Parse { path: path.into(), what: format!("version {v} is not a number") })?;
            if found > VERSION {
                return Err(MetaError::Version { path: path.into(), found });
            }
        }
        serde_json::from_value(value).map_err(|e| MetaError::Parse { path: path.into(), what: e.to_string() })
    }

    /// Write `folder/meta.json` atomically.
    pub fn write(&self, folder: &Path) -> Result<(), MetaError> {
        let path = crate::run_folder::layout::meta_json(folder);
        // Whatever schema a folder was read as, it is written as this one.
        let meta = Meta { version: Some(VERSION), ..self.clone() };
        let text = serde_json::to_string_pretty(&meta)
            .map_err(|e| MetaError::Write { path: path.clone(), what: e.to_string() })?;
        write_atomic(&path, text.as_bytes()).map_err(|e| MetaError::Write { path, what: format!("{e:#}") })
    }

    /// The config's `name`.
    pub fn config_name(&self) -> Option<&str> {
        self.config.get("name")?.as_str()
    }

    /// A key of the config as read.
    pub fn config_str(&self, key: &str) -> Option<&str> {
        self.config.get(key)?.as_str()
    }
}

/// A field as `meta.json` shows it: strings bare, other values as their JSON, `None` for
/// no value (or `null`).
pub fn shown<T: Serialize>(v: &Option<T>) -> Option<String> {
    match serde_json::to_value(v.as_ref()?).ok()? {
        Value::Null => None,
        Value::String(s) => Some(s),
        v => Some(v.to_string()),
    }
}
