//! The batch runner: every (dataset, energy, solver) of a config, on `--jobs` worker threads,
//! each run's failure recorded without stopping the batch. Workers solve; the calling thread
//! writes every file, so each file has one writer.

pub mod merge;
mod pages;
pub mod progress;
mod record;
pub mod resume;

mod finish;
mod memory;
mod meshes;
mod one;
mod options;
mod repeats;
mod round;

use crate::calibration::Calibration;
use crate::external::probe::Probe;
use crate::history::{Decision, HistoryOutcome};
use crate::paths::absolute;
use crate::plan::config::Maps;
use crate::plan::{Plan, PlannedRun};
use crate::run_folder::reuse::{self, Identity, Reuse};
use crate::run_folder::RunStop;
use crate::run_folder::{summary_csv, SummaryRow, SummaryWriter};
use anyhow::{Context, Result};
pub use finish::BatchReport;
use finish::{batch_notices, judge_and_write, Finisher};
use one::RunResult;
pub use options::RunOptions;
use pages::conclude_history;
pub use pages::Pages;
use progress::Progress;
use record::{code_id, BatchRecord};
pub use repeats::REPEAT_WITHIN;
use repeats::{Repeats, Slot};
use round::{run_round, Done, RoundSource, Todo, Workers};
use solvers::solver::StopReason;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::SystemTime;

/// Run the plan's runs (those of `opts.shard`) into `out_dir`, then render its report and,
/// after a history append, its config's trend page (`pages`). With `repeat = N` every run
/// runs once, then every run again (round-robin), N times, with a calibration sample before
/// the first round, between rounds and after the last.
pub fn run_batch(
    plan: &Plan,
    out_dir: &Path,
    opts: &RunOptions,
    progress: &dyn Progress,
    pages: &dyn Pages,
) -> Result<BatchReport> {
    for n in &plan.notices {
        progress.notice(n);
    }
    let mine = my_runs(plan, opts);
    let cores = crate::plan::config::available_cores();
    crate::plan::config::check_jobs(opts.jobs, cores)?;
    claim_folder(plan, out_dir, opts, progress)?;
    let jobs = opts.jobs.unwrap_or(cores).clamp(1, mine.len().max(1));
    let threads =
        plan.threads_per_run.unwrap_or_else(|| default_threads(opts.jobs.unwrap_or(cores), cores, mine.len()));
    // A resumed folder whose batch is already in the history is not appended twice.
    let previous = opts.resume.then(|| HistoryOutcome::of_folder(out_dir)).flatten();
    let probes = probe_externals(plan, &mine, &opts.interrupt, progress);
    let mut meta = BatchRecord::starting(plan, opts, (jobs, threads), previous.clone(), probes);
    let mut calibration = Calibration::new();
    let summary = open_folder(out_dir, &meta, &calibration)?;
    // The reference minima the runs are judged by, before any run (computing a missing one
    // is a tight solve, timed by nobody).
    meta.references = crate::judge::reference::prepare(plan, &mine, &|line| progress.notice(line), &opts.interrupt)?;
    calibrate(&mut calibration, jobs, threads, progress);
    meta.write(out_dir, None, false, &calibration)?;
    let report = BatchReport { notices: plan.notices.clone(), out_dir: out_dir.to_path_buf(), ..Default::default() };
    let code = code_id();
    let total = mine.len();
    if plan.repeat > 1 {
        progress.notice(&format!("{total} runs, each repeated {} times round-robin", plan.repeat));
    }
    progress.start(total * plan.repeat, jobs);
    let mut slots: Vec<Option<Slot>> = (0..total).map(|_| None).collect();
    let mut done =
        Finisher { out_dir, mine: &mine, progress, summary, finished: Vec::new(), meshes_written: Vec::new(), report };
    let workers = Workers {
        plan,
        out_dir,
        mine: &mine,
        opts,
        progress,
        jobs,
        threads,
        code: &code,
        probes: &meta.external,
        references: &meta.references,
    };
    run_rounds(&workers, &mut calibration, &mut slots, &mut done)?;
    done.keep_partials(&mut slots, plan.repeat)?;
    progress.finish();
    // A stopped batch ends without the last sample (Slurm kills a job some seconds after its
    // SIGTERM). It is interrupted when runs are missing: a signal after the last run cuts
    // nothing (the exit code still says it came).
    if !opts.interrupt.load(Ordering::Relaxed) {
        calibrate(&mut calibration, jobs, threads, progress);
    }
    let Finisher { mut finished, mut report, .. } = done;
    report.interrupted = total - report.runs;
    batch_notices(&report, plan.repeat, &calibration, progress);
    let batch = BatchContext { plan, mine: &mine, code: &code, out_dir, opts, progress };
    lower_references(&batch, &mut meta.references, &mut finished)?;
    let rows = judge_and_write(plan, out_dir, &mine, &meta, &calibration, finished, &mut report, progress)?;
    crate::run_folder::fill_energy_minus_best(out_dir, &rows)?;
    // meta.json before the report, which states its calibration samples, then the history,
    // which reads the finished folder and records its outcome in meta.json for the report.
    let interrupted = report.interrupted > 0;
    meta.write(out_dir, Some(SystemTime::now()), interrupted, &calibration)?;
    report.history = record_history(pages, plan, out_dir, previous.as_ref(), &report)?;
    progress.notice(&format!("rendering the report: {}", out_dir.join("index.html").display()));
    render_report(pages, out_dir, &rows, opts.jobs.unwrap_or(cores).max(1))?;
    Ok(report)
}

