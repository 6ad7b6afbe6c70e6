//! One run: solve with the plan's settings, turn the outcome (or the failure) into the run's
//! summary row and rows, never stopping the batch.

use super::progress::Progress;
use crate::external::execute::{execute, Executed, ExternalError, Job, Setup};
use crate::external::probe::Probe;
use crate::external::protocol::TargetSpec;
use crate::judge::end::TargetEnd;
use crate::plan::external::Declared;
use crate::plan::{Plan, PlannedRun, RunSettings};
use crate::run_folder::{RunStop, Status, SummaryRow};
use crate::stats::median;
use anyhow::Result;
use solvers::linear::AnalysisCache;
use solvers::mesh::Mesh;
use solvers::solver::{Flow, IterationRecord, Observer, Outcome, RuleUse, StopReason, StopRule};
use solvers::tasks::authalic::{solve_authalic, AreaMetrics};
use solvers::tasks::deform::solve_deform;
use solvers::tasks::param::solve_param_with;
use std::panic::AssertUnwindSafe;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// Keeps every row of a run (a run has at most `max_iters + 1` rows), shows progress, says
/// when a row is at the run's target, and stops the solver after the row that passes the
/// run's deadline (`timeout` in the config) or when the batch is interrupted.
struct Rows<'a> {
    rows: Vec<IterationRecord>,
    deadline: Option<Instant>,
    interrupt: &'a AtomicBool,
    progress: &'a dyn Progress,
    worker: usize,
    /// Stop as a timeout after this iteration: a repeat of a run that timed out replays the
    /// same iterations (a deadline would cut it elsewhere).
    stop_at: Option<usize>,
    /// The run's target (`None`: its rules end it).
    target: Option<TargetEnd>,
}

impl Observer for Rows<'_> {
    fn observe(&mut self, record: &IterationRecord) -> Flow {
        self.rows.push(record.clone());
        self.progress.iteration(self.worker, record.iter, record.energy);
        if self.interrupt.load(Ordering::Relaxed) {
            return Flow::Stop;
        }
        if self.deadline.is_some_and(|d| Instant::now() >= d) || self.stop_at.is_some_and(|n| record.iter >= n) {
            return Flow::Timeout;
        }
        let run_e0 = self.rows[0].energy;
        match self.target {
            Some(t) if t.reached(record.energy, record.flips, run_e0) => Flow::AtTarget,
            _ => Flow::Continue,
        }
    }
}

/// What one run produced.
#[derive(Default)]
pub(super) struct RunResult {
    pub summary: SummaryRow,
    pub rows: Vec<IterationRecord>,
    /// The final map's `uv/<run>.uv.gz` bytes, when the folder keeps maps; taken when written.
    pub map_uv: Option<Vec<u8>>,
    /// Its mesh's `meshes/<dataset>.obj.gz` bytes, shared by the runs on the mesh.
    pub mesh_file: Option<Arc<Vec<u8>>>,
    /// Stopped by an interrupt of the batch: not a result, nothing is written.
    pub interrupted: bool,
    /// Skipped for want of something on this machine (an external solver's program or
    /// package): no `--resume` key, so the run runs once it is installed.
    pub unkeyed: bool,
    /// The final map (normalized frame; `authalic`: the image on the unit disk), until the
    /// worker has looked at it (`judge::confirm`).
    pub final_x: Option<Vec<f64>>,
    /// The run's map that ended below its group's reference (`judge::improve`).
    pub candidate: Option<crate::judge::improve::Candidate>,
}

