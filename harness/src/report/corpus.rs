//! Aggregates over the corpus of one energy, as
//! pure functions of the summary rows: solved counts, shifted geometric means with unsolved
//! runs at the cap (the Mittelmann convention), Dolan–Moré performance profiles and Moré–Wild
//! data profiles. The aggregates table (`tables/aggregates.rs`) and the profile plots
//! (`plots/profiles.rs`) only format and draw what these return. The report passes judged
//! runs as [`crate::report::to_target`] ranks them: iterations and time to the tightest target.
//!
//! The rules, stated once (the captions and the README repeat them):
//! - Skipped pairs are left out entirely; `runs` counts the others, `solved` the converged.
//! - Shifts: [`ITERATION_SHIFT`] iterations; [`TIME_SHIFT_S`] seconds, or
//!   [`TIME_NORM_SHIFT`] calibration units when times are normalized.
//! - Unsolved runs (not converged or failed) enter at the cap: iterations at the energy's
//!   `max_iters` (meta.json `stop_per_energy`), else at the most iterations any run of the
//!   energy made; time at the config's `timeout`, else at the longest time any run of the
//!   energy took; never below the run's own value.
//! - Time is `time_norm` when every finished run has one, else `time_s` (both the median
//!   over repeats).
//! - Profiles: the problems are the datasets on which every profiled solver has a run that
//!   was not skipped (a common problem set, as Dolan and Moré require); datasets where some
//!   solver was skipped or has no run are left out and counted. Unsolved runs never count as
//!   solved; a dataset nobody solved stays in the denominator. Data profiles use the same
//!   problem set.

use super::batch::Batch;
use super::tables::ranking::Timed;
use super::{finished, skipped, unique};
use crate::run_folder::{Status, SummaryRow};
use crate::stats::shifted_geometric_mean;

/// Shift of the shifted geometric mean of iterations (the methodology note's example).
pub const ITERATION_SHIFT: f64 = 10.0;
/// Shift of the shifted geometric mean of seconds. Our runs take milliseconds to minutes
/// (the CI batch: 5 ms to 5 s, median 0.3 s); below about 0.1 s fixed costs and timer noise
/// dominate a run, and a 1 s shift would turn the mean of most runs back into an arithmetic
/// mean that the few large meshes decide.
pub const TIME_SHIFT_S: f64 = 0.1;
/// Shift in calibration units (`time_norm`): the reference workload takes about 0.4 s on the
/// 2-core machine (0.35–0.41 s measured), so this is about [`TIME_SHIFT_S`]; a constant, so
/// that normalized means compare across batches and machines.
pub const TIME_NORM_SHIFT: f64 = 0.25;
/// Profiles floor a cost here (a run that converged at its initial map made 0 iterations).
pub const PROFILE_MIN_ITERATIONS: f64 = 1.0;
/// Likewise for times (in the time unit).
pub const PROFILE_MIN_TIME: f64 = 1e-6;

/// The time measure of the aggregates and profiles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeUnit {
    /// `time_s`, seconds.
    Seconds,
    /// `time_norm`, multiples of the batch's median calibration time.
    Calibrated,
}