/// The plan's runs this batch runs: those of its shard (`--shard`, `--shard-plan`), or all.
fn my_runs<'a>(plan: &'a Plan, opts: &RunOptions) -> Vec<&'a PlannedRun> {
    plan.runs
        .iter()
        .enumerate()
        .filter(|(i, p)| match (&opts.shard_runs, opts.shard) {
            (Some(planned), _) => planned.contains(&p.stem),
            (None, shard) => shard.is_none_or(|s| s.selects(*i)),
        })
        .map(|(_, p)| p)
        .collect()
}

/// meta.json and summary.csv first: from then on the folder is a run folder, whenever the
/// batch is stopped.
fn open_folder(out_dir: &Path, meta: &BatchRecord, calibration: &Calibration) -> Result<SummaryWriter> {
    std::fs::create_dir_all(out_dir).with_context(|| format!("{}: cannot create", out_dir.display()))?;
    meta.write(out_dir, None, false, calibration)?;
    let summary = SummaryWriter::create(&summary_csv(out_dir))?;
    std::fs::create_dir_all(crate::run_folder::runs_dir(out_dir))
        .with_context(|| format!("{}: cannot create", out_dir.display()))?;
    Ok(summary)
}

/// The rounds of the batch (one, or `repeat` round-robin), with a calibration sample between
/// two rounds; an interrupt ends them.
fn run_rounds(
    workers: &Workers,
    calibration: &mut Calibration,
    slots: &mut [Option<Slot>],
    done: &mut Finisher,
) -> Result<()> {
    let (plan, mine, progress) = (workers.plan, workers.mine, workers.progress);
    for round in 0..plan.repeat {
        if workers.opts.interrupt.load(Ordering::Relaxed) {
            break;
        }
        let todo = round_todo(round, slots, mine.len(), plan.maps);
        if todo.is_empty() {
            continue;
        }
        if round > 0 {
            calibrate(calibration, workers.jobs, workers.threads, progress);
        }
        run_round(workers, &todo, round, |d| match absorb(slots, d, plan, mine, progress) {
            Some((i, worker, slot)) => done.finish(i, worker, slot),
            None => Ok(()),
        })?;
        let ranked_only = plan.repeat_runs == crate::plan::config::RepeatRuns::Ranked;
        if round == 0 && plan.repeat > 1 && ranked_only && !workers.opts.interrupt.load(Ordering::Relaxed) {
            keep_one_sample(slots, plan, mine, progress, done)?;
        }
    }
    Ok(())
}

