//! Solvers and what they report.
//!
//! A solver never prints and never touches files: it calls [`Observer::observe`] once per
//! iteration (row 0 is the initial state) and returns a [`Outcome`]. The harness owns I/O.

#[cfg(test)]
mod after_papers_tests;
pub mod aqp;
pub mod catalogue;
pub mod executor;
pub mod lbfgs;
pub mod map_iterate;
pub mod newton;
pub mod newton_system;
pub mod options;
pub mod planar;
pub mod proxy;
pub mod solver_error;
pub mod truncated;

pub use crate::line_search::LineSearchSettings;
pub use catalogue::{SlimOptions, SolverEntry, SolverError, SOLVERS};
pub use newton::SolverSpec;
pub use newton::{newton, NewtonSettings};
pub use options::RawOptions;

use crate::linear::{AnalysisCache, LinearSettings};
use std::sync::Arc;

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
    pub extra: Vec<(&'static str, f64)>,
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
}

impl Flow {
    /// The reason a solver records when it stops on this answer (`None`: go on).
    pub fn stop_reason(self) -> Option<StopReason> {
        match self {
            Flow::Continue => None,
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

/// Errors that prevent a run from starting; once iterating, problems become a
/// [`StopReason`] and the run returns the last accepted iterate.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum SolveError {
    /// The start map cannot be evaluated (an inverted or degenerate element, a non-finite value).
    #[error("initial map: {0}")]
    InitialMap(#[from] crate::problem::EvalError),
    /// The linear solver's setup (ordering, symbolic analysis) failed.
    #[error("linear solver setup: {0}")]
    Linear(#[from] crate::linear::LinearError),
}

/// Why a solver stopped. `as_str` is the `stop_reason` column.
#[derive(Clone, Debug, PartialEq)]
pub enum StopReason {
    /// `|grad| <= grad_tol`.
    GradientTolerance,
    /// Energy decrease below `energy_decrease_tol` (on by default for SARAP in `param` only).
    EnergyDecrease,
    /// `max_iters` steps were taken.
    MaxIterations,
    /// Armijo backtracking shrank the step below `t |d| <= min_step` without sufficient decrease.
    LineSearchFailed,
    /// The factorization failed even after increasing the regularization.
    LinearSolveFailed(String),
    /// The direction is not a descent direction (possible for unprojected Newton).
    NotDescent,
    /// Energy or gradient became non-finite.
    NonFinite(String),
    /// A fixed-point step would increase the energy; the previous iterate is kept (SEM).
    EnergyIncreased,
    /// The observer asked to stop.
    Interrupted,
    /// The observer stopped the run at its deadline.
    Timeout,
    /// An external solver stopped by its own convergence rule (its `result.json` says
    /// `converged`); the harness's verdict judges the run as any other.
    SolverRule,
    /// Never started: the solver is not defined for the energy (or its parameters). No
    /// solver returns it; the harness records such pairs as skipped, the reason in `error`
    /// (`SolverEntry::skip_reason`).
    Skipped,
}

/// A `stop_reason` string that names no [`StopReason`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown stop reason '{0}' (known: {known})", known = StopReason::ALL.map(|r| r.as_str()).join(", "))]
pub struct UnknownStopReason(pub String);

impl StopReason {
    /// Every reason, payloads empty (parsing, listings).
    pub const ALL: [StopReason; 12] = [
        StopReason::GradientTolerance,
        StopReason::EnergyDecrease,
        StopReason::MaxIterations,
        StopReason::LineSearchFailed,
        StopReason::LinearSolveFailed(String::new()),
        StopReason::NotDescent,
        StopReason::NonFinite(String::new()),
        StopReason::EnergyIncreased,
        StopReason::Interrupted,
        StopReason::Timeout,
        StopReason::SolverRule,
        StopReason::Skipped,
    ];

    /// The `stop_reason` column's string.
    pub fn as_str(&self) -> &'static str {
        match self {
            StopReason::GradientTolerance => "grad_tol",
            StopReason::EnergyDecrease => "energy_decrease",
            StopReason::MaxIterations => "max_iters",
            StopReason::LineSearchFailed => "line_search_failed",
            StopReason::LinearSolveFailed(_) => "linear_solve_failed",
            StopReason::NotDescent => "not_descent",
            StopReason::NonFinite(_) => "non_finite",
            StopReason::EnergyIncreased => "energy_increased",
            StopReason::Interrupted => "interrupted",
            StopReason::Timeout => "timeout",
            StopReason::SolverRule => "solver_rule",
            StopReason::Skipped => "skipped",
        }
    }

    /// Convergence by one of the configured stopping rules.
    pub fn is_converged(&self) -> bool {
        matches!(self, StopReason::GradientTolerance | StopReason::EnergyDecrease | StopReason::SolverRule)
    }

    /// Detail for the `error` column, if any.
    pub fn detail(&self) -> Option<&str> {
        match self {
            StopReason::LinearSolveFailed(s) | StopReason::NonFinite(s) => Some(s),
            _ => None,
        }
    }
}

/// The `stop_reason` column's string; the variants with a detail get an empty one (the
/// detail travels in the `error` column).
impl std::str::FromStr for StopReason {
    type Err = UnknownStopReason;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        StopReason::ALL.into_iter().find(|r| r.as_str() == s).ok_or_else(|| UnknownStopReason(s.to_string()))
    }
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// As its `stop_reason` string (the detail is not part of it).
impl serde::Serialize for StopReason {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de> serde::Deserialize<'de> for StopReason {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = <std::borrow::Cow<'de, str>>::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

/// Stopping rules (`[stop]`). The default is the `param` task's rule (docs/src/design/numerics.md); the tasks that stop
/// otherwise have their own (`param::default_stop` for SARAP, `deform::default_stop`,
/// `authalic::default_stop`), and [`StopOverrides`] lays a config's keys over any of them.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StopSettings {
    /// Stop when `|grad| <= grad_tol`; 0 disables the rule.
    pub grad_tol: f64,
    /// Stop when `E_old - E_new < energy_decrease_tol`; 0 disables the rule.
    pub energy_decrease_tol: f64,
    /// Stop after this many accepted steps.
    pub max_iters: usize,
}

impl StopSettings {
    /// A fixed-budget protocol: no tolerance rule, so every run that goes on takes
    /// `max_iters` steps (the AEM paper's Table 1, 100 iterations).
    pub fn is_fixed_budget(&self) -> bool {
        self.grad_tol == 0.0 && self.energy_decrease_tol == 0.0
    }

    /// The stop rules the executor checks before an iteration, in this order:
    /// `|grad| <= grad_tol`, then the last accepted step's decrease `< energy_decrease_tol`
    /// (`last_decrease` is infinite before the first step), then `iter >= max_iters`. A
    /// tolerance of 0 turns its rule off (a rise of SEM's energy is no stall).
    pub fn reached(&self, grad_norm: f64, last_decrease: f64, iter: usize) -> Option<StopReason> {
        if self.grad_tol > 0.0 && grad_norm <= self.grad_tol {
            Some(StopReason::GradientTolerance)
        } else if self.energy_decrease_tol > 0.0 && last_decrease < self.energy_decrease_tol {
            Some(StopReason::EnergyDecrease)
        } else if iter >= self.max_iters {
            Some(StopReason::MaxIterations)
        } else {
            None
        }
    }
}

impl Default for StopSettings {
    /// `|grad| <= 1e-3`, no energy-decrease rule, 1000 iterations.
    fn default() -> Self {
        StopSettings { grad_tol: 1e-3, energy_decrease_tol: 0.0, max_iters: 1000 }
    }
}

/// The keys a `[stop]` section sets; the others keep the task's and energy's default
/// (a partial [`StopSettings`], since those defaults differ: SARAP, deform, authalic).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StopOverrides {
    /// Replaces [`StopSettings::grad_tol`] when set.
    pub grad_tol: Option<f64>,
    /// Replaces [`StopSettings::energy_decrease_tol`] when set.
    pub energy_decrease_tol: Option<f64>,
    /// Replaces [`StopSettings::max_iters`] when set.
    pub max_iters: Option<usize>,
}

impl StopOverrides {
    /// `base` with the keys that were set replaced.
    pub fn over(&self, base: StopSettings) -> StopSettings {
        StopSettings {
            grad_tol: self.grad_tol.unwrap_or(base.grad_tol),
            energy_decrease_tol: self.energy_decrease_tol.unwrap_or(base.energy_decrease_tol),
            max_iters: self.max_iters.unwrap_or(base.max_iters),
        }
    }
}

/// Everything a solver run needs besides the problem.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Settings {
    /// The stopping rules.
    pub stop: StopSettings,
    /// The line search's parameters.
    pub line_search: LineSearchSettings,
    /// The linear solver's shift, scaling and ordering.
    pub linear: LinearSettings,
    /// The run's solver's own options (`[solver.<name>]`) as given, e.g. SLIM's weight
    /// clamping; its catalogue entry reads them (null: none given).
    pub options: RawOptions,
    /// Symbolic analyses shared with the other runs on the same mesh (`None`: analyse
    /// privately). Sharing never changes results, only the setup time.
    #[serde(skip)]
    pub analyses: Option<Arc<AnalysisCache>>,
}

/// How a run obtained the symbolic analysis (ordering + symbolic Cholesky) of its system.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AnalysisReport {
    /// Wall time of the analysis, measured by the run that computed it.
    pub seconds: f64,
    /// This run's wall time spent obtaining it: computing it, or waiting while another run
    /// on the same mesh computed it (about 0 when it was ready).
    pub setup_seconds: f64,
    /// Taken from an [`AnalysisCache`] entry another run computed.
    pub reused: bool,
}