impl TimeUnit {
    /// `Calibrated` when every finished run (ok or not converged) has `time_norm`.
    pub fn choose<'a>(runs: impl IntoIterator<Item = &'a SummaryRow>) -> TimeUnit {
        let mut any = false;
        for r in runs.into_iter().filter(|r| finished(r)) {
            if r.time_norm.is_none() {
                return TimeUnit::Seconds;
            }
            any = true;
        }
        if any {
            TimeUnit::Calibrated
        } else {
            TimeUnit::Seconds
        }
    }

    /// The run's time in this unit, with its spread over the repeats.
    pub fn timed(self, r: &SummaryRow) -> Option<Timed> {
        let v = match self {
            TimeUnit::Seconds => r.time_s,
            TimeUnit::Calibrated => r.time_norm,
        }?;
        v.is_finite().then(|| Timed::of(r, v))
    }

    pub fn shift(self) -> f64 {
        match self {
            TimeUnit::Seconds => TIME_SHIFT_S,
            TimeUnit::Calibrated => TIME_NORM_SHIFT,
        }
    }

    /// Seconds in this unit (`None`: calibrated without a calibration time).
    pub fn from_seconds(self, s: f64, batch: &Batch) -> Option<f64> {
        match self {
            TimeUnit::Seconds => Some(s),
            TimeUnit::Calibrated => batch.calibration_s().map(|c| s / c),
        }
    }

    /// The column unit: `s` or `cal` (calibration units).
    pub fn symbol(self) -> &'static str {
        match self {
            TimeUnit::Seconds => "s",
            TimeUnit::Calibrated => "cal",
        }
    }

    /// What the caption says the times are.
    pub fn describe(self) -> String {
        match self {
            TimeUnit::Seconds => format!(
                "time = time_s in seconds (the median over repeats; not every finished run has time_norm), \
                 shift {TIME_SHIFT_S} s"
            ),
            TimeUnit::Calibrated => format!(
                "time = time_norm in calibration units (the run's median time over repeats divided by the \
                 batch's median calibration time; every finished run has it), shift {TIME_NORM_SHIFT} units \
                 (about {TIME_SHIFT_S} s where the reference workload takes 0.4 s)"
            ),
        }
    }
}

/// Where a cap comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CapSource {
    /// The batch's limit: `max_iters` or the config's `timeout`.
    Limit,
    /// No limit known: the largest value any run of the energy shows.
    Observed,
}

/// The value at which an unsolved run enters a shifted geometric mean.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cap {
    pub value: f64,
    pub source: CapSource,
}

/// One solver's aggregate over an energy's runs.
#[derive(Clone, Debug, PartialEq)]
pub struct SolverAggregate {
    pub solver: String,
    /// Runs that were not skipped.
    pub runs: usize,
    /// `status = ok`.
    pub solved: usize,
    pub not_converged: usize,
    pub failed: usize,
    pub skipped: usize,
    /// Runs with `shifted_iters > 0` (regularized beyond the base Tikhonov shift).
    pub shifted: usize,
    /// Shifted geometric mean of iterations, unsolved at the cap.
    pub sgm_iterations: Option<f64>,
    /// Shifted geometric mean of time, unsolved at the cap; bounds from the repeats' min and
    /// max times.
    pub sgm_time: Option<Timed>,
}

/// The aggregates of one energy.
#[derive(Clone, Debug, PartialEq)]
pub struct EnergyAggregate {
    pub energy: String,
    /// Datasets with a run that was not skipped.
    pub datasets: usize,
    pub iteration_cap: Option<Cap>,
    pub time_cap: Option<Cap>,
    pub solvers: Vec<SolverAggregate>,
}

/// The iteration cap of `energy`: its `max_iters`, else the most iterations of a run in `runs`.
pub fn iteration_cap(energy: &str, runs: &[&SummaryRow], batch: &Batch) -> Option<Cap> {
    if let Some(&m) = batch.max_iters.get(energy) {
        return Some(Cap { value: m as f64, source: CapSource::Limit });
    }
    let most = runs.iter().filter(|r| !skipped(r)).filter_map(|r| r.iterations).max()?;
    Some(Cap { value: most as f64, source: CapSource::Observed })
}

/// The time cap: the config's `timeout` in `unit`, else the longest time of a run in `runs`.
pub fn time_cap(runs: &[&SummaryRow], batch: &Batch, unit: TimeUnit) -> Option<Cap> {
    if let Some(t) = batch.timeout_s.and_then(|s| unit.from_seconds(s, batch)) {
        return Some(Cap { value: t, source: CapSource::Limit });
    }
    let longest =
        runs.iter().filter(|r| !skipped(r)).filter_map(|r| unit.timed(r)).map(|t| t.value).reduce(f64::max)?;
    Some(Cap { value: longest, source: CapSource::Observed })
}

