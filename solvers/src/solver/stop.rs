//! Why a solver stops: the stopping rules of a run and the reason it ended.

/// Why a solver stopped. `as_str` is the `stop_reason` column.
#[derive(Clone, Debug, PartialEq)]
pub enum StopReason {
    /// `|grad| <= grad_tol`, a rule that ends the run ([`RuleUse::End`]).
    GradientTolerance,
    /// Energy decrease below `energy_decrease_tol` (on by default for SARAP in `param` only),
    /// a rule that ends the run.
    EnergyDecrease,
    /// The observer said the row is at its target ([`Flow::AtTarget`](super::Flow::AtTarget))
    /// and a rule of the run had held (its event is recorded).
    Target,
    /// `|grad| <= grad_floor`: a stationary point, far tighter than any rule.
    GradientFloor,
    /// The lowest energy so far fell by no more than round-off over `stall_window` iterations.
    NoDecrease,
    /// A line search found no decrease where its full step's first-order model predicts less
    /// than round-off ([`StopReason::after_line_search`]): stationary at working precision.
    RoundOff,
    /// `max_iters` steps were taken.
    MaxIterations,
    /// Armijo backtracking shrank the step below `t |d| <= min_step` without sufficient
    /// decrease, where the full step predicted a decrease above round-off.
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
    pub const ALL: [StopReason; 15] = [
        StopReason::GradientTolerance,
        StopReason::EnergyDecrease,
        StopReason::Target,
        StopReason::GradientFloor,
        StopReason::NoDecrease,
        StopReason::RoundOff,
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
            StopReason::Target => "target",
            StopReason::GradientFloor => "grad_floor",
            StopReason::NoDecrease => "no_decrease",
            StopReason::RoundOff => "round_off",
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
    /// descend, a non-finite value, an energy that rose where it must fall, a line search that
    /// found no decrease where its model predicted one above round-off. Not a stop short of the
    /// target, which another iteration or a looser rule would pass, but a failure of the method
    /// on this problem.
    pub fn is_breakdown(&self) -> bool {
        matches!(
            self,
            StopReason::LinearSolveFailed(_)
                | StopReason::NotDescent
                | StopReason::NonFinite(_)
                | StopReason::EnergyIncreased
                | StopReason::LineSearchFailed
        )
    }

    /// Why a line search that accepted no step ended a run at an iterate of energy `energy`
    /// whose direction `d` has slope `g_dot_d = <g, d>`: [`StopReason::RoundOff`] when the
    /// full step's first-order decrease `|<g, d>|` is within round-off ([`STALL_RTOL`]) of
    /// `max(1, |E|)`, so no step can show a decrease (for a Newton direction `|<g, d>|` is the
    /// squared Newton decrement, twice the model's decrease: Boyd and Vandenberghe's
    /// stationarity test at working precision); else [`StopReason::LineSearchFailed`].
    pub fn after_line_search(g_dot_d: f64, energy: f64) -> StopReason {
        if g_dot_d.abs() <= STALL_RTOL * energy.abs().max(1.0) {
            StopReason::RoundOff
        } else {
            StopReason::LineSearchFailed
        }
    }

    /// A stationary end: the gradient floor, no decrease beyond round-off over the window, or a
    /// line search whose model predicts less.
    pub fn is_stationary(&self) -> bool {
        matches!(self, StopReason::GradientFloor | StopReason::NoDecrease | StopReason::RoundOff)
    }

    /// The run's budget ended it: the iteration cap or the deadline.
    pub fn is_budget(&self) -> bool {
        matches!(self, StopReason::MaxIterations | StopReason::Timeout)
    }

    /// Ended by one of the tolerance rules ([`RuleUse::End`]) or an external solver's own.
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

/// A tolerance rule of `[stop]`: the papers' convergence tests.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StopRule {
    /// `|grad| <= grad_tol`.
    GradientTolerance,
    /// The last accepted step lowered the energy by less than `energy_decrease_tol`.
    EnergyDecrease,
}

impl StopRule {
    /// Every rule, in the order they are checked.
    pub const ALL: [StopRule; 2] = [StopRule::GradientTolerance, StopRule::EnergyDecrease];

    /// The rule's name: its stop reason's string (`grad_tol`, `energy_decrease`).
    pub fn as_str(self) -> &'static str {
        self.stop_reason().as_str()
    }

    /// The reason a run records when this rule ends it.
    pub fn stop_reason(self) -> StopReason {
        match self {
            StopRule::GradientTolerance => StopReason::GradientTolerance,
            StopRule::EnergyDecrease => StopReason::EnergyDecrease,
        }
    }
}

