//! What a solver run returns: the final map and how it ended, or why it never started.

use super::observer::IterationRecord;
use super::stop::{Events, StopReason};

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

/// How a run obtained the symbolic analysis (ordering + symbolic Cholesky) of its system.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AnalysisReport {
    /// Wall time of the analysis, measured by the run that computed it.
    pub seconds: f64,
    /// This run's wall time spent obtaining it: computing it, or waiting while another run
    /// on the same mesh computed it (about 0 when it was ready).
    pub setup_seconds: f64,
    /// Taken from an [`AnalysisCache`](crate::linear::AnalysisCache) entry another run computed.
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
    /// `param`: the SD minimum of the same problem (exp-SD's chained start, which the param
    /// task's settings choose).
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
    /// The first iteration at which each tolerance rule held.
    pub events: Events,
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
            events: Events::default(),
            init_energy,
            final_energy: last.energy,
            grad_norm: last.grad_norm,
            flips: last.flips,
            analysis,
            start: None,
        }
    }
}
