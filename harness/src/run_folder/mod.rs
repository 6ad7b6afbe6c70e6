//! The run folder and every file in it (docs/src/reference/run-folder.md): `summary.csv`,
//! `meta.json`, `runs/<run>.csv` (per iteration) and `runs/<run>.json` (the resume sidecar),
//! `uv/<run>.uv.gz` (the final map's UVs) with `meshes/<dataset>.obj.gz` (the mesh they map, once
//! per dataset; `map.rs`), the maps that `maps` keeps (`keep.rs`). This module owns their names
//! and formats; files are
//! written atomically (temporary file + rename), so an interrupted batch never leaves a
//! half-written run.

mod atomic;
mod best;
mod error;
pub mod iterations;
pub mod keep;
mod layout;
pub mod map;
mod maps_policy;
pub mod meta;
pub mod reuse;
mod run_stop;
pub mod sidecar;
pub mod status;
pub mod summary;
pub mod timed;
mod upgrade;

pub use crate::names::run_stem;
pub use atomic::write_atomic;
pub use best::fill_energy_minus_best;
pub use error::{csv_error, read_csv_bytes, FolderError};
pub use iterations::{iteration_csv, read_iterations, read_run, IterationFile, ITERATION_COLUMNS};
pub use layout::{external_dir, iterations_csv, meta_json, runs_dir, summary_csv};
pub use run_stop::{parse_stop, stop_text, RunStop, FAILED_STOP, SKIPPED_STOP};
pub use summary::{read_summary, write_summary, Status, SummaryRow, SummaryWriter, SUMMARY_COLUMNS};

use anyhow::Result;
use solvers::solver::IterationRecord;
use std::path::{Path, PathBuf};

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
pub const OWN_ENTRIES: [&str; 11] = [
    "summary.csv",
    "meta.json",
    "index.html",
    "explorer.html",
    "runs",
    "uv",
    "meshes",
    "plots",
    "tables",
    "explorer",
    "external",
];

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
