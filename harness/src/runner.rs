//! The batch runner: every (dataset, energy, solver) of a config, one after the other, each
//! run's failure recorded without stopping the batch.

use crate::config::{LoadedConfig, Task};
use crate::output::{iteration_csv, median, run_stem, write_atomic, SummaryRow, SummaryWriter};
use crate::registry::{resolve, Dataset};
use anyhow::{Context, Result};
use solvers::authalic::{solve_authalic, AreaMetrics, AUTHALIC_ENERGY};
use solvers::deform::solve_deform;
use solvers::mesh::Mesh;
use solvers::param::solve_param;
use solvers::solver::{Flow, IterationRecord, Observer, Outcome, StopReason};
use std::collections::BTreeMap;
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// Keeps every row of a run (a run has at most `max_iters + 1` rows) and stops the solver
/// after the row that passes the run's deadline (`timeout` in the config).
#[derive(Default)]
struct Rows {
    rows: Vec<IterationRecord>,
    deadline: Option<Instant>,
    timed_out: bool,
}

impl Observer for Rows {
    fn observe(&mut self, record: &IterationRecord) -> Flow {
        self.rows.push(record.clone());
        if self.deadline.is_some_and(|d| Instant::now() >= d) {
            self.timed_out = true;
            return Flow::Stop;
        }
        Flow::Continue
    }
}

/// What one run produced.
struct RunResult {
    summary: SummaryRow,
    rows: Vec<IterationRecord>,
    /// The final map as OBJ text (`uv/<run>.obj`), taken when written.
    map_obj: Option<Vec<u8>>,
}

/// Totals of a batch.
#[derive(Debug, Default, PartialEq)]
pub struct BatchReport {
    pub runs: usize,
    pub ok: usize,
    pub not_converged: usize,
    pub failed: usize,
    pub skipped_datasets: Vec<String>,
    pub out_dir: PathBuf,
}

/// How to run a batch (the `run` flags).
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Globs on `<dataset>__<energy>__<solver>`; empty: every run.
    pub only: Vec<String>,
    /// Reuse finished runs of a previous batch in the same folder with the same key.
    pub resume: bool,
}

