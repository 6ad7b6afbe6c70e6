//! `runs/<run>.json`: the sidecar that marks a run finished, with its `--resume` key and its
//! summary row. Written last, after the run's other files.

use super::{write_atomic, SummaryRow};
use anyhow::Result;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The sidecar of a finished run.
#[derive(Debug, Serialize, Deserialize)]
pub struct Sidecar {
    pub key: String,
    pub summary: SummaryRow,
}

/// `runs/<run>.json`.
pub fn path(out_dir: &Path, stem: &str) -> PathBuf {
    super::runs_dir(out_dir).join(format!("{stem}.json"))
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