/// Per energy (first-appearance order) and solver: counts and shifted geometric means of
/// `rows` (callers pass `param`/`deform` rows).
pub fn aggregate(rows: &[SummaryRow], batch: &Batch, unit: TimeUnit) -> Vec<EnergyAggregate> {
    let solvers = unique(rows.iter().map(|r| r.solver.as_str()));
    unique(rows.iter().map(|r| r.energy.as_str()))
        .into_iter()
        .map(|energy| {
            let runs: Vec<&SummaryRow> = rows.iter().filter(|r| r.energy == energy).collect();
            let iteration_cap = iteration_cap(energy, &runs, batch);
            let time_cap = time_cap(&runs, batch, unit);
            let datasets = unique(runs.iter().filter(|r| !skipped(r)).map(|r| r.dataset.as_str())).len();
            let solvers = solvers
                .iter()
                .filter(|s| runs.iter().any(|r| r.solver == **s))
                .map(|s| {
                    let mine: Vec<&SummaryRow> = runs.iter().copied().filter(|r| r.solver == *s).collect();
                    solver_aggregate(s, &mine, iteration_cap, time_cap, unit)
                })
                .collect();
            EnergyAggregate { energy: energy.to_string(), datasets, iteration_cap, time_cap, solvers }
        })
        .collect()
}

fn solver_aggregate(
    solver: &str,
    runs: &[&SummaryRow],
    iteration_cap: Option<Cap>,
    time_cap: Option<Cap>,
    unit: TimeUnit,
) -> SolverAggregate {
    let count = |st: Status| runs.iter().filter(|r| r.status == st).count();
    let counted: Vec<&SummaryRow> = runs.iter().copied().filter(|r| !skipped(r)).collect();
    // Each run's cost: its own when solved, the cap (or its own, if larger) when not.
    let iterations: Option<Vec<f64>> = counted
        .iter()
        .map(|r| {
            let own = r.iterations.map(|i| i as f64);
            match (r.status == Status::Ok, own, iteration_cap) {
                (true, Some(i), _) => Some(i),
                (_, own, Some(cap)) => Some(own.map_or(cap.value, |i| i.max(cap.value))),
                (false, _, None) | (true, None, None) => None,
            }
        })
        .collect();
    let times: Option<Vec<Timed>> = counted
        .iter()
        .map(|r| {
            let own = unit.timed(r);
            match (r.status == Status::Ok, own, time_cap) {
                (true, Some(t), _) => Some(t),
                (_, Some(t), Some(cap)) if t.value > cap.value => Some(Timed::exact(t.value)),
                (_, _, Some(cap)) => Some(Timed::exact(cap.value)),
                (_, _, None) => None,
            }
        })
        .collect();
    let shift = unit.shift();
    SolverAggregate {
        solver: solver.to_string(),
        runs: counted.len(),
        solved: count(Status::Ok),
        not_converged: count(Status::NotConverged),
        failed: count(Status::Failed),
        skipped: count(Status::Skipped),
        shifted: counted.iter().filter(|r| r.shifted_iters.unwrap_or(0) > 0).count(),
        sgm_iterations: iterations.and_then(|v| shifted_geometric_mean(&v, ITERATION_SHIFT)),
        sgm_time: times.and_then(|v| {
            Timed::combine(&v, |x| shifted_geometric_mean(x, shift).unwrap_or(f64::NAN)).filter(|t| t.value.is_finite())
        }),
    }
}

/// One solver's performance profile: its ratio to the best solver on each problem.
#[derive(Clone, Debug, PartialEq)]
pub struct Profile {
    pub solver: String,
    /// One per problem, ascending; `f64::INFINITY` where the solver did not solve it.
    pub ratios: Vec<f64>,
}

impl Profile {
    /// ρ(τ): the fraction of the problems solved within `tau` times the best solver's cost.
    pub fn fraction_within(&self, tau: f64) -> f64 {
        if self.ratios.is_empty() {
            return 0.0;
        }
        self.ratios.iter().filter(|r| **r <= tau).count() as f64 / self.ratios.len() as f64
    }

