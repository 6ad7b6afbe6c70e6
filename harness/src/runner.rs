//! The batch runner: every (dataset, energy, solver) of a config, on `--jobs` worker threads,
//! each run's failure recorded without stopping the batch. Workers solve; the calling thread
//! writes every file, so each file has one writer.

use crate::config::{LoadedConfig, Task};
use crate::output::{iteration_csv, median, run_stem, write_atomic, SummaryRow, SummaryWriter};
use crate::progress::Progress;
use crate::registry::{resolve, Dataset, MeshSource};
use anyhow::{bail, Context, Result};
use solvers::authalic::{solve_authalic, AreaMetrics, AUTHALIC_ENERGY};
use solvers::deform::solve_deform;
use solvers::linear::AnalysisCache;
use solvers::mesh::Mesh;
use solvers::param::solve_param;
use solvers::solver::{Flow, IterationRecord, Observer, Outcome, StopReason};
use std::collections::BTreeMap;
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{mpsc, Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// Keeps every row of a run (a run has at most `max_iters + 1` rows), shows progress, and
/// stops the solver after the row that passes the run's deadline (`timeout` in the config)
/// or when the batch is interrupted.
struct Rows<'a> {
    rows: Vec<IterationRecord>,
    deadline: Option<Instant>,
    timed_out: bool,
    interrupt: &'a AtomicBool,
    progress: &'a dyn Progress,
    worker: usize,
}

impl Observer for Rows<'_> {
    fn observe(&mut self, record: &IterationRecord) -> Flow {
        self.rows.push(record.clone());
        self.progress.iteration(self.worker, record.iter, record.energy);
        if self.interrupt.load(Ordering::Relaxed) {
            return Flow::Stop;
        }
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
    /// Stopped by an interrupt of the batch: not a result, nothing is written.
    interrupted: bool,
}

/// Totals of a batch.
#[derive(Debug, Default, PartialEq)]
pub struct BatchReport {
    pub runs: usize,
    pub ok: usize,
    pub not_converged: usize,
    pub failed: usize,
    /// Runs not done because the batch was interrupted.
    pub interrupted: usize,
    pub skipped_datasets: Vec<String>,
    pub out_dir: PathBuf,
}

/// `--shard I/N`: the runs whose position in the batch's canonical order is `I-1` modulo `N`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Shard, String> {
        let parse = |t: &str| t.trim().parse::<usize>().ok();
        match s.split_once('/').map(|(i, n)| (parse(i), parse(n))) {
            Some((Some(index), Some(count))) if (1..=count).contains(&index) => Ok(Shard { index, count }),
            _ => Err(format!("'{s}' is not I/N with 1 <= I <= N (e.g. 3/8)")),
        }
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// How to run a batch (the `run` flags).
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Globs on `<dataset>__<energy>__<solver>`; empty: every run.
    pub only: Vec<String>,
    /// Reuse finished runs of a previous batch in the same folder with the same key.
    pub resume: bool,
    /// Runs at once (worker threads); default: the machine's cores.
    pub jobs: Option<usize>,
    pub shard: Option<Shard>,
    /// Set (by Ctrl-C) to stop: running runs are abandoned, no new run starts.
    pub interrupt: Arc<AtomicBool>,
}

/// One planned run.
pub struct Planned {
    /// Index into the resolved datasets.
    pub dataset: usize,
    pub energy: String,
    pub solver: String,
    pub stem: String,
}

/// The runs of a config in canonical order (datasets, then energies, then solvers, as the
/// config lists them), filtered by `--only`.
pub fn plan(datasets: &[Dataset], energies: &[String], solvers: &[String], only: &[String]) -> Vec<Planned> {
    let mut out = Vec::new();
    for (d, ds) in datasets.iter().enumerate() {
        for e in energies {
            for s in solvers {
                let stem = run_stem(&ds.name, e, s);
                if only.is_empty() || only.iter().any(|g| glob_match(g, &stem)) {
                    out.push(Planned { dataset: d, energy: e.clone(), solver: s.clone(), stem });
                }
            }
        }
    }
    out
}

