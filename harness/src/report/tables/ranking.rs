//! The one rule by which every table marks a value as best (bold), so that a mark is a claim
//! the data supports:
//!
//! - Only runs that reached the table's common stopping criterion compete: converged runs
//!   (`status = ok`, [`comparable`]). A failed, not converged or skipped run is never best.
//!   Fixed-budget tables (authalic, where every solver runs its `max_iters` as in the AEM
//!   paper) also admit runs that used the whole budget ([`comparable_at_budget`]).
//! - Counts and energies are deterministic: the lowest value is best, equal values tie.
//! - Times are noisy: the fastest (lowest median) is best, and every competitor whose
//!   `[time_s_min, time_s_max]` interval (over the repeats) overlaps the fastest's ties with
//!   it. With one sample per run there is no interval; the marks then carry
//!   [`SINGLE_SAMPLE`] and the caption says so ([`time_rule`]).

use crate::run_folder::timed::Timed;
use crate::run_folder::RunStop;
use crate::run_folder::{Status, SummaryRow};
use solvers::solver::StopReason;

/// Appended to a bold time made from single samples (repeat = 1).
pub const SINGLE_SAMPLE: &str = "†";

/// The run may be ranked: it converged.
pub fn comparable(r: &SummaryRow) -> bool {
    r.status == Status::Ok
}

/// The run may be ranked in a fixed-budget comparison: it converged, or it ran the whole
/// iteration budget (`status = budget`, or `stop_reason = max_iters` in a folder written before
/// that status). Runs that stopped early for another reason (line search, non-finite values,
/// energy increase, timeout, interruption), failed or were skipped never compete.
pub fn comparable_at_budget(r: &SummaryRow) -> bool {
    comparable(r)
        || r.status == Status::Budget
        || (r.status == Status::NotConverged && r.stop_reason == Some(RunStop::Solver(StopReason::MaxIterations)))
}

/// The indices of the lowest of the competing `values` (`None` = does not compete; non-finite
/// values never do), every value `same` as the lowest included.
pub fn lowest(values: &[Option<f64>], same: impl Fn(f64, f64) -> bool) -> Vec<usize> {
    let competing = || values.iter().enumerate().filter_map(|(i, v)| v.filter(|v| v.is_finite()).map(|v| (i, v)));
    let Some(best) = competing().map(|(_, v)| v).min_by(f64::total_cmp) else { return Vec::new() };
    competing().filter(|&(_, v)| v == best || same(v, best)).map(|(i, _)| i).collect()
}

/// Exact equality: the tie rule of deterministic counts.
pub fn equal(a: f64, b: f64) -> bool {
    a == b
}

/// What [`fastest`] marks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TimeMarks {
    /// The fastest and every competitor tied with it.
    pub best: Vec<usize>,
    /// Some competitor's time is a single sample: the marks carry [`SINGLE_SAMPLE`].
    pub single_sample: bool,
}

impl TimeMarks {
    pub fn contains(&self, i: usize) -> bool {
        self.best.contains(&i)
    }

    /// `text` with the single-sample mark when competitor `i` is marked best.
    pub fn label(&self, i: usize, text: String) -> String {
        if self.single_sample && self.contains(i) {
            text + SINGLE_SAMPLE
        } else {
            text
        }
    }
}

/// The fastest of the competing `times` (`None` = does not compete; non-finite never does)
/// and every competitor whose min–max interval overlaps the fastest's.
pub fn fastest(times: &[Option<Timed>]) -> TimeMarks {
    let competing = || times.iter().enumerate().filter_map(|(i, t)| t.filter(|t| t.value.is_finite()).map(|t| (i, t)));
    let Some((_, best)) = competing().min_by(|a, b| a.1.value.total_cmp(&b.1.value)) else {
        return TimeMarks::default();
    };
    TimeMarks {
        best: competing().filter(|(_, t)| t.overlaps(&best)).map(|(i, _)| i).collect(),
        single_sample: competing().any(|(_, t)| t.single_sample()),
    }
}

/// The caption sentence of a time ranking: the tie rule, and the single-sample label when
/// `single` (some compared time has no spread).
pub fn time_rule(single: bool) -> String {
    let mut s = "Times tie when their min–max intervals over the repeats overlap the fastest's (all tied \
                 solvers are bold); times in parentheses are the min–max over the repeats."
        .to_string();
    if single {
        s += &format!(
            " {SINGLE_SAMPLE} single sample (repeat = 1): the times have no spread, so only equal times tie and \
             differences within the machine's noise are not resolved."
        );
    }
    s
}

