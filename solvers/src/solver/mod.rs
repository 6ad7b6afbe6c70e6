//! Solvers and what they report.
//!
//! A solver never prints and never touches files: it calls [`Observer::observe`] once per
//! iteration (row 0 is the initial state) and returns a [`Outcome`]. The harness owns I/O.

pub mod newton;
pub mod registry;

pub use crate::line_search::LineSearchSettings;
pub use newton::{newton, NewtonSettings};
pub use registry::{solver_names, SolverSpec};

use crate::linear::{AnalysisCache, LinearSettings};
use std::sync::Arc;

/// One row of the per-iteration CSV (design.md column order). Row `iter` describes the
/// iterate after `iter` accepted steps; `neg_eig`/`indefinite_elems` come from the
/// unmodified element Hessians of that same iterate; timings are those of the iteration
/// that produced it (all zero in row 0).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct IterationRecord {
    pub iter: usize,
    pub energy: f64,
    pub grad_norm: f64,
    /// Accepted step length `t` (0 in row 0).
    pub step: f64,
    pub neg_eig: usize,
    pub indefinite_elems: usize,
    pub flips: usize,
    /// Derivative evaluation at the new iterate plus scattering into the sparse matrix.
    pub t_assemble_s: f64,
    /// Per-element Hessian modification including the triple product `M^T K M`.
    pub t_project_s: f64,
    /// Numeric factorization plus triangular solves.
    pub t_solve_s: f64,
    /// Maximal injective step plus Armijo backtracking.
    pub t_linesearch_s: f64,
    pub t_iter_s: f64,
    pub t_cum_s: f64,
    /// Energy evaluations of the line search.
    pub ls_evals: usize,
    /// Solver-specific columns appended after the design.md ones (same names in every row
    /// of a run), e.g. the safeguards of `aem-cg-safe`.
    pub extra: Vec<(&'static str, f64)>,
}

/// What the observer wants next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    Continue,
    /// Stop after this row (timeouts, Ctrl-C); recorded as [`StopReason::Interrupted`].
    Stop,
}

pub trait Observer {
    fn observe(&mut self, record: &IterationRecord) -> Flow;
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

/// An observer that keeps every row (tests, small runs).
#[derive(Default, Debug)]
pub struct Recorder {
    pub rows: Vec<IterationRecord>,
}

impl Observer for Recorder {
    fn observe(&mut self, record: &IterationRecord) -> Flow {
        self.rows.push(record.clone());
        Flow::Continue
    }
}

/// Why a solver stopped. `as_str` is the `stop_reason` column.
#[derive(Clone, Debug, PartialEq)]
pub enum StopReason {
    /// `|grad| <= grad_tol`.
    GradientTolerance,
    /// Energy decrease below `energy_decrease_tol` (SARAP in param, every energy in deform).
    EnergyDecrease,
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
}

impl StopReason {
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
        }
    }

    /// Convergence by one of the configured stopping rules.
    pub fn is_converged(&self) -> bool {
        matches!(self, StopReason::GradientTolerance | StopReason::EnergyDecrease)
    }

    /// Detail for the `error` column, if any.
    pub fn detail(&self) -> Option<&str> {
        match self {
            StopReason::LinearSolveFailed(s) | StopReason::NonFinite(s) => Some(s),
            _ => None,
        }
    }
}

/// Stopping rules (`[stop]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StopSettings {
    pub grad_tol: f64,
    /// Stop when `E_old - E_new < energy_decrease_tol`; 0 disables the rule.
    pub energy_decrease_tol: f64,
    pub max_iters: usize,
}

/// Everything a solver run needs besides the problem.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub stop: StopSettings,
    pub line_search: LineSearchSettings,
    pub linear: LinearSettings,
    /// Symbolic analyses shared with the other runs on the same mesh (`None`: analyse
    /// privately). Sharing never changes results, only the setup time.
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

/// Result of a solver run.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// Final map, interleaved `[u0, v0, u1, v1, ...]`.
    pub x: Vec<f64>,
    pub iterations: usize,
    pub stop_reason: StopReason,
    pub init_energy: f64,
    pub final_energy: f64,
    pub grad_norm: f64,
    pub flips: usize,
    /// The system's symbolic analysis (`None` for solvers without a shared system).
    pub analysis: Option<AnalysisReport>,
}