/// What the tolerance rules do to a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RuleUse {
    /// The first rule that holds ends the run (the papers' protocol; reference minima, tests).
    #[default]
    End,
    /// A rule that holds is an event: its first iteration is recorded and the run goes on
    /// until the observer's target, a stationary point, a breakdown or the budget.
    Event,
}

/// The first iteration at which each rule held (`None`: it never did, or is off).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Events {
    /// `|grad| <= grad_tol` first held at this row.
    pub grad_tol: Option<usize>,
    /// A step lowered the energy by less than `energy_decrease_tol` first at this row.
    pub energy_decrease: Option<usize>,
}

impl Events {
    /// The iteration at which `rule` first held.
    pub fn of(&self, rule: StopRule) -> Option<usize> {
        match rule {
            StopRule::GradientTolerance => self.grad_tol,
            StopRule::EnergyDecrease => self.energy_decrease,
        }
    }

    fn set(&mut self, rule: StopRule, iter: usize) {
        let slot = match rule {
            StopRule::GradientTolerance => &mut self.grad_tol,
            StopRule::EnergyDecrease => &mut self.energy_decrease,
        };
        slot.get_or_insert(iter);
    }

    /// The rule that would have ended the run first and its iteration: the earliest event,
    /// the gradient's on a tie (the order the rules are checked in).
    pub fn first(&self) -> Option<(StopRule, usize)> {
        StopRule::ALL.into_iter().filter_map(|r| self.of(r).map(|k| (r, k))).min_by_key(|&(_, k)| k)
    }
}

/// How far the lowest energy must fall over `stall_window` iterations, relative to
/// `max(1, |E|)`, to count as a decrease: above the round-off of a sum of element energies
/// (about 1e-14 of it), far below any target.
pub const STALL_RTOL: f64 = 1e-12;

/// The lowest energy of the last `window + 1` rows, to tell a stall ([`StopReason::NoDecrease`]).
#[derive(Clone, Debug, Default)]
pub struct Stall {
    window: usize,
    best: std::collections::VecDeque<f64>,
}

impl Stall {
    /// A detector over `window` iterations (0: off).
    pub fn new(window: usize) -> Stall {
        Stall { window, best: std::collections::VecDeque::with_capacity(window + 1) }
    }

    /// Take the next row's energy; whether the lowest energy fell by no more than round-off
    /// over the last `window` iterations. A non-monotone method (`aqp`) is judged on its
    /// lowest energy so far.
    pub fn push(&mut self, energy: f64) -> bool {
        if self.window == 0 {
            return false;
        }
        let last = self.best.back().copied().unwrap_or(f64::INFINITY);
        let best = if energy < last { energy } else { last };
        if self.best.len() > self.window {
            self.best.pop_front();
        }
        self.best.push_back(best);
        match self.best.front() {
            Some(&old) if self.best.len() > self.window => old - best <= STALL_RTOL * best.abs().max(1.0),
            _ => false,
        }
    }
}

/// Stopping rules (`[stop]`). The default is the `param` task's rule (docs/src/design/numerics.md); the tasks that stop
/// otherwise have their own (`param::default_stop` for SARAP, `deform::default_stop`,
/// `authalic::default_stop`), and [`StopOverrides`] lays a config's keys over any of them.
/// The tolerance rules end the run or are events ([`RuleUse`]); the stationary ends and the
/// cap always end it.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StopSettings {
    /// The rule `|grad| <= grad_tol`; 0 disables it.
    pub grad_tol: f64,
    /// The rule `E_old - E_new < energy_decrease_tol`; 0 disables it.
    pub energy_decrease_tol: f64,
    /// Stop after this many accepted steps.
    pub max_iters: usize,
    /// A stationary point: stop when `|grad| <= grad_floor`; 0 disables it.
    pub grad_floor: f64,
    /// A stall: stop when the lowest energy fell by no more than round-off ([`STALL_RTOL`])
    /// over this many iterations; 0 disables it.
    pub stall_window: usize,
    /// Whether the tolerance rules end the run or mark events (the harness decides: a run
    /// with a target goes to it; a config cannot set it).
    #[serde(skip_deserializing)]
    pub rules: RuleUse,
}

/// The gradient floor of the `param` and `deform` tasks: far below any rule (the papers'
/// 1e-3, deform's 1e-6) and any gradient a run at its target still has.
pub const GRAD_FLOOR: f64 = 1e-10;

/// The stall window of the `param` and `deform` tasks, in iterations.
pub const STALL_WINDOW: usize = 50;

