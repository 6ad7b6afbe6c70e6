//! The history of batches: after every `run` and `merge` the batch is appended to
//! an SQLite database (`db`), read back from the finished run folder's `meta.json` and
//! `summary.csv` so that both verbs share one path. The trend page of a config's batches is
//! the report's (`report::trend`): whoever appends renders it into [`trend_dir`] from the
//! database the append leaves open ([`Recorded`]), and `mapbench history` anywhere.

mod claim_rows;
pub mod db;
mod error;
mod run_row;

use crate::paths::absolute;
#[cfg(test)]
use crate::plan::paths::resolve_path;
pub use claim_rows::{started_holding, stopped_holding, ClaimRow};
pub use db::{BatchRow, HistoryDb, Source, SCHEMA_VERSION};
pub use error::HistoryError;
pub use run_row::RunRow;

use crate::run_folder::meta::Meta;
use crate::run_folder::{meta_json, read_summary};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// `--history PATH` / `--no-history`, applied over what the config resolved to.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HistoryChoice {
    /// The config's `history` key, else [`crate::plan::paths::DEFAULT_PATH`].
    #[default]
    FromConfig,
    Path(PathBuf),
    Off,
}

impl HistoryChoice {
    pub fn from_flags(path: Option<PathBuf>, off: bool) -> HistoryChoice {
        match (path, off) {
            (_, true) => HistoryChoice::Off,
            (Some(p), false) => HistoryChoice::Path(p),
            (None, false) => HistoryChoice::FromConfig,
        }
    }

    /// The database to append to, given what the config resolves to.
    pub fn apply(&self, from_config: PathBuf) -> Option<PathBuf> {
        match self {
            HistoryChoice::FromConfig => Some(from_config),
            HistoryChoice::Path(p) => Some(p.clone()),
            HistoryChoice::Off => None,
        }
    }
}

/// Where `run` and `merge` render the trend page of `config` after appending to `db`:
/// `<db folder>/<db stem>-trend/<config>/` (`reports/history-trend/param/` by default).
pub fn trend_dir(db: &Path, config: &str) -> PathBuf {
    let stem = db.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "history".into());
    db.parent().unwrap_or(Path::new("")).join(format!("{stem}-trend")).join(config)
}

/// The hash of what a batch ran (16 hex digits of FNV-1a): the config as read without its
/// `history` key, each energy's resolved settings, the planned runs and the repeat count,
/// all from `meta.json` (serde_json keeps object keys sorted, so the text is canonical).
pub fn config_hash(meta: &Meta) -> String {
    let mut config = meta.config.clone();
    if let Some(c) = config.as_object_mut() {
        c.remove("history");
    }
    let value = |part: Result<Value, serde_json::Error>| part.unwrap_or(Value::Null);
    let parts = [
        config,
        value(serde_json::to_value(&meta.settings_per_energy)),
        value(serde_json::to_value(&meta.plan)),
        value(serde_json::to_value(&meta.only)),
        value(serde_json::to_value(meta.repeat)),
    ];
    let mut h = crate::hash::Fnv::new();
    for part in &parts {
        h.bytes(part.to_string().as_bytes());
    }
    format!("{:016x}", h.0)
}

/// The `batches` row of a run folder, from its `meta.json`.
pub fn batch_row(run_dir: &Path, meta: &Meta) -> Result<BatchRow, HistoryError> {
    let path = meta_json(run_dir);
    let config_name = meta
        .config_name()
        .ok_or_else(|| HistoryError::Meta { path: path.clone(), what: "no config.name".into() })?
        .to_string();
    let int = |n: Option<usize>| n.and_then(|n| i64::try_from(n).ok());
    let unix = |n: Option<u64>| n.and_then(|n| i64::try_from(n).ok());
    let source = if meta.merged_from.is_some() { Source::Merge } else { Source::Run };
    let recorded =
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs() as i64).unwrap_or(0);
    Ok(BatchRow {
        id: 0,
        config_hash: config_hash(meta),
        config_name,
        started_unix: unix(meta.started_unix),
        ended_unix: unix(meta.ended_unix),
        git_revision: meta.git_revision.clone(),
        git_dirty: meta.git_dirty,
        host: meta.host.clone(),
        cores: int(meta.cores),
        jobs: int(meta.jobs),
        threads_per_run: int(meta.threads_per_run),
        repeats: int(meta.repeat),
        calibration_median_s: meta.calibration_median_s,
        calibration_spread: meta.calibration_spread,
        run_dir: absolute(run_dir).display().to_string(),
        recorded_unix: recorded,
        source,
    })
}

