//! The run folder and every file in it (docs/src/reference/run-folder.md): `summary.csv`,
//! `meta.json`, `runs/<run>.csv` (per iteration) and `runs/<run>.json` (the resume sidecar),
//! `uv/<run>.uv.gz` (the final map's UVs) with `meshes/<dataset>.obj.gz` (the mesh they map, once
//! per dataset; `map.rs`), the maps that `maps` keeps (`keep.rs`). This module owns their names
//! and formats; files are
//! written atomically (temporary file + rename), so an interrupted batch never leaves a
//! half-written run.

mod error;
pub mod iterations;
pub mod keep;
pub mod map;
pub mod meta;
pub mod reuse;
pub mod sidecar;
pub mod status;
pub mod summary;
pub mod timed;

pub use crate::names::run_stem;
pub use error::FolderError;
pub use iterations::{iteration_csv, read_iterations, read_run, IterationFile, ITERATION_COLUMNS};
pub use summary::{read_summary, write_summary, Status, SummaryRow, SummaryWriter, SUMMARY_COLUMNS};

use anyhow::{bail, Context, Result};
use solvers::solver::IterationRecord;
use std::path::{Path, PathBuf};

/// `summary.csv` of a run folder.
pub fn summary_csv(dir: &Path) -> PathBuf {
    dir.join("summary.csv")
}

/// `meta.json` of a run folder.
pub fn meta_json(dir: &Path) -> PathBuf {
    dir.join("meta.json")
}

/// The folder of the per-iteration CSVs and sidecars.
pub fn runs_dir(dir: &Path) -> PathBuf {
    dir.join("runs")
}

/// `external/`: the problem folders of external runs (`external/<run>/`, removed after the run
/// unless the solver's `keep_problem`) and their output (`external/<run>.stdout.txt`,
/// `.stderr.txt`).
pub fn external_dir(dir: &Path) -> PathBuf {
    dir.join("external")
}

/// `runs/<run>.csv`, the per-iteration rows of a run.
pub fn iterations_csv(dir: &Path, stem: &str) -> PathBuf {
    runs_dir(dir).join(format!("{stem}.csv"))
}

/// The final map of a finished run, encoded for its files.
pub struct MapBytes<'a> {
    pub dataset: &'a str,
    /// `uv/<run>.uv.gz`.
    pub uv: &'a [u8],
    /// `meshes/<dataset>.obj.gz`, when this batch has not written it yet.
    pub mesh: Option<&'a [u8]>,
}

/// The files of a finished run, as the batch writes them.
pub struct RunFiles<'a> {
    pub stem: &'a str,
    pub summary: &'a SummaryRow,
    pub rows: &'a [IterationRecord],
    /// The final map, when the run has one and the folder keeps maps.
    pub map: Option<MapBytes<'a>>,
    /// The run's `--resume` key: given, the sidecar is written last.
    pub key: Option<&'a str>,
}

/// Write a run's files: its map (when it has one), its per-iteration CSV and, given the run's
/// key, the sidecar that marks it finished, written last. On an error nothing of this run is
/// left that `--resume` or the report would take for a result.
pub fn write_run(dir: &Path, run: &RunFiles) -> Result<()> {
    let map = map::uv_path(dir, run.stem);
    let written = (|| {
        if let Some(m) = &run.map {
            if let Some(mesh) = m.mesh {
                write_atomic(&map::mesh_path(dir, m.dataset), mesh)?;
            }
            write_atomic(&map, m.uv)?;
            // A previous batch's map of this run in the old format is stale now.
            let _ = std::fs::remove_file(map::legacy_obj_path(dir, run.stem));
        }
        // With this run's own best; `report::refresh` fills in the group's best at the end.
        let own_best = run.rows.iter().map(|x| x.energy).fold(f64::INFINITY, f64::min);
        write_atomic(&iterations_csv(dir, run.stem), &iteration_csv(run.rows, own_best, None, None)?)?;
        if let Some(k) = run.key {
            sidecar::write(dir, run.stem, k, run.summary)?;
        }
        // Finished: a partial state of an interrupted batch is over.
        sidecar::remove_partial(dir, run.stem);
        Ok(())
    })();
    if written.is_err() {
        if run.map.is_some() {
            let _ = std::fs::remove_file(&map);
        }
        // A previous batch's sidecar would vouch for files that are now a mix.
        if run.key.is_some() {
            let _ = std::fs::remove_file(sidecar::path(dir, run.stem));
        }
    }
    written
}

