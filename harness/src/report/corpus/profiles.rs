//! Dolan–Moré performance profiles and Moré–Wild data profiles over the common problem set.

use crate::report::select::{counted_in, unique};
use crate::run_folder::{Status, SummaryRow};

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
    let solvers = unique(runs.iter().filter(|r| counted_in(r)).map(|r| r.solver.as_str()));
    let datasets = unique(runs.iter().filter(|r| counted_in(r)).map(|r| r.dataset.as_str()));
    let (problems, left_out): (Vec<&str>, Vec<&str>) =
        datasets.into_iter().partition(|d| solvers.iter().all(|s| run_of(runs, d, s).is_some()));
    (solvers, problems, left_out)
}

/// The run of solver `s` on dataset `d` that was not skipped.
fn run_of<'a>(runs: &[&'a SummaryRow], d: &str, s: &str) -> Option<&'a SummaryRow> {
    runs.iter().copied().find(|r| r.dataset == d && r.solver == s && counted_in(r))
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
