//! `summary.csv`: one row per run, in the columns of docs/src/reference/columns.md, appended as runs finish and
//! rewritten in the plan's order at the end.

use super::atomic::write_atomic;
use super::error::{csv_error, read_csv_bytes, FolderError};
use super::run_stop::{stop_text, RunStop};
pub use super::status::{RefSource, Status, ToTarget, Verdict};
use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use solvers::solver::{StartMap, StopRule};
use solvers::tasks::Task;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// `summary.csv` columns, in the book's order (docs/src/reference/columns.md); `area_ratio_sd` .. `folded` are filled by
/// `authalic` runs, `analysis_s` and `analysis_shared` by the Newton-type solvers; then the
/// repeat and calibration columns (`time_s` is the median over `repeats`), the count of
/// iterations whose system needed more than the base Tikhonov shift, and of those whose
/// system clamped SLIM weights; then the peak resident memory; then the harness's verdict:
/// the start map, the reference minimum and where it came from, the final gap and the
/// verdict; then the count of the truncated solvers' steps whose CG stopped at its cap and
/// the energy span the gaps are fractions of, and the snapshots of an external solver the
/// harness verified, the peak memory growth; then the yardstick's common start energy, the
/// energy's isometry value and whether `E*` is certified, the energy a polish from the final
/// map reached, and why a repeat differed; then an external solver's CPU time and whether the
/// sandbox's protections that held; then the iteration, time and energy at which each tolerance rule of
/// `[stop]` first held, whether it ended the run or was an event on its way to the target
/// (appended: a file written before them reads them as the run's own stop where a rule ended
/// it, [`SummaryRow::with_rules_of_its_stop`]). After them, for each target `tau` of the batch, `iters_to_<tau>`
/// and `time_to_<tau>` ([`target_columns`]).
pub const SUMMARY_COLUMNS: [&str; 55] = [
    "dataset",
    "task",
    "energy",
    "solver",
    "vertices",
    "faces",
    "iterations",
    "converged",
    "stop_reason",
    "init_energy",
    "final_energy",
    "grad_norm",
    "time_s",
    "ms_per_vertex",
    "iter_ms_median",
    "project_ms_median",
    "solve_ms_median",
    "flips",
    "status",
    "error",
    "area_ratio_sd",
    "area_ratio_mad",
    "authalic_energy",
    "folded",
    "analysis_s",
    "analysis_shared",
    "repeats",
    "time_s_min",
    "time_s_max",
    "time_norm",
    "shifted_iters",
    "clamped_iters",
    "peak_rss_mb",
    "start",
    "ref_energy",
    "ref_source",
    "final_gap",
    "verdict",
    "cg_capped_iters",
    "gap_scale",
    "verified_snapshots",
    "peak_growth_mb",
    "start_energy",
    "ideal_energy",
    "ref_certified",
    "polished_energy",
    "repeats_differ",
    "cpu_s",
    "confined",
    "rule_grad_tol_iters",
    "rule_grad_tol_time_s",
    "rule_grad_tol_energy",
    "rule_energy_decrease_iters",
    "rule_energy_decrease_time_s",
    "rule_energy_decrease_energy",
];

/// `iters_to_<tau>` and `time_to_<tau>` for a target `tau` (`1e-3` for 0.001).
pub fn target_columns(tau: f64) -> [String; 2] {
    [format!("iters_to_{tau:e}"), format!("time_to_{tau:e}")]
}