/// A run folder's `meta.json`.
pub fn read_meta(run_dir: &Path) -> Result<Meta, HistoryError> {
    Ok(Meta::read(run_dir)?)
}

/// What [`record`] appended, and the database still open: the caller renders the config's
/// trend page from it (into [`trend_dir`]).
pub struct Recorded {
    pub history: HistoryDb,
    pub batch_id: i64,
    pub runs: usize,
    pub config: String,
}

/// Append the finished run folder `run_dir` to the database at `db` (created when absent)
/// in one transaction.
pub fn record(db: &Path, run_dir: &Path) -> Result<Recorded, HistoryError> {
    insert(db, run_dir, run_dir)
}

/// [`record`], the run folder recorded as `recorded_as` (where a merged folder is moved).
fn insert(db: &Path, folder: &Path, recorded_as: &Path) -> Result<Recorded, HistoryError> {
    let meta = read_meta(folder)?;
    let mut batch = batch_row(folder, &meta)?;
    batch.run_dir = absolute(recorded_as).display().to_string();
    let summary = read_summary(folder)?;
    let runs: Vec<RunRow> = summary.iter().map(RunRow::from_summary).collect();
    // The papers' claims this config answers, decided over the folder as it will be recorded.
    let claims = crate::claims::Folder { config: batch.config_name.clone(), dir: absolute(recorded_as), rows: summary };
    let claims = crate::claims::for_folder(&claims).map_err(|e| HistoryError::Claims(e.to_string()))?;
    let mut history = HistoryDb::open_or_create(db)?;
    let batch_id = history.insert_batch(&batch, &runs, &ClaimRow::of(&claims))?;
    Ok(Recorded { history, batch_id, runs: runs.len(), config: batch.config_name })
}

/// What became of a batch in the history: `meta.json`'s `history_outcome`, and what `run` and
/// `merge` print (the book's "The history database").
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "outcome", rename_all = "snake_case")]
pub enum HistoryOutcome {
    /// No database: `--no-history`, or a `--shard` batch (`merge` appends the whole batch).
    #[default]
    Off,
    /// Not appended, and why: interrupted, planned runs missing.
    NotAppended { db: PathBuf, reason: String },
    /// Appending failed: nothing of the batch is in the database.
    Failed { db: PathBuf, error: String },
    /// Appended as batch `batch_id`. `trend` is the config's trend page, or `trend_error`
    /// says why it was not rendered (the batch is in the database either way).
    Appended {
        db: PathBuf,
        batch_id: i64,
        runs: usize,
        config: String,
        trend: Option<PathBuf>,
        trend_error: Option<String>,
    },
    /// Already in the database as batch `batch_id`, appended by an earlier `run` or `merge`
    /// of this folder (a `--resume` that resumed every run, a merge of the same shards):
    /// not appended twice.
    AlreadyIn { db: PathBuf, batch_id: i64, trend: Option<PathBuf> },
}

/// What to do with a finished batch.
#[derive(Clone, Debug, PartialEq)]
pub enum Decision {
    Append,
    /// Not appended, for this reason.
    Skip(String),
    /// It is in the database already ([`HistoryOutcome::in_history`] of the folder's earlier outcome).
    AlreadyIn {
        batch_id: i64,
        trend: Option<PathBuf>,
    },
}

