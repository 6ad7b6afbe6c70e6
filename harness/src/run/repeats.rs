//! Repeats of one run (`repeat = N`): every repeat must reproduce the first one's iterates
//! bit for bit. One that does not is non-determinism: the run keeps repeat 1's result (and
//! verdict), its `repeats_differ` says where they parted, the report flags it, and no further
//! repeat runs. The run's times are the median over the repeats that agreed with their min
//! and max, and each timing column of the per-iteration CSV is the median of that row over
//! them.

use super::one::{fill_times, RunResult};
use crate::run_folder::Status;
use crate::stats::median;
use solvers::solver::{IterationRecord, StopReason};

/// A ranked run is repeated when its time is within this factor of the fastest ranked run of
/// its problem: the machine's noise (40% between batches) cannot make a run twice as slow as
/// another tie with it, so repeats would not change which runs tie.
pub const REPEAT_WITHIN: f64 = 2.0;

/// Which of the runs whose first results are `firsts` (with their problem: dataset and energy)
/// are worth repeating: those [`Repeats::ranked`] whose time is within [`REPEAT_WITHIN`] of the
/// fastest ranked run of their problem. The rest keep their one sample.
pub fn worth_repeating(firsts: &[(&str, &str, &RunResult)]) -> Vec<bool> {
    let time = |r: &RunResult| r.summary.time_s.filter(|t| t.is_finite());
    let fastest = |d: &str, e: &str| {
        firsts
            .iter()
            .filter(|(d2, e2, r)| *d2 == d && *e2 == e && Repeats::ranked(r))
            .filter_map(|(_, _, r)| time(r))
            .reduce(f64::min)
    };
    firsts
        .iter()
        .map(|(d, e, r)| {
            Repeats::ranked(r) && time(r).zip(fastest(d, e)).is_some_and(|(t, best)| t <= REPEAT_WITHIN * best)
        })
        .collect()
}

/// The timing columns of one row: assemble, project, solve, line search, iteration,
/// cumulative, record-only.
type Timings = [f64; 7];

fn timings(r: &IterationRecord) -> Timings {
    [r.t_assemble_s, r.t_project_s, r.t_solve_s, r.t_linesearch_s, r.t_iter_s, r.t_cum_s, r.t_record_s]
}

/// What the repeats of one run measured so far; kept in `runs/<run>.partial.json` when an
/// interrupt cuts them short.
#[derive(Debug, serde::Serialize, serde::Deserialize)]
pub(super) struct Repeats {
    /// `time_s` of each repeat, the first one's first.
    times: Vec<f64>,
    /// Each repeat's timing columns, row by row.
    rows: Vec<Vec<Timings>>,
    /// Why a repeat did not reproduce the first (`repeats_differ`).
    mismatch: Option<String>,
    /// The largest peak resident set of the repeats (MiB), and the largest growth.
    peak_rss_mb: Option<f64>,
    peak_growth_mb: Option<f64>,
}

impl Repeats {
    /// Start from the run's first result.
    pub fn new(first: &RunResult) -> Repeats {
        Repeats {
            times: first.summary.time_s.into_iter().collect(),
            rows: vec![first.rows.iter().map(timings).collect()],
            mismatch: None,
            peak_rss_mb: first.summary.peak_rss_mb,
            peak_growth_mb: first.summary.peak_growth_mb,
        }
    }

    /// How many repeats were measured (the first included).
    pub fn count(&self) -> usize {
        self.times.len()
    }

    /// A repeat did not reproduce the first: no further repeat runs.
    pub fn mismatched(&self) -> bool {
        self.mismatch.is_some()
    }

    /// Why a repeat did not reproduce the first (empty when all did).
    pub fn why(&self) -> &str {
        self.mismatch.as_deref().unwrap_or("")
    }

    /// `time_s` of the latest repeat.
    pub fn last_time(&self) -> Option<f64> {
        self.times.last().copied()
    }

    /// A run may be repeated: it ran (converged or not), and its repeats agreed so far.
    pub fn wanted(first: &RunResult) -> bool {
        first.summary.status.ran() && first.summary.time_s.is_some()
    }

    /// Whether a run's time is one the report ranks: it ended at its target, by its own rule
    /// (a run without a target), or ran a fixed budget; a run that stalled, broke down or ran
    /// out of budget counts at the cap, whatever its time.
    pub fn ranked(first: &RunResult) -> bool {
        let s = &first.summary;
        let stop = s.stop_reason.as_ref().and_then(|r| r.solver());
        s.status == Status::Budget || stop.is_some_and(|r| *r == StopReason::Target || r.is_converged())
    }