/// One row of `summary.csv`. Fields unknown for a failed run are empty.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SummaryRow {
    pub dataset: String,
    pub task: Task,
    pub energy: String,
    pub solver: String,
    pub vertices: Option<usize>,
    pub faces: Option<usize>,
    pub iterations: Option<usize>,
    pub converged: bool,
    /// Why the run ended; `None` for a failed run (the column says `error`).
    #[serde(with = "super::run_stop::column")]
    pub stop_reason: Option<RunStop>,
    pub init_energy: Option<f64>,
    pub final_energy: Option<f64>,
    pub grad_norm: Option<f64>,
    pub time_s: Option<f64>,
    pub ms_per_vertex: Option<f64>,
    pub iter_ms_median: Option<f64>,
    pub project_ms_median: Option<f64>,
    pub solve_ms_median: Option<f64>,
    pub flips: Option<usize>,
    pub status: Status,
    pub error: String,
    #[serde(default)]
    pub area_ratio_sd: Option<f64>,
    #[serde(default)]
    pub area_ratio_mad: Option<f64>,
    #[serde(default)]
    pub authalic_energy: Option<f64>,
    #[serde(default)]
    pub folded: Option<usize>,
    /// Wall time of the system's symbolic analysis (ordering + symbolic Cholesky), which
    /// `time_s` leaves out: the runs on a mesh share it.
    #[serde(default)]
    pub analysis_s: Option<f64>,
    /// The run took the analysis computed by another run on the same mesh.
    #[serde(default)]
    pub analysis_shared: Option<bool>,
    /// How many times the run was repeated (`repeat` in the config); `time_s` is their median.
    #[serde(default)]
    pub repeats: Option<usize>,
    #[serde(default)]
    pub time_s_min: Option<f64>,
    #[serde(default)]
    pub time_s_max: Option<f64>,
    /// `time_s` over the batch's median calibration time (`meta.json`'s `calibration`).
    #[serde(default)]
    pub time_norm: Option<f64>,
    /// Iterations whose Newton system was solved with more than the base Tikhonov shift
    /// (the `shift` column above `[linear] tikhonov`); `None` without a Newton system.
    #[serde(default)]
    pub shifted_iters: Option<usize>,
    /// Iterations whose system clamped at least one weight (the `clamped` column of `slim`;
    /// above 0 only outside its energies, with `[solver.slim] clamp_weights = true`): tables
    /// label such runs "SLIM (clamped)". `None` for solvers without the column.
    #[serde(default)]
    pub clamped_iters: Option<usize>,
    /// The process's peak resident set (MiB) while the run ran, the largest over its repeats
    /// (`run::memory`): the loaded meshes, and with `--jobs` above 1 the runs beside it, are
    /// included. Empty where the OS does not report it, and for runs that did not run.
    #[serde(default)]
    pub peak_rss_mb: Option<f64>,
    /// The map the run started from.
    #[serde(default, with = "start_column")]
    pub start: Option<StartMap>,
    /// The reference minimum `E*` the run is judged by (`param`, `deform`).
    #[serde(default)]
    pub ref_energy: Option<f64>,
    #[serde(default)]
    pub ref_source: Option<RefSource>,
    /// `(E_final - E*) / gap_scale`.
    #[serde(default)]
    pub final_gap: Option<f64>,
    /// The harness's verdict (`status` is `ok` exactly when it is `solved`).
    #[serde(default, deserialize_with = "super::upgrade::verdict")]
    pub verdict: Option<Verdict>,
    /// Iterations whose truncated step's CG stopped at `max_cg_iters` short of its forcing
    /// term (the `cg_capped` column of `kp-newton-cg` and `kp-newton-cg-laplacian`): a safety
    /// net that changes the method, like a shifted or clamped system. `None` for solvers
    /// without the column.
    #[serde(default)]
    pub cg_capped_iters: Option<usize>,
    /// The span the gaps are fractions of: `final_gap = (E_final - E*) / gap_scale`, and the
    /// convergence test at `tau` is `E - E* <= tau gap_scale`: `min(E0 - E*, A)`, the common
    /// start's distance (Moré and Wild) or the minimum's accuracy scale (`convergence::span`).
    #[serde(default)]
    pub gap_scale: Option<f64>,
    /// The maps of an external solver's run that the harness recomputed (energy, gradient
    /// norm, flips); empty for the catalogue's solvers, whose iterates are our own code's.
    #[serde(default)]
    pub verified_snapshots: Option<usize>,
    /// How far the process's resident memory rose above its level at the run's start (MiB),
    /// when no other run was in flight beside it (`run::memory`: the run's own peak, less
    /// what it reused of memory the allocator kept from earlier runs); an external solver's
    /// own process group's peak. Empty otherwise.
    #[serde(default)]
    pub peak_growth_mb: Option<f64>,
    /// `E0` of the run's group: the common start's energy, whatever the run's start (`init_energy`).
    #[serde(default)]
    pub start_energy: Option<f64>,
    /// `E_iso`: the energy at an isometry, its lower bound, from which the accuracy scale
    /// `max(E* - E_iso, 1e-4 max(1, |E_iso|))` is measured (`convergence::span`).
    #[serde(default)]
    pub ideal_energy: Option<f64>,
    /// Whether the group's `E*` carries a certificate (`judge::reference`): `false` marks the
    /// run's verdict wherever it appears.
    #[serde(default)]
    pub ref_certified: Option<bool>,
    /// The energy a tight KP-Newton polish from the final map reached, run when the run ended
    /// stationary or with a small gradient above its tightest target: `other_minimum` only
    /// when the polish stays there (`judge::confirm`, `judge::verdict::STAYED`). Empty otherwise.
    #[serde(default)]
    pub polished_energy: Option<f64>,
    /// A later repeat that did not reproduce repeat 1 (the first difference); the run keeps
    /// repeat 1's result and verdict, and the report flags it.
    #[serde(default)]
    pub repeats_differ: Option<String>,
    /// An external solver's CPU time (user + system) over all its processes, beside its wall
    /// time; empty for the catalogue's solvers and outside the sandbox.
    #[serde(default)]
    pub cpu_s: Option<f64>,
    /// An external solver's run: the sandbox's protections that held, space-separated
    /// (`external::confine::Protection`; a folder of an older version wrote `true` for
    /// Landlock's write rule, `false` for none). Empty for ours.
    #[serde(default, deserialize_with = "super::upgrade::confined")]
    pub confined: Option<String>,
    /// The row at which `|grad| <= grad_tol` first held (empty: never, or the rule is off): a
    /// run that rule ends stops there, with the same rows.
    #[serde(default)]
    pub rule_grad_tol_iters: Option<usize>,
    /// `time_s` less the iterations after that row.
    #[serde(default)]
    pub rule_grad_tol_time_s: Option<f64>,
    /// The energy at that row.
    #[serde(default)]
    pub rule_grad_tol_energy: Option<f64>,
    /// The row at which a step first lowered the energy by less than `energy_decrease_tol`.
    #[serde(default)]
    pub rule_energy_decrease_iters: Option<usize>,
    #[serde(default)]
    pub rule_energy_decrease_time_s: Option<f64>,
    #[serde(default)]
    pub rule_energy_decrease_energy: Option<f64>,
    /// Iterations and time to each target, the loosest first.
    #[serde(skip)]
    pub to_targets: Vec<ToTarget>,
}