/// Where a row stands: what the executor's end test reads.
#[derive(Clone, Copy, Debug)]
pub struct RowState {
    /// The row's gradient norm.
    pub grad_norm: f64,
    /// The last accepted step's decrease (infinite before the first step).
    pub last_decrease: f64,
    /// The row's iteration.
    pub iter: usize,
    /// The observer said the row is at its target.
    pub at_target: bool,
    /// The lowest energy fell by no more than round-off over the stall window.
    pub stalled: bool,
}

impl StopSettings {
    /// The tolerance rules only (no stationary ends), each ending the run: reference
    /// minima, polishes and tests.
    pub const fn rules_only(grad_tol: f64, energy_decrease_tol: f64, max_iters: usize) -> StopSettings {
        StopSettings { grad_tol, energy_decrease_tol, max_iters, grad_floor: 0.0, stall_window: 0, rules: RuleUse::End }
    }

    /// A fixed-budget protocol: no tolerance rule, so every run that goes on takes
    /// `max_iters` steps (the AEM paper's Table 1, 100 iterations).
    pub fn is_fixed_budget(&self) -> bool {
        self.grad_tol == 0.0 && self.energy_decrease_tol == 0.0
    }

    /// The rules that are on.
    pub fn enabled(&self) -> impl Iterator<Item = StopRule> + '_ {
        StopRule::ALL.into_iter().filter(|r| match r {
            StopRule::GradientTolerance => self.grad_tol > 0.0,
            StopRule::EnergyDecrease => self.energy_decrease_tol > 0.0,
        })
    }

    /// Whether `rule` holds at a row of gradient norm `grad_norm` whose step lowered the
    /// energy by `last_decrease` (infinite before the first step). A tolerance of 0 turns its
    /// rule off (a rise of SEM's energy is no stall).
    pub fn holds(&self, rule: StopRule, grad_norm: f64, last_decrease: f64) -> bool {
        match rule {
            StopRule::GradientTolerance => self.grad_tol > 0.0 && grad_norm <= self.grad_tol,
            StopRule::EnergyDecrease => self.energy_decrease_tol > 0.0 && last_decrease < self.energy_decrease_tol,
        }
    }

    /// Record the rules that hold at `row` for the first time in `events`.
    pub fn mark(&self, row: &RowState, events: &mut Events) {
        for rule in StopRule::ALL {
            if self.holds(rule, row.grad_norm, row.last_decrease) {
                events.set(rule, row.iter);
            }
        }
    }

    /// Why the run ends at `row` (whose rules are already in `events`), checked before an
    /// iteration in this order: a rule that holds, when rules end runs; the target, once a
    /// rule that is on has held (where the papers' protocol stops: one run gives both), or at
    /// once without rules; the gradient floor; the stall; `iter >= max_iters`. A rule that
    /// holds only after the target (SARAP's gradient, which need not vanish) is not waited for.
    pub fn end(&self, row: &RowState, events: &Events) -> Option<StopReason> {
        if self.rules == RuleUse::End {
            let now = StopRule::ALL.into_iter().find(|&r| self.holds(r, row.grad_norm, row.last_decrease));
            if let Some(rule) = now {
                return Some(rule.stop_reason());
            }
        }
        let ruled = self.enabled().next().is_none() || self.enabled().any(|r| events.of(r).is_some());
        if row.at_target && ruled {
            Some(StopReason::Target)
        } else if self.grad_floor > 0.0 && row.grad_norm <= self.grad_floor {
            Some(StopReason::GradientFloor)
        } else if row.stalled {
            Some(StopReason::NoDecrease)
        } else if row.iter >= self.max_iters {
            Some(StopReason::MaxIterations)
        } else {
            None
        }
    }
}

impl Default for StopSettings {
    /// `|grad| <= 1e-3`, no energy-decrease rule, 1000 iterations, the gradient floor and the
    /// stall window on, the rules ending the run.
    fn default() -> Self {
        StopSettings { grad_floor: GRAD_FLOOR, stall_window: STALL_WINDOW, ..StopSettings::rules_only(1e-3, 0.0, 1000) }
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
    /// Replaces [`StopSettings::grad_floor`] when set.
    pub grad_floor: Option<f64>,
    /// Replaces [`StopSettings::stall_window`] when set.
    pub stall_window: Option<usize>,
}

impl StopOverrides {
    /// `base` with the keys that were set replaced.
    pub fn over(&self, base: StopSettings) -> StopSettings {
        StopSettings {
            grad_tol: self.grad_tol.unwrap_or(base.grad_tol),
            energy_decrease_tol: self.energy_decrease_tol.unwrap_or(base.energy_decrease_tol),
            max_iters: self.max_iters.unwrap_or(base.max_iters),
            grad_floor: self.grad_floor.unwrap_or(base.grad_floor),
            stall_window: self.stall_window.unwrap_or(base.stall_window),
            rules: base.rules,
        }
    }
}