impl AnalysisReport {
    /// How `solver` obtained its analysis.
    pub fn of(solver: &crate::linear::SpdSolver) -> AnalysisReport {
        AnalysisReport {
            seconds: solver.analysis().seconds(),
            setup_seconds: solver.setup_seconds(),
            reused: solver.analysis_reused(),
        }
    }
}

/// The map a run started from (`summary.csv`'s `start`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StartMap {
    /// `param`: the Tutte map globally scaled (Section 4.2).
    TutteScaled,
    /// `param`: the Tutte map (the energies without the scaling rule, `kp-newton-noscale`).
    Tutte,
    /// `deform`: the rest pose.
    Rest,
    /// `deform`: the dataset's own start (a generated shape's released pose).
    Given,
    /// `authalic`: the arc-length boundary on the unit circle and the fixed-boundary stretch
    /// steps.
    ArclengthStretch,
    /// `param`: the SD minimum of the same problem (exp-SD's chained start,
    /// [`crate::param::ParamStart::SdMinimum`]).
    SdMinimum,
}

impl StartMap {
    /// Every start map (parsing, listings).
    pub const ALL: [StartMap; 6] = [
        StartMap::TutteScaled,
        StartMap::Tutte,
        StartMap::Rest,
        StartMap::Given,
        StartMap::ArclengthStretch,
        StartMap::SdMinimum,
    ];

