//! What can be wrong with a run folder's files: every error names the file, and the line and
//! column where there is one; a CSV file read into these errors.

use crate::names::NameError;
use std::path::{Path, PathBuf};

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

/// The bytes of a CSV file mapbench wrote, refused when its last row has no line end: every
/// row is written with one, so the file was cut mid-row (and its last cell may still parse,
/// as a shorter number).
pub fn read_csv_bytes(path: &Path) -> Result<Vec<u8>, FolderError> {
    let bytes = std::fs::read(path).map_err(|source| FolderError::Read { path: path.to_path_buf(), source })?;
    if bytes.last().is_some_and(|&b| b != b'\n') {
        let line = bytes.iter().filter(|&&b| b == b'\n').count() + 1;
        return Err(FolderError::Cut { path: path.to_path_buf(), line });
    }
    Ok(bytes)
}

/// A CSV reader error as `FILE: line N: what`; `header` names the column of a bad cell and
/// `record` (the row being deserialized) quotes it.
pub fn csv_error(
    path: &Path,
    header: Option<&csv::StringRecord>,
    record: Option<&csv::StringRecord>,
    e: &csv::Error,
) -> FolderError {
    use csv::ErrorKind;
    let column = |i: usize| match header.and_then(|h| h.get(i)) {
        Some(name) => format!("column {} `{name}`", i + 1),
        None => format!("column {}", i + 1),
    };
    let (pos, what) = match e.kind() {
        ErrorKind::Utf8 { pos, err } => (pos, format!("{}: not UTF-8 text", column(err.field()))),
        ErrorKind::UnequalLengths { pos, expected_len, len } => {
            (pos, format!("{len} cells where the header has {expected_len}: the row is cut or corrupt"))
        }
        ErrorKind::Deserialize { pos, err } => (
            pos,
            match err.field().map(|i| i as usize) {
                Some(i) => match record.and_then(|r| r.get(i)) {
                    Some(cell) => format!("{}: `{cell}`: {}", column(i), err.kind()),
                    None => format!("{}: {}", column(i), err.kind()),
                },
                None => err.kind().to_string(),
            },
        ),
        _ => (&None, e.to_string()),
    };
    let path = path.to_path_buf();
    match pos {
        Some(p) => FolderError::Line { path, line: p.line(), what },
        None => FolderError::File { path, what },
    }
}
