//! What can go wrong with the history: one error for the database (`db.rs`) and for reading
//! a run folder into it (`mod.rs`).

use crate::run_folder::meta::MetaError;
use crate::run_folder::FolderError;
use std::path::PathBuf;
use thiserror::Error;

/// What can go wrong with the history; every error names the database or the file. The
/// underlying error is part of the message (not a `source`), so it is printed once.
#[derive(Debug, Error)]
pub enum HistoryError {
    #[error("{}: {err}", path.display())]
    Sql { path: PathBuf, err: rusqlite::Error },
    #[error("{}: run {run}: {err}", path.display())]
    Run { path: PathBuf, run: String, err: rusqlite::Error },
    #[error(
        "{}: history schema version {found} is newer than this mapbench's ({supported}); \
         use a newer mapbench or another --history file",
        path.display()
    )]
    Newer { path: PathBuf, found: i64, supported: i64 },
    #[error(
        "{}: history schema version {found} is negative: not a mapbench history (mapbench numbers its schemas 1, 2, ...)",
        path.display()
    )]
    BadVersion { path: PathBuf, found: i64 },
    #[error("{}: an SQLite database with tables but no mapbench schema version: not a mapbench history", path.display())]
    Foreign { path: PathBuf },
    #[error("{}: an empty file, not a history yet (a `run` or `merge` creates one)", path.display())]
    Empty { path: PathBuf },
    #[error("{}: no history database (a `run` or `merge` creates it)", path.display())]
    Missing { path: PathBuf },
    #[error("{}: {what}: {err}", path.display())]
    Io { path: PathBuf, what: &'static str, err: std::io::Error },
    #[error("{}: {what}", path.display())]
    Meta { path: PathBuf, what: String },
    #[error(transparent)]
    Folder(#[from] FolderError),
    #[error(transparent)]
    MetaFile(#[from] MetaError),
    #[error("the papers' claims: {0}")]
    Claims(String),
    #[error("trend page {}: {err:#}", path.display())]
    Render { path: PathBuf, err: anyhow::Error },
}
