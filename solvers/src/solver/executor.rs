//! The one loop every solver runs under. A method only says how it takes one step
//! ([`Method::step`]); the executor owns what every run shares: row 0, the ends in their
//! order (the observer's answer, then [`StopSettings::end`]), the tolerance rules' events,
//! the iteration's time with the setup charged to iteration 1 and the record-only work kept
//! apart, the rows handed to the observer, and the outcome. A rule is checked at a row
//! whether it ends the run or marks an event, and nothing a method does depends on which:
//! the rows up to a rule's event are those of the run that rule ends.

use super::observer::{Flow, IterationRecord, Metric, Observer};
use super::outcome::{AnalysisReport, Outcome};
use super::stop::{Events, RowState, Stall, StopReason, StopSettings};
use std::time::Instant;

/// The state a method advances and the rows describe (a planar map with its evaluation,
/// the authalic variables with their terms).
pub trait Iterate {
    /// Row `iter` of this iterate, reached by a step of length `step`: the fields measured
    /// on the iterate (energy, gradient norm, inertia, flips); the executor adds the rest.
    /// Its time is record-only work (`t_record_s`).
    fn row(&self, iter: usize, step: f64) -> IterationRecord;

    /// The method's own values in row 0, by column (by default none: no step was taken, and
    /// every declared column reads NaN).
    fn initial_extra(&self) -> Vec<Metric> {
        Vec::new()
    }

    /// The map the outcome reports, interleaved `[u0, v0, ...]` (it may be moved out: the
    /// executor asks once, at the end).
    fn take_map(&mut self) -> Vec<f64>;
}

/// What one step did, for its row. Times in seconds.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Step {
    /// The accepted step length.
    pub step: f64,
    /// The energy's decrease for the energy-decrease rule; `None` leaves the rule's last one
    /// (AQP's iterations in which `f(x)` rose).
    pub decrease: Option<f64>,
    /// Evaluation and assembly time (`t_assemble_s`).
    pub t_assemble: f64,
    /// Per-element Hessian modification time (`t_project_s`).
    pub t_project: f64,
    /// Factorization and solve time (`t_solve_s`).
    pub t_solve: f64,
    /// Line-search time (`t_linesearch_s`).
    pub t_linesearch: f64,
    /// Work inside the step done only for the row and the stop rule (inertia counts, AQP's
    /// evaluation at `x`): left out of the iteration's time.
    pub t_record: f64,
    /// Work of an earlier row's record-only part the step used after all (AQP's evaluation
    /// at `x` when `y = x`): charged to this iteration (already in `t_assemble`).
    pub t_reused: f64,
    /// The Tikhonov shift of the step's linear system, if it has one.
    pub shift: Option<f64>,
    /// Energy evaluations of the line search.
    pub ls_evals: usize,
    /// The method's own values, each named by its column where it was measured.
    pub extra: Vec<Metric>,
}

/// A method's iteration.
pub trait Method {
    /// The state the method advances.
    type Iterate: Iterate;

    /// One iteration from `at`, iterate `iter`: on success `at` is the next iterate, evaluated
    /// for its row; on failure the reason to stop (`at` is the last accepted iterate, or for
    /// a failed evaluation the iterate that failed). `observer` sees the systems a method
    /// factorizes ([`Observer::system`]); the executor reports the rows.
    fn step(&mut self, at: &mut Self::Iterate, iter: usize, observer: &mut dyn Observer) -> Result<Step, StopReason>;
}

/// A method ready to run, and what its setup reports.
pub struct ReadyMethod<M> {
    /// The method, or why it cannot start: the run then ends at row 0 with that reason
    /// (unless the observer stopped it there first).
    pub method: Result<M, StopReason>,
    /// The method's own CSV columns, after the common ones.
    pub columns: Vec<&'static str>,
    /// How the method obtained its symbolic analysis (`None`: no shared system).
    pub analysis: Option<AnalysisReport>,
    /// Setup work that is part of the method's cost (the numeric factorization of a
    /// constant proxy): charged to iteration 1, as solve time.
    pub charged: f64,
}

/// A finished run: the outcome and the last iterate (the authalic task computes its metrics
/// on it).
pub struct Finished<I> {
    /// The run's outcome.
    pub outcome: Outcome,
    /// The last iterate; its map may have been moved into `outcome.x`.
    pub last: I,
}

