//! What can be wrong with a run folder's files: every error names the file, and the line and
//! column where there is one.

use crate::names::NameError;
use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum FolderError {
    #[error("{}: cannot read", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// mapbench ends every row with a line end: a last row without one was cut, and its last
    /// cell may still parse (as a shorter number).
    #[error("{}: line {line}: the row has no line end: the file was cut", path.display())]
    Cut { path: PathBuf, line: usize },
    /// A problem at a line: a bad cell (its column named), a row of the wrong length, a
    /// header without a column mapbench writes.
    #[error("{}: line {line}: {what}", path.display())]
    Line { path: PathBuf, line: u64, what: String },
    #[error("{}: {what}", path.display())]
    File { path: PathBuf, what: String },
    #[error(
        "{}: {rows} rows, but summary.csv says {iterations} iterations, which is {} rows with iteration 0: \
         the file is incomplete or not this run's",
        path.display(),
        iterations + 1
    )]
    RowCount { path: PathBuf, rows: usize, iterations: usize },
    /// A summary row whose name would become a file name outside the run folder.
    #[error("{}: line {line}", path.display())]
    Name {
        path: PathBuf,
        line: u64,
        #[source]
        source: NameError,
    },
}