/// Where a tolerance rule first held in a run: what a run that rule ended would report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RuleEvent {
    pub rule: StopRule,
    pub iters: usize,
    /// Empty before the batch is judged (times are the repeats' median's).
    pub time_s: Option<f64>,
    /// Empty where the row's energy is unknown (an external solver's unverified row).
    pub energy: Option<f64>,
}

impl SummaryRow {
    /// The `stop_reason` column's text.
    pub fn stop_column(&self) -> &'static str {
        stop_text(self.stop_reason.as_ref())
    }

    /// Where `rule` first held, `None` where it never did.
    pub fn rule_event(&self, rule: StopRule) -> Option<RuleEvent> {
        let (iters, time_s, energy) = match rule {
            StopRule::GradientTolerance => {
                (self.rule_grad_tol_iters, self.rule_grad_tol_time_s, self.rule_grad_tol_energy)
            }
            StopRule::EnergyDecrease => {
                (self.rule_energy_decrease_iters, self.rule_energy_decrease_time_s, self.rule_energy_decrease_energy)
            }
        };
        iters.map(|iters| RuleEvent { rule, iters, time_s, energy })
    }

    /// Set where `rule` first held (the time is the judge's).
    pub fn set_rule_event(&mut self, rule: StopRule, iters: Option<usize>, energy: Option<f64>) {
        match rule {
            StopRule::GradientTolerance => (self.rule_grad_tol_iters, self.rule_grad_tol_energy) = (iters, energy),
            StopRule::EnergyDecrease => {
                (self.rule_energy_decrease_iters, self.rule_energy_decrease_energy) = (iters, energy)
            }
        }
    }

    /// Where the run's own rules would have ended it: the first rule to hold (the gradient's
    /// on a tie), `None` where none did (the run then ended as a run its rules end would:
    /// the same breakdown, stationary point or budget, or it went to its target first).
    pub fn rule_stop(&self) -> Option<RuleEvent> {
        StopRule::ALL.into_iter().filter_map(|r| self.rule_event(r)).min_by_key(|e| e.iters)
    }

    /// The problem is solved at its start (the common start within round-off of `E*`): its
    /// runs say nothing of a solver, and the report counts them apart.
    pub fn trivial(&self) -> bool {
        self.start_energy.zip(self.ref_energy).is_some_and(|(e0, e_star)| crate::convergence::trivial(e0, e_star))
    }

    /// A row without the rules' events (a folder or history written before them): a run its
    /// own rule ended has that rule's event at its last row, the stop being the event. A row
    /// with them, or of a run no rule ended, is unchanged.
    pub fn with_rules_of_its_stop(mut self) -> SummaryRow {
        if self.rule_stop().is_some() {
            return self;
        }
        let Some(RunStop::Solver(reason)) = &self.stop_reason else { return self };
        let rule = StopRule::ALL.into_iter().find(|r| r.stop_reason() == *reason);
        if let (Some(rule), Some(iters)) = (rule, self.iterations) {
            self.set_rule_event(rule, Some(iters), self.final_energy);
            match rule {
                StopRule::GradientTolerance => self.rule_grad_tol_time_s = self.time_s,
                StopRule::EnergyDecrease => self.rule_energy_decrease_time_s = self.time_s,
            }
        }
        self
    }
}

