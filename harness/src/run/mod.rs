//! The batch runner: every (dataset, energy, solver) of a config, on `--jobs` worker threads,
//! each run's failure recorded without stopping the batch. Workers solve; the calling thread
//! writes every file, so each file has one writer.

pub mod merge;
pub mod progress;
pub mod resume;

mod meshes;
mod one;

use crate::calibration::Calibration;
use crate::plan::select::Shard;
use crate::plan::{Plan, PlannedRun};
use crate::run_folder::meta::{code_id, Meta};
use crate::run_folder::{summary_csv, write_run, RunFiles, Status, SummaryRow, SummaryWriter};
use anyhow::{Context, Result};
use meshes::MeshCache;
use one::{run_one, RunContext, RunResult};
use progress::Progress;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{mpsc, Arc};
use std::time::SystemTime;

/// Totals of a batch.
#[derive(Debug, Default, PartialEq)]
pub struct BatchReport {
    pub runs: usize,
    pub ok: usize,
    pub not_converged: usize,
    pub failed: usize,
    /// Pairs outside a solver's declared energies: not run.
    pub skipped: usize,
    /// Runs not done because the batch was interrupted.
    pub interrupted: usize,
    pub skipped_datasets: Vec<String>,
    pub out_dir: PathBuf,
}

/// How to run a batch (the `run` flags).
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Reuse finished runs of a previous batch in the same folder with the same key.
    pub resume: bool,
    /// Runs at once (worker threads); default: the machine's cores.
    pub jobs: Option<usize>,
    pub shard: Option<Shard>,
    /// Set (by Ctrl-C) to stop: running runs are abandoned, no new run starts.
    pub interrupt: Arc<AtomicBool>,
}

/// Run the plan's runs (those of `opts.shard`) into `out_dir`, then render its report.
pub fn run_batch(plan: &Plan, out_dir: &Path, opts: &RunOptions, progress: &dyn Progress) -> Result<BatchReport> {
    for n in &plan.notices {
        progress.notice(n);
    }
    let mine: Vec<&PlannedRun> = plan
        .runs
        .iter()
        .enumerate()
        .filter(|(i, _)| opts.shard.is_none_or(|s| s.selects(*i)))
        .map(|(_, p)| p)
        .collect();
    std::fs::create_dir_all(crate::run_folder::runs_dir(out_dir))
        .with_context(|| format!("{}: cannot create", out_dir.display()))?;
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let jobs = opts.jobs.unwrap_or(cores).clamp(1, mine.len().max(1));
    let threads = plan.threads_per_run.unwrap_or_else(|| (opts.jobs.unwrap_or(cores) / mine.len().max(1)).max(1));
    let meta = Meta { plan, shard: opts.shard, resume: opts.resume, jobs, threads, started: SystemTime::now() };
    let mut calibration = Calibration::new();
    calibrate(&mut calibration, threads, progress);
    meta.write(out_dir, None, false, &calibration)?;
    let mut summary = SummaryWriter::create(&summary_csv(out_dir))?;
    let mut report =
        BatchReport { skipped_datasets: plan.notices.clone(), out_dir: out_dir.to_path_buf(), ..Default::default() };
    let code = code_id(&plan.config.dir);
    let meshes = MeshCache::new(mine.iter().map(|r| r.dataset), plan.datasets.len());
    let next = AtomicUsize::new(0);
    let total = mine.len();
    progress.start(total, jobs);
    let mut finished: Vec<(usize, SummaryRow)> = Vec::new();
    let (tx, rx) = mpsc::channel::<(usize, usize, RunResult, bool, Option<String>)>();
    let outcome: Result<()> = std::thread::scope(|scope| {
        for worker in 0..jobs {
            let tx = tx.clone();
            let (mine, meshes, next, code) = (&mine, &meshes, &next, &code);
            scope.spawn(move || {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build();
                let work = || loop {
                    if opts.interrupt.load(Ordering::Relaxed) {
                        break;
                    }
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(p) = mine.get(i) else { break };
                    let ds = plan.dataset(p);
                    progress.run_started(worker, &format!("{} {} {}", ds.name, p.energy, p.solver));
                    // An unreadable mesh file has no key; its run fails below as usual.
                    let key = resume::run_key(plan, p, code).ok();
                    let previous = match (&key, opts.resume) {
                        (Some(k), true) => resume::previous(out_dir, &p.stem, k),
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
                            run_one(plan, p, loaded.mesh.as_ref(), &ctx)
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
            let files = RunFiles {
                stem: &p.stem,
                summary: &result.summary,
                rows: &result.rows,
                map_obj: result.map_obj.as_deref(),
                key: sidecar_key,
            };
            if let Err(e) = write_run(out_dir, &files) {
                let s = &result.summary;
                result.summary = SummaryRow {
                    dataset: s.dataset.clone(),
                    task: s.task,
                    energy: s.energy.clone(),
                    solver: s.solver.clone(),
                    vertices: s.vertices,
                    faces: s.faces,
                    status: Status::Failed,
                    error: format!("{e:#}"),
                    ..Default::default()
                };
                result.rows.clear();
            }
            let s = &result.summary;
            progress.run_finished(worker, &run_line(finished.len() + 1, total, s, resumed));
            match s.status {
                Status::Ok => report.ok += 1,
                Status::NotConverged => report.not_converged += 1,
                Status::Failed => report.failed += 1,
                Status::Skipped => report.skipped += 1,
            }
            report.runs += 1;
            summary.append(s)?;
            finished.push((i, result.summary));
        }
        Ok(())
    });
    progress.finish();
    outcome?;
    calibrate(&mut calibration, threads, progress);
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
    crate::run_folder::write_summary(&summary_csv(out_dir), &rows)?;
    progress.notice(&format!("rendering the report: {}", out_dir.join("index.html").display()));
    // The report keeps to the batch's core budget too: `--jobs 1` (say a Slurm task with one
    // CPU) must not fan the plots out to every core of the node.
    let report_threads = opts.jobs.unwrap_or(cores).max(1);
    match rayon::ThreadPoolBuilder::new().num_threads(report_threads).build() {
        Ok(pool) => pool.install(|| crate::report::refresh(out_dir, &rows))?,
        Err(_) => crate::report::refresh(out_dir, &rows)?,
    }
    meta.write(out_dir, Some(SystemTime::now()), interrupted, &calibration)?;
    Ok(report)
}

/// One more calibration sample, on a pool of the runs' thread count. A failed sample is a
/// notice, never the end of the batch: the runs' own times do not depend on it.
fn calibrate(calibration: &mut Calibration, threads: usize, progress: &dyn Progress) {
    let sample = match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
        Ok(pool) => pool.install(|| calibration.sample()),
        Err(_) => calibration.sample(),
    };
    if let Err(e) = sample {
        progress.notice(&format!("calibration sample failed (time_norm left empty if none succeeds): {e:#}"));
    }
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
            (Some(it), Some(e), Some(t)) => format!(" ({}), {it} iterations, E = {e:.8}, {t:.2} s", s.stop_column()),
            _ => format!(": {}", s.error),
        }
    )
}
