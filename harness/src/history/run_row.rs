//! A past run as the history keeps it (`RunRow`, a row of the `runs` table) and the way back
//! to the summary row the report reads: the trend page computes each batch's numbers with the
//! report's own function from these.

use crate::plan::Task;
use crate::run_folder::summary::{ToTarget, Verdict};
use crate::run_folder::{RunStop, Status, SummaryRow};

/// One row of `runs` (the summary row's columns the history keeps).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunRow {
    pub batch_id: i64,
    pub dataset: String,
    pub task: Task,
    pub energy: String,
    pub solver: String,
    pub vertices: Option<i64>,
    pub iterations: Option<i64>,
    pub status: Status,
    /// `None` for a failed run (the column says `error`, as in `summary.csv`).
    pub stop_reason: Option<RunStop>,
    pub final_energy: Option<f64>,
    pub grad_norm: Option<f64>,
    pub flips: Option<i64>,
    pub time_s: Option<f64>,
    pub time_s_min: Option<f64>,
    pub time_s_max: Option<f64>,
    pub time_norm: Option<f64>,
    pub repeats: Option<i64>,
    pub shifted_iters: Option<i64>,
    pub clamped_iters: Option<i64>,
    pub peak_rss_mb: Option<f64>,
    /// `summary.csv`'s `start`, `ref_source` and `verdict` as written there.
    pub start: Option<String>,
    pub ref_energy: Option<f64>,
    pub ref_source: Option<String>,
    pub final_gap: Option<f64>,
    pub verdict: Option<String>,
    pub cg_capped_iters: Option<i64>,
    /// The tightest target of a judged run, and the iterations and time to it when reached.
    pub target_tau: Option<f64>,
    pub iters_to_target: Option<i64>,
    pub time_s_to_target: Option<f64>,
    pub peak_growth_mb: Option<f64>,
    /// `summary.csv`'s yardstick columns, the polish's energy and a differing repeat.
    pub start_energy: Option<f64>,
    pub ideal_energy: Option<f64>,
    pub ref_certified: Option<bool>,
    pub polished_energy: Option<f64>,
    pub repeats_differ: Option<String>,
    /// Where each tolerance rule first held (`summary.csv`'s `rule_*` columns).
    pub rule_grad_tol_iters: Option<i64>,
    pub rule_grad_tol_time_s: Option<f64>,
    pub rule_grad_tol_energy: Option<f64>,
    pub rule_energy_decrease_iters: Option<i64>,
    pub rule_energy_decrease_time_s: Option<f64>,
    pub rule_energy_decrease_energy: Option<f64>,
}

impl RunRow {
    /// The history's row of a summary row.
    pub fn from_summary(s: &SummaryRow) -> RunRow {
        let int = |v: Option<usize>| v.and_then(|x| i64::try_from(x).ok());
        RunRow {
            batch_id: 0,
            dataset: s.dataset.clone(),
            task: s.task,
            energy: s.energy.clone(),
            solver: s.solver.clone(),
            vertices: int(s.vertices),
            iterations: int(s.iterations),
            status: s.status,
            stop_reason: s.stop_reason.clone(),
            final_energy: s.final_energy,
            grad_norm: s.grad_norm,
            flips: int(s.flips),
            time_s: s.time_s,
            time_s_min: s.time_s_min,
            time_s_max: s.time_s_max,
            time_norm: s.time_norm,
            repeats: int(s.repeats),
            shifted_iters: int(s.shifted_iters),
            clamped_iters: int(s.clamped_iters),
            peak_rss_mb: s.peak_rss_mb,
            start: s.start.map(|x| x.as_str().to_string()),
            ref_energy: s.ref_energy,
            ref_source: s.ref_source.map(|x| x.as_str().to_string()),
            final_gap: s.final_gap,
            verdict: s.verdict.map(|x| x.as_str().to_string()),
            cg_capped_iters: int(s.cg_capped_iters),
            target_tau: s.to_targets.last().map(|t| t.tau),
            iters_to_target: s.to_targets.last().and_then(|t| int(t.iters)),
            time_s_to_target: s.to_targets.last().and_then(|t| t.time_s),
            peak_growth_mb: s.peak_growth_mb,
            start_energy: s.start_energy,
            ideal_energy: s.ideal_energy,
            ref_certified: s.ref_certified,
            polished_energy: s.polished_energy,
            repeats_differ: s.repeats_differ.clone(),
            rule_grad_tol_iters: int(s.rule_grad_tol_iters),
            rule_grad_tol_time_s: s.rule_grad_tol_time_s,
            rule_grad_tol_energy: s.rule_grad_tol_energy,
            rule_energy_decrease_iters: int(s.rule_energy_decrease_iters),
            rule_energy_decrease_time_s: s.rule_energy_decrease_time_s,
            rule_energy_decrease_energy: s.rule_energy_decrease_energy,
        }
    }