    /// Add repeat `again` of the run whose first result is `first`; a repeat whose iterates
    /// differ records the first differing iteration.
    pub fn add(&mut self, first: &RunResult, again: &RunResult) {
        if self.mismatch.is_some() {
            return;
        }
        let n = self.times.len() + 1;
        if again.summary.status == Status::Failed {
            self.mismatch = Some(format!("repeat {n} failed where repeat 1 ran: {}", again.summary.error));
            return;
        }
        if let Some(what) = first_difference(&first.rows, &again.rows) {
            self.mismatch =
                Some(format!("repeat {n} does not reproduce repeat 1 ({what}): the solver is not deterministic"));
            return;
        }
        let larger = |a: Option<f64>, b: Option<f64>| match (a, b) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
        self.peak_rss_mb = larger(self.peak_rss_mb, again.summary.peak_rss_mb);
        self.peak_growth_mb = larger(self.peak_growth_mb, again.summary.peak_growth_mb);
        if let Some(t) = again.summary.time_s {
            self.times.push(t);
            self.rows.push(again.rows.iter().map(timings).collect());
        }
    }

    /// Write the repeats into the first result: `time_s` the median with its min and max,
    /// the timing columns per-row medians, the per-row statistics recomputed from them, over
    /// the repeats that reproduced the first; a mismatch in `repeats_differ`.
    pub fn apply(self, result: &mut RunResult) {
        let s = &mut result.summary;
        s.repeats_differ = self.mismatch;
        let mut times = self.times.clone();
        s.repeats = Some(times.len());
        s.time_s = median(&mut times);
        s.time_s_min = times.first().copied();
        s.time_s_max = times.last().copied();
        (s.peak_rss_mb, s.peak_growth_mb) = (self.peak_rss_mb, self.peak_growth_mb);
        for (i, row) in result.rows.iter_mut().enumerate() {
            let column =
                |c: usize| median(&mut self.rows.iter().filter_map(|r| r.get(i).map(|t| t[c])).collect::<Vec<_>>());
            let m: Vec<f64> = (0..7).map(|c| column(c).unwrap_or(f64::NAN)).collect();
            [row.t_assemble_s, row.t_project_s, row.t_solve_s, row.t_linesearch_s, row.t_iter_s, row.t_cum_s] =
                [m[0], m[1], m[2], m[3], m[4], m[5]];
            row.t_record_s = m[6];
        }
        fill_times(s, &result.rows);
    }
}

/// The first row where two runs' iterates differ (energy or gradient norm, bit for bit, or
/// the number of rows), described; `None` when they agree.
fn first_difference(a: &[IterationRecord], b: &[IterationRecord]) -> Option<String> {
    for (x, y) in a.iter().zip(b) {
        if x.energy.to_bits() != y.energy.to_bits() || x.grad_norm.to_bits() != y.grad_norm.to_bits() {
            return Some(format!(
                "first difference at iteration {}: energy {:e} vs {:e}, |grad| {:e} vs {:e}",
                x.iter, x.energy, y.energy, x.grad_norm, y.grad_norm
            ));
        }
    }
    (a.len() != b.len()).then(|| {
        format!(
            "{} iterations vs {}, first difference at iteration {}",
            a.len().saturating_sub(1),
            b.len().saturating_sub(1),
            a.len().min(b.len())
        )
    })
}

/// A run of the batch across its repeats: its first result, where it came from, and what
/// its repeats measured. Its files are written once its last repeat is in.
pub(super) struct Slot {
    pub first: RunResult,
    pub resumed: bool,
    pub key: Option<String>,
    pub repeats: Option<Repeats>,
}

impl Slot {
    /// Every repeat is in (or one did not reproduce the first, which fails the run).
    pub fn complete(&self, repeat: usize) -> bool {
        self.repeats.as_ref().is_none_or(|r| r.mismatched() || r.count() >= repeat)
    }