/// One run; never returns an error or panics: failures become a `failed` summary row.
pub(super) fn run_one(
    plan: &Plan,
    run: &PlannedRun,
    mesh: Result<&Mesh, &anyhow::Error>,
    ctx: &RunContext,
) -> RunResult {
    let mut summary = SummaryRow {
        dataset: plan.dataset(run).name.clone(),
        task: run.settings.task(),
        energy: run.energy.clone(),
        solver: run.solver.clone(),
        ..Default::default()
    };
    let fail = |mut summary: SummaryRow, error: String| {
        summary.status = Status::Failed;
        summary.error = error;
        RunResult { summary, ..Default::default() }
    };
    // A pair outside the solver's definition is not solved: no rows, no map, the reason.
    if let Some(reason) = &run.skip {
        return skipped(summary, reason, mesh.ok());
    }
    let mesh = match mesh {
        Ok(m) => m,
        Err(e) => return fail(summary, format!("{e:#}")),
    };
    summary.vertices = Some(mesh.n_vertices());
    summary.faces = Some(mesh.n_faces());
    if let Some(declared) = plan.external(run) {
        // Our code runs on what the solver wrote: a panic in it fails this run alone.
        let unwound = summary.clone();
        return std::panic::catch_unwind(AssertUnwindSafe(|| run_external(plan, run, declared, mesh, ctx, summary)))
            .unwrap_or_else(|panic| {
                fail(unwound, format!("{}: internal error (panic): {}", mesh.source, panic_text(&panic)))
            });
    }
    let mut rows = Rows {
        rows: Vec::new(),
        deadline: if ctx.stop_at.is_some() { None } else { plan.timeout.map(|t| Instant::now() + t) },
        interrupt: ctx.interrupt,
        progress: ctx.progress,
        worker: ctx.worker,
        stop_at: ctx.stop_at,
        target: ctx.target,
    };
    let t0 = Instant::now();
    let result = std::panic::catch_unwind(AssertUnwindSafe(|| solve(plan, run, mesh, &ctx.analyses, &mut rows)));
    let elapsed = t0.elapsed().as_secs_f64();
    let (outcome, metrics) = match result {
        Ok(Ok(o)) => o,
        Ok(Err(e)) => {
            // Most solver errors already start with the mesh source; name it where they do not.
            let msg = format!("{e:#}");
            let msg = if msg.starts_with(&mesh.source) { msg } else { format!("{}: {msg}", mesh.source) };
            return fail(summary, msg);
        }
        Err(panic) => return fail(summary, format!("{}: internal error (panic): {}", mesh.source, panic_text(&panic))),
    };
    let rows = rows.rows;
    // A map with a non-finite coordinate is not a result (its energy and flips mean nothing).
    if let Some(v) = outcome.x.iter().position(|c| !c.is_finite()) {
        let (iterations, stop) = (outcome.iterations, outcome.stop_reason.as_str());
        let what = format!(
            "{}: the final map has a non-finite coordinate at vertex {} ({}), after {iterations} iterations ({stop})",
            mesh.source,
            v / 2,
            outcome.x[v]
        );
        return fail(summary, what);
    }
    record_outcome(&mut summary, &outcome, metrics, &rows, elapsed, run, mesh);
    let map_uv = ctx.keep_map.then(|| crate::run_folder::map::encode_uv(mesh, &outcome.x));
    // A timeout is a result (stop_reason = timeout); an interrupt of the batch is not.
    let interrupted = matches!(outcome.stop_reason, StopReason::Interrupted);
    let final_x = Some(outcome.x);
    RunResult { summary, rows, map_uv, interrupted, final_x, ..Default::default() }
}

/// A run outside its solver's definition: the mesh's size and the reason, nothing else.
fn skipped(mut summary: SummaryRow, reason: &str, mesh: Option<&Mesh>) -> RunResult {
    if let Some(m) = mesh {
        (summary.vertices, summary.faces) = (Some(m.n_vertices()), Some(m.n_faces()));
    }
    summary.status = Status::Skipped;
    summary.stop_reason = Some(RunStop::Skipped);
    summary.error = reason.to_string();
    RunResult { summary, ..Default::default() }
}

/// The message of a caught panic.
fn panic_text(panic: &Box<dyn std::any::Any + Send>) -> String {
    panic
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "unknown panic".into())
}

