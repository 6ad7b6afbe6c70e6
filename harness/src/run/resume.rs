//! `run --resume`: every finished run leaves `runs/<run>.json` with a key of everything that
//! determines its result (code version, the run's resolved settings from the plan, the energy,
//! the solver, and the mesh and handle files' contents). A resumed batch reuses a run whose
//! key matches and whose files (per-iteration CSV, map) are intact, and runs the others.

use crate::hash::Fnv;
use crate::plan::config::Maps;
use crate::plan::{Plan, PlannedRun};
use crate::run_folder::{map, read_run, sidecar, SummaryRow};
use anyhow::Result;
use solvers::solver::IterationRecord;
use std::path::Path;

/// The key of one run (hex): `code` identifies the code (version and git revision), then
/// the run's resolved settings (task, energy parameters, stop, line search, linear, init,
/// smoothness, deform or authalic settings), the timeout and repeat count, the solver, a chained
/// start's map (its checksum), and the mesh and
/// handles it runs on (files by content).
pub fn run_key(plan: &Plan, run: &PlannedRun, code: &str) -> Result<String> {
    let ds = plan.dataset(run);
    // The repeat count too: a median over another number of repeats is another measurement.
    let settings = format!("{} timeout={:?} repeat={}", run.settings.key_text(), plan.timeout, plan.repeat);
    let (energy, solver) = (&run.energy, &run.solver);
    let mut h = Fnv::new();
    h.bytes(code.as_bytes()).bytes(settings.to_string().as_bytes()).bytes(energy.as_bytes()).bytes(solver.as_bytes());
    // A chained start is a map, not a setting: the SD minimum the batch resolved (it moves
    // when a run lowers the SD reference).
    if let Some(start) = plan.starts.of(plan, run) {
        let x = start.map_err(|e| anyhow::anyhow!("{}: the sd-minimum start: {e}", run.stem))?;
        h.bytes(crate::judge::reference::store::map_checksum(&x).as_bytes());
    }
    // An external solver: its command and snapshots (not whether its problem folder is kept),
    // and the contents of the files its command names (an adapter edited but not committed
    // is another solver).
    if let Some(declared) = plan.external(run) {
        let ran = crate::plan::external::Declared { keep_problem: false, ..declared.clone() };
        h.bytes(serde_json::to_string(&ran)?.as_bytes());
        for file in crate::external::child::absolute_in(&declared.command, &plan.config.dir) {
            if std::path::Path::new(&file).is_file() {
                h.file(std::path::Path::new(&file))?;
            }
        }
    }
    ds.hash_into(&mut h)?;
    Ok(format!("{:016x}", h.0))
}

/// The finished run `stem` if its sidecar has `key` and all its files are intact: the CSV
/// reads back completely and its map, where the folder has one, reads back too. With
/// `maps = "all"` a run that produced a map (every run with iterations, see
/// `run::one::run_one`) must have it; otherwise the batch's end decides which maps stay
/// (`run_folder::keep`). Otherwise the run runs again.
pub fn previous(out_dir: &Path, stem: &str, key: &str, maps: Maps) -> Option<(SummaryRow, Vec<IterationRecord>)> {
    let side = sidecar::read(out_dir, stem)?;
    if side.key != key {
        return None;
    }
    let rows = read_run(out_dir, &side.summary).ok()?.rows;
    // A run that finished has its final row; a failed run has none.
    let expected = side.summary.iterations.map_or(0, |i| i + 1);
    if rows.len() != expected {
        return None;
    }
    if side.summary.iterations.is_some() {
        let map = map::read(out_dir, &side.summary.dataset, stem).ok()?;
        if map.is_none() && maps == Maps::All {
            return None;
        }
    }
    Some((side.summary, rows))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_stable_hex_and_separate_fields() {
        let mut a = Fnv::new();
        a.bytes(b"ab").bytes(b"c");
        let mut b = Fnv::new();
        b.bytes(b"a").bytes(b"bc");
        assert_ne!(a.0, b.0);
        let mut c = Fnv::new();
        c.bytes(b"ab").bytes(b"c");
        assert_eq!(a.0, c.0);
    }
}