/// The `start` column: the start map's name, empty when unknown.
mod start_column {
    use serde::{de::Error, Deserialize, Deserializer, Serializer};
    use solvers::solver::StartMap;

    pub fn serialize<S: Serializer>(v: &Option<StartMap>, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(v.map_or("", StartMap::as_str))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<StartMap>, D::Error> {
        let text = String::deserialize(d)?;
        if text.is_empty() {
            return Ok(None);
        }
        text.parse().map(Some).map_err(D::Error::custom)
    }
}

/// `summary.csv`, appended a row at a time as runs finish (flushed each time).
pub struct SummaryWriter {
    path: PathBuf,
    file: File,
}

impl SummaryWriter {
    /// Start a new summary (header only).
    pub fn create(path: &Path) -> Result<SummaryWriter> {
        let mut header = csv::Writer::from_writer(Vec::new());
        header.write_record(SUMMARY_COLUMNS)?;
        write_atomic(path, &header.into_inner()?)?;
        let file =
            OpenOptions::new().append(true).open(path).with_context(|| format!("{}: cannot open", path.display()))?;
        Ok(SummaryWriter { path: path.to_path_buf(), file })
    }

    pub fn append(&mut self, row: &SummaryRow) -> Result<()> {
        let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(Vec::new());
        w.serialize(row)?;
        let bytes = w.into_inner()?;
        self.file.write_all(&bytes).with_context(|| format!("{}: cannot append", self.path.display()))?;
        self.file.flush()?;
        Ok(())
    }
}

/// Write a whole `summary.csv` atomically (the batch's final, canonically ordered one), with
/// the target columns of every target a row has.
pub fn write_summary(path: &Path, rows: &[SummaryRow]) -> Result<()> {
    let mut taus: Vec<f64> = Vec::new();
    for t in rows.iter().flat_map(|r| &r.to_targets) {
        if !taus.contains(&t.tau) {
            taus.push(t.tau);
        }
    }
    taus.sort_by(|a, b| b.total_cmp(a));
    // The header is written by hand so that an empty summary has one too.
    let mut header: Vec<String> = SUMMARY_COLUMNS.iter().map(|c| c.to_string()).collect();
    header.extend(taus.iter().flat_map(|&t| target_columns(t)));
    let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(Vec::new());
    w.write_record(&header)?;
    for r in rows {
        let mut record = fixed_record(r)?;
        for &tau in &taus {
            let t = r.to_targets.iter().find(|t| t.tau == tau);
            record.push_field(&t.and_then(|t| t.iters).map_or(String::new(), |i| i.to_string()));
            record.push_field(&t.and_then(|t| t.time_s).map_or(String::new(), |s| s.to_string()));
        }
        w.write_record(&record)?;
    }
    write_atomic(path, &w.into_inner().context("flushing CSV")?)
}

/// The fixed columns of a row as one record (serde's CSV writer cannot add fields to it).
fn fixed_record(row: &SummaryRow) -> Result<csv::StringRecord> {
    let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(Vec::new());
    w.serialize(row)?;
    let bytes = w.into_inner().context("flushing CSV")?;
    let mut r = csv::ReaderBuilder::new().has_headers(false).from_reader(bytes.as_slice());
    Ok(r.records().next().context("an empty record")??)
}

/// The `iters_to_<tau>` / `time_to_<tau>` cells of a record, by header name.
fn read_targets(header: &csv::StringRecord, rec: &csv::StringRecord) -> Result<Vec<ToTarget>, String> {
    let mut out: Vec<ToTarget> = Vec::new();
    for (j, name) in header.iter().enumerate() {
        let Some(tau) = name.strip_prefix("iters_to_") else { continue };
        let bad = |j: usize, what: &str| format!("column {} `{}`: `{}` is not {what}", j + 1, &header[j], &rec[j]);
        let tau_value: f64 = tau.parse().map_err(|_| format!("column {} `{name}`: not a target", j + 1))?;
        let cell = rec.get(j).unwrap_or("");
        let iters = if cell.is_empty() { None } else { Some(cell.parse().map_err(|_| bad(j, "a count"))?) };
        let time_col = header.iter().position(|h| h == format!("time_to_{tau}"));
        let time_s = match time_col.and_then(|k| rec.get(k).map(|c| (k, c))) {
            None | Some((_, "")) => None,
            Some((k, c)) => match c.parse::<f64>() {
                Ok(t) if t.is_finite() && t >= 0.0 => Some(t),
                _ => return Err(bad(k, "a time (finite, at least 0)")),
            },
        };
        out.push(ToTarget { tau: tau_value, iters, time_s });
    }
    Ok(out)
}

/// Read a run folder's `summary.csv`; errors name the file, the line and the column.
pub fn read_summary(run_dir: &Path) -> Result<Vec<SummaryRow>, FolderError> {
    let path = super::layout::summary_csv(run_dir);
    let bytes = read_csv_bytes(&path)?;
    let mut r = csv::Reader::from_reader(bytes.as_slice());
    let header = r.headers().map_err(|e| csv_error(&path, None, None, &e))?.clone();
    // The design columns up to `error` are in every summary mapbench wrote (an empty or
    // foreign file would otherwise read as a batch of no runs).
    let required = &SUMMARY_COLUMNS[..=SUMMARY_COLUMNS.iter().position(|c| *c == "error").unwrap_or(0)];
    if let Some(missing) = required.iter().find(|c| !header.iter().any(|h| h == **c)) {
        let what = format!("no column `{missing}`: not a mapbench summary");
        return Err(FolderError::Line { path, line: 1, what });
    }
    let mut rows = Vec::new();
    for rec in r.records() {
        let rec = rec.map_err(|e| csv_error(&path, Some(&header), None, &e))?;
        let row: SummaryRow =
            rec.deserialize(Some(&header)).map_err(|e| csv_error(&path, Some(&header), Some(&rec), &e))?;
        // `report` and `merge` derive file names from these fields: a folder written by
        // another tool or edited by hand must not make them write outside the run folder.
        let line = rec.position().map_or(0, |p| p.line());
        for (kind, name) in [("dataset", &row.dataset), ("energy", &row.energy), ("solver", &row.solver)] {
            crate::names::check_name(kind, name).map_err(|source| FolderError::Name {
                path: path.clone(),
                line,
                source,
            })?;
        }
        let mut row = row.with_rules_of_its_stop();
        row.to_targets =
            read_targets(&header, &rec).map_err(|what| FolderError::Line { path: path.clone(), line, what })?;
        // Ratios and medians of times would be nonsense (`compare` showed a -35x "ratio").
        let times = [
            ("time_s", row.time_s),
            ("time_s_min", row.time_s_min),
            ("time_s_max", row.time_s_max),
            ("rule_grad_tol_time_s", row.rule_grad_tol_time_s),
            ("rule_energy_decrease_time_s", row.rule_energy_decrease_time_s),
        ];
        for (column, value) in times.into_iter().chain([("time_norm", row.time_norm)]) {
            if let Some(t) = value.filter(|t| !(t.is_finite() && *t >= 0.0)) {
                let at = header.iter().position(|h| h == column).map_or(0, |i| i + 1);
                let what = format!("column {at} `{column}`: `{t}`: a time is a finite number, at least 0");
                return Err(FolderError::Line { path, line, what });
            }
        }
        rows.push(row);
    }
    // A row's targets are its energy's own (`meta.json`): the columns are those of every
    // energy, and a SARAP row judged at 1e-3 only must not read an empty 1e-6 as not reached.
    if let Some(t) = super::meta::Meta::read(run_dir).ok().filter(|m| m.targets.is_some()).map(|m| m.targets()) {
        rows.iter_mut().for_each(|r| r.to_targets.retain(|x| t.of(&r.energy).contains(&x.tau)));
    }
    Ok(rows)
}

#[cfg(test)]
#[path = "summary_tests.rs"]
mod tests;