/// A run of an external solver: skipped when its command cannot start (found by the batch's
/// probe, or at the start), failed on anything it did wrong, otherwise a result like ours,
/// with the child's own wall time and peak memory.
fn run_external(
    plan: &Plan,
    run: &PlannedRun,
    declared: &Declared,
    mesh: &Mesh,
    ctx: &RunContext,
    mut summary: SummaryRow,
) -> RunResult {
    let result = |summary, rows| RunResult { summary, rows, ..Default::default() };
    let skip = |mut summary: SummaryRow, reason: String| {
        summary.status = Status::Skipped;
        summary.stop_reason = Some(RunStop::Skipped);
        summary.error = reason;
        RunResult { unkeyed: true, ..result(summary, Vec::new()) }
    };
    if let Some(why) = ctx.probes.iter().find(|p| p.name == run.solver).and_then(|p| p.unavailable.clone()) {
        return skip(summary, why);
    }
    let (handles, init, sd_min);
    let setup = match &run.settings {
        RunSettings::Param { energy, settings } => {
            sd_min = match plan.starts.of(plan, run).transpose() {
                Ok(x) => x,
                Err(e) => {
                    summary.status = Status::Failed;
                    summary.error = format!("the sd-minimum start: {e}");
                    return result(summary, Vec::new());
                }
            };
            Setup::Param { energy: *energy, settings, sd_min: sd_min.as_ref().map(|x| &x[..]) }
        }
        RunSettings::Deform { energy, settings } => {
            // As for ours: a bad mesh fails with validate's reason, not the handle rule's.
            let loaded = solvers::tasks::validate_for(mesh, solvers::tasks::Task::Deform)
                .into_result()
                .map_err(anyhow::Error::new)
                .and_then(|()| plan.dataset(run).handles.load(mesh));
            handles = match loaded {
                Ok(h) => h,
                Err(e) => {
                    summary.status = Status::Failed;
                    summary.error = format!("{e:#}");
                    return result(summary, Vec::new());
                }
            };
            init = plan.dataset(run).initial_map();
            Setup::Deform { energy: *energy, settings, handles: &handles, init: init.as_deref() }
        }
        RunSettings::Authalic(_) => {
            let why = format!("{}: the external-solver protocol has no authalic task", run.solver);
            return RunResult { unkeyed: false, ..skip(summary, why) };
        }
    };
    let external = crate::run_folder::external_dir(ctx.out_dir);
    let job = Job {
        name: &run.solver,
        declared,
        cwd: &plan.config.dir,
        dir: external.join(&run.stem),
        logs: external.join(&run.stem),
        setup,
        timeout: plan.timeout,
        stop_at: ctx.stop_at,
        threads: ctx.threads,
        interrupt: ctx.interrupt,
        targets: target_specs(plan, run, ctx.target),
    };
    ctx.progress.iteration(ctx.worker, 0, f64::NAN);
    let executed = match execute(&job, mesh) {
        Ok(e) => e,
        Err(ExternalError::CannotStart(why)) => return skip(summary, why),
        Err(ExternalError::Interrupted) => return RunResult { interrupted: true, ..result(summary, Vec::new()) },
        Err(ExternalError::Failed(why)) => {
            summary.status = Status::Failed;
            summary.error = why;
            return result(summary, Vec::new());
        }
    };
    external_result(summary, executed, run, mesh, ctx)
}

/// The verdict's targets of `run`'s energy as energies, for an external solver's problem
/// folder (none without a target).
fn target_specs(plan: &Plan, run: &PlannedRun, target: Option<TargetEnd>) -> Vec<TargetSpec> {
    let Some(t) = target else { return Vec::new() };
    let taus = plan.targets.of(&run.energy);
    taus.iter().filter_map(|&tau| t.energy_at(tau).map(|energy| TargetSpec { tau, energy })).collect()
}

