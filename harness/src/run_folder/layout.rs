//! Where the files of a run folder live: `summary.csv`, `meta.json`, the `runs/` folder of the
//! per-iteration CSVs and sidecars, `external/`.

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
