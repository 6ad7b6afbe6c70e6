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
/// sandbox confined it; then the iteration, time and energy at which each tolerance rule of
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
    /// An external solver's run: whether the sandbox confined it (it could write only in its
    /// problem folder; `false`: the kernel could not, and it was not). Empty for ours.
    #[serde(default)]
    pub confined: Option<bool>,
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
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use solvers::solver::StopReason;

    /// Task, status and stop reason are enums up to the file: their column strings are
    /// written and read back to the same values, a failed run's reason as `error`.
    #[test]
    fn typed_columns_round_trip_through_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let row = |task, status, stop_reason| SummaryRow {
            dataset: "m".into(),
            task,
            energy: "sd".into(),
            solver: "cm".into(),
            status,
            stop_reason,
            ..Default::default()
        };
        let mut skipped = row(Task::Param, Status::Skipped, Some(RunStop::Skipped));
        skipped.error = "slim is not defined for nh: its reweighting ...".into();
        let mut rows = vec![
            row(Task::Param, Status::Ok, Some(StopReason::GradientTolerance.into())),
            row(Task::Deform, Status::NotConverged, Some(StopReason::Timeout.into())),
            row(Task::Authalic, Status::Failed, None),
            skipped,
        ];
        (rows[0].shifted_iters, rows[0].clamped_iters, rows[0].cg_capped_iters) = (Some(2), Some(0), Some(5));
        write_summary(&dir.path().join("summary.csv"), &rows).unwrap();
        let text = std::fs::read_to_string(dir.path().join("summary.csv")).unwrap();
        let cells: Vec<Vec<&str>> = text.lines().skip(1).map(|l| l.split(',').collect()).collect();
        let col = |name: &str| SUMMARY_COLUMNS.iter().position(|c| *c == name).unwrap();
        let column = |name: &str| cells.iter().map(|r| r[col(name)]).collect::<Vec<_>>();
        assert_eq!(column("task"), ["param", "deform", "authalic", "param"]);
        assert_eq!(column("status"), ["ok", "not_converged", "failed", "skipped"]);
        assert_eq!(column("stop_reason"), ["grad_tol", "timeout", "error", "skipped"]);
        assert_eq!(read_summary(dir.path()).unwrap(), rows);
        let bad = text.replace("timeout", "timed_out");
        std::fs::write(dir.path().join("summary.csv"), bad).unwrap();
        let e = read_summary(dir.path()).unwrap_err().to_string();
        assert!(e.contains("summary.csv: line 3: unknown stop reason 'timed_out'"), "{e}");
    }

    /// `cg_capped_iters` round-trips, after `verdict` and before `gap_scale` and the target
    /// columns; a summary written before the column existed reads it as empty.
    #[test]
    fn cg_capped_iters_round_trips_and_an_older_file_reads_without_it() {
        let dir = tempfile::tempdir().unwrap();
        let row = |solver: &str, capped| SummaryRow {
            dataset: "sack_1k".into(),
            energy: "sarap".into(),
            solver: solver.into(),
            status: Status::Ok,
            cg_capped_iters: capped,
            to_targets: vec![ToTarget { tau: 1e-6, iters: Some(4), time_s: Some(0.25) }],
            ..Default::default()
        };
        let rows = vec![row("kp-newton-cg", Some(210)), row("kp-newton", None)];
        let path = dir.path().join("summary.csv");
        write_summary(&path, &rows).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        let at = header.iter().position(|c| *c == "cg_capped_iters").unwrap();
        assert_eq!(
            (header[at - 1], header[at + 1], header[at + 2], header[at + 3]),
            ("verdict", "gap_scale", "verified_snapshots", "peak_growth_mb")
        );
        let cells: Vec<Vec<&str>> = text.lines().skip(1).map(|l| l.split(',').collect()).collect();
        assert_eq!((cells[0][at], cells[1][at]), ("210", ""));
        assert_eq!(read_summary(dir.path()).unwrap(), rows);
        // the file as written before the column: every line without its cell
        let older: String = text
            .lines()
            .map(|l| {
                let mut c: Vec<&str> = l.split(',').collect();
                c.remove(at);
                c.join(",") + "\n"
            })
            .collect();
        std::fs::write(&path, older).unwrap();
        let back = read_summary(dir.path()).unwrap();
        assert_eq!(back.iter().map(|r| r.cg_capped_iters).collect::<Vec<_>>(), [None, None]);
        assert_eq!(back[0].to_targets, rows[0].to_targets);
    }

    /// `gap_scale`, `verified_snapshots` and `peak_growth_mb` round-trip as the last fixed
    /// columns; a summary written before they existed reads them as empty.
    #[test]
    fn gap_scale_round_trips_and_an_older_file_reads_without_it() {
        let dir = tempfile::tempdir().unwrap();
        let row = |solver: &str, scale| SummaryRow {
            dataset: "archer".into(),
            task: Task::Deform,
            energy: "sd".into(),
            solver: solver.into(),
            status: Status::Ok,
            gap_scale: scale,
            verified_snapshots: scale.map(|_| 12),
            peak_growth_mb: scale.map(|_| 41.5),
            cpu_s: scale.map(|_| 1.25),
            confined: scale.map(|_| true),
            ..Default::default()
        };
        let rows = vec![row("kp-newton", Some(0.2103)), row("aqp", None)];
        let path = dir.path().join("summary.csv");
        write_summary(&path, &rows).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.lines().next().unwrap().ends_with(
            ",cg_capped_iters,gap_scale,verified_snapshots,peak_growth_mb,start_energy,ideal_energy,ref_certified,\
             polished_energy,repeats_differ,cpu_s,confined,rule_grad_tol_iters,rule_grad_tol_time_s,\
             rule_grad_tol_energy,rule_energy_decrease_iters,rule_energy_decrease_time_s,rule_energy_decrease_energy"
        ));
        assert_eq!(read_summary(dir.path()).unwrap(), rows);
        // A file written before the last columns (the rules' 6, the yardstick's 5, the sandbox's
        // 2) reads them as empty.
        for (cut_columns, left) in [(14, (Some(0.2103), Some(12))), (16, (None, None))] {
            let cut = |l: &str| l.rsplitn(cut_columns + 1, ',').nth(cut_columns).unwrap().to_string() + "\n";
            let older: String = text.lines().map(cut).collect();
            std::fs::write(&path, older).unwrap();
            let back = read_summary(dir.path()).unwrap();
            assert_eq!((back[0].gap_scale, back[0].verified_snapshots), left);
            assert_eq!((back[0].peak_growth_mb, back[1].peak_growth_mb), (None, None));
        }
    }

    /// The rules' events: written and read back; a folder written before their columns reads a
    /// run its own rule ended as that rule's event at its last row, and nothing for the others.
    #[test]
    fn the_rules_events_round_trip_and_an_older_folder_reads_its_stop_as_one() {
        let dir = tempfile::tempdir().unwrap();
        let run = |solver: &str, stop: StopReason| SummaryRow {
            dataset: "d".into(),
            task: Task::Param,
            energy: "sd".into(),
            solver: solver.into(),
            status: Status::Ok,
            iterations: Some(40),
            time_s: Some(2.0),
            final_energy: Some(2.5),
            stop_reason: Some(RunStop::Solver(stop)),
            ..Default::default()
        };
        let mut went_on = run("kp-newton", StopReason::Target);
        (went_on.rule_grad_tol_iters, went_on.rule_grad_tol_time_s, went_on.rule_grad_tol_energy) =
            (Some(12), Some(0.5), Some(2.6));
        let rows = vec![went_on.clone(), run("slim", StopReason::EnergyDecrease), run("aqp", StopReason::NoDecrease)];
        let path = dir.path().join("summary.csv");
        write_summary(&path, &rows).unwrap();
        let back = read_summary(dir.path()).unwrap();
        assert_eq!(back[0], went_on);
        let stop = |r: &SummaryRow| r.rule_stop().map(|e| (e.rule, e.iters, e.time_s, e.energy));
        assert_eq!(stop(&back[0]), Some((StopRule::GradientTolerance, 12, Some(0.5), Some(2.6))));
        assert_eq!(stop(&back[1]), Some((StopRule::EnergyDecrease, 40, Some(2.0), Some(2.5))));
        assert_eq!(stop(&back[2]), None);
        // without the six columns: the stop of the run its rule ended is the event
        let text = std::fs::read_to_string(&path).unwrap();
        let cut = |l: &str| l.rsplitn(7, ',').nth(6).unwrap().to_string() + "\n";
        std::fs::write(&path, text.lines().map(cut).collect::<String>()).unwrap();
        let old = read_summary(dir.path()).unwrap();
        assert_eq!(stop(&old[0]), None, "a target end has no rule's event to read");
        assert_eq!(stop(&old[1]), Some((StopRule::EnergyDecrease, 40, Some(2.0), Some(2.5))));
    }

    #[test]
    fn the_header_is_exactly_the_design_columns() {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.serialize(SummaryRow::default()).unwrap();
        let s = String::from_utf8(w.into_inner().unwrap()).unwrap();
        assert_eq!(s.lines().next().unwrap(), SUMMARY_COLUMNS.join(","));
    }

    #[test]
    fn verdict_names_are_distinct_and_snake_case() {
        let names: std::collections::HashSet<&str> = Verdict::ALL.iter().map(|v| v.as_str()).collect();
        assert_eq!(names.len(), Verdict::ALL.len());
        for v in Verdict::ALL {
            assert_eq!(serde_json::to_value(v).unwrap(), v.as_str());
        }
    }
}