/// The files and folders of a run folder that mapbench writes (a verb's output named by the
/// user must not be one of them: see [`owner`]).
pub const OWN_ENTRIES: [&str; 9] =
    ["summary.csv", "meta.json", "index.html", "runs", "uv", "meshes", "plots", "tables", "external"];

/// The folder `mapbench submit` keeps its scripts, shard plan and shard folders in, inside the
/// folder the shards are merged into. Not one of [`OWN_ENTRIES`]: a merge or `--force` leaves it.
pub const SUBMISSION_DIR: &str = "slurm";

/// Whether `dir` is a run folder: it has the `meta.json` and `summary.csv` every batch writes.
pub fn is_run_folder(dir: &Path) -> bool {
    meta_json(dir).is_file() && summary_csv(dir).is_file()
}

/// The run folder whose own file (or folder, [`OWN_ENTRIES`]) `path` is, links followed:
/// `B/summary.csv`, `B/runs/x.csv`, `B/new/../summary.csv`, a link to any of them (a dangling
/// one too). `None` for any other path, a new file beside them included.
pub fn owner(path: &Path) -> Option<PathBuf> {
    owner_within(path, 8)
}

fn owner_within(path: &Path, links: usize) -> Option<PathBuf> {
    // A link is judged by where it points (`write_atomic` writes through it), also when its
    // target does not exist yet.
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) && links > 0 {
        let target = std::fs::read_link(path).ok()?;
        let target = path.parent().map_or(target.clone(), |p| p.join(&target));
        return owner_within(&target, links - 1);
    }
    // The path as the OS resolves it: its longest existing part, links followed, then the
    // rest with `.` and `..` applied.
    let resolved = path.ancestors().find_map(|a| {
        let existing = if a.as_os_str().is_empty() { Path::new(".") } else { a };
        Some(crate::paths::absolute(&std::fs::canonicalize(existing).ok()?.join(path.strip_prefix(a).ok()?)))
    })?;
    resolved.ancestors().skip(1).find_map(|dir| {
        let first = resolved.strip_prefix(dir).ok()?.components().next()?;
        (OWN_ENTRIES.iter().any(|e| first.as_os_str() == *e) && is_run_folder(dir)).then(|| dir.to_path_buf())
    })
}

/// Write `bytes` to `path`: atomically (a temporary file in the same folder, then rename) when
/// `path` is new or a regular file; through it when it is a symlink, a FIFO, a character
/// device or a socket, which a rename would replace (a link broken and its target never
/// written; as root, `/dev/stdout` replaced by a file). A link is written through whatever
/// it points to (`/dev/stdout` to the open standard output, not to the file behind it).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(_) if path.is_dir() => bail!("{}: is a folder", path.display()),
        Ok(m) if !m.is_file() => return write_through(path, bytes),
        _ => {}
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create folder", dir.display()))?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp: PathBuf = dir.join(format!(".{name}.tmp{}", std::process::id()));
    // Errors name `path`, the file the caller asked for; a failed write leaves no temporary.
    let written = std::fs::write(&tmp, bytes)
        .with_context(|| format!("{}: cannot write (temporary file {})", path.display(), tmp.display()))
        .and_then(|()| {
            std::fs::rename(&tmp, path).with_context(|| format!("{}: cannot rename into place", path.display()))
        });
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

/// Open `path` for writing (following links, creating a missing target) and write `bytes`.
fn write_through(path: &Path, bytes: &[u8]) -> Result<()> {
    use std::io::Write;
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .open(path)
        .with_context(|| format!("{}: cannot open for writing", path.display()))?;
    f.write_all(bytes).and_then(|()| f.flush()).with_context(|| format!("{}: cannot write", path.display()))
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
