//! `compare RUN_A RUN_B`: what changed from one run folder (A, before) to another (B, after),
//! the question of `asv compare`. Per run in both: iterations, status, final energy and time
//! before / after / ratio, gated by the rules `check` uses ([`super::rules`]); times are
//! labelled when they moved beyond their noise and are never gated unless asked
//! ([`CompareOptions::time_regressions`]). Runs in one folder only are listed, and the settings in
//! which the two batches' `meta.json` differ head the output. The gate computes; the report
//! layer writes it out (`report::compare`: Markdown and HTML).

use super::rules::{self, Change, GatedRun, TimeChange};
use crate::run_folder::meta::Meta;
use crate::run_folder::timed::Timed;
use crate::run_folder::{self, SummaryRow};
use anyhow::{bail, Context, Result};
use std::collections::{BTreeMap, HashSet};
use std::path::Path;

mod settings;
#[cfg(test)]
mod tests;

use settings::provenance;
pub use settings::{settings_diff, SettingDiff};

/// How strict the comparison is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompareOptions {
    /// Relative tolerance on the final energy (as a baseline's `energy_rtol`).
    pub energy_rtol: f64,
    /// Allowed increase of iterations (as a baseline record's `iterations_tolerance`).
    pub iterations_tolerance: usize,
    /// A time flagged slower is a regression (exit 1). Off by default: times are noisy and
    /// the gate keeps to the deterministic counts.
    pub time_regressions: bool,
}

impl Default for CompareOptions {
    fn default() -> CompareOptions {
        CompareOptions { energy_rtol: rules::DEFAULT_ENERGY_RTOL, iterations_tolerance: 0, time_regressions: false }
    }
}

/// One side of the comparison: a run folder's `summary.csv` rows and its `meta.json`.
#[derive(Clone, Debug, PartialEq)]
pub struct Side {
    /// The folder as given, for the output.
    pub name: String,
    pub rows: Vec<SummaryRow>,
    /// `None` when the folder has no `meta.json`.
    pub meta: Option<Meta>,
}

impl Side {
    /// Read a run folder; errors name the file (and line) at fault.
    pub fn load(dir: &Path) -> Result<Side> {
        let rows = run_folder::read_summary(dir)?;
        let summary = run_folder::summary_csv(dir);
        let mut seen = HashSet::new();
        for r in &rows {
            if !seen.insert((r.dataset.as_str(), r.task, r.energy.as_str(), r.solver.as_str())) {
                bail!("{}: run {} appears twice", summary.display(), GatedRun::from(r).label());
            }
        }
        let meta = if run_folder::meta_json(dir).exists() { Some(Meta::read(dir)?) } else { None };
        Ok(Side { name: dir.display().to_string(), rows, meta })
    }
}

/// Which time the comparison uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeMeasure {
    /// `time_norm`, in units of each batch's calibration workload: comparable across nights.
    Norm,
    /// `time_s`, wall seconds: only comparable when the machine was the same and as fast.
    Seconds,
}

impl TimeMeasure {
    /// `time_norm` when every timed run of both folders has it, else `time_s`.
    fn of(a: &[SummaryRow], b: &[SummaryRow]) -> TimeMeasure {
        let has_norm = |rows: &[SummaryRow]| {
            let timed: Vec<&SummaryRow> = rows.iter().filter(|r| r.time_s.is_some()).collect();
            !timed.is_empty() && timed.iter().all(|r| r.time_norm.is_some())
        };
        if has_norm(a) && has_norm(b) {
            TimeMeasure::Norm
        } else {
            TimeMeasure::Seconds
        }
    }

    fn timed(self, r: &SummaryRow) -> Option<Timed> {
        match self {
            TimeMeasure::Norm => r.time_norm.map(|v| Timed::of(r, v)),
            TimeMeasure::Seconds => Timed::time_s(r),
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            TimeMeasure::Norm => "time_norm (time_s over each batch's calibration median)",
            TimeMeasure::Seconds => "time_s (wall seconds; a folder has no time_norm)",
        }
    }
}

/// A run's time in both folders.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimePair {
    pub before: Timed,
    pub after: Timed,
    /// Beyond the noise, by [`rules::time_change`].
    pub change: Option<TimeChange>,
}