/// Run a whole config into `out_dir`. `log` receives one human-readable line per event.
pub fn run_batch(
    cfg: &LoadedConfig,
    out_dir: &Path,
    opts: &RunOptions,
    log: &mut dyn FnMut(&str),
) -> Result<BatchReport> {
    let only = &opts.only[..];
    let (datasets, notices) = resolve(cfg).with_context(|| format!("{}: datasets", cfg.path.display()))?;
    for n in &notices {
        log(n);
    }
    std::fs::create_dir_all(out_dir.join("runs")).with_context(|| format!("{}: cannot create", out_dir.display()))?;
    let started = SystemTime::now();
    write_meta(cfg, out_dir, opts, started, None)?;
    let mut summary = SummaryWriter::create(&out_dir.join("summary.csv"))?;
    let c = &cfg.config;
    let energies = c.energy_names();
    let selected =
        |d: &str, e: &str, s: &str| only.is_empty() || only.iter().any(|g| glob_match(g, &run_stem(d, e, s)));
    let total = datasets
        .iter()
        .flat_map(|d| energies.iter().flat_map(move |e| c.solvers.iter().map(move |s| (d, e, s))))
        .filter(|(d, e, s)| selected(&d.name, e, s))
        .count();
    if total == 0 {
        anyhow::bail!("--only {} selects no run of {}", only.join(" "), cfg.path.display());
    }
    let mut report = BatchReport { skipped_datasets: notices, out_dir: out_dir.to_path_buf(), ..Default::default() };
    // Rows by (dataset, energy) group, kept to fill `energy_minus_best` once the group is done.
    let mut done = 0;
    let mut summaries: Vec<SummaryRow> = Vec::new();
    let (rev, dirty) = git_revision(&cfg.dir);
    let code = format!("mapbench {} {} dirty={dirty:?}", env!("CARGO_PKG_VERSION"), rev.unwrap_or_default());
    for ds in &datasets {
        if !energies.iter().any(|e| c.solvers.iter().any(|s| selected(&ds.name, e, s))) {
            continue;
        }
        // Loaded on the first run that is not resumed.
        let mut mesh: Option<Result<Mesh>> = None;
        for energy in &energies {
            let mut group: Vec<RunResult> = Vec::new();
            for solver in c.solvers.iter().filter(|s| selected(&ds.name, energy, s)) {
                done += 1;
                let stem = run_stem(&ds.name, energy, solver);
                // An unreadable mesh file has no key; its run fails below as usual.
                let key = crate::resume::run_key(cfg, ds, energy, solver, &code).ok();
                let previous = match (&key, opts.resume) {
                    (Some(k), true) => crate::resume::previous(out_dir, &stem, k),
                    _ => None,
                };
                let resumed = previous.is_some();
                let mut result = match previous {
                    Some((summary, rows)) => RunResult { summary, rows, map_obj: None },
                    None => {
                        let m = mesh.get_or_insert_with(|| ds.load());
                        run_one(cfg, ds, m.as_ref(), energy, solver)
                    }
                };
                if let Some(obj) = result.map_obj.take() {
                    let stem = run_stem(&ds.name, energy, solver);
                    write_atomic(&out_dir.join("uv").join(format!("{stem}.obj")), &obj)?;
                }
                let s = &result.summary;
                log(&format!(
                    "[{done}/{total}] {} {} {}: {}{}{}",
                    ds.name,
                    energy,
                    solver,
                    if resumed { "resumed, " } else { "" },
                    s.status,
                    match (&s.iterations, &s.final_energy, &s.time_s) {
                        (Some(it), Some(e), Some(t)) =>
                            format!(" ({}), {it} iterations, E = {e:.8}, {t:.2} s", s.stop_reason),
                        _ => format!(": {}", s.error),
                    }
                ));
                match s.status.as_str() {
                    "ok" => report.ok += 1,
                    "not_converged" => report.not_converged += 1,
                    _ => report.failed += 1,
                }
                report.runs += 1;
                // Written now with this run's own best; rewritten with the group's best below.
                let own_best = result.rows.iter().map(|r| r.energy).fold(f64::INFINITY, f64::min);
                write_run(out_dir, &result, own_best)?;
                if let (Some(k), false) = (&key, resumed) {
                    crate::resume::write_sidecar(out_dir, &stem, k, &result.summary)?;
                }
                summary.append(&result.summary)?;
                summaries.push(result.summary.clone());
                group.push(result);
            }
            let best = group
                .iter()
                .filter(|r| r.summary.status != "failed")
                .flat_map(|r| r.rows.iter().map(|x| x.energy))
                .filter(|e| e.is_finite())
                .fold(f64::INFINITY, f64::min);
            if best.is_finite() {
                for r in &group {
                    write_run(out_dir, r, best)?;
                }
            }
        }
    }
    if let Some(t) = crate::tables::projection_table(&summaries) {
        t.write(&out_dir.join("tables"), "projection")?;
    }
    if let Some(t) = crate::tables::smoothness_table(&summaries) {
        t.write(&out_dir.join("tables"), "smoothness")?;
    }
    if let Some(t) = crate::tables::deform_table(&summaries) {
        t.write(&out_dir.join("tables"), "deform")?;
    }
    if let Some(t) = crate::tables::authalic_table(&summaries) {
        t.write(&out_dir.join("tables"), "authalic")?;
    }
    write_meta(cfg, out_dir, opts, started, Some(SystemTime::now()))?;
    Ok(report)
}

fn write_run(out_dir: &Path, r: &RunResult, best: f64) -> Result<()> {
    let s = &r.summary;
    let path = out_dir.join("runs").join(format!("{}.csv", run_stem(&s.dataset, &s.energy, &s.solver)));
    write_atomic(&path, &iteration_csv(&r.rows, best)?)
}

