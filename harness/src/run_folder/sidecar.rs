//! `runs/<run>.json`: the sidecar that marks a run finished, with its `--resume` key and its
//! summary row. Written last, after the run's other files.

use super::atomic::write_atomic;
use super::iterations::{extra_columns, iteration_csv, read_iterations};
use super::layout::runs_dir;
use super::summary::SummaryRow;
use anyhow::Result;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use solvers::solver::IterationRecord;
use std::path::{Path, PathBuf};

/// The sidecar of a finished run.
#[derive(Debug, Serialize, Deserialize)]
pub struct Sidecar {
    pub key: String,
    pub summary: SummaryRow,
}

/// `runs/<run>.json`.
pub fn path(out_dir: &Path, stem: &str) -> PathBuf {
    runs_dir(out_dir).join(format!("{stem}.json"))
}

/// Write the sidecar of a finished run.
pub fn write(out_dir: &Path, stem: &str, key: &str, summary: &SummaryRow) -> Result<()> {
    let json = serde_json::to_string_pretty(&Sidecar { key: key.to_string(), summary: summary.clone() })?;
    write_atomic(&path(out_dir, stem), json.as_bytes())
}

/// The sidecar of `stem`, if it reads back.
pub fn read(out_dir: &Path, stem: &str) -> Option<Sidecar> {
    let text = std::fs::read_to_string(path(out_dir, stem)).ok()?;
    serde_json::from_str(&text).ok()
}

/// A run whose repeats an interrupt cut short: `runs/<run>.partial.json` (its key, its first
/// repeat's summary row and what its repeats measured) and `runs/<run>.partial.csv` (the
/// first repeat's rows, which every later repeat must reproduce). Not a finished run: no
/// summary row, no sidecar; `--resume` runs the missing repeats.
#[derive(Debug, Serialize, Deserialize)]
pub struct Partial<R> {
    pub key: String,
    pub summary: SummaryRow,
    pub repeats: R,
}

/// `runs/<run>.partial.json` and `runs/<run>.partial.csv`.
pub fn partial_paths(out_dir: &Path, stem: &str) -> [PathBuf; 2] {
    ["json", "csv"].map(|ext| runs_dir(out_dir).join(format!("{stem}.partial.{ext}")))
}

/// Write a partial run: its rows first, then the JSON that makes it resumable.
pub fn write_partial<R: Serialize>(
    out_dir: &Path,
    stem: &str,
    partial: &Partial<R>,
    rows: &[IterationRecord],
) -> Result<()> {
    let [json, csv] = partial_paths(out_dir, stem);
    write_atomic(&csv, &iteration_csv(rows, f64::NAN, None, None)?)?;
    write_atomic(&json, serde_json::to_string_pretty(partial)?.as_bytes())
}

/// The partial run `stem` when its key is `key` and both files read back.
pub fn read_partial<R: DeserializeOwned>(
    out_dir: &Path,
    stem: &str,
    key: &str,
) -> Option<(Partial<R>, Vec<IterationRecord>)> {
    let [json, csv] = partial_paths(out_dir, stem);
    let partial: Partial<R> = serde_json::from_str(&std::fs::read_to_string(json).ok()?).ok()?;
    if partial.key != key {
        return None;
    }
    let rows = read_iterations(&csv, extra_columns(&partial.summary.solver)).ok()?.rows;
    (Some(rows.len()) == partial.summary.iterations.map(|n| n + 1)).then_some((partial, rows))
}

/// Remove a run's partial files (it finished, or runs anew).
pub fn remove_partial(out_dir: &Path, stem: &str) {
    for p in partial_paths(out_dir, stem) {
        let _ = std::fs::remove_file(p);
    }
}