/// After the first round: the runs whose times decide no ranking keep their one sample
/// (`repeats::worth_repeating`) and are finished now; the others go on to their repeats.
fn keep_one_sample(
    slots: &mut [Option<Slot>],
    plan: &Plan,
    mine: &[&PlannedRun],
    progress: &dyn Progress,
    done: &mut Finisher,
) -> Result<()> {
    let waiting: Vec<usize> = (0..slots.len())
        .filter(|&i| slots[i].as_ref().is_some_and(|s| s.repeats.is_some() && !s.complete(plan.repeat)))
        .collect();
    let firsts: Vec<(&str, &str, &one::RunResult)> = waiting
        .iter()
        .filter_map(|&i| {
            slots[i].as_ref().map(|s| (s.first.summary.dataset.as_str(), mine[i].energy.as_str(), &s.first))
        })
        .collect();
    let worth = repeats::worth_repeating(&firsts);
    let once: Vec<usize> = waiting.iter().zip(worth).filter(|(_, w)| !w).map(|(&i, _)| i).collect();
    for i in once {
        let Some(slot) = slots[i].take() else { continue };
        let count = slot.repeats.as_ref().map_or(1, |r| r.count());
        progress.fewer_solves(plan.repeat.saturating_sub(count));
        done.finish(i, 0, slot)?;
    }
    Ok(())
}

/// What [`lower_references`] needs of the batch.
struct BatchContext<'a> {
    plan: &'a Plan,
    mine: &'a [&'a PlannedRun],
    code: &'a str,
    out_dir: &'a Path,
    opts: &'a RunOptions,
    progress: &'a dyn Progress,
}

/// References only get better: the finished runs that ended below theirs lower it (each
/// candidate named with the batch and run it came from) before the judge; not after an
/// interrupt.
fn lower_references(
    batch: &BatchContext,
    references: &mut [crate::judge::reference::GroupReference],
    finished: &mut [finish::FinishedRun],
) -> Result<()> {
    let candidates = finish::take_candidates(finished);
    if candidates.is_empty() || batch.opts.interrupt.load(Ordering::Relaxed) {
        return Ok(());
    }
    let source = crate::judge::reference::BatchSource {
        config: batch.plan.config.config.name.clone(),
        code: batch.code.to_string(),
        folder: absolute(batch.out_dir).display().to_string(),
        run: String::new(),
        unix_time: SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs()),
    };
    let candidates = candidates
        .into_iter()
        .map(|c| {
            let source = crate::judge::reference::BatchSource { run: c.stem.clone(), ..source.clone() };
            (c, source)
        })
        .collect();
    let notice = |line: &str| batch.progress.notice(line);
    let interrupt = &batch.opts.interrupt;
    crate::judge::improve::improve(batch.plan, batch.mine, references, candidates, &notice, interrupt)?;
    Ok(())
}

/// The batch's report on `threads` threads: it keeps to the batch's core budget too, so
/// `--jobs 1` (say a Slurm task with one CPU) does not fan the plots out to every core of the
/// node.
fn render_report(pages: &dyn Pages, out_dir: &Path, rows: &[SummaryRow], threads: usize) -> Result<()> {
    match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
        Ok(pool) => pool.install(|| pages.report(out_dir, rows)),
        Err(_) => pages.report(out_dir, rows),
    }
}