/// What an external solver's run that ended comes to: a result like ours, with the child's
/// own wall time and peak memory.
fn external_result(
    mut summary: SummaryRow,
    executed: Executed,
    run: &PlannedRun,
    mesh: &Mesh,
    ctx: &RunContext,
) -> RunResult {
    // `time_s`: the child's wall time on our clock (its start-up included), less what it said
    // its records took; its memory is its own process group's; it has no Newton systems.
    record_outcome(&mut summary, &executed.outcome, None, &executed.rows, executed.wall_s, run, mesh);
    // Our safety-net counts mean nothing of its columns, whatever they are called.
    (summary.shifted_iters, summary.clamped_iters, summary.cg_capped_iters) = (None, None, None);
    (summary.peak_rss_mb, summary.peak_growth_mb) = (executed.peak_rss_mb, executed.peak_rss_mb);
    summary.verified_snapshots = Some(executed.verified);
    let confined = crate::external::confine::Protection::join(&executed.held);
    (summary.cpu_s, summary.confined) = (executed.cpu_s, Some(confined));
    if !executed.unconfined.is_empty() {
        ctx.progress.notice(&format!("{}: sandbox not whole: {}", run.stem, executed.unconfined.join("; ")));
    }
    let map_uv = ctx.keep_map.then(|| crate::run_folder::map::encode_uv(mesh, &executed.outcome.x));
    let final_x = Some(executed.outcome.x);
    RunResult { summary, rows: executed.rows, map_uv, final_x, ..Default::default() }
}

/// What a finished solve says of the run: its summary's outcome, times and counts.
fn record_outcome(
    summary: &mut SummaryRow,
    outcome: &Outcome,
    metrics: Option<AreaMetrics>,
    rows: &[IterationRecord],
    elapsed: f64,
    run: &PlannedRun,
    mesh: &Mesh,
) {
    if let Some(m) = metrics {
        summary.area_ratio_sd = Some(m.area_ratio_sd);
        summary.area_ratio_mad = Some(m.area_ratio_mad);
        summary.authalic_energy = Some(m.authalic_energy);
        summary.folded = Some(m.folded);
    }
    summary.iterations = Some(outcome.iterations);
    // Converged: its own rule held (whether it ended the run or was an event on its way).
    summary.converged = outcome.stop_reason.is_converged() || outcome.events.first().is_some();
    for rule in StopRule::ALL {
        let k = outcome.events.of(rule);
        summary.set_rule_event(rule, k, k.and_then(|k| rows.get(k)).map(|r| r.energy).filter(|e| !e.is_nan()));
    }
    summary.stop_reason = Some(outcome.stop_reason.clone().into());
    summary.init_energy = Some(outcome.init_energy);
    summary.final_energy = Some(outcome.final_energy);
    summary.grad_norm = Some(outcome.grad_norm);
    summary.start = outcome.start;
    // The symbolic analysis is shared by the runs on a mesh, so which run computes it depends
    // on scheduling: time_s leaves it out for every run (including any wait for another run
    // computing it) and analysis_s reports its cost.
    let setup = outcome.analysis.map_or(0.0, |a| a.setup_seconds);
    let elapsed = run_time(elapsed, setup, rows);
    summary.analysis_s = outcome.analysis.map(|a| a.seconds);
    summary.analysis_shared = outcome.analysis.map(|a| a.reused);
    summary.time_s = Some(elapsed);
    (summary.repeats, summary.time_s_min, summary.time_s_max) = (Some(1), Some(elapsed), Some(elapsed));
    fill_times(summary, rows);
    summary.flips = Some(outcome.flips);
    // Rows after row 0 each come from one solved system (row 0 has none, `shift` empty).
    summary.shifted_iters = run.settings.base_shift().map(|base| shifted_iters(base, rows));
    summary.clamped_iters = marked_iters(rows, solvers::hessian::slim::CLAMPED_COLUMN[0]);
    summary.cg_capped_iters = marked_iters(rows, solvers::solver::truncated::CG_CAPPED_COLUMN);
    // The judge's verdict sets `ok`; until then a run is ok by its own word.
    summary.status = match &outcome.stop_reason {
        _ if summary.converged || outcome.stop_reason == StopReason::Target => Status::Ok,
        StopReason::MaxIterations if run.settings.stop().is_fixed_budget() => Status::Budget,
        _ => Status::NotConverged,
    };
    summary.error = match &outcome.stop_reason {
        StopReason::LinearSolveFailed(d) | StopReason::NonFinite(d) => format!("{}: {d}", mesh.source),
        _ => String::new(),
    };
}

