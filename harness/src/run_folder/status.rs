//! What a summary row says of how a run ended: its `status` (ordered for the gate), the
//! harness's `verdict`, where its reference minimum came from, and when it passed each
//! target.

use serde::{Deserialize, Serialize};

/// Where a run's reference minimum came from (`ref_source`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RefSource {
    /// A reference store's entry (computed, certified, possibly lowered by this batch).
    Reference,
    /// No reference could be had: the batch's best final energy without flips, uncertified.
    Batch,
}

impl RefSource {
    pub fn as_str(self) -> &'static str {
        match self {
            RefSource::Reference => "reference",
            RefSource::Batch => "batch",
        }
    }
}

/// When a run passed the convergence test at one target.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ToTarget {
    pub tau: f64,
    /// The first iteration that passed (`None`: never).
    pub iters: Option<usize>,
    /// The run's time up to it: `time_s` less the iterations after it.
    pub time_s: Option<f64>,
}

/// How a run ended: the `status` column. Ordered worst to best for the gate: a pair that
/// stops being run (`skipped`) is worse than one that runs and fails.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Not run: the solver is not defined for the energy (the reason is in `error`). Neither
    /// ok nor failed, and left out of aggregates and rankings.
    Skipped,
    /// The run could not run or finish: bad mesh, unsupported pair, solver error, unwritable
    /// files. What a row knows nothing else about.
    #[default]
    Failed,
    /// It ran, but no stop rule of convergence was met (iteration limit, timeout, line
    /// search failure, ...).
    NotConverged,
    /// It ran the fixed budget its config asks for: a protocol without a tolerance stop
    /// (`grad_tol = 0` and no energy-decrease rule, the AEM paper's 100 iterations) whose run
    /// reached `max_iters`. A result at the budget, compared by its final values; a judged
    /// run within the tightest target is `ok` all the same.
    Budget,
    /// It converged.
    Ok,
}

impl Status {
    pub fn as_str(&self) -> &'static str {
        match self {
            Status::Failed => "failed",
            Status::NotConverged => "not_converged",
            Status::Budget => "budget",
            Status::Ok => "ok",
            Status::Skipped => "skipped",
        }
    }

    /// Whether the run ran to an end of its own (ok, not converged or its budget spent): it has
    /// a final map, iterations and times.
    pub fn ran(self) -> bool {
        matches!(self, Status::Ok | Status::NotConverged | Status::Budget)
    }
}

impl std::str::FromStr for Status {
    type Err = String;
    fn from_str(s: &str) -> Result<Status, String> {
        [Status::Failed, Status::NotConverged, Status::Budget, Status::Ok, Status::Skipped]
            .into_iter()
            .find(|x| x.as_str() == s)
            .ok_or_else(|| format!("unknown status '{s}' (known: ok, budget, not_converged, failed, skipped)"))
    }
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The `verdict` column, the harness's word on a finished run: solved when its final map has
/// no flipped triangle and passes the convergence test at the tightest target, otherwise why not
/// (`judge::verdict` decides it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Passed the tightest target, no flips: `status = ok`.
    Solved,
    /// Its final map flips triangles (inverts or collapses a face): never solved.
    Flipped,
    /// A stop rule ended it above the tightest target: an external solver's own, a run of a
    /// group without a reference (nothing to go to), or the target of a reference this batch
    /// then lowered.
    StoppedAboveTarget,
    /// Ended stationary (or with a small gradient) above its tightest target, and a tight
    /// polish from its final map stayed there: at another local minimum, not short of this one.
    OtherMinimum,
    /// Ended stationary above the target without another minimum to show for it: the
    /// gradient floor, or no decrease beyond round-off (over the stall window, or in a line
    /// search whose model predicts less).
    Stalled,
    /// The method broke down above the target: a failed factorization, a line search that
    /// found no decrease its model promised, a direction that does not descend, a non-finite value.
    BrokeDown,
    /// Its budget ended it above the target: the iteration cap or the time limit.
    Unfinished,
}

impl Verdict {
    pub const ALL: [Verdict; 7] = [
        Verdict::Solved,
        Verdict::Flipped,
        Verdict::StoppedAboveTarget,
        Verdict::OtherMinimum,
        Verdict::Stalled,
        Verdict::BrokeDown,
        Verdict::Unfinished,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Solved => "solved",
            Verdict::Flipped => "flipped",
            Verdict::StoppedAboveTarget => "stopped_above_target",
            Verdict::OtherMinimum => "other_minimum",
            Verdict::Stalled => "stalled",
            Verdict::BrokeDown => "broke_down",
            Verdict::Unfinished => "unfinished",
        }
    }
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}
