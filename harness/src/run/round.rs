//! One round of a batch: its work items on `--jobs` worker threads, each either the earlier
//! result of a run (`--resume`) or a new run, its memory measured and its final map looked at
//! against its group's reference; the calling thread takes the results as they arrive.

use super::memory::Monitor;
use super::meshes::MeshCache;
use super::one::{run_one, RunContext, RunResult};
use super::options::RunOptions;
use super::progress::Progress;
use super::repeats::Repeats;
use super::resume;
use crate::external::probe::Probe;
use crate::judge::end::TargetEnd;
use crate::plan::{Plan, PlannedRun};
use crate::run_folder::{sidecar, Status};
use anyhow::Result;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;

/// Where a result of a round came from.
pub(super) enum RoundSource {
    Ran,
    /// A finished run of an earlier batch in the folder (`--resume`).
    Resumed,
    /// The repeats an interrupt cut short in an earlier batch (`--resume`): the rest are run.
    Restored(Repeats),
}

/// One finished work item of a round.
pub(super) struct Done {
    /// The run's index in the batch.
    pub(super) index: usize,
    pub(super) worker: usize,
    pub(super) result: RunResult,
    pub(super) origin: RoundSource,
    pub(super) key: Option<String>,
}

/// One work item of a round.
#[derive(Clone, Copy)]
pub(super) struct Todo {
    /// The run's index in the batch.
    pub(super) index: usize,
    /// Where a replay of a timed-out run stops.
    pub(super) stop_at: Option<usize>,
    /// Keep the final map (the first time the run runs in this batch).
    pub(super) keep_map: bool,
}

/// What every worker of a batch shares.
pub(super) struct Workers<'a> {
    pub(super) plan: &'a Plan,
    pub(super) out_dir: &'a Path,
    pub(super) mine: &'a [&'a PlannedRun],
    pub(super) opts: &'a RunOptions,
    pub(super) progress: &'a dyn Progress,
    pub(super) jobs: usize,
    pub(super) threads: usize,
    /// The code's identity in the run keys.
    pub(super) code: &'a str,
    /// What the batch found out about its external solvers.
    pub(super) probes: &'a [Probe],
    /// The groups' references: a run's final map is looked at against its group's.
    pub(super) references: &'a [crate::judge::reference::GroupReference],
}