/// A run's `time_s` from its wall time `elapsed`: less the shared analysis's `setup` and the
/// work its solver did only for the rows and the stop rule (`t_record_s`, as the authors of
/// `aqp` leave their logging out of the timed iterate).
fn run_time(elapsed: f64, setup: f64, rows: &[IterationRecord]) -> f64 {
    let record: f64 = rows.iter().map(|r| r.t_record_s).sum();
    (elapsed - setup - record).max(0.0)
}

/// The statistics of a run's times: `ms_per_vertex` from `time_s`, and the medians over
/// iterations (row 0 is the initial state) of the per-iteration times.
pub(super) fn fill_times(summary: &mut SummaryRow, rows: &[IterationRecord]) {
    let per_iter = |f: fn(&IterationRecord) -> f64| {
        let mut v: Vec<f64> = rows.iter().skip(1).map(|r| 1e3 * f(r)).collect();
        median(&mut v)
    };
    summary.ms_per_vertex = summary.time_s.zip(summary.vertices).map(|(t, n)| 1e3 * t / n.max(1) as f64);
    summary.iter_ms_median = per_iter(|r| r.t_iter_s);
    summary.project_ms_median = per_iter(|r| r.t_project_s);
    summary.solve_ms_median = per_iter(|r| r.t_solve_s);
}

/// Rows whose system was solved with more than the `base` shift (a retry after a failed
/// factorization).
fn shifted_iters(base: f64, rows: &[IterationRecord]) -> usize {
    rows.iter().filter(|r| r.shift.is_some_and(|s| s > base)).count()
}

/// Rows marked by a safety net in the extra column `name` (above 0), for a solver that writes
/// it (row 0's is NaN: it has no system): `clamped` (the system clamped at least one SLIM
/// weight), `cg_capped` (the truncated step's CG stopped at `max_cg_iters`).
fn marked_iters(rows: &[IterationRecord], name: &str) -> Option<usize> {
    let col = rows.first()?.extra.iter().position(|e| e.0 == name)?;
    Some(rows.iter().filter(|r| r.extra.get(col).is_some_and(|e| e.1 > 0.0)).count())
}

/// What a run needs from the batch around it.
pub(super) struct RunContext<'a> {
    /// The run folder (external runs write their problem folders in it).
    pub out_dir: &'a Path,
    /// rayon threads of the run (what an external solver is told it may use).
    pub threads: usize,
    /// What the batch found out about its external solvers.
    pub probes: &'a [Probe],
    pub interrupt: &'a AtomicBool,
    pub progress: &'a dyn Progress,
    pub worker: usize,
    /// Symbolic analyses shared by the runs on this mesh.
    pub analyses: Arc<AnalysisCache>,
    /// Stop after this iteration (with `stop_reason = timeout`) instead of at the deadline.
    pub stop_at: Option<usize>,
    /// Encode the final map (the folder keeps maps, and this is the run's first repeat, whose
    /// files are written).
    pub keep_map: bool,
    /// The run's target: it goes there, its tolerance rules are events (`None`: they end it).
    pub target: Option<TargetEnd>,
}