    /// The `start` column's string.
    pub fn as_str(self) -> &'static str {
        match self {
            StartMap::TutteScaled => "tutte-scaled",
            StartMap::Tutte => "tutte",
            StartMap::Rest => "rest",
            StartMap::Given => "given",
            StartMap::ArclengthStretch => "arclength-stretch",
            StartMap::SdMinimum => "sd-minimum",
        }
    }
}

impl std::str::FromStr for StartMap {
    type Err = String;
    fn from_str(s: &str) -> Result<StartMap, String> {
        StartMap::ALL
            .into_iter()
            .find(|m| m.as_str() == s)
            .ok_or_else(|| format!("unknown start '{s}' (known: {})", StartMap::ALL.map(|m| m.as_str()).join(", ")))
    }
}

/// Result of a solver run.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// Final map, interleaved `[u0, v0, u1, v1, ...]`.
    pub x: Vec<f64>,
    /// Accepted steps taken.
    pub iterations: usize,
    /// Why the run stopped.
    pub stop_reason: StopReason,
    /// Energy of the start map (row 0).
    pub init_energy: f64,
    /// Energy of the final map.
    pub final_energy: f64,
    /// Gradient norm at the final map.
    pub grad_norm: f64,
    /// Inverted or degenerate triangles of the final map.
    pub flips: usize,
    /// The system's symbolic analysis (`None` for solvers without a shared system).
    pub analysis: Option<AnalysisReport>,
    /// The start map, set by the task (a driver does not know it).
    pub start: Option<StartMap>,
}

