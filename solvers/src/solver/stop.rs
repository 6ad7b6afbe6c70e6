//! Why a solver stops: the stopping rules of a run and the reason it ended.

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
}

/// A `stop_reason` string that names no [`StopReason`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown stop reason '{0}' (known: {known})", known = StopReason::ALL.map(|r| r.as_str()).join(", "))]
pub struct UnknownStopReason(pub String);

impl StopReason {
    /// Every reason, payloads empty (parsing, listings).
    pub const ALL: [StopReason; 11] = [
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
        }
    }

    /// The method broke down: a linear system it could not solve, a direction that does not
    /// descend, a non-finite value, an energy that rose where it must fall. Not a stop short
    /// of the target, which another iteration or a looser rule would pass, but a failure of
    /// the method on this problem.
    pub fn is_breakdown(&self) -> bool {
        matches!(
            self,
            StopReason::LinearSolveFailed(_)
                | StopReason::NotDescent
                | StopReason::NonFinite(_)
                | StopReason::EnergyIncreased
        )
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