/// One run; never returns an error or panics: failures become a `failed` summary row.
fn run_one(
    cfg: &LoadedConfig,
    ds: &Dataset,
    mesh: Result<&Mesh, &anyhow::Error>,
    energy: &str,
    solver: &str,
) -> RunResult {
    let mut summary = SummaryRow {
        dataset: ds.name.clone(),
        task: cfg.config.task.as_str().to_string(),
        energy: energy.to_string(),
        solver: solver.to_string(),
        ..Default::default()
    };
    let fail = |mut summary: SummaryRow, error: String| {
        summary.status = "failed".into();
        summary.stop_reason = "error".into();
        summary.error = error;
        RunResult { summary, rows: Vec::new(), map_obj: None }
    };
    let mesh = match mesh {
        Ok(m) => m,
        Err(e) => return fail(summary, format!("{e:#}")),
    };
    summary.vertices = Some(mesh.n_vertices());
    summary.faces = Some(mesh.n_faces());
    let timeout = cfg.config.timeout_secs().ok().flatten();
    let mut rows =
        Rows { deadline: timeout.map(|t| Instant::now() + Duration::from_secs_f64(t)), ..Default::default() };
    let t0 = Instant::now();
    let result = std::panic::catch_unwind(AssertUnwindSafe(|| solve(cfg, ds, mesh, energy, solver, &mut rows)));
    let elapsed = t0.elapsed().as_secs_f64();
    let (outcome, metrics) = match result {
        Ok(Ok(o)) => o,
        Ok(Err(e)) => {
            // Most solver errors already start with the mesh source; name it where they do not.
            let msg = format!("{e:#}");
            let msg = if msg.starts_with(&mesh.source) { msg } else { format!("{}: {msg}", mesh.source) };
            return fail(summary, msg);
        }
        Err(panic) => {
            let msg = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "unknown panic".into());
            return fail(summary, format!("{}: internal error (panic): {msg}", mesh.source));
        }
    };
    if let Some(m) = metrics {
        summary.area_ratio_sd = Some(m.area_ratio_sd);
        summary.area_ratio_mad = Some(m.area_ratio_mad);
        summary.authalic_energy = Some(m.authalic_energy);
        summary.folded = Some(m.folded);
    }
    let timed_out = rows.timed_out;
    let rows = rows.rows;
    let per_iter = |f: fn(&IterationRecord) -> f64| {
        let mut v: Vec<f64> = rows.iter().skip(1).map(|r| 1e3 * f(r)).collect();
        median(&mut v)
    };
    summary.iterations = Some(outcome.iterations);
    summary.converged = outcome.stop_reason.is_converged();
    summary.stop_reason = match (&outcome.stop_reason, timed_out) {
        (StopReason::Interrupted, true) => "timeout".to_string(),
        (r, _) => r.as_str().to_string(),
    };
    summary.init_energy = Some(outcome.init_energy);
    summary.final_energy = Some(outcome.final_energy);
    summary.grad_norm = Some(outcome.grad_norm);
    summary.time_s = Some(elapsed);
    summary.ms_per_vertex = Some(1e3 * elapsed / mesh.n_vertices().max(1) as f64);
    summary.iter_ms_median = per_iter(|r| r.t_iter_s);
    summary.project_ms_median = per_iter(|r| r.t_project_s);
    summary.solve_ms_median = per_iter(|r| r.t_solve_s);
    summary.flips = Some(outcome.flips);
    summary.status = if summary.converged { "ok" } else { "not_converged" }.into();
    summary.error = match &outcome.stop_reason {
        StopReason::LinearSolveFailed(d) | StopReason::NonFinite(d) => format!("{}: {d}", mesh.source),
        _ => String::new(),
    };
    let map_obj = Some(crate::mapfile::to_obj(mesh, &outcome.x));
    RunResult { summary, rows, map_obj }
}

/// One solve of the config's task; `authalic` runs also return their area metrics.
fn solve(
    cfg: &LoadedConfig,
    ds: &Dataset,
    mesh: &Mesh,
    energy: &str,
    solver: &str,
    rows: &mut Rows,
) -> Result<(Outcome, Option<AreaMetrics>)> {
    match cfg.config.task {
        Task::Authalic => {
            let out = solve_authalic(mesh, solver, &cfg.config.authalic_settings(), rows)?;
            Ok((out.outcome, Some(out.metrics)))
        }
        Task::Param => {
            let kind = cfg.config.energy_kind(energy)?;
            let mut settings = cfg.config.param_settings(&kind);
            settings.smoothness = cfg.config.smoothness_for(energy);
            Ok((solve_param(mesh, kind, solver, &settings, rows)?, None))
        }
        Task::Deform => {
            let kind = cfg.config.energy_kind(energy)?;
            let handles = ds.handles.load(mesh)?;
            let mut settings = cfg.config.deform_settings();
            settings.smoothness = cfg.config.smoothness_for(energy);
            Ok((solve_deform(mesh, &handles, kind, solver, &settings, rows)?, None))
        }
    }
}