    /// Repeat `round + 1` (of round-robin round `round`) is this run's next.
    pub fn next_in(&self, round: usize) -> bool {
        self.repeats.as_ref().is_some_and(|r| !r.mismatched() && r.count() == round)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run_folder::SummaryRow;

    fn result(energies: &[f64], time: f64, t_iter: f64) -> RunResult {
        let rows = energies
            .iter()
            .enumerate()
            .map(|(i, &e)| IterationRecord {
                iter: i,
                energy: e,
                t_iter_s: t_iter,
                t_cum_s: t_iter * i as f64,
                t_record_s: t_iter / 4.0,
                ..Default::default()
            })
            .collect();
        let summary = SummaryRow {
            status: Status::Ok,
            iterations: Some(energies.len() - 1),
            vertices: Some(10),
            time_s: Some(time),
            ..Default::default()
        };
        RunResult { summary, rows, ..Default::default() }
    }

    #[test]
    fn the_median_min_and_max_are_over_repeats_and_timings_are_per_row_medians() {
        let with_peak = |mut r: RunResult, mb: f64| {
            r.summary.peak_rss_mb = Some(mb);
            r
        };
        let mut first = with_peak(result(&[3.0, 2.0, 1.0], 0.30, 0.1), 100.0);
        let mut r = Repeats::new(&first);
        r.add(&first, &with_peak(result(&[3.0, 2.0, 1.0], 0.10, 0.3), 120.0));
        r.add(&first, &with_peak(result(&[3.0, 2.0, 1.0], 0.20, 0.2), 110.0));
        assert_eq!(r.count(), 3);
        r.apply(&mut first);
        let s = &first.summary;
        assert_eq!((s.repeats, s.time_s, s.time_s_min, s.time_s_max), (Some(3), Some(0.20), Some(0.10), Some(0.30)));
        assert_eq!(first.rows[1].t_iter_s, 0.2);
        assert_eq!(first.rows[2].t_cum_s, 0.4);
        assert_eq!(first.rows[2].t_record_s, 0.05);
        assert_eq!(s.iter_ms_median, Some(200.0));
        assert_eq!(s.peak_rss_mb, Some(120.0), "the largest peak of the repeats");
        assert!((s.ms_per_vertex.unwrap() - 20.0).abs() < 1e-12);
        assert_eq!(s.status, Status::Ok);
    }

    /// A repeat that differs is flagged: the run keeps repeat 1's result and its status,
    /// the times of the repeats that agreed, and says where they parted.
    #[test]
    fn a_repeat_that_differs_is_flagged_and_the_run_keeps_repeat_1() {
        let mut first = result(&[3.0, 2.0, 1.0], 0.3, 0.1);
        let mut r = Repeats::new(&first);
        r.add(&first, &result(&[3.0, 2.0, 1.0], 0.1, 0.1));
        r.add(&first, &result(&[3.0, 2.0, 1.0 + 1e-15], 0.3, 0.1));
        assert!(r.mismatched());
        r.apply(&mut first);
        let s = &first.summary;
        assert_eq!((s.status, s.repeats, s.time_s_min), (Status::Ok, Some(2), Some(0.1)));
        assert!(s.error.is_empty());
        let d = s.repeats_differ.as_deref().unwrap_or_default();
        assert!(d.contains("repeat 3 does not reproduce repeat 1") && d.contains("iteration 2"), "{d}");
        assert_eq!(first.rows[2].energy, 1.0);

        let mut first = result(&[3.0, 2.0, 1.0], 0.3, 0.1);
        let mut r = Repeats::new(&first);
        r.add(&first, &result(&[3.0, 2.0], 0.3, 0.1));
        r.apply(&mut first);
        let d = first.summary.repeats_differ.as_deref().unwrap_or_default();
        assert!(d.contains("2 iterations vs 1, first difference at iteration 2"), "{d}");
        assert_eq!(first.summary.iterations, Some(2));
    }

    /// Runs whose times rank and are within twice the fastest of their problem are repeated;
    /// a run that ran out of budget, and one far slower than the fastest, keep one sample.
    #[test]
    fn repeats_go_to_the_runs_whose_times_decide_a_ranking() {
        let ended = |stop: StopReason, time: f64| {
            let mut r = result(&[3.0, 1.0], time, 0.1);
            r.summary.stop_reason = Some(crate::run_folder::RunStop::Solver(stop));
            r
        };
        let (fast, near, slow) =
            (ended(StopReason::Target, 1.0), ended(StopReason::Target, 1.9), ended(StopReason::Target, 2.5));
        let capped = ended(StopReason::MaxIterations, 1.2);
        let other = ended(StopReason::GradientTolerance, 9.0);
        let firsts = [
            ("a", "sd", &fast),
            ("a", "sd", &near),
            ("a", "sd", &slow),
            ("a", "sd", &capped),
            ("b", "sd", &other),
            ("a", "bconf", &slow),
        ];
        assert_eq!(worth_repeating(&firsts), [true, true, false, false, true, true]);
        let mut budget = ended(StopReason::MaxIterations, 1.0);
        budget.summary.status = Status::Budget;
        assert!(Repeats::ranked(&budget) && !Repeats::ranked(&capped));
    }

    #[test]
    fn only_runs_that_ran_are_repeated() {
        let mut failed = result(&[1.0], 0.1, 0.1);
        failed.summary.status = Status::Failed;
        assert!(!Repeats::wanted(&failed));
        failed.summary.status = Status::Skipped;
        assert!(!Repeats::wanted(&failed));
        let mut nc = result(&[1.0], 0.1, 0.1);
        nc.summary.status = Status::NotConverged;
        assert!(Repeats::wanted(&nc));
    }
}