    /// The summary row back, with the columns the report's tables and aggregates read: names,
    /// counts, times and their spread, the verdict and the tightest target (the history keeps
    /// no other target, nor the per-energy settings).
    pub fn to_summary(&self) -> SummaryRow {
        let count = |v: Option<i64>| v.and_then(|x| usize::try_from(x).ok());
        let to_targets = match self.target_tau {
            Some(tau) => vec![ToTarget { tau, iters: count(self.iters_to_target), time_s: self.time_s_to_target }],
            None => Vec::new(),
        };
        SummaryRow {
            dataset: self.dataset.clone(),
            task: self.task,
            energy: self.energy.clone(),
            solver: self.solver.clone(),
            vertices: count(self.vertices),
            iterations: count(self.iterations),
            converged: self.status == Status::Ok,
            stop_reason: self.stop_reason.clone(),
            final_energy: self.final_energy,
            grad_norm: self.grad_norm,
            flips: count(self.flips),
            time_s: self.time_s,
            time_s_min: self.time_s_min,
            time_s_max: self.time_s_max,
            time_norm: self.time_norm,
            repeats: count(self.repeats),
            shifted_iters: count(self.shifted_iters),
            clamped_iters: count(self.clamped_iters),
            peak_rss_mb: self.peak_rss_mb,
            ref_energy: self.ref_energy,
            final_gap: self.final_gap,
            verdict: self.verdict.as_deref().and_then(|v| Verdict::ALL.into_iter().find(|x| x.as_str() == v)),
            cg_capped_iters: count(self.cg_capped_iters),
            to_targets,
            peak_growth_mb: self.peak_growth_mb,
            start_energy: self.start_energy,
            ideal_energy: self.ideal_energy,
            ref_certified: self.ref_certified,
            polished_energy: self.polished_energy,
            repeats_differ: self.repeats_differ.clone(),
            rule_grad_tol_iters: count(self.rule_grad_tol_iters),
            rule_grad_tol_time_s: self.rule_grad_tol_time_s,
            rule_grad_tol_energy: self.rule_grad_tol_energy,
            rule_energy_decrease_iters: count(self.rule_energy_decrease_iters),
            rule_energy_decrease_time_s: self.rule_energy_decrease_time_s,
            rule_energy_decrease_energy: self.rule_energy_decrease_energy,
            status: self.status,
            ..Default::default()
        }
        .with_rules_of_its_stop()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run_folder::summary::RefSource;

    #[test]
    fn a_summary_row_comes_back_with_what_the_report_reads() {
        let s = SummaryRow {
            dataset: "cow".into(),
            task: Task::Deform,
            energy: "sd".into(),
            solver: "slim".into(),
            vertices: Some(4540),
            iterations: Some(41),
            converged: true,
            stop_reason: Some(RunStop::Solver(solvers::solver::StopReason::GradientTolerance)),
            final_energy: Some(2.08),
            time_s: Some(0.98),
            time_s_min: Some(0.9),
            time_s_max: Some(1.1),
            time_norm: Some(2.4),
            repeats: Some(3),
            shifted_iters: Some(2),
            clamped_iters: Some(5),
            verdict: Some(Verdict::Solved),
            ref_energy: Some(2.07),
            ref_source: Some(RefSource::Batch),
            to_targets: vec![ToTarget { tau: 1e-6, iters: Some(30), time_s: Some(0.7) }],
            status: Status::Ok,
            ..Default::default()
        };
        let back = RunRow::from_summary(&s).to_summary();
        // ref_source and start stay text in the history (no number of the report reads them);
        // a row without the rules' events (from before schema 9) has its stop's.
        let rules = SummaryRow {
            rule_grad_tol_iters: Some(41),
            rule_grad_tol_time_s: Some(0.98),
            rule_grad_tol_energy: Some(2.08),
            ..s.clone()
        };
        assert_eq!(back, SummaryRow { ref_source: None, ..rules.clone() });
        // one with them keeps them
        let event = SummaryRow { rule_grad_tol_iters: Some(12), stop_reason: rules.stop_reason.clone(), ..rules };
        assert_eq!(RunRow::from_summary(&event).to_summary().rule_grad_tol_iters, Some(12));
    }
}