/// One round: the runs `todo` on `jobs` workers; the calling thread hands each result to
/// `done` as it arrives.
pub(super) fn run_round(
    w: &Workers,
    todo: &[Todo],
    round: usize,
    mut done: impl FnMut(Done) -> Result<()>,
) -> Result<()> {
    let meshes = MeshCache::new(todo.iter().map(|t| w.mine[t.index].dataset), w.plan.datasets.len());
    let next = AtomicUsize::new(0);
    let (tx, rx) = mpsc::channel::<Done>();
    let workers = w.jobs.min(todo.len());
    let monitor = Monitor::new(workers);
    std::thread::scope(|scope| {
        // The sampler ends with the round, however the round ends (an error below included).
        let _stop = StopOnDrop(&monitor);
        scope.spawn(|| monitor.sample_until_stopped());
        for worker in 0..workers {
            let tx = tx.clone();
            let (meshes, next, monitor) = (&meshes, &next, &monitor);
            scope.spawn(move || {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(w.threads).build();
                let work = || loop {
                    if w.opts.interrupt.load(Ordering::Relaxed) {
                        break;
                    }
                    let Some(&item) = todo.get(next.fetch_add(1, Ordering::Relaxed)) else {
                        break;
                    };
                    // Busy from here to the hand-over: a run measured beside it shares the process.
                    let busy = monitor.busy(worker);
                    let d = w.work(item, round, worker, meshes, monitor);
                    drop(busy);
                    if tx.send(d).is_err() {
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
        for d in rx {
            done(d)?;
        }
        Ok(())
    })
}

impl Workers<'_> {
    /// Work item `item` of round `round` on `worker`: the run's earlier result (`--resume`)
    /// or a new run.
    pub(super) fn work(&self, item: Todo, round: usize, worker: usize, meshes: &MeshCache, monitor: &Monitor) -> Done {
        let Workers { plan, out_dir, mine, opts, progress, threads, code, probes, .. } = *self;
        let p = mine[item.index];
        let ds = plan.dataset(p);
        let again = if round > 0 { format!(" (repeat {})", round + 1) } else { String::new() };
        progress.run_started(worker, &format!("{} {} {}{again}", ds.name, p.energy, p.solver));
        // An unreadable mesh file has no key; its run fails below as usual. An external
        // solver's version is part of its code, and the threads it is given (ours give
        // the same bits on any).
        let probe = probes.iter().find(|x| x.name == p.solver);
        let code = match probe {
            Some(x) => format!("{code} {} {:?} threads={threads}", p.solver, x.version),
            None => code.to_string(),
        };
        // Where the run ends is part of what it computes: its group's reference and target.
        let target = TargetEnd::of(plan, p, self.references);
        let code = match &target {
            Some(t) => format!("{code} {}", t.key_text()),
            None => code,
        };
        let key = resume::run_key(plan, p, &code).ok();
        let earlier = |summary, rows| RunResult { summary, rows, ..Default::default() };
        let previous = match (&key, opts.resume && round == 0) {
            (Some(k), true) => resume::previous(out_dir, &p.stem, k, plan.maps)
                .map(|(summary, rows)| (earlier(summary, rows), RoundSource::Resumed))
                .or_else(|| {
                    let (partial, rows) = sidecar::read_partial::<Repeats>(out_dir, &p.stem, k)?;
                    Some((earlier(partial.summary, rows), RoundSource::Restored(partial.repeats)))
                }),
            _ => None,
        };
        let (result, origin) = match previous {
            Some(earlier) => earlier,
            None => (self.run_new(item, round, worker, meshes, monitor, target), RoundSource::Ran),
        };
        meshes.done(p.dataset);
        let key = key.filter(|_| !result.unkeyed);
        Done { index: item.index, worker, result, origin, key }
    }

    /// A new run of work item `item`, its memory measured, its final map looked at once
    /// against its group's reference (untimed).
    fn run_new(
        &self,
        item: Todo,
        round: usize,
        worker: usize,
        meshes: &MeshCache,
        monitor: &Monitor,
        target: Option<TargetEnd>,
    ) -> RunResult {
        let Workers { plan, out_dir, mine, opts, progress, threads, probes, references, .. } = *self;
        let p = mine[item.index];
        let ds = plan.dataset(p);
        let loaded = meshes.get(p.dataset, ds);
        let ctx = RunContext {
            out_dir,
            threads,
            probes,
            interrupt: &opts.interrupt,
            progress,
            worker,
            analyses: loaded.analyses.clone(),
            stop_at: item.stop_at,
            keep_map: item.keep_map,
            target,
        };
        monitor.start(worker);
        let mut result = run_one(plan, p, loaded.mesh.as_ref(), &ctx);
        let memory = monitor.finish(worker);
        // An external run has its child's own peak.
        if result.summary.status != Status::Skipped && plan.external(p).is_none() {
            result.summary.peak_rss_mb = memory.process_mb;
            result.summary.peak_growth_mb = memory.growth_mb;
        }
        if result.map_uv.is_some() {
            result.mesh_file = loaded.mesh_file();
        }
        // What the final map says, once (a repeat reproduces it).
        if let (Some(x), Ok(mesh)) = (result.final_x.take(), loaded.mesh.as_ref()) {
            if round == 0 && result.summary.status.ran() {
                let group = references.iter().find(|g| g.dataset == ds.name && g.energy == p.energy);
                let tightest = plan.targets.tightest(&p.energy).unwrap_or(0.0);
                let s = &result.summary;
                let (polished, candidate) =
                    crate::judge::confirm::after_run(plan, p, mesh, s, x, group, tightest, &opts.interrupt);
                (result.summary.polished_energy, result.candidate) = (polished, candidate);
            }
        }
        result
    }
}

/// Stops the memory sampler when dropped.
struct StopOnDrop<'a>(&'a Monitor);

impl Drop for StopOnDrop<'_> {
    fn drop(&mut self) {
        self.0.stop();
    }
}