/// A row's extra columns: the method's declared `columns` in their order, each with the value
/// named after it (NaN when the step did not measure it). A value of an undeclared column is
/// a method's bug, caught by every test that runs the method.
fn by_column(columns: &[&'static str], values: Vec<Metric>) -> Vec<Metric> {
    assert!(values.iter().all(|(name, _)| columns.contains(name)), "a column the method did not declare: {values:?}");
    columns.iter().map(|&c| (c, values.iter().find(|(name, _)| *name == c).map_or(f64::NAN, |v| v.1))).collect()
}

/// Run `start`'s method from the evaluated iterate `at` under the stop rules `stop`.
pub fn execute<M: Method>(
    start: ReadyMethod<M>,
    mut at: M::Iterate,
    stop: &StopSettings,
    observer: &mut dyn Observer,
) -> Finished<M::Iterate> {
    let ReadyMethod { method, columns, analysis, mut charged } = start;
    let mut record = IterationRecord { extra: by_column(&columns, at.initial_extra()), ..at.row(0, 0.0) };
    let init_energy = record.energy;
    let mut flow = observer.observe(&record);
    let mut events = Events::default();
    let mut stall = Stall::new(stop.stall_window);
    let mut method = match method {
        Ok(m) => m,
        Err(reason) => return finish(at, &record, init_energy, flow.stop_reason().unwrap_or(reason), events, analysis),
    };
    let mut last_decrease = f64::INFINITY;
    let mut t_cum = 0.0;
    let mut iter = 0usize;
    let reason = loop {
        if let Some(reason) = flow.stop_reason() {
            break reason;
        }
        let row = RowState {
            grad_norm: record.grad_norm,
            last_decrease,
            iter,
            at_target: flow == Flow::AtTarget,
            stalled: stall.push(record.energy),
        };
        stop.mark(&row, &mut events);
        if let Some(reason) = stop.end(&row, &events) {
            break reason;
        }
        let t_start = Instant::now();
        let step = match method.step(&mut at, iter, observer) {
            Ok(step) => step,
            Err(reason) => break reason,
        };
        let setup = std::mem::take(&mut charged);
        let t_iter = (t_start.elapsed().as_secs_f64() - step.t_record).max(0.0) + step.t_reused + setup;
        if let Some(d) = step.decrease {
            last_decrease = d;
        }
        let t0 = Instant::now();
        let row = at.row(iter + 1, step.step);
        let t_record = step.t_record + t0.elapsed().as_secs_f64();
        t_cum += t_iter;
        iter += 1;
        record = IterationRecord {
            t_assemble_s: step.t_assemble,
            t_project_s: step.t_project,
            t_solve_s: step.t_solve + setup,
            t_linesearch_s: step.t_linesearch,
            t_iter_s: t_iter,
            t_cum_s: t_cum,
            t_record_s: t_record,
            shift: step.shift,
            ls_evals: step.ls_evals,
            extra: by_column(&columns, step.extra),
            ..row
        };
        flow = observer.observe(&record);
    };
    finish(at, &record, init_energy, reason, events, analysis)
}

fn finish<I: Iterate>(
    mut at: I,
    last: &IterationRecord,
    init_energy: f64,
    reason: StopReason,
    events: Events,
    analysis: Option<AnalysisReport>,
) -> Finished<I> {
    let outcome = Outcome { events, ..Outcome::at(at.take_map(), last, init_energy, reason, analysis) };
    Finished { outcome, last: at }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::observer::{Recorder, StopAt};

    /// `f(x) = x^2 / 2` halved by every step: the gradient is `x`.
    struct Halving {
        x: f64,
    }

    impl Iterate for Halving {
        fn row(&self, iter: usize, step: f64) -> IterationRecord {
            IterationRecord { iter, energy: 0.5 * self.x * self.x, grad_norm: self.x.abs(), step, ..Default::default() }
        }
        fn take_map(&mut self) -> Vec<f64> {
            vec![self.x, 0.0]
        }
    }

    /// Halves `x`; fails at iterate `fail_at`.
    struct Halve {
        fail_at: usize,
    }

    impl Method for Halve {
        type Iterate = Halving;
        fn step(&mut self, at: &mut Halving, iter: usize, _: &mut dyn Observer) -> Result<Step, StopReason> {
            if iter == self.fail_at {
                return Err(StopReason::LineSearchFailed);
            }
            let e_old = 0.5 * at.x * at.x;
            at.x *= 0.5;
            let reused = if iter == 2 { 5.0 } else { 0.0 };
            Ok(Step {
                step: 0.5,
                decrease: Some(e_old - 0.5 * at.x * at.x),
                t_solve: 1.0,
                t_assemble: reused,
                t_reused: reused,
                shift: Some(1e-10),
                extra: vec![("k", iter as f64)],
                ..Step::default()
            })
        }
    }

    fn start(method: Result<Halve, StopReason>, charged: f64) -> ReadyMethod<Halve> {
        ReadyMethod { method, columns: vec!["k"], analysis: None, charged }
    }

    fn stop(grad_tol: f64, energy_decrease_tol: f64, max_iters: usize) -> StopSettings {
        StopSettings::rules_only(grad_tol, energy_decrease_tol, max_iters)
    }

    #[test]
    fn rows_follow_the_iterates_and_the_rules_stop_in_order() {
        let mut rec = Recorder::default();
        let run = execute(start(Ok(Halve { fail_at: 99 }), 3.0), Halving { x: 1.0 }, &stop(0.1, 0.0, 50), &mut rec);
        // |x| = 2^-k <= 0.1 first at k = 4
        assert_eq!((run.outcome.stop_reason.clone(), run.outcome.iterations), (StopReason::GradientTolerance, 4));
        assert_eq!(run.outcome.x, vec![0.0625, 0.0]);
        assert_eq!((run.outcome.init_energy, run.outcome.final_energy), (0.5, 0.5 * 0.0625 * 0.0625));
        assert_eq!(rec.rows.len(), 5);
        assert!(rec.rows.iter().enumerate().all(|(k, r)| r.iter == k && r.grad_norm == 0.5f64.powi(k as i32)));
        // row 0: extras undefined, no step, no time
        assert!(rec.rows[0].extra[0].1.is_nan() && rec.rows[0].step == 0.0 && rec.rows[0].t_cum_s == 0.0);
        assert_eq!(rec.rows[0].shift, None);
        // the setup is charged to iteration 1 as solve time, the reused work to its iteration
        assert!(rec.rows[1].t_solve_s == 4.0 && rec.rows[1].t_iter_s >= 3.0 && rec.rows[2].t_solve_s == 1.0);
        assert!(rec.rows[3].t_iter_s >= 5.0 && rec.rows[3].t_iter_s < 5.5, "{:?}", rec.rows[3]);
        let cum: f64 = rec.rows.iter().map(|r| r.t_iter_s).sum();
        assert!((rec.rows[4].t_cum_s - cum).abs() < 1e-12);
        assert!(rec.rows[1..].iter().enumerate().all(|(k, r)| r.extra == [("k", k as f64)] && r.shift == Some(1e-10)));

        // the decrease rule after the gradient's, then the iteration cap
        let run = execute(
            start(Ok(Halve { fail_at: 99 }), 0.0),
            Halving { x: 1.0 },
            &stop(0.0, 0.01, 50),
            &mut Recorder::default(),
        );
        // step k decreases the energy by 3/8 4^(1-k): below 0.01 first at k = 4
        assert_eq!((run.outcome.stop_reason, run.outcome.iterations), (StopReason::EnergyDecrease, 4));
        let run = execute(
            start(Ok(Halve { fail_at: 99 }), 0.0),
            Halving { x: 1.0 },
            &stop(0.0, 0.0, 2),
            &mut Recorder::default(),
        );
        assert_eq!((run.outcome.stop_reason, run.outcome.iterations), (StopReason::MaxIterations, 2));
    }

    #[test]
    fn a_failed_step_or_setup_ends_the_run_at_the_last_row() {
        let mut rec = Recorder::default();
        let run = execute(start(Ok(Halve { fail_at: 2 }), 0.0), Halving { x: 1.0 }, &stop(0.0, 0.0, 50), &mut rec);
        assert_eq!(
            (run.outcome.stop_reason, run.outcome.iterations, rec.rows.len()),
            (StopReason::LineSearchFailed, 2, 3)
        );
        assert_eq!(run.last.x, 0.25);

        let failed = || Err(StopReason::LinearSolveFailed("setup".into()));
        let mut rec = Recorder::default();
        let run = execute(start(failed(), 0.0), Halving { x: 1.0 }, &stop(0.0, 0.0, 50), &mut rec);
        assert_eq!(
            (run.outcome.stop_reason.as_str(), run.outcome.iterations, rec.rows.len()),
            ("linear_solve_failed", 0, 1)
        );
        // the observer's answer at row 0 comes first
        let run = execute(start(failed(), 0.0), Halving { x: 1.0 }, &stop(0.0, 0.0, 50), &mut StopAt(0));
        assert_eq!(run.outcome.stop_reason, StopReason::Interrupted);
        let run =
            execute(start(Ok(Halve { fail_at: 99 }), 0.0), Halving { x: 1.0 }, &stop(0.0, 0.0, 50), &mut StopAt(3));
        assert_eq!((run.outcome.stop_reason, run.outcome.iterations), (StopReason::Interrupted, 3));
    }
}
