//! What a solver reports: one row per iteration to an [`Observer`], which may stop the run.

use super::stop::StopReason;
use crate::linear::LinearSettings;

/// A solver's own per-iteration value with its column's name, named where it is measured.
pub type Metric = (&'static str, f64);

/// One row of the per-iteration CSV (docs/src/reference/columns.md order). Row `iter` describes the
/// iterate after `iter` accepted steps; `neg_eig`/`indefinite_elems` come from the
/// unmodified element Hessians of that same iterate; timings are those of the iteration
/// that produced it (all zero in row 0).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct IterationRecord {
    /// Accepted steps so far (0: the start map).
    pub iter: usize,
    /// The objective's value at the iterate.
    pub energy: f64,
    /// Euclidean norm of the gradient at the iterate.
    pub grad_norm: f64,
    /// Accepted step length `t` (0 in row 0).
    pub step: f64,
    /// Negative eigenvalues summed over the unmodified element Hessians.
    pub neg_eig: usize,
    /// Elements whose unmodified Hessian has a negative eigenvalue.
    pub indefinite_elems: usize,
    /// Inverted or degenerate triangles of the map (the folded faces for `authalic`).
    pub flips: usize,
    /// Derivative evaluation at the new iterate plus scattering into the sparse matrix.
    pub t_assemble_s: f64,
    /// Per-element Hessian modification including the triple product `M^T K M`.
    pub t_project_s: f64,
    /// Numeric factorization plus triangular solves.
    pub t_solve_s: f64,
    /// Maximal injective step plus Armijo backtracking.
    pub t_linesearch_s: f64,
    /// The iteration's time: the method's work, without `t_record_s`.
    pub t_iter_s: f64,
    /// `t_iter_s` summed over the iterations so far (the setup charged to iteration 1).
    pub t_cum_s: f64,
    /// Work done only for this row and the stop rule, not for the method: for `aqp` the
    /// evaluation at `x` (its steps need `f` and its gradient at `y` only; the authors'
    /// logging is outside their timed iterate), for every `param`/`deform` solver the inertia
    /// counts and the flips. Not in `t_iter_s` or `t_cum_s`, and the harness leaves it out of
    /// the run's `time_s`; 0 where a solver separates nothing (row 0, the authalic solvers).
    pub t_record_s: f64,
    /// The Tikhonov shift (`LinearSettings::tikhonov`, added before and after Jacobi scaling)
    /// of the Newton system that produced this row: the base shift of the settings when its
    /// factorization succeeded at once, the retry's larger shift otherwise. `None` in row 0
    /// (no system has been solved yet; the driver factorizes only after reporting it) and
    /// for the solvers without a Newton system (the authalic ones).
    pub shift: Option<f64>,
    /// Energy evaluations of the line search.
    pub ls_evals: usize,
    /// Solver-specific columns appended after the common ones (same names in every row
    /// of a run), e.g. the safeguards of `aem-cg-safe`.
    pub extra: Vec<Metric>,
}

impl IterationRecord {
    /// The value of the solver's extra column `name`, `None` when it has no such column.
    pub fn extra_value(&self, name: &str) -> Option<f64> {
        self.extra.iter().find(|e| e.0 == name).map(|e| e.1)
    }

    /// Row `iter`: the iterate evaluated in `ev` with `flips` inverted elements, reached by a
    /// step of length `step`; timings, shift, `ls_evals` and extras to be filled in.
    pub fn of(iter: usize, ev: &crate::problem::Evaluation, flips: usize, step: f64) -> IterationRecord {
        IterationRecord {
            iter,
            energy: ev.energy,
            grad_norm: crate::problem::norm(&ev.grad),
            step,
            neg_eig: ev.neg_eig,
            indefinite_elems: ev.indefinite_elems,
            flips,
            ..Default::default()
        }
    }
}

/// What the observer wants next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    /// Go on with the next iteration.
    Continue,
    /// Stop after this row (Ctrl-C, SIGTERM); recorded as [`StopReason::Interrupted`].
    Stop,
    /// Stop after this row because the run's deadline passed; recorded as [`StopReason::Timeout`].
    Timeout,
    /// This row is at the run's target: stop once a tolerance rule of the run has held
    /// (recorded as [`StopReason::Target`]); go on while none has.
    AtTarget,
}

impl Flow {
    /// The reason a solver records when it stops on this answer (`None`: go on).
    pub fn stop_reason(self) -> Option<StopReason> {
        match self {
            Flow::Continue | Flow::AtTarget => None,
            Flow::Stop => Some(StopReason::Interrupted),
            Flow::Timeout => Some(StopReason::Timeout),
        }
    }
}

/// Receives a run's rows, and the systems a Newton-type solver factorizes.
pub trait Observer {
    /// Take the next row; the answer says whether the solver goes on.
    fn observe(&mut self, record: &IterationRecord) -> Flow;

    /// The system a Newton-type solver is about to factorize for the step from iterate
    /// `system.iter`; most observers ignore it (exports and tests look at it).
    fn system(&mut self, _system: &SystemView) {}
}

/// The Newton system before the factorization: the assembled lower triangle in CSC form
/// (before the shift and scaling of `linear`, which the factorization applies) and the
/// gradient at iterate `iter`.
pub struct SystemView<'a> {
    /// The iterate whose step the system is for.
    pub iter: usize,
    /// Start of each column in `row_idx` and `values`, then their length (CSC).
    pub col_ptr: &'a [usize],
    /// Row of each stored entry.
    pub row_idx: &'a [usize],
    /// Position of each column's diagonal entry.
    pub diag: &'a [usize],
    /// Value of each stored entry.
    pub values: &'a [f64],
    /// The gradient at the iterate (the right-hand side is its negative).
    pub grad: &'a [f64],
    /// The shift and scaling the factorization applies.
    pub linear: &'a LinearSettings,
}

/// An observer that stops the solver once it reports iteration `k` (exporting the system
/// of an iterate, tests).
#[derive(Clone, Copy, Debug)]
pub struct StopAt(pub usize);

impl Observer for StopAt {
    fn observe(&mut self, r: &IterationRecord) -> Flow {
        if r.iter >= self.0 {
            Flow::Stop
        } else {
            Flow::Continue
        }
    }
}

/// An observer whose deadline passes at iteration `k` (tests of the timeout path).
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct TimeoutAt(pub usize);

#[cfg(test)]
impl Observer for TimeoutAt {
    fn observe(&mut self, r: &IterationRecord) -> Flow {
        match StopAt(self.0).observe(r) {
            Flow::Stop => Flow::Timeout,
            flow => flow,
        }
    }
}

/// An observer that keeps every row (tests, small runs).
#[derive(Default, Debug)]
pub struct Recorder {
    /// Every row reported, in order.
    pub rows: Vec<IterationRecord>,
}

impl Observer for Recorder {
    fn observe(&mut self, record: &IterationRecord) -> Flow {
        self.rows.push(record.clone());
        Flow::Continue
    }
}
