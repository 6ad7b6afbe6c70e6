//! `energy_minus_best` of the per-iteration files: each run's energies against the lowest
//! energy any finished run of its (dataset, energy) group reached
//! (docs/src/reference/columns.md). Runs finish in any order, in shards or resumed, so the
//! column is filled once they are all on disk, by the batch (`run`, `merge`) that wrote them;
//! the report only reads it.

use super::atomic::write_atomic;
use super::iterations::{iteration_csv, read_run};
use super::summary::SummaryRow;
use crate::names::run_stem;
use anyhow::Result;
use solvers::solver::IterationRecord;
use std::collections::BTreeMap;
use std::path::Path;

/// The per-iteration rows of each run of a group, by run stem, with the reference minimum the
/// run is judged by and the span of its gaps.
type Group = Vec<(String, Vec<IterationRecord>, (Option<f64>, Option<f64>))>;

/// Rewrite `runs/<run>.csv` of every finished run of `summary` with `energy_minus_best` from
/// its group's lowest finite energy. A file whose content would not change is left alone.
pub fn fill_energy_minus_best(run_dir: &Path, summary: &[SummaryRow]) -> Result<()> {
    let mut groups: BTreeMap<(&str, &str), Group> = BTreeMap::new();
    for s in summary.iter().filter(|s| s.status.ran()) {
        let stem = run_stem(&s.dataset, &s.energy, &s.solver);
        let rows = read_run(run_dir, s)?.rows;
        groups.entry((&s.dataset, &s.energy)).or_default().push((stem, rows, (s.ref_energy, s.gap_scale)));
    }
    for runs in groups.values() {
        let best = runs
            .iter()
            .flat_map(|(_, r, _)| r.iter().map(|x| x.energy))
            .filter(|e| e.is_finite())
            .fold(f64::INFINITY, f64::min);
        if !best.is_finite() {
            continue;
        }
        for (stem, rows, (e_star, gap_scale)) in runs {
            let path = run_dir.join("runs").join(format!("{stem}.csv"));
            let bytes = iteration_csv(rows, best, *e_star, *gap_scale)?;
            if std::fs::read(&path).ok().as_deref() != Some(&bytes[..]) {
                write_atomic(&path, &bytes)?;
            }
        }
    }
    Ok(())
}
