//! The report's reading of the task and status strings, in one place: the tables and plots
//! filter and mark runs through these, and list their names in summary.csv's order ([`unique`]).

use crate::plan::Task;
use crate::run_folder::{RunStop, Status, SummaryRow};

/// The run failed: no iterations to show, left out of means and curves.
pub(super) fn failed(r: &SummaryRow) -> bool {
    r.status == Status::Failed
}

/// A run that ran and whose method broke down (a failed factorization, a direction that does
/// not descend: `StopReason::is_breakdown`): a failure of the method, not a stop short of the
/// target. The tables show its stop instead of its numbers and leave it out of their means.
pub(crate) fn broke_down(r: &SummaryRow) -> bool {
    r.status == Status::NotConverged && matches!(&r.stop_reason, Some(RunStop::Solver(s)) if s.is_breakdown())
}

/// The pair was not run (outside the solver's declared energies): no files, left out of
/// means, aggregates, profiles and curves, and never ranked.
pub(super) fn skipped(r: &SummaryRow) -> bool {
    r.status == Status::Skipped
}

/// A run the aggregates and profiles count: not skipped, and not on a problem solved at its
/// start (`SummaryRow::trivial`: every run of it is solved at row 0, which ranks nothing).
pub(crate) fn counted_in(r: &SummaryRow) -> bool {
    !skipped(r) && !r.trivial()
}

/// The run ran to a stop (converged or not): it has iterations, curves and a map to show.
pub(super) fn finished(r: &SummaryRow) -> bool {
    r.status.ran()
}

/// The run converged (other finished runs are marked `*` or drawn dashed).
pub(super) fn converged(r: &SummaryRow) -> bool {
    r.status == Status::Ok
}

/// An authalic run: its maps show area ratios, it has no distortion energy to compare.
pub(super) fn is_authalic(r: &SummaryRow) -> bool {
    r.task == Task::Authalic
}

/// A `param` or `deform` run: a distortion energy minimized by the Newton-type solvers.
pub(super) fn is_param_or_deform(r: &SummaryRow) -> bool {
    matches!(r.task, Task::Param | Task::Deform)
}

/// The distinct items with how often each occurs, in first-appearance order (as [`unique`]).
pub(crate) fn counted<T: PartialEq>(items: impl IntoIterator<Item = T>) -> Vec<(T, usize)> {
    let mut out: Vec<(T, usize)> = Vec::new();
    for i in items {
        match out.iter_mut().find(|(k, _)| *k == i) {
            Some((_, n)) => *n += 1,
            None => out.push((i, 1)),
        }
    }
    out
}

/// The distinct items in first-appearance order, so rows and columns follow summary.csv.
pub(crate) fn unique<T: PartialEq>(items: impl IntoIterator<Item = T>) -> Vec<T> {
    let mut out: Vec<T> = Vec::new();
    for i in items {
        if !out.contains(&i) {
            out.push(i);
        }
    }
    out
}