impl HistoryOutcome {
    /// Carry out `decision` for the finished run folder `folder` and the database `db` (none:
    /// [`HistoryOutcome::Off`]): append the batch, its run folder recorded as `recorded_as` (where
    /// the folder is moved after a merge). What happened to the database is the outcome. An
    /// appended batch comes with the database still open: the caller renders its config's
    /// trend page, says how that went ([`HistoryOutcome::set_trend`]) and then records the outcome
    /// in the folder ([`HistoryOutcome::write_into`]).
    pub fn conclude(
        db: Option<&Path>,
        folder: &Path,
        recorded_as: &Path,
        decision: Decision,
    ) -> (HistoryOutcome, Option<Recorded>) {
        match (db, decision) {
            (None, _) => (HistoryOutcome::Off, None),
            (Some(db), Decision::Skip(reason)) => (HistoryOutcome::NotAppended { db: absolute(db), reason }, None),
            (Some(db), Decision::AlreadyIn { batch_id, trend }) => {
                (HistoryOutcome::AlreadyIn { db: absolute(db), batch_id, trend }, None)
            }
            (Some(db), Decision::Append) => match insert(db, folder, recorded_as) {
                Ok(r) => {
                    let (batch_id, runs, config) = (r.batch_id, r.runs, r.config.clone());
                    let appended = HistoryOutcome::Appended {
                        db: absolute(db),
                        batch_id,
                        runs,
                        config,
                        trend: None,
                        trend_error: None,
                    };
                    (appended, Some(r))
                }
                Err(e) => (HistoryOutcome::Failed { db: absolute(db), error: e.to_string() }, None),
            },
        }
    }

    /// An appended batch's trend page: the page rendered, or why it was not (the batch is
    /// in the database either way).
    pub fn set_trend(&mut self, rendered: Result<PathBuf, HistoryError>) {
        if let HistoryOutcome::Appended { trend, trend_error, .. } = self {
            (*trend, *trend_error) = match rendered {
                Ok(page) => (Some(absolute(&page)), None),
                Err(e) => (None, Some(e.to_string())),
            };
        }
    }

    /// Take an appended batch out of the database again (its folder could not be put in
    /// place). The database stays open for the caller to render the config's trend page
    /// without it; `None` when nothing was appended.
    pub fn withdraw(&self) -> Result<Option<HistoryDb>, HistoryError> {
        let HistoryOutcome::Appended { db, batch_id, .. } = self else { return Ok(None) };
        let history = HistoryDb::open_existing(db)?;
        history.remove_batch(*batch_id)?;
        Ok(Some(history))
    }

    /// The database and batch id when the batch is in the history (appended now or before).
    pub fn in_history(&self) -> Option<(&Path, i64, Option<&PathBuf>)> {
        match self {
            HistoryOutcome::Appended { db, batch_id, trend, .. }
            | HistoryOutcome::AlreadyIn { db, batch_id, trend } => Some((db, *batch_id, trend.as_ref())),
            _ => None,
        }
    }

    /// The `history` key of `meta.json`: the database when the batch is in it.
    pub fn meta_history(&self) -> Option<String> {
        self.in_history().map(|(db, ..)| db.display().to_string())
    }

    /// Record the outcome in `folder`'s `meta.json`: `history` (the database when the batch
    /// is in it, else null) and `history_outcome`. Its error is only a `meta.json` that cannot
    /// be written.
    pub fn write_into(&self, folder: &Path) -> Result<(), HistoryError> {
        let mut meta = read_meta(folder)?;
        meta.history = self.meta_history();
        meta.history_outcome = serde_json::to_value(self).ok();
        Ok(meta.write(folder)?)
    }

    /// The outcome a run folder's `meta.json` records (`None`: no meta, or a batch from
    /// before outcomes were recorded).
    pub fn of_folder(run_dir: &Path) -> Option<HistoryOutcome> {
        serde_json::from_value(read_meta(run_dir).ok()?.history_outcome?).ok()
    }
}

#[cfg(test)]
mod tests;