    /// The step function as a polyline in (log2 τ, ρ) from τ = 1 to `tau_max`: a vertical
    /// step at every ratio, flat after the last one (the unsolved never arrive).
    pub fn steps(&self, tau_max: f64) -> Vec<(f64, f64)> {
        let mut pts = vec![(0.0, self.fraction_within(1.0))];
        let mut finite: Vec<f64> = self.ratios.iter().copied().filter(|r| r.is_finite() && *r > 1.0).collect();
        finite.dedup();
        for r in finite.into_iter().filter(|r| *r <= tau_max) {
            let below = pts.last().map_or(0.0, |p| p.1);
            pts.push((r.log2(), below));
            pts.push((r.log2(), self.fraction_within(r)));
        }
        let last = pts.last().map_or(0.0, |p| p.1);
        pts.push((tau_max.max(1.0).log2(), last));
        pts
    }
}

/// The profiles of one energy and cost.
#[derive(Clone, Debug, PartialEq)]
pub struct Profiles {
    /// The common problem set: datasets on which every profiled solver has a run that was
    /// not skipped.
    pub problems: Vec<String>,
    /// Datasets left out: some profiled solver was skipped there or has no run.
    pub left_out: Vec<String>,
    /// Solvers with a run that was not skipped, in first-appearance order.
    pub profiles: Vec<Profile>,
}

impl Profiles {
    /// The right end of the τ axis: a little past the largest finite ratio, at least 2.
    pub fn tau_max(&self) -> f64 {
        let largest =
            self.profiles.iter().flat_map(|p| &p.ratios).copied().filter(|r| r.is_finite()).fold(1.0, f64::max);
        (largest * 1.25).max(2.0)
    }
}

/// The common problem set of `runs` (one energy): the solvers with a run that was not
/// skipped, the datasets on which each of them has one (the problems) and the others (left
/// out), in first-appearance order.
fn problem_set<'a>(runs: &[&'a SummaryRow]) -> (Vec<&'a str>, Vec<&'a str>, Vec<&'a str>) {
    let solvers = unique(runs.iter().filter(|r| !skipped(r)).map(|r| r.solver.as_str()));
    let datasets = unique(runs.iter().filter(|r| !skipped(r)).map(|r| r.dataset.as_str()));
    let (problems, left_out): (Vec<&str>, Vec<&str>) =
        datasets.into_iter().partition(|d| solvers.iter().all(|s| run_of(runs, d, s).is_some()));
    (solvers, problems, left_out)
}

/// The run of solver `s` on dataset `d` that was not skipped.
fn run_of<'a>(runs: &[&'a SummaryRow], d: &str, s: &str) -> Option<&'a SummaryRow> {
    runs.iter().copied().find(|r| r.dataset == d && r.solver == s && !skipped(r))
}

/// The cost of solver `s` on problem `d` when it solved it (status ok, finite cost), floored
/// at `floor`.
fn solved_cost(
    runs: &[&SummaryRow],
    d: &str,
    s: &str,
    cost: &impl Fn(&SummaryRow) -> Option<f64>,
    floor: f64,
) -> Option<f64> {
    run_of(runs, d, s).filter(|r| r.status == Status::Ok).and_then(cost).filter(|c| c.is_finite()).map(|c| c.max(floor))
}

/// Dolan–Moré performance profiles of `runs` (one energy) for `cost` (iterations, time):
/// r(p, s) = c(p, s) / min over the solvers that solved p of c(p, ·); a run solves its
/// problem when its status is ok and its cost is finite; costs are floored at `floor`.
pub fn performance_profiles(runs: &[&SummaryRow], cost: impl Fn(&SummaryRow) -> Option<f64>, floor: f64) -> Profiles {
    let (solvers, problems, left_out) = problem_set(runs);
    let best: Vec<Option<f64>> = problems
        .iter()
        .map(|d| solvers.iter().filter_map(|s| solved_cost(runs, d, s, &cost, floor)).reduce(f64::min))
        .collect();
    let profiles = solvers
        .iter()
        .map(|s| {
            let mut ratios: Vec<f64> = problems
                .iter()
                .zip(&best)
                .map(|(d, b)| match (solved_cost(runs, d, s, &cost, floor), b) {
                    (Some(c), Some(b)) => c / b,
                    _ => f64::INFINITY,
                })
                .collect();
            ratios.sort_by(f64::total_cmp);
            Profile { solver: s.to_string(), ratios }
        })
        .collect();
    Profiles {
        problems: problems.into_iter().map(String::from).collect(),
        left_out: left_out.into_iter().map(String::from).collect(),
        profiles,
    }
}