/// Glob match of `text` against `pattern` with `*` (any run of characters) and `?` (one).
pub fn glob_match(pattern: &str, text: &str) -> bool {
    let (p, t): (Vec<char>, Vec<char>) = (pattern.chars().collect(), text.chars().collect());
    // Iterative matching with one backtrack point for the last `*`.
    let (mut i, mut j, mut star, mut mark) = (0, 0, None, 0);
    while j < t.len() {
        if i < p.len() && (p[i] == '?' || p[i] == t[j]) {
            i += 1;
            j += 1;
        } else if i < p.len() && p[i] == '*' {
            star = Some(i);
            mark = j;
            i += 1;
        } else if let Some(s) = star {
            i = s + 1;
            mark += 1;
            j = mark;
        } else {
            return false;
        }
    }
    p[i..].iter().all(|&c| c == '*')
}

/// `meta.json`: the resolved config and provenance (code version, git revision, machine).
fn write_meta(
    cfg: &LoadedConfig,
    out_dir: &Path,
    opts: &RunOptions,
    started: SystemTime,
    ended: Option<SystemTime>,
) -> Result<()> {
    let secs = |t: SystemTime| t.duration_since(UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0);
    let (rev, dirty) = git_revision(&cfg.dir);
    let mut stop = BTreeMap::new();
    if cfg.config.task == Task::Authalic {
        let s = cfg.config.authalic_settings();
        stop.insert(AUTHALIC_ENERGY.to_string(), (s.stop.grad_tol, s.stop.energy_decrease_tol, s.stop.max_iters));
    }
    for e in &cfg.config.energies {
        if let Ok(k) = cfg.config.energy_kind(e) {
            let s = match cfg.config.task {
                Task::Deform => cfg.config.deform_settings().solver.stop,
                _ => cfg.config.param_settings(&k).solver.stop,
            };
            stop.insert(e.clone(), (s.grad_tol, s.energy_decrease_tol, s.max_iters));
        }
    }
    let meta = serde_json::json!({
        "config_path": cfg.path.display().to_string(),
        "config": cfg.config,
        "only": opts.only,
        "resume": opts.resume,
        "stop_per_energy": stop.iter().map(|(e, (g, d, m))| (e.clone(), serde_json::json!({
            "grad_tol": g, "energy_decrease_tol": d, "max_iters": m
        }))).collect::<serde_json::Map<_, _>>(),
        "meshes_dir": std::env::var(crate::registry::MESHES_ENV).ok(),
        "mapbench_version": env!("CARGO_PKG_VERSION"),
        "git_revision": rev,
        "git_dirty": dirty,
        "host": std::env::var("HOSTNAME").ok().or_else(|| std::fs::read_to_string("/etc/hostname").ok().map(|s| s.trim().to_string())),
        "cores": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        "rayon_threads": rayon::current_num_threads(),
        "started_unix": secs(started),
        "ended_unix": ended.map(secs),
    });
    write_atomic(&out_dir.join("meta.json"), serde_json::to_string_pretty(&meta)?.as_bytes())
}

/// The git revision of the folder holding the config, and whether the tree is dirty.
fn git_revision(dir: &Path) -> (Option<String>, Option<bool>) {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .current_dir(dir)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    let rev = git(&["rev-parse", "HEAD"]);
    let dirty =
        rev.as_ref().and_then(|_| git(&["status", "--porcelain", "--untracked-files=no"])).map(|s| !s.is_empty());
    (rev, dirty)
}

#[cfg(test)]
mod tests {
    use super::glob_match;

    #[test]
    fn globs() {
        assert!(glob_match("*", "a__sd__kp-newton"));
        assert!(glob_match("*__sd__*", "cow__sd__kp-newton"));
        assert!(!glob_match("*__sd__*", "cow__sarap__kp-newton"));
        assert!(glob_match("cow__*__kp-newton", "cow__bconf__kp-newton"));
        assert!(glob_match("c?w*", "cow__sd__cm"));
        assert!(!glob_match("cow", "cow__sd__cm"));
        assert!(glob_match("*cm", "cow__sd__cm"));
        assert!(glob_match("a*b*c", "aXXbYYbZc"));
        assert!(!glob_match("a*b*c", "aXXbYYbZ"));
    }
}