impl Outcome {
    /// A run that ends at the iterate `x` its last reported row `last` describes.
    pub fn at(
        x: Vec<f64>,
        last: &IterationRecord,
        init_energy: f64,
        stop_reason: StopReason,
        analysis: Option<AnalysisReport>,
    ) -> Outcome {
        Outcome {
            x,
            iterations: last.iter,
            stop_reason,
            init_energy,
            final_energy: last.energy,
            grad_norm: last.grad_norm,
            flips: last.flips,
            analysis,
            start: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stop_reasons_round_trip_through_their_strings() {
        for r in StopReason::ALL {
            assert_eq!(r.as_str().parse::<StopReason>(), Ok(r.clone()));
            assert_eq!(r.to_string(), r.as_str());
            let de = serde::de::value::StrDeserializer::<serde::de::value::Error>::new(r.as_str());
            assert_eq!(<StopReason as serde::Deserialize>::deserialize(de), Ok(r.clone()));
        }
        let names: std::collections::BTreeSet<_> = StopReason::ALL.iter().map(|r| r.as_str()).collect();
        assert_eq!(names.len(), StopReason::ALL.len(), "one string per reason");
        // the detail travels in the error column, not in the reason
        assert_eq!("non_finite".parse(), Ok(StopReason::NonFinite(String::new())));
        assert_eq!(StopReason::LinearSolveFailed("pivot 3".into()).as_str(), "linear_solve_failed");
        let err = "converged".parse::<StopReason>().unwrap_err().to_string();
        assert!(err.starts_with("unknown stop reason 'converged' (known: grad_tol, "), "{err}");
        assert_eq!(StopReason::Timeout.as_str(), "timeout");
        assert!(!StopReason::Timeout.is_converged());
        assert_eq!(("skipped".parse(), StopReason::Skipped.is_converged()), (Ok(StopReason::Skipped), false));
    }

    #[test]
    fn stop_rules_apply_in_order() {
        let s = StopSettings { grad_tol: 1e-3, energy_decrease_tol: 1e-6, max_iters: 10 };
        assert_eq!(s.reached(1e-4, 0.0, 99), Some(StopReason::GradientTolerance));
        assert_eq!(s.reached(1.0, 1e-7, 99), Some(StopReason::EnergyDecrease));
        assert_eq!(s.reached(1.0, f64::INFINITY, 10), Some(StopReason::MaxIterations));
        assert_eq!(s.reached(1.0, 1e-5, 9), None);
        // before the first step nothing has decreased: the decrease rule waits
        assert_eq!(StopSettings { energy_decrease_tol: 1e300, ..s }.reached(1.0, f64::INFINITY, 0), None);
        // a zero tolerance is no rule: neither a zero gradient nor a rise stops the run
        let off = StopSettings { grad_tol: 0.0, energy_decrease_tol: 0.0, max_iters: 10 };
        assert_eq!((off.reached(0.0, -1.0, 9), off.reached(0.0, -1.0, 10)), (None, Some(StopReason::MaxIterations)));
    }

    #[test]
    fn flows_map_to_their_stop_reasons() {
        assert_eq!(Flow::Continue.stop_reason(), None);
        assert_eq!(Flow::Stop.stop_reason(), Some(StopReason::Interrupted));
        assert_eq!(Flow::Timeout.stop_reason(), Some(StopReason::Timeout));
    }
}