/// `out_dir` for this batch: refused when it holds another batch's results, unless
/// `--force` (then they are deleted).
fn claim_folder(plan: &Plan, out_dir: &Path, opts: &RunOptions, progress: &dyn Progress) -> Result<()> {
    let identity = Identity {
        config: plan.config.config.name.clone(),
        plan: plan.runs.iter().map(|p| p.stem.clone()).collect(),
        shard: opts.shard.map(|s| s.to_string()),
    };
    if reuse::check(out_dir, &identity, opts.force)? == Reuse::Another {
        reuse::clean(out_dir)?;
        progress.notice(&format!("--force: deleted the results of another batch in {}", out_dir.display()));
    }
    Ok(())
}

/// The work of round `round`: round 0 runs everything; round r the runs whose next repeat
/// is r + 1 (a run whose repeats an earlier batch began waits for the round of its next one).
fn round_todo(round: usize, slots: &[Option<Slot>], total: usize, maps: Maps) -> Vec<Todo> {
    if round == 0 {
        return (0..total).map(|index| Todo { index, stop_at: None, keep_map: maps != Maps::None }).collect();
    }
    slots
        .iter()
        .enumerate()
        .filter_map(|(index, s)| {
            let s = s.as_ref().filter(|s| s.next_in(round))?;
            let keep_map = s.first.map_uv.is_none() && maps != Maps::None;
            Some(Todo { index, stop_at: replay_to(&s.first), keep_map })
        })
        .collect()
}

/// Probe each external solver the batch runs (not those of skipped pairs only), once, and say
/// what became of it.
fn probe_externals(plan: &Plan, mine: &[&PlannedRun], interrupt: &AtomicBool, progress: &dyn Progress) -> Vec<Probe> {
    let mut probes: Vec<Probe> = Vec::new();
    for run in mine.iter().filter(|r| r.skip.is_none()) {
        let Some(declared) = plan.external(run) else { continue };
        if probes.iter().any(|p| p.name == run.solver) {
            continue;
        }
        let p = crate::external::probe::probe(&run.solver, declared, &plan.config.dir, interrupt);
        progress.notice(&match (&p.unavailable, &p.version) {
            (Some(why), _) => format!("external solver {}: its runs are skipped: {why}", p.name),
            (None, Some(v)) => format!("external solver {}: version {v}", p.name),
            (None, None) => format!("external solver {}: `{}`", p.name, p.command.join(" ")),
        });
        probes.push(p);
    }
    probes
}

/// The batch into the history database, unless it was interrupted (its means would read as
/// a change of the code) or, resumed whole, is in it already.
fn record_history(
    pages: &dyn Pages,
    plan: &Plan,
    out_dir: &Path,
    previous: Option<&HistoryOutcome>,
    report: &BatchReport,
) -> Result<HistoryOutcome> {
    let decision = if report.interrupted > 0 {
        Decision::Skip("the batch was interrupted: its means would read as a change of the code".into())
    } else {
        match previous.and_then(HistoryOutcome::in_history) {
            Some((db, batch_id, trend))
                if report.resumed == report.runs && plan.history.as_deref().map(absolute).as_deref() == Some(db) =>
            {
                Decision::AlreadyIn { batch_id, trend: trend.cloned() }
            }
            _ => Decision::Append,
        }
    };
    Ok(conclude_history(pages, plan.history.as_deref(), out_dir, out_dir, decision)?)
}