/// One solver's data profile (Moré and Wild 2009): what it cost to solve each problem.
#[derive(Clone, Debug, PartialEq)]
pub struct DataProfile {
    pub solver: String,
    /// One per problem, ascending; `f64::INFINITY` where the solver did not solve it.
    pub costs: Vec<f64>,
}

impl DataProfile {
    /// d_s(α): the fraction of the problems solved within the budget `alpha`.
    pub fn fraction_within(&self, alpha: f64) -> f64 {
        if self.costs.is_empty() {
            return 0.0;
        }
        self.costs.iter().filter(|c| **c <= alpha).count() as f64 / self.costs.len() as f64
    }

    /// The step function as a polyline in (log10 α, d) from `lo` to `hi`: 0 until the first
    /// solve, a vertical step at every cost, flat after the last one.
    pub fn steps(&self, lo: f64, hi: f64) -> Vec<(f64, f64)> {
        let mut pts = vec![(lo.log10(), self.fraction_within(lo))];
        let mut finite: Vec<f64> =
            self.costs.iter().copied().filter(|c| c.is_finite() && *c > lo && *c <= hi).collect();
        finite.dedup();
        for c in finite {
            let below = pts.last().map_or(0.0, |p| p.1);
            pts.push((c.log10(), below));
            pts.push((c.log10(), self.fraction_within(c)));
        }
        let last = pts.last().map_or(0.0, |p| p.1);
        pts.push((hi.log10(), last));
        pts
    }
}

/// The data profiles of one energy.
#[derive(Clone, Debug, PartialEq)]
pub struct DataProfiles {
    /// The common problem set, as for [`performance_profiles`].
    pub problems: Vec<String>,
    pub left_out: Vec<String>,
    pub profiles: Vec<DataProfile>,
}

impl DataProfiles {
    /// The budget axis: from a little below the cheapest solve to a little above the dearest
    /// (a decade around one cost when there is one, `None` when nothing was solved).
    pub fn budget_range(&self) -> Option<(f64, f64)> {
        let costs = || self.profiles.iter().flat_map(|p| &p.costs).copied().filter(|c| c.is_finite());
        let lo = costs().reduce(f64::min)?;
        let hi = costs().reduce(f64::max)?;
        Some((lo / 2.0, (hi * 2.0).max(lo * 10.0)))
    }
}