/// A dataset's mesh and what its runs share: the symbolic analyses of their systems.
struct Loaded {
    mesh: Result<Mesh>,
    analyses: Arc<AnalysisCache>,
}

/// Meshes shared by the workers: loaded by the first run that needs one, dropped (with their
/// analyses) after the dataset's last run.
struct MeshCache {
    slots: Vec<Mutex<Option<Arc<Loaded>>>>,
    remaining: Vec<AtomicUsize>,
}

impl MeshCache {
    fn new(runs: &[&Planned], n_datasets: usize) -> MeshCache {
        let remaining: Vec<AtomicUsize> = (0..n_datasets).map(|_| AtomicUsize::new(0)).collect();
        for r in runs {
            remaining[r.dataset].fetch_add(1, Ordering::Relaxed);
        }
        MeshCache { slots: (0..n_datasets).map(|_| Mutex::new(None)).collect(), remaining }
    }

    fn get(&self, d: usize, ds: &Dataset) -> Arc<Loaded> {
        let mut slot = self.slots[d].lock().unwrap_or_else(|e| e.into_inner());
        slot.get_or_insert_with(|| Arc::new(Loaded { mesh: ds.load(), analyses: Default::default() })).clone()
    }

    fn done(&self, d: usize) {
        if self.remaining[d].fetch_sub(1, Ordering::AcqRel) == 1 {
            *self.slots[d].lock().unwrap_or_else(|e| e.into_inner()) = None;
        }
    }
}