/// One result of a round into its run's slot: the run's slot when its last repeat is in
/// (with the worker that ran it), to be finished; `None` while repeats are to come, or for
/// a run an interrupt abandoned.
fn absorb(
    slots: &mut [Option<Slot>],
    done: Done,
    plan: &Plan,
    mine: &[&PlannedRun],
    progress: &dyn Progress,
) -> Option<(usize, usize, Slot)> {
    let Done { index: i, worker, result, origin, key } = done;
    if result.interrupted {
        return None;
    }
    let stem = &mine[i].stem;
    let ran = matches!(origin, RoundSource::Ran);
    let slot = match (slots[i].take(), origin) {
        (None, RoundSource::Resumed) => Slot { first: result, resumed: true, key, repeats: None },
        (None, RoundSource::Restored(repeats)) => {
            // Those repeats were solved in the earlier batch.
            progress.fewer_solves(repeats.count());
            progress.notice(&format!("  {stem}: {} of {} repeats resumed", repeats.count(), plan.repeat));
            Slot { first: result, resumed: false, key, repeats: Some(repeats) }
        }
        (None, RoundSource::Ran) => {
            let repeats = (plan.repeat > 1 && Repeats::wanted(&result)).then(|| Repeats::new(&result));
            Slot { first: result, resumed: false, key, repeats }
        }
        (Some(mut slot), _) => {
            if let Some(r) = slot.repeats.as_mut() {
                r.add(&slot.first, &result);
            }
            // A run resumed from its partial repeats gets its map from this repeat.
            if slot.first.map_uv.is_none() && result.map_uv.is_some() {
                (slot.first.map_uv, slot.first.mesh_file) = (result.map_uv, result.mesh_file);
            }
            slot
        }
    };
    if slot.repeats.is_none() && plan.repeat > 1 {
        // Failed, skipped and resumed runs are not repeated: fewer solves to go.
        progress.fewer_solves(plan.repeat - 1);
    }
    if slot.complete(plan.repeat) {
        // A repeat that did not reproduce the first ends the run: its other repeats will not
        // run.
        if let Some(r) = slot.repeats.as_ref().filter(|r| r.mismatched()) {
            progress.fewer_solves(plan.repeat.saturating_sub(r.count() + 1));
            progress.notice(&format!("{stem}: {} (kept repeat 1's result; flagged in the report)", r.why()));
        }
        return Some((i, worker, slot));
    }
    if let Some(r) = slot.repeats.as_ref().filter(|_| ran) {
        let t = r.last_time().map_or("-".to_string(), |t| format!("{t:.3} s"));
        progress.run_finished(worker, &format!("  repeat {}/{} {stem}: {t}", r.count(), plan.repeat));
    }
    slots[i] = Some(slot);
    None
}

/// Threads per run when the config does not say: the cores the batch may use (`--jobs`, at
/// most the machine's) shared among its runs, at least 1. `--jobs` above the cores gives
/// more runs at once, never more threads to each.
fn default_threads(jobs: usize, cores: usize, runs: usize) -> usize {
    (jobs.min(cores) / runs.max(1)).max(1)
}

/// A repeat of a run that timed out replays its iterations: it stops (as a timeout) where
/// the first one did, rather than at a deadline the machine's speed moves.
fn replay_to(first: &RunResult) -> Option<usize> {
    matches!(first.summary.stop_reason, Some(RunStop::Solver(StopReason::Timeout)))
        .then_some(first.summary.iterations)
        .flatten()
}

/// One more calibration sample, `jobs` copies at once on pools of the runs' thread count. A
/// failed sample is a notice, never the end of the batch: the runs' own times do not depend
/// on it.
fn calibrate(calibration: &mut Calibration, jobs: usize, threads: usize, progress: &dyn Progress) {
    if let Err(e) = calibration.sample(jobs, threads) {
        progress.notice(&format!("calibration sample failed (time_norm left empty if none succeeds): {e:#}"));
    }
}

#[cfg(test)]
mod tests {
    use super::default_threads;

    #[test]
    fn default_threads_share_the_cores_never_more() {
        // one run on 2 cores: both cores, whatever --jobs says
        assert_eq!(default_threads(2, 2, 1), 2);
        assert_eq!(default_threads(8, 2, 1), 2);
        assert_eq!(default_threads(usize::MAX, 2, 1), 2);
        // a --jobs 1 Slurm task keeps to one thread
        assert_eq!(default_threads(1, 64, 1), 1);
        // more runs than cores: one thread each
        assert_eq!(default_threads(2, 2, 5), 1);
        assert_eq!(default_threads(16, 16, 4), 4);
        assert_eq!(default_threads(4, 2, 0), 2);
    }
}
