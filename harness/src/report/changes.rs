//! What changed between two batches of one config in the history database, by the rules of
//! `check` (iterations, status, final energy, flips, the final gap), with each solver's
//! solved count then and now and the runs only one batch has. The report's first screen
//! (`html/changes.rs`), the trend page and `history --fail-on-regression` read it.

use crate::gate::check::{self, Baseline, Comparison, DEFAULT_ENERGY_RTOL};
use crate::gate::rules::GatedRun;
use crate::history::{started_holding, stopped_holding, BatchRow, ClaimRow, HistoryDb, HistoryError, RunRow};
use crate::run_folder::Status;

/// One solver's solved runs out of its runs that were not skipped, in each batch (`None`:
/// the solver has no such run there).
#[derive(Clone, Debug, PartialEq)]
pub struct Solved {
    pub solver: String,
    pub before: Option<(usize, usize)>,
    pub after: Option<(usize, usize)>,
}

impl Solved {
    pub fn changed(&self) -> bool {
        self.before != self.after
    }
}

/// From one batch to the next of a config.
#[derive(Clone, Debug)]
pub struct Changes {
    pub before: BatchRow,
    pub after: BatchRow,
    pub comparison: Comparison,
    /// Runs of `after` that `before` does not have (`dataset task energy solver`).
    pub added: Vec<String>,
    pub solved: Vec<Solved>,
    /// The papers' claims that held before and do not now, and those that hold now and did
    /// not (by the same rule); empty where the history has no claims of a batch.
    pub claims_lost: Vec<ClaimRow>,
    pub claims_won: Vec<ClaimRow>,
}

impl Changes {
    pub fn between(before: (&BatchRow, &[RunRow]), after: (&BatchRow, &[RunRow])) -> Changes {
        let (b, b_runs) = before;
        let (a, a_runs) = after;
        let base = Baseline { energy_rtol: DEFAULT_ENERGY_RTOL, runs: b_runs.iter().map(record).collect() };
        let now: Vec<GatedRun> = a_runs.iter().map(record).collect();
        let comparison = check::compare(&base, &now);
        let added = now.iter().filter(|r| !base.runs.iter().any(|p| p.key() == r.key())).map(GatedRun::label).collect();
        let solvers = crate::report::select::unique(b_runs.iter().chain(a_runs).map(|r| r.solver.as_str()));
        let solved = solvers
            .into_iter()
            .map(|s| Solved { solver: s.to_string(), before: solved_count(b_runs, s), after: solved_count(a_runs, s) })
            .collect();
        Changes {
            before: b.clone(),
            after: a.clone(),
            comparison,
            added,
            solved,
            claims_lost: Vec::new(),
            claims_won: Vec::new(),
        }
    }

    /// The two batches ran different configs or plans: changes may come from the settings.
    pub fn settings_differ(&self) -> bool {
        self.before.config_hash != self.after.config_hash
    }

    pub fn regressions(&self) -> usize {
        self.comparison.regressions()
    }

    pub fn improvements(&self) -> usize {
        self.comparison.improvements()
    }

    /// Nothing moved and no run came or went.
    pub fn is_quiet(&self) -> bool {
        self.comparison.changes.is_empty() && self.comparison.missing.is_empty() && self.added.is_empty()
    }
}

/// A solver's (solved, runs not skipped) in a batch: solved = `ok`, which for a judged run
/// is the harness's verdict at the target.
fn solved_count(runs: &[RunRow], solver: &str) -> Option<(usize, usize)> {
    let mine: Vec<&RunRow> = runs.iter().filter(|r| r.solver == solver && r.status != Status::Skipped).collect();
    (!mine.is_empty()).then(|| (mine.iter().filter(|r| r.status == Status::Ok).count(), mine.len()))
}

/// What `check`'s rules compare of a history row. SQLite keeps a NaN as NULL: a run that ran
/// without a final energy had a NaN one, and reads back as such (as `check` and `compare`
/// read it from `summary.csv`).
pub fn record(r: &RunRow) -> GatedRun {
    let ran = r.status.ran();
    GatedRun {
        dataset: r.dataset.clone(),
        task: r.task,
        energy: r.energy.clone(),
        solver: r.solver.clone(),
        iterations: r.iterations.and_then(|i| usize::try_from(i).ok()),
        final_energy: r.final_energy.or(ran.then_some(f64::NAN)),
        status: r.status,
        flips: r.flips.and_then(|i| usize::try_from(i).ok()),
        iterations_tolerance: None,
        time_s: r.time_s,
        final_gap: r.final_gap,
        ref_energy: r.ref_energy,
        start_energy: r.start_energy,
        ideal_energy: r.ideal_energy,
        target: r.target_tau,
        rule_iters: r.to_summary().rule_stop().map(|e| e.iters),
        target_iters: r.iters_to_target.and_then(|i| usize::try_from(i).ok()),
    }
}

/// Where batch `batch_id` stands in its config's history.
#[derive(Clone, Debug)]
pub enum Since {
    /// The first batch of the config in this database.
    First { config: String },
    /// The changes from the batch before it (in time order).
    Previous(Box<Changes>),
}

/// The changes of batch `batch_id` of `config` since the batch before it.
pub fn since_previous(db: &HistoryDb, config: &str, batch_id: i64) -> Result<Option<Since>, HistoryError> {
    let batches = db.batches(Some(config), None)?;
    let Some(at) = batches.iter().position(|b| b.id == batch_id) else { return Ok(None) };
    if at == 0 {
        return Ok(Some(Since::First { config: config.to_string() }));
    }
    let (before, after) = (&batches[at - 1], &batches[at]);
    let (b_runs, a_runs) = (db.runs(before.id)?, db.runs(after.id)?);
    let mut changes = Changes::between((before, &b_runs), (after, &a_runs));
    let (b_claims, a_claims) = (db.claims(before.id)?, db.claims(after.id)?);
    changes.claims_lost = stopped_holding(&b_claims, &a_claims).into_iter().cloned().collect();
    changes.claims_won = started_holding(&b_claims, &a_claims).into_iter().cloned().collect();
    Ok(Some(Since::Previous(Box::new(changes))))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run_folder::SummaryRow;

    /// SQLite keeps a NaN as NULL: a run that ran and reads back without a final energy had a
    /// NaN one, and the history's gate calls it a regression as `check` and `compare` do; a
    /// failed run's missing energy stays missing.
    #[test]
    fn a_nan_final_energy_in_the_history_is_a_regression_as_in_check() {
        let row = |e: Option<f64>, status: Status| {
            let s = SummaryRow {
                dataset: "d".into(),
                energy: "sd".into(),
                solver: "kp-newton".into(),
                iterations: Some(5),
                final_energy: Some(2.5),
                flips: Some(0),
                status,
                ..Default::default()
            };
            RunRow { final_energy: e, ..RunRow::from_summary(&s) }
        };
        let batch = BatchRow::default();
        let before = [row(Some(2.5), Status::NotConverged)];
        let after = [row(None, Status::NotConverged)];
        let c = Changes::between((&batch, &before), (&batch, &after));
        assert_eq!(c.regressions(), 1, "{:?}", c.comparison.changes);
        assert_eq!(c.comparison.changes[0].metric, "final_energy");
        assert!(record(&after[0]).final_energy.is_some_and(f64::is_nan));
        assert_eq!(record(&row(None, Status::Failed)).final_energy, None);
    }
}