impl TimePair {
    /// after / before, when both are positive measurements.
    pub fn ratio(&self) -> Option<f64> {
        let (b, a) = (self.before.value, self.after.value);
        (b > 0.0 && a > 0.0 && (a / b).is_finite()).then(|| a / b)
    }
}

/// A run in both folders.
#[derive(Clone, Debug, PartialEq)]
pub struct RunPair {
    pub before: SummaryRow,
    pub after: SummaryRow,
    /// The metrics that moved, by the rules of `check`.
    pub changes: Vec<Change>,
    pub time: Option<TimePair>,
}

/// The outcome of comparing two run folders.
#[derive(Clone, Debug, PartialEq)]
pub struct FolderComparison {
    pub a: String,
    pub b: String,
    /// `None` when a folder has no `meta.json` (the settings cannot be compared).
    pub settings: Option<Vec<SettingDiff>>,
    /// Where and how each batch ran: (what, A, B).
    pub provenance: Vec<(String, String, String)>,
    pub unit: TimeMeasure,
    /// In A's order.
    pub pairs: Vec<RunPair>,
    pub only_a: Vec<SummaryRow>,
    pub only_b: Vec<SummaryRow>,
    pub options: CompareOptions,
}

impl FolderComparison {
    /// Regressed metrics, and slower times when they are gated.
    pub fn regressions(&self) -> usize {
        let metrics = self.pairs.iter().flat_map(|p| &p.changes).filter(|c| c.regression).count();
        metrics + if self.options.time_regressions { self.times(TimeChange::Slower) } else { 0 }
    }

    pub fn improvements(&self) -> usize {
        self.pairs.iter().flat_map(|p| &p.changes).filter(|c| !c.regression).count()
    }

    /// Runs whose time moved `way` beyond the noise.
    pub fn times(&self, way: TimeChange) -> usize {
        self.pairs.iter().filter(|p| p.time.and_then(|t| t.change) == Some(way)).count()
    }

    /// 2 when the folders share no run, 1 on a regression, else 0.
    pub fn exit_code(&self) -> u8 {
        if self.pairs.is_empty() {
            2
        } else if self.regressions() > 0 {
            1
        } else {
            0
        }
    }
}

/// Compare two run folders.
pub fn compare_folders(a: &Path, b: &Path, options: CompareOptions) -> Result<FolderComparison> {
    rules::check_energy_rtol(options.energy_rtol).context("--energy-rtol")?;
    Ok(compare(&Side::load(a)?, &Side::load(b)?, options))
}

/// Compare side `a` (before) with side `b` (after).
pub fn compare(a: &Side, b: &Side, options: CompareOptions) -> FolderComparison {
    let unit = TimeMeasure::of(&a.rows, &b.rows);
    let key = |r: &SummaryRow| (r.dataset.clone(), r.task, r.energy.clone(), r.solver.clone());
    let in_b: BTreeMap<_, &SummaryRow> = b.rows.iter().map(|r| (key(r), r)).collect();
    let in_a: HashSet<_> = a.rows.iter().map(key).collect();
    let mut pairs = Vec::new();
    let mut only_a = Vec::new();
    for before in &a.rows {
        let Some(&after) = in_b.get(&key(before)) else {
            only_a.push(before.clone());
            continue;
        };
        let base = GatedRun { iterations_tolerance: Some(options.iterations_tolerance), ..GatedRun::from(before) };
        let changes = rules::changes(&base, &GatedRun::from(after), options.energy_rtol);
        let time = match (unit.timed(before), unit.timed(after)) {
            (Some(tb), Some(ta)) => Some(TimePair { before: tb, after: ta, change: rules::time_change(&tb, &ta) }),
            _ => None,
        };
        pairs.push(RunPair { before: before.clone(), after: after.clone(), changes, time });
    }
    let only_b = b.rows.iter().filter(|r| !in_a.contains(&key(r))).cloned().collect();
    let settings = match (&a.meta, &b.meta) {
        (Some(ma), Some(mb)) => Some(settings_diff(ma, mb)),
        _ => None,
    };
    FolderComparison {
        a: a.name.clone(),
        b: b.name.clone(),
        settings,
        provenance: provenance(a.meta.as_ref(), b.meta.as_ref()),
        unit,
        pairs,
        only_a,
        only_b,
        options,
    }
}