/// The caption sentence of the convergence rule.
pub const CONVERGED_RULE: &str =
    "Bold considers converged runs only (status ok): a failed, not converged or skipped run is never best.";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run_folder::timed::tests::run;

    /// What a table does: competitors are the comparable runs' times.
    fn marks(rows: &[SummaryRow]) -> TimeMarks {
        let times: Vec<Option<Timed>> =
            rows.iter().map(|r| comparable(r).then(|| Timed::time_s(r)).flatten()).collect();
        fastest(&times)
    }

    #[test]
    fn a_failed_unconverged_or_skipped_solver_is_never_best() {
        // The failed, unconverged and skipped runs are the fastest, and still not marked.
        let rows = [
            run(Status::Failed, 0.001, None),
            run(Status::NotConverged, 0.01, Some((0.009, 0.011, 5))),
            run(Status::Skipped, 0.0, None),
            run(Status::Ok, 1.0, Some((0.9, 1.1, 5))),
        ];
        assert_eq!(marks(&rows).best, [3]);
        // Iteration counts likewise: 0 iterations of a failed Newton are not the fewest.
        let iters = [Some(0.0), None, Some(12.0)];
        assert_eq!(lowest(&iters[1..], equal), [1]);
        let counts: Vec<Option<f64>> =
            rows.iter().zip([0.0, 3.0, 0.0, 12.0]).map(|(r, c)| comparable(r).then_some(c)).collect();
        assert_eq!(lowest(&counts, equal), [3]);
        // Nothing comparable: nothing is bold.
        assert_eq!(marks(&rows[..3]), TimeMarks::default());
        assert!(lowest(&[None, Some(f64::NAN)], equal).is_empty());
    }

    #[test]
    fn overlapping_intervals_tie_and_disjoint_ones_do_not() {
        let a = run(Status::Ok, 1.00, Some((0.95, 1.10, 5)));
        let b = run(Status::Ok, 1.10, Some((1.08, 1.20, 5)));
        let c = run(Status::Ok, 1.30, Some((1.25, 1.40, 5)));
        // b's interval overlaps a's (1.08 <= 1.10): both bold; c's does not.
        let m = marks(&[c.clone(), a.clone(), b.clone()]);
        assert_eq!(m.best, [1, 2]);
        assert!(!m.single_sample);
        assert_eq!(m.label(1, "1.00".into()), "1.00", "no single-sample mark with repeats");
        // Disjoint: only the fastest.
        let b_far = run(Status::Ok, 1.2, Some((1.11, 1.3, 5)));
        assert_eq!(marks(&[a.clone(), b_far]).best, [0]);
        // Touching intervals share a point: a tie.
        let b_touch = run(Status::Ok, 1.2, Some((1.10, 1.3, 5)));
        assert_eq!(marks(&[a, b_touch]).best, [0, 1]);
    }

    #[test]
    fn single_samples_tie_only_when_equal_and_say_so() {
        let a = run(Status::Ok, 1.00, None);
        let b = run(Status::Ok, 1.01, None);
        let m = marks(&[a.clone(), b]);
        assert_eq!(m.best, [0]);
        assert!(m.single_sample);
        assert_eq!(m.label(0, "1.00".into()), "1.00†");
        assert_eq!(m.label(1, "1.01".into()), "1.01", "only bold cells carry the mark");
        assert_eq!(marks(&[a.clone(), a.clone()]).best, [0, 1]);
        // repeats = 1 with min = max = time_s, and a row without the columns: single samples.
        let one = SummaryRow { repeats: Some(1), ..run(Status::Ok, 2.0, Some((2.0, 2.0, 1))) };
        assert!(Timed::time_s(&one).unwrap().single_sample());
        let old = SummaryRow { status: Status::Ok, time_s: Some(2.0), ..Default::default() };
        assert_eq!(Timed::time_s(&old), Some(Timed { value: 2.0, lo: 2.0, hi: 2.0, samples: 1 }));
        assert!(time_rule(true).contains("† single sample"));
        assert!(!time_rule(false).contains('†'));
    }

    #[test]
    fn fixed_budget_tables_admit_runs_that_used_the_whole_budget() {
        let r = |status, stop| SummaryRow { status, stop_reason: stop, ..Default::default() };
        assert!(comparable_at_budget(&r(Status::Ok, Some(StopReason::GradientTolerance.into()))));
        assert!(comparable_at_budget(&r(Status::NotConverged, Some(StopReason::MaxIterations.into()))));
        assert!(comparable_at_budget(&r(Status::Budget, Some(StopReason::MaxIterations.into()))));
        assert!(!comparable_at_budget(&r(Status::NotConverged, Some(StopReason::NonFinite("energy".into()).into()))));
        assert!(!comparable_at_budget(&r(Status::NotConverged, Some(StopReason::Timeout.into()))));
        assert!(!comparable_at_budget(&r(Status::Failed, None)));
        assert!(!comparable_at_budget(&r(Status::Skipped, None)));
        assert!(!comparable(&r(Status::NotConverged, Some(StopReason::MaxIterations.into()))));
    }
}