/// Moré–Wild data profiles of `runs` (one energy): for each solver, the costs (`cost`,
/// floored at `floor`) of the problems it solved (status ok) on the common problem set, so
/// that d_s(α) = |{p : c(p, s) ≤ α}| / |P|.
pub fn data_profiles(runs: &[&SummaryRow], cost: impl Fn(&SummaryRow) -> Option<f64>, floor: f64) -> DataProfiles {
    let (solvers, problems, left_out) = problem_set(runs);
    let profiles = solvers
        .iter()
        .map(|s| {
            let mut costs: Vec<f64> =
                problems.iter().map(|d| solved_cost(runs, d, s, &cost, floor).unwrap_or(f64::INFINITY)).collect();
            costs.sort_by(f64::total_cmp);
            DataProfile { solver: s.to_string(), costs }
        })
        .collect();
    DataProfiles {
        problems: problems.into_iter().map(String::from).collect(),
        left_out: left_out.into_iter().map(String::from).collect(),
        profiles,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Task;

    fn run(d: &str, s: &str, status: Status, it: usize, t: f64) -> SummaryRow {
        SummaryRow {
            dataset: d.into(),
            task: Task::Param,
            energy: "sd".into(),
            solver: s.into(),
            iterations: Some(it),
            time_s: Some(t),
            status,
            ..Default::default()
        }
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * b.abs().max(1.0)
    }

    #[test]
    fn profile_values_on_a_hand_made_summary() {
        // 3 datasets x 2 solvers; a solves d1 in 10, d2 in 20, fails d3; b takes 20, 10, 30.
        let rows = [
            run("d1", "a", Status::Ok, 10, 1.0),
            run("d1", "b", Status::Ok, 20, 4.0),
            run("d2", "a", Status::Ok, 20, 1.0),
            run("d2", "b", Status::Ok, 10, 3.0),
            run("d3", "a", Status::Failed, 0, 0.001),
            run("d3", "b", Status::Ok, 30, 2.0),
        ];
        let refs: Vec<&SummaryRow> = rows.iter().collect();
        let p = performance_profiles(&refs, |r| r.iterations.map(|i| i as f64), PROFILE_MIN_ITERATIONS);
        assert_eq!(p.problems, ["d1", "d2", "d3"]);
        assert!(p.left_out.is_empty());
        let (a, b) = (&p.profiles[0], &p.profiles[1]);
        assert_eq!((a.solver.as_str(), b.solver.as_str()), ("a", "b"));
        assert_eq!(a.ratios[..2], [1.0, 2.0]);
        assert_eq!(a.ratios[2], f64::INFINITY, "a failure is never solved");
        assert_eq!(b.ratios, [1.0, 1.0, 2.0]);
        for (tau, ra, rb) in
            [(1.0, 1.0 / 3.0, 2.0 / 3.0), (1.5, 1.0 / 3.0, 2.0 / 3.0), (2.0, 2.0 / 3.0, 1.0), (1e9, 2.0 / 3.0, 1.0)]
        {
            assert!(close(a.fraction_within(tau), ra), "a at {tau}");
            assert!(close(b.fraction_within(tau), rb), "b at {tau}");
        }
        assert!(close(p.tau_max(), 2.5));
        // The step polyline in log2 tau: flat at 1/3 until tau = 2 (x = 1), then 2/3.
        let steps = a.steps(p.tau_max());
        let want = [(0.0, 1.0 / 3.0), (1.0, 1.0 / 3.0), (1.0, 2.0 / 3.0), (2.5f64.log2(), 2.0 / 3.0)];
        assert_eq!(steps.len(), want.len());
        for (s, w) in steps.iter().zip(want) {
            assert!(close(s.0, w.0) && close(s.1, w.1), "{steps:?}");
        }
        // Times: a's 0.001 s failure does not make it the best on d3; ratios 4 and 3 for b.
        let p = performance_profiles(&refs, |r| r.time_s, PROFILE_MIN_TIME);
        assert_eq!(p.profiles[0].ratios[..2], [1.0, 1.0]);
        assert_eq!(p.profiles[1].ratios, [1.0, 3.0, 4.0]);
        assert!(close(p.profiles[1].fraction_within(3.5), 2.0 / 3.0));
    }

    #[test]
    fn data_profiles_count_the_problems_solved_within_each_budget() {
        let rows = [
            run("d1", "a", Status::Ok, 10, 1.0),
            run("d1", "b", Status::Ok, 10, 4.0),
            // b's unsolved run is fast and never counts.
            run("d2", "a", Status::Ok, 10, 2.0),
            run("d2", "b", Status::NotConverged, 10, 0.5),
            run("d3", "a", Status::Failed, 0, 0.001),
            run("d3", "b", Status::Ok, 10, 3.0),
            // b skipped on d4: not a common problem.
            run("d4", "a", Status::Ok, 10, 0.1),
            run("d4", "b", Status::Skipped, 0, 0.0),
        ];
        let refs: Vec<&SummaryRow> = rows.iter().collect();
        let p = data_profiles(&refs, |r| r.time_s, PROFILE_MIN_TIME);
        assert_eq!(
            (p.problems.clone(), p.left_out.clone()),
            (vec!["d1".into(), "d2".into(), "d3".into()], vec!["d4".into()])
        );
        let (a, b) = (&p.profiles[0], &p.profiles[1]);
        assert_eq!(a.costs, [1.0, 2.0, f64::INFINITY]);
        assert_eq!(b.costs, [3.0, 4.0, f64::INFINITY]);
        for (alpha, da, db) in [
            (0.5, 0.0, 0.0),
            (1.0, 1.0 / 3.0, 0.0),
            (2.0, 2.0 / 3.0, 0.0),
            (3.0, 2.0 / 3.0, 1.0 / 3.0),
            (4.0, 2.0 / 3.0, 2.0 / 3.0),
            (1e9, 2.0 / 3.0, 2.0 / 3.0),
        ] {
            assert!(close(a.fraction_within(alpha), da), "a at {alpha}");
            assert!(close(b.fraction_within(alpha), db), "b at {alpha}");
        }
        // Half the cheapest solve to twice the dearest, at least a decade.
        assert_eq!(p.budget_range(), Some((0.5, 10.0)));
        let steps = a.steps(0.5, 10.0);
        let want = [
            (0.5f64.log10(), 0.0),
            (0.0, 0.0),
            (0.0, 1.0 / 3.0),
            (2f64.log10(), 1.0 / 3.0),
            (2f64.log10(), 2.0 / 3.0),
            (1.0, 2.0 / 3.0),
        ];
        assert_eq!(steps.len(), want.len(), "{steps:?}");
        for (s, w) in steps.iter().zip(want) {
            assert!(close(s.0, w.0) && close(s.1, w.1), "{steps:?}");
        }
        // Nothing solved: no axis.
        let none = data_profiles(&refs[4..5], |r| r.time_s, PROFILE_MIN_TIME);
        assert_eq!(none.budget_range(), None);
    }

    #[test]
    fn profiles_use_a_common_problem_set_without_skipped_pairs() {
        let rows = [
            run("d1", "a", Status::Ok, 10, 1.0),
            run("d1", "b", Status::NotConverged, 1000, 9.0),
            run("d1", "c", Status::Skipped, 0, 0.0),
            // b skipped on d2: d2 leaves the problem set for everyone.
            run("d2", "a", Status::Ok, 10, 1.0),
            run("d2", "b", Status::Skipped, 0, 0.0),
            // nobody solves d3: it stays, unsolved for both.
            run("d3", "a", Status::NotConverged, 1000, 1.0),
            run("d3", "b", Status::Failed, 0, 0.0),
            // a converged at its initial map: floored at one iteration.
            run("d4", "a", Status::Ok, 0, 1.0),
            run("d4", "b", Status::Ok, 3, 1.0),
        ];
        let refs: Vec<&SummaryRow> = rows.iter().collect();
        let p = performance_profiles(&refs, |r| r.iterations.map(|i| i as f64), PROFILE_MIN_ITERATIONS);
        let names: Vec<&str> = p.profiles.iter().map(|x| x.solver.as_str()).collect();
        assert_eq!(names, ["a", "b"], "c was skipped everywhere: not profiled");
        assert_eq!(p.problems, ["d1", "d3", "d4"]);
        assert_eq!(p.left_out, ["d2"]);
        assert_eq!(p.profiles[0].ratios, [1.0, 1.0, f64::INFINITY]);
        assert_eq!(p.profiles[1].ratios, [3.0, f64::INFINITY, f64::INFINITY]);
        assert!(close(p.profiles[1].fraction_within(2.9), 0.0));
        assert!(close(p.profiles[1].fraction_within(3.0), 1.0 / 3.0));
    }

    #[test]
    fn shifted_geometric_means_count_unsolved_runs_at_the_cap_and_leave_skipped_out() {
        let mut rows = vec![
            run("d1", "a", Status::Ok, 10, 1.0),
            run("d2", "a", Status::Ok, 30, 3.0),
            run("d1", "b", Status::Ok, 20, 2.0),
            // Fails fast: enters at the caps, not at its 3 iterations and 0.01 s.
            run("d2", "b", Status::NotConverged, 3, 0.01),
            run("d1", "c", Status::Skipped, 0, 0.0),
            run("d2", "c", Status::Failed, 0, 0.0),
        ];
        rows[5].time_s = None;
        rows[5].iterations = None;
        rows[2].shifted_iters = Some(4);
        let batch = Batch { max_iters: [("sd".to_string(), 100)].into(), ..Default::default() };
        let agg = aggregate(&rows, &batch, TimeUnit::Seconds);
        assert_eq!(agg.len(), 1);
        let e = &agg[0];
        assert_eq!((e.energy.as_str(), e.datasets), ("sd", 2));
        assert_eq!(e.iteration_cap, Some(Cap { value: 100.0, source: CapSource::Limit }));
        // No timeout: the longest time any run of the energy took.
        assert_eq!(e.time_cap, Some(Cap { value: 3.0, source: CapSource::Observed }));
        let (a, b, c) = (&e.solvers[0], &e.solvers[1], &e.solvers[2]);
        assert_eq!((a.runs, a.solved, a.skipped, a.shifted), (2, 2, 0, 0));
        assert!(close(a.sgm_iterations.unwrap(), (20.0f64 * 40.0).sqrt() - 10.0));
        assert!(close(a.sgm_time.unwrap().value, (1.1f64 * 3.1).sqrt() - 0.1));
        assert_eq!((b.runs, b.solved, b.not_converged, b.shifted), (2, 1, 1, 1));
        assert!(close(b.sgm_iterations.unwrap(), (30.0f64 * 110.0).sqrt() - 10.0));
        assert!(close(b.sgm_time.unwrap().value, (2.1f64 * 3.1).sqrt() - 0.1));
        // c: the skipped run is left out, the failed one counts at the caps.
        assert_eq!((c.runs, c.solved, c.failed, c.skipped), (1, 0, 1, 1));
        assert!(close(c.sgm_iterations.unwrap(), 100.0));
        assert!(close(c.sgm_time.unwrap().value, 3.0));
        // Without max_iters in meta.json: the most iterations seen; with a timeout: the timeout.
        let batch = Batch { timeout_s: Some(60.0), ..Default::default() };
        let e = &aggregate(&rows, &batch, TimeUnit::Seconds)[0];
        assert_eq!(e.iteration_cap, Some(Cap { value: 30.0, source: CapSource::Observed }));
        assert_eq!(e.time_cap, Some(Cap { value: 60.0, source: CapSource::Limit }));
        assert!(close(e.solvers[2].sgm_time.unwrap().value, 60.0));
    }

    #[test]
    fn time_spreads_and_units() {
        let mut rows = vec![run("d1", "a", Status::Ok, 10, 1.0), run("d2", "a", Status::Ok, 10, 4.0)];
        for r in &mut rows {
            (r.repeats, r.time_s_min, r.time_s_max) = (Some(5), r.time_s.map(|t| t * 0.5), r.time_s.map(|t| t * 2.0));
        }
        assert_eq!(TimeUnit::choose(&rows), TimeUnit::Seconds, "no time_norm");
        let t = aggregate(&rows, &Batch::default(), TimeUnit::Seconds)[0].solvers[0].sgm_time.unwrap();
        assert!(close(t.value, (1.1f64 * 4.1).sqrt() - 0.1));
        assert!(close(t.lo, (0.6f64 * 2.1).sqrt() - 0.1) && close(t.hi, (2.1f64 * 8.1).sqrt() - 0.1));
        assert_eq!(t.samples, 5);
        rows[0].time_norm = Some(2.0);
        assert_eq!(TimeUnit::choose(&rows), TimeUnit::Seconds, "one run without time_norm");
        rows[1].time_norm = Some(8.0);
        // A failed run without times does not stop normalization.
        rows.push(SummaryRow { status: Status::Failed, ..run("d3", "a", Status::Failed, 0, 0.0) });
        assert_eq!(TimeUnit::choose(&rows), TimeUnit::Calibrated);
        let t = TimeUnit::Calibrated.timed(&rows[0]).unwrap();
        assert!(close(t.lo, 1.0) && close(t.hi, 4.0), "the spread scales with the unit");
        let batch = Batch {
            calibration: Some(crate::calibration::Calibration { workload: "w".into(), samples_s: vec![0.5] }),
            timeout_s: Some(10.0),
            ..Default::default()
        };
        assert_eq!(TimeUnit::Calibrated.from_seconds(10.0, &batch), Some(20.0));
        assert_eq!(time_cap(&rows.iter().collect::<Vec<_>>(), &batch, TimeUnit::Calibrated).unwrap().value, 20.0);
        assert_eq!(TimeUnit::Calibrated.from_seconds(10.0, &Batch::default()), None);
    }
}