/// Run a whole config into `out_dir`, then render its report.
pub fn run_batch(
    cfg: &LoadedConfig,
    out_dir: &Path,
    opts: &RunOptions,
    progress: &dyn Progress,
) -> Result<BatchReport> {
    let (datasets, notices) = resolve(cfg).with_context(|| format!("{}: datasets", cfg.path.display()))?;
    for n in &notices {
        progress.notice(n);
    }
    let c = &cfg.config;
    let energies = c.energy_names();
    let planned = plan(&datasets, &energies, &c.solvers, &opts.only);
    if planned.is_empty() {
        bail!("--only {} selects no run of {}", opts.only.join(" "), cfg.path.display());
    }
    let mine: Vec<&Planned> = planned
        .iter()
        .enumerate()
        .filter(|(i, _)| opts.shard.is_none_or(|s| i % s.count == s.index - 1))
        .map(|(_, p)| p)
        .collect();
    std::fs::create_dir_all(out_dir.join("runs")).with_context(|| format!("{}: cannot create", out_dir.display()))?;
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let jobs = opts.jobs.unwrap_or(cores).clamp(1, mine.len().max(1));
    let threads = c.threads_per_run.unwrap_or_else(|| (opts.jobs.unwrap_or(cores) / mine.len().max(1)).max(1));
    let meta = Meta { cfg, opts, planned: &planned, jobs, threads, started: SystemTime::now() };
    meta.write(out_dir, None, false)?;
    let mut summary = SummaryWriter::create(&out_dir.join("summary.csv"))?;
    let mut report = BatchReport { skipped_datasets: notices, out_dir: out_dir.to_path_buf(), ..Default::default() };
    let (rev, dirty) = git_revision(&cfg.dir);
    let code = format!("mapbench {} {} dirty={dirty:?}", env!("CARGO_PKG_VERSION"), rev.unwrap_or_default());
    let meshes = MeshCache::new(&mine, datasets.len());
    let next = AtomicUsize::new(0);
    let total = mine.len();
    progress.start(total, jobs);
    let mut finished: Vec<(usize, SummaryRow)> = Vec::new();
    let (tx, rx) = mpsc::channel::<(usize, usize, RunResult, bool, Option<String>)>();
    let outcome: Result<()> = std::thread::scope(|scope| {
        for worker in 0..jobs {
            let tx = tx.clone();
            let (mine, datasets, meshes, next, code) = (&mine, &datasets, &meshes, &next, &code);
            scope.spawn(move || {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build();
                let work = || loop {
                    if opts.interrupt.load(Ordering::Relaxed) {
                        break;
                    }
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(p) = mine.get(i) else { break };
                    let ds = &datasets[p.dataset];
                    progress.run_started(worker, &format!("{} {} {}", ds.name, p.energy, p.solver));
                    // An unreadable mesh file has no key; its run fails below as usual.
                    let key = crate::resume::run_key(cfg, ds, &p.energy, &p.solver, code).ok();
                    let previous = match (&key, opts.resume) {
                        (Some(k), true) => crate::resume::previous(out_dir, &p.stem, k),
                        _ => None,
                    };
                    let resumed = previous.is_some();
                    let result = match previous {
                        Some((summary, rows)) => RunResult { summary, rows, map_obj: None, interrupted: false },
                        None => {
                            let loaded = meshes.get(p.dataset, ds);
                            let ctx = RunContext {
                                interrupt: &opts.interrupt,
                                progress,
                                worker,
                                analyses: loaded.analyses.clone(),
                            };
                            run_one(cfg, ds, loaded.mesh.as_ref(), &p.energy, &p.solver, &ctx)
                        }
                    };
                    meshes.done(p.dataset);
                    if tx.send((i, worker, result, resumed, key)).is_err() {
                        break;
                    }
                };
                match pool {
                    Ok(pool) => pool.install(work),
                    Err(_) => work(),
                }
            });
        }
        drop(tx);
        // The calling thread writes every file as results arrive.
        for (i, worker, mut result, resumed, key) in rx {
            if result.interrupted {
                continue;
            }
            let p = mine[i];
            // A run whose files cannot be written (a folder in the way, a name the OS refuses)
            // fails alone, like any other failed run; without a sidecar `--resume` retries it.
            let sidecar_key = key.as_deref().filter(|_| !resumed);
            if let Err(e) = write_run_files(out_dir, &p.stem, &mut result, sidecar_key) {
                let s = &result.summary;
                result.summary = SummaryRow {
                    dataset: s.dataset.clone(),
                    task: s.task.clone(),
                    energy: s.energy.clone(),
                    solver: s.solver.clone(),
                    vertices: s.vertices,
                    faces: s.faces,
                    stop_reason: "error".into(),
                    status: "failed".into(),
                    error: format!("{e:#}"),
                    ..Default::default()
                };
                result.rows.clear();
            }
            let s = &result.summary;
            progress.run_finished(worker, &run_line(finished.len() + 1, total, s, resumed));
            match s.status.as_str() {
                "ok" => report.ok += 1,
                "not_converged" => report.not_converged += 1,
                _ => report.failed += 1,
            }
            report.runs += 1;
            summary.append(s)?;
            finished.push((i, result.summary));
        }
        Ok(())
    });
    progress.finish();
    outcome?;
    let interrupted = opts.interrupt.load(Ordering::Relaxed);
    report.interrupted = total - report.runs;
    if interrupted {
        progress.notice(&format!(
            "interrupted: {} runs finished and written, {} not run (`--resume` runs them)",
            report.runs, report.interrupted
        ));
    }
    // summary.csv in canonical order, whatever order the workers finished in.
    finished.sort_by_key(|(i, _)| *i);
    let rows: Vec<SummaryRow> = finished.into_iter().map(|(_, s)| s).collect();
    crate::output::write_summary(&out_dir.join("summary.csv"), &rows)?;
    progress.notice(&format!("rendering the report: {}", out_dir.join("index.html").display()));
    // The report keeps to the batch's core budget too: `--jobs 1` (say a Slurm task with one
    // CPU) must not fan the plots out to every core of the node.
    let report_threads = opts.jobs.unwrap_or(cores).max(1);
    match rayon::ThreadPoolBuilder::new().num_threads(report_threads).build() {
        Ok(pool) => pool.install(|| crate::report::refresh(out_dir, &rows))?,
        Err(_) => crate::report::refresh(out_dir, &rows)?,
    }
    meta.write(out_dir, Some(SystemTime::now()), interrupted)?;
    Ok(report)
}