/// One solve with the run's settings; `authalic` runs also return their area metrics.
fn solve(
    plan: &Plan,
    run: &PlannedRun,
    mesh: &Mesh,
    analyses: &Arc<AnalysisCache>,
    rows: &mut Rows<'_>,
) -> Result<(Outcome, Option<AreaMetrics>)> {
    let rules = if rows.target.is_some() { RuleUse::Event } else { RuleUse::End };
    match &run.settings {
        RunSettings::Authalic(settings) => {
            let mut settings = *settings;
            settings.stop.rules = rules;
            let out = solve_authalic(mesh, &run.solver, &settings, rows)?;
            Ok((out.outcome, Some(out.metrics)))
        }
        RunSettings::Param { energy, settings } => {
            let sd_min =
                plan.starts.of(plan, run).transpose().map_err(|e| anyhow::anyhow!("the sd-minimum start: {e}"))?;
            let mut settings = settings.clone();
            settings.solver.analyses = Some(analyses.clone());
            settings.solver.stop.rules = rules;
            let out = solve_param_with(mesh, *energy, &run.solver, &settings, sd_min.as_ref().map(|x| &x[..]), rows)?;
            Ok((out, None))
        }
        RunSettings::Deform { energy, settings } => {
            // Handle rules pick vertices by position: check the mesh first, so a bad mesh fails
            // with validate's reason rather than with what the rule made of it.
            solvers::tasks::validate_for(mesh, solvers::tasks::Task::Deform).into_result()?;
            let handles = plan.dataset(run).handles.load(mesh)?;
            let mut settings = settings.clone();
            settings.solver.analyses = Some(analyses.clone());
            settings.solver.stop.rules = rules;
            // A generated shape may bring its own start (the released bar), as it brings its handles.
            let init = plan.dataset(run).initial_map();
            Ok((solve_deform(mesh, &handles, init.as_deref(), *energy, &run.solver, &settings, rows)?, None))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_run_time_leaves_out_the_analysis_and_the_record_only_work() {
        let row = |t_record_s: f64| IterationRecord { t_iter_s: 0.5, t_record_s, ..Default::default() };
        let rows = [row(0.0), row(0.125), row(0.25)];
        assert_eq!(run_time(2.0, 0.5, &rows), 1.125);
        assert_eq!(run_time(2.0, 0.0, &[row(0.0), row(0.0)]), 2.0);
        assert_eq!(run_time(0.1, 0.0, &rows), 0.0);
    }

    #[test]
    fn shifted_clamped_and_cg_capped_iterations_are_counted_from_the_rows() {
        let clamped_iters = |rows: &[IterationRecord]| marked_iters(rows, "clamped");
        let row = |shift: Option<f64>, clamped: Option<f64>| IterationRecord {
            shift,
            extra: clamped.map(|c| vec![("clamped", c)]).unwrap_or_default(),
            ..Default::default()
        };
        // row 0 has no system; then one retry at 1e-7 and one at 0.1
        let rows = [
            row(None, Some(f64::NAN)),
            row(Some(1e-10), Some(0.0)),
            row(Some(1e-7), Some(3.0)),
            row(Some(0.1), Some(1.0)),
        ];
        assert_eq!((shifted_iters(1e-10, &rows), clamped_iters(&rows)), (2, Some(2)));
        // a base shift of 0 (config) counts every shifted system
        assert_eq!(shifted_iters(0.0, &rows), 3);
        // no clamped column: not a solver that clamps
        let rows = [row(None, None), row(Some(1e-10), None)];
        assert_eq!((shifted_iters(1e-10, &rows), clamped_iters(&rows)), (0, None));
        assert_eq!(clamped_iters(&[]), None);
        // kp-newton-cg's rows: the steps whose CG stopped at the cap
        let cg = |capped: f64| IterationRecord {
            extra: vec![("cg_iters", 500.0), ("forcing", 0.5), ("cg_residual", 0.7), ("cg_capped", capped)],
            ..Default::default()
        };
        let rows = [cg(f64::NAN), cg(1.0), cg(0.0), cg(1.0)];
        assert_eq!(marked_iters(&rows, solvers::solver::truncated::CG_CAPPED_COLUMN), Some(2));
        assert_eq!(marked_iters(&rows, "clamped"), None);
    }
}
