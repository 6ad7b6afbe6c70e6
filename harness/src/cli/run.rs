//! `run`, `merge` and `report`: the verbs that write a run folder, and what they say of it.

use super::args::{MergeArgs, ReportArgs, RunArgs};
use anyhow::{Context, Result};
use mapbench::history::{self, HistoryChoice};
use mapbench::plan::config::{self, LoadedConfig};
use mapbench::plan::shard_plan::ShardPlanFile;
use mapbench::plan::Plan;
use mapbench::run::{self, merge, progress};
use mapbench::{report, run_folder, signals};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// `run CONFIG`: the batch, the line it ends with and its exit code.
pub(crate) fn run(a: RunArgs) -> Result<ExitCode> {
    // External solvers run through this binary's `sandbox` verb.
    if let Ok(me) = std::env::current_exe() {
        mapbench::external::sandbox::use_sandbox(me);
    }
    // First, before any thread starts: every thread inherits the blocked signals.
    let interrupt = Arc::new(AtomicBool::new(false));
    let signal = signals::on_interrupt(interrupt.clone());
    config::check_jobs(a.jobs, config::available_cores())?;
    let plan = run_plan(&a.config, &a.only.globs, a.repeat, &a.history.choice(), a.shard.is_some())?;
    let out = a.out.unwrap_or_else(|| PathBuf::from("reports").join(&plan.config.config.name));
    let shard_runs = match (&a.shard_plan, a.shard) {
        (Some(file), Some(shard)) => {
            Some(ShardPlanFile::read(file)?.runs_of(shard, &plan).with_context(|| file.display().to_string())?)
        }
        _ => None,
    };
    let opts =
        run::RunOptions { resume: a.resume, jobs: a.jobs, shard: a.shard, shard_runs, force: a.force, interrupt };
    let progress = progress::for_stderr();
    let report = run::run_batch(&plan, &out, &opts, progress.as_ref(), &report::Renderer)?;
    say_batch(&report);
    let written = say_history(&report.history);
    // A signal at any moment, after the last run too (the batch is then complete).
    Ok(run_exit(signal.load(Ordering::SeqCst), written, report.failed))
}

/// The plan of `run`: the config resolved with `--only`, `--repeat` and the history choice.
fn run_plan(
    config: &std::path::Path,
    only: &[String],
    repeat: Option<usize>,
    choice: &HistoryChoice,
    sharded: bool,
) -> Result<Plan> {
    let mut plan = Plan::resolve(LoadedConfig::load(config)?, only)?;
    if let Some(r) = repeat {
        mapbench::plan::config::check_repeat(r).context("--repeat")?;
        plan.repeat = r;
    }
    plan.history = plan.history.take().and_then(|p| choice.apply(p));
    if *choice == HistoryChoice::Off {
        // Nothing outside the run folder: the references it computes stay its own.
        plan.references.iter_mut().for_each(|r| r.persist = false);
    }
    if sharded && plan.history.take().is_some() {
        eprintln!("note: a --shard batch is not appended to the history; `merge` appends the whole batch");
    }
    Ok(plan)
}

/// The line `run` ends with: how the batch's runs ended and where the results are.
fn say_batch(report: &run::BatchReport) {
    eprintln!(
        "{} runs: {} ok, {}{} not converged, {} failed{}{}; results in {}",
        report.runs,
        report.ok,
        if report.budget > 0 { format!("{} at their budget, ", report.budget) } else { String::new() },
        report.not_converged,
        report.failed,
        if report.skipped > 0 { format!(", {} skipped", report.skipped) } else { String::new() },
        match (report.interrupted - report.partial.len(), report.partial.len()) {
            (0, 0) => String::new(),
            (n, 0) => format!(", {n} not run (interrupted)"),
            (n, p) => format!(", {p} cut short in their repeats and {n} not run (interrupted)"),
        },
        report.out_dir.display()
    );
}

/// The exit code of `run`: a signal first, then a result not written to the history, then
/// a failed run.
fn run_exit(signalled: i32, written: bool, failed: usize) -> ExitCode {
    if signalled != 0 {
        // The shell's convention: 128 + the signal (130 Ctrl-C, 143 SIGTERM).
        ExitCode::from(128 + signalled.clamp(1, 127) as u8)
    } else if !written {
        ExitCode::from(2)
    } else if failed > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

/// Say what became of the batch in the history. `false` when it could not be appended (a
/// warning: the run folder is complete either way; the command exits 2). A trend page that
/// could not be rendered is a warning of its own: the batch is in the history.
pub(crate) fn say_history(outcome: &history::HistoryOutcome) -> bool {
    use history::HistoryOutcome;
    match outcome {
        HistoryOutcome::Off => true,
        HistoryOutcome::NotAppended { reason, .. } => {
            eprintln!("note: not appended to the history: {reason}");
            true
        }
        HistoryOutcome::Failed { error, .. } => {
            eprintln!("warning: history not updated: {error} (the run folder is complete)");
            false
        }
        HistoryOutcome::AlreadyIn { db, batch_id, .. } => {
            eprintln!(
                "history: already in {} as batch {batch_id} (appended by an earlier batch of this folder); not \
                 appended again",
                db.display()
            );
            true
        }
        HistoryOutcome::Appended { db, batch_id, runs, config, trend, trend_error } => {
            eprintln!("history: batch {batch_id} ({runs} runs of {config}) appended to {}", db.display());
            match (trend, trend_error) {
                (Some(page), _) => eprintln!("history: trend page {}", page.display()),
                (None, e) => eprintln!(
                    "warning: the trend page was not rendered: {} (`mapbench history --db {} --config {config} \
                     --out DIR` renders it)",
                    e.as_deref().unwrap_or("?"),
                    db.display()
                ),
            }
            true
        }
    }
}

/// `merge`: shard folders of one batch into one folder.
pub(crate) fn merge(a: MergeArgs) -> Result<ExitCode> {
    let m = merge::merge(&a.shards, a.out.as_deref(), &a.history.choice(), a.force, &report::Renderer)?;
    if !m.missing.is_empty() {
        eprintln!(
            "warning: {} planned runs are in no shard (first: {}); the report covers the rest",
            m.missing.len(),
            m.missing[0]
        );
    }
    for d in &m.interrupted {
        eprintln!("warning: shard {} was interrupted (`run --resume` completes it)", d.display());
    }
    eprintln!("merged {} runs from {} shards into {}", m.runs, a.shards.len(), m.out_dir.display());
    let written = say_history(&m.history);
    let complete = m.missing.is_empty() && m.interrupted.is_empty();
    Ok(if complete && written { ExitCode::SUCCESS } else { ExitCode::from(2) })
}

/// `report`: the tables, plots and index.html of a run folder again, from its CSVs.
pub(crate) fn report(a: ReportArgs) -> Result<ExitCode> {
    let rows = run_folder::read_summary(&a.run_dir)?;
    report::refresh(&a.run_dir, &rows)?;
    eprintln!("report of {} runs in {}", rows.len(), a.run_dir.display());
    Ok(ExitCode::SUCCESS)
}