/// The line a finished run prints.
fn run_line(done: usize, total: usize, s: &SummaryRow, resumed: bool) -> String {
    format!(
        "[{done}/{total}] {} {} {}: {}{}{}",
        s.dataset,
        s.energy,
        s.solver,
        if resumed { "resumed, " } else { "" },
        s.status,
        match (&s.iterations, &s.final_energy, &s.time_s) {
            (Some(it), Some(e), Some(t)) => format!(" ({}), {it} iterations, E = {e:.8}, {t:.2} s", s.stop_reason),
            _ => format!(": {}", s.error),
        }
    )
}

/// Write a run's files: its map (when it has one), its per-iteration CSV and, given the run's
/// key, the sidecar that marks it finished, written last. On an error nothing of this run
/// is left that `--resume` or the report would take for a result.
fn write_run_files(out_dir: &Path, stem: &str, r: &mut RunResult, key: Option<&str>) -> Result<()> {
    let map = out_dir.join("uv").join(format!("{stem}.obj"));
    let wrote_map = r.map_obj.is_some();
    let written = (|| {
        if let Some(obj) = r.map_obj.take() {
            write_atomic(&map, &obj)?;
        }
        // With this run's own best; `report::refresh` fills in the group's best at the end.
        let own_best = r.rows.iter().map(|x| x.energy).fold(f64::INFINITY, f64::min);
        write_atomic(&out_dir.join("runs").join(format!("{stem}.csv")), &iteration_csv(&r.rows, own_best)?)?;
        if let Some(k) = key {
            crate::resume::write_sidecar(out_dir, stem, k, &r.summary)?;
        }
        Ok(())
    })();
    if written.is_err() {
        if wrote_map {
            let _ = std::fs::remove_file(&map);
        }
        // A previous batch's sidecar would vouch for files that are now a mix.
        if key.is_some() {
            let _ = std::fs::remove_file(crate::resume::sidecar_path(out_dir, stem));
        }
    }
    written
}

/// One run; never returns an error or panics: failures become a `failed` summary row.
fn run_one(
    cfg: &LoadedConfig,
    ds: &Dataset,
    mesh: Result<&Mesh, &anyhow::Error>,
    energy: &str,
    solver: &str,
    ctx: &RunContext,
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
        RunResult { summary, rows: Vec::new(), map_obj: None, interrupted: false }
    };
    let mesh = match mesh {
        Ok(m) => m,
        Err(e) => return fail(summary, format!("{e:#}")),
    };
    summary.vertices = Some(mesh.n_vertices());
    summary.faces = Some(mesh.n_faces());
    let timeout = cfg.config.timeout_secs().ok().flatten();
    let mut rows = Rows {
        rows: Vec::new(),
        deadline: timeout.map(|t| Instant::now() + Duration::from_secs_f64(t)),
        timed_out: false,
        interrupt: ctx.interrupt,
        progress: ctx.progress,
        worker: ctx.worker,
    };
    let t0 = Instant::now();
    let result =
        std::panic::catch_unwind(AssertUnwindSafe(|| solve(cfg, ds, mesh, energy, solver, &ctx.analyses, &mut rows)));
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
    // The symbolic analysis is shared by the runs on a mesh, so which run computes it depends
    // on scheduling: time_s leaves it out for every run (including any wait for another run
    // computing it) and analysis_s reports its cost.
    let setup = outcome.analysis.map_or(0.0, |a| a.setup_seconds);
    let elapsed = (elapsed - setup).max(0.0);
    summary.analysis_s = outcome.analysis.map(|a| a.seconds);
    summary.analysis_shared = outcome.analysis.map(|a| a.reused);
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
    let interrupted = matches!(outcome.stop_reason, StopReason::Interrupted) && !timed_out;
    RunResult { summary, rows, map_obj, interrupted }
}

