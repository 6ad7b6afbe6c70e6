//! Aggregates over the corpus of one energy, as
//! pure functions of the summary rows: solved counts, shifted geometric means with unsolved
//! runs at the cap (the Mittelmann convention), Dolan–Moré performance profiles and Moré–Wild
//! data profiles. The aggregates table (`tables/aggregates.rs`) and the profile plots
//! (`plots/profiles.rs`) only format and draw what these return. The report passes judged
//! runs as [`crate::report::target::to_target`] ranks them: iterations and time to the tightest target.
//!
//! The rules, stated once (the captions and the book repeat them):
//! - Skipped pairs are left out entirely, and so are the runs of a problem solved at its start
//!   (`select::counted_in`); `runs` counts the others, `solved` the converged.
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
use super::select::{counted_in, finished, skipped, unique};
use crate::run_folder::timed::Timed;
use crate::run_folder::{Status, SummaryRow};
use crate::stats::shifted_geometric_mean;

mod profiles;
#[cfg(test)]
mod tests;

pub use profiles::{data_profiles, performance_profiles, DataProfile, DataProfiles, Profile, Profiles};

/// Shift of the shifted geometric mean of iterations (the methodology note's example).
pub const ITERATION_SHIFT: f64 = 10.0;
/// Shift of the shifted geometric mean of seconds. Our runs take milliseconds to minutes;
/// below about 0.1 s fixed costs and timer noise dominate a run, and a 1 s shift would turn the mean of most runs back into an arithmetic
/// mean that the few large meshes decide.
pub const TIME_SHIFT_S: f64 = 0.1;
/// Shift in calibration units (`time_norm`): a quarter of the reference workload, which on
/// the machines we run takes a few tenths of a second, so about [`TIME_SHIFT_S`]; a constant,
/// so that normalized means compare across batches and machines.
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
    /// Not solved: not converged, or a fixed budget spent.
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
    let most = runs.iter().filter(|r| counted_in(r)).filter_map(|r| r.iterations).max()?;
    Some(Cap { value: most as f64, source: CapSource::Observed })
}

/// The time cap: the config's `timeout` in `unit`, else the longest time of a run in `runs`.
pub fn time_cap(runs: &[&SummaryRow], batch: &Batch, unit: TimeUnit) -> Option<Cap> {
    if let Some(t) = batch.timeout_s.and_then(|s| unit.from_seconds(s, batch)) {
        return Some(Cap { value: t, source: CapSource::Limit });
    }
    let longest =
        runs.iter().filter(|r| counted_in(r)).filter_map(|r| unit.timed(r)).map(|t| t.value).reduce(f64::max)?;
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
            let datasets = unique(runs.iter().filter(|r| counted_in(r)).map(|r| r.dataset.as_str())).len();
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
    let counted: Vec<&SummaryRow> = runs.iter().copied().filter(|r| counted_in(r)).collect();
    let count = |st: Status| counted.iter().filter(|r| r.status == st).count();
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
        not_converged: count(Status::NotConverged) + count(Status::Budget),
        failed: count(Status::Failed),
        skipped: runs.iter().filter(|r| skipped(r)).count(),
        shifted: counted.iter().filter(|r| r.shifted_iters.unwrap_or(0) > 0).count(),
        sgm_iterations: iterations.and_then(|v| shifted_geometric_mean(&v, ITERATION_SHIFT)),
        sgm_time: times.and_then(|v| {
            Timed::combine(&v, |x| shifted_geometric_mean(x, shift).unwrap_or(f64::NAN)).filter(|t| t.value.is_finite())
        }),
    }
}