/// What a run needs from the batch around it.
struct RunContext<'a> {
    interrupt: &'a AtomicBool,
    progress: &'a dyn Progress,
    worker: usize,
    /// Symbolic analyses shared by the runs on this mesh.
    analyses: Arc<AnalysisCache>,
}

/// One solve of the config's task; `authalic` runs also return their area metrics.
fn solve(
    cfg: &LoadedConfig,
    ds: &Dataset,
    mesh: &Mesh,
    energy: &str,
    solver: &str,
    analyses: &Arc<AnalysisCache>,
    rows: &mut Rows<'_>,
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
            settings.solver.analyses = Some(analyses.clone());
            Ok((solve_param(mesh, kind, solver, &settings, rows)?, None))
        }
        Task::Deform => {
            let kind = cfg.config.energy_kind(energy)?;
            // Handle rules pick vertices by position: check the mesh first, so a bad mesh fails
            // with validate's reason rather than with what the rule made of it.
            solvers::mesh::validate_for(mesh, solvers::mesh::Task::Deform).into_result()?;
            let handles = ds.handles.load(mesh)?;
            let mut settings = cfg.config.deform_settings();
            settings.smoothness = cfg.config.smoothness_for(energy);
            settings.solver.analyses = Some(analyses.clone());
            // A generated shape may bring its start (the released bar), like its handles.
            let init = match &ds.source {
                MeshSource::Generated(g) => solvers::generate::generated_init(g),
                MeshSource::File(_) => None,
            };
            Ok((solve_deform(mesh, &handles, init.as_deref(), kind, solver, &settings, rows)?, None))
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

/// `meta.json`: the resolved config and provenance (code version, git revision, machine,
/// toolchain), the batch's plan and how it ran.
struct Meta<'a> {
    cfg: &'a LoadedConfig,
    opts: &'a RunOptions,
    planned: &'a [Planned],
    jobs: usize,
    threads: usize,
    started: SystemTime,
}

impl Meta<'_> {
    fn write(&self, out_dir: &Path, ended: Option<SystemTime>, interrupted: bool) -> Result<()> {
        let cfg = self.cfg;
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
            "only": self.opts.only,
            "resume": self.opts.resume,
            "shard": self.opts.shard.map(|s| s.to_string()),
            "plan": self.planned.iter().map(|p| p.stem.as_str()).collect::<Vec<_>>(),
            "jobs": self.jobs,
            "threads_per_run": self.threads,
            // Newton systems of fewer than METIS_MIN_NODES vertices use AMD whatever this says.
            "linear_ordering": cfg.config.linear.ordering.unwrap_or_default().as_str(),
            "stop_per_energy": stop.iter().map(|(e, (g, d, m))| (e.clone(), serde_json::json!({
                "grad_tol": g, "energy_decrease_tol": d, "max_iters": m
            }))).collect::<serde_json::Map<_, _>>(),
            "meshes_dir": std::env::var(crate::registry::MESHES_ENV).ok(),
            "mapbench_version": env!("CARGO_PKG_VERSION"),
            "rustc": env!("MAPBENCH_RUSTC"),
            "crates": env!("MAPBENCH_CRATES"),
            "git_revision": rev,
            "git_dirty": dirty,
            "host": std::env::var("HOSTNAME").ok().or_else(|| std::fs::read_to_string("/etc/hostname").ok().map(|s| s.trim().to_string())),
            "cores": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
            "started_unix": secs(self.started),
            "ended_unix": ended.map(secs),
            "interrupted": interrupted,
        });
        write_atomic(&out_dir.join("meta.json"), serde_json::to_string_pretty(&meta)?.as_bytes())
    }
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
