//! `submit`: a batch on a Slurm cluster, what it says of the jobs, and `--wait`.

use super::args::SubmitArgs;
use anyhow::Result;
use mapbench::history::HistoryChoice;
use mapbench::slurm;
use std::process::ExitCode;

/// How often `submit --wait` looks at the queue.
const POLL: std::time::Duration = std::time::Duration::from_secs(2);

/// `submit`: a new submission (CONFIG and --shards) or the missing shards of one (--resume).
pub(crate) fn verb(a: SubmitArgs) -> Result<ExitCode> {
    match (a.resume, a.config, a.shards) {
        (Some(dir), _, _) => {
            if a.history.history.is_some() || a.history.no_history {
                anyhow::bail!("--history and --no-history are the submission's: not with --resume");
            }
            submit_resume(&dir, (!a.sbatch.is_empty()).then_some(a.sbatch), a.wait)
        }
        (None, Some(config), Some(shards)) => {
            let request = slurm::Request {
                config,
                shards,
                out: a.out,
                only: a.only,
                repeat: a.repeat,
                cpus_per_task: a.cpus_per_task,
                sbatch: a.sbatch,
                history: a.history.choice(),
            };
            submit(&request, a.dry_run, a.wait)
        }
        _ => anyhow::bail!("give CONFIG and --shards N, or --resume DIR"),
    }
}

/// `submit CONFIG`: plan, write, submit (unless --dry-run), and wait when asked.
fn submit(request: &slurm::Request, dry_run: bool, wait: bool) -> Result<ExitCode> {
    let prepared = slurm::prepare(request, || {
        eprintln!("submit: no past times in the history: timing the calibration workload here to scale the estimates");
        let mut c = mapbench::calibration::Calibration::new();
        c.sample(1, 1)
    })?;
    for n in &prepared.notices {
        eprintln!("{n}");
    }
    slurm::write(&prepared)?;
    let out_dir = prepared.submission.commands.out.clone();
    eprint!("{}", slurm::describe(&prepared.plan_file));
    let refs = &prepared.missing_references;
    let references = !refs.is_empty() && prepared.submission.commands.history != HistoryChoice::Off;
    if references {
        eprintln!(
            "{} reference minima are not in the stores (first: {} {}): a job computes them before the shards",
            refs.len(),
            refs[0].0,
            refs[0].1
        );
    }
    let dir = slurm::script::slurm_dir(&out_dir);
    if dry_run {
        eprintln!(
            "dry run: wrote {} (shards.json, array.sh, merge.sh, references.sh); nothing submitted",
            dir.display()
        );
        return Ok(ExitCode::SUCCESS);
    }
    let mut submission = prepared.submission;
    let tasks: Vec<usize> = (1..=submission.commands.shards).collect();
    let round = slurm::submit(&slurm::scheduler::Slurm, &mut submission, &tasks, references)?;
    say_round(&round, &out_dir);
    if !wait {
        return Ok(ExitCode::SUCCESS);
    }
    waited(&submission, &round)
}

/// `submit --resume DIR`.
fn submit_resume(dir: &std::path::Path, sbatch: Option<Vec<String>>, wait: bool) -> Result<ExitCode> {
    let resumed = slurm::resume(&slurm::scheduler::Slurm, dir, sbatch)?;
    for id in &resumed.cancelled {
        eprintln!("cancelled merge job {id}: its shards had failed, so it could never start");
    }
    for (i, state) in &resumed.shards {
        eprintln!("shard {i}: {}", say_state(state));
    }
    let Some(round) = resumed.round else {
        eprintln!("nothing to resume: every shard is complete and the merge succeeded");
        return Ok(ExitCode::SUCCESS);
    };
    let submission = resumed.submission;
    say_round(&round, &submission.commands.out);
    if !wait {
        return Ok(ExitCode::SUCCESS);
    }
    waited(&submission, &round)
}

fn say_state(state: &slurm::ShardState) -> String {
    match state {
        slurm::ShardState::Complete => "complete".into(),
        slurm::ShardState::Missing => "missing (no run folder)".into(),
        slurm::ShardState::Incomplete { done, of } => format!("incomplete ({done} of {of} runs)"),
        slurm::ShardState::Unreadable(e) => format!("unreadable ({e})"),
    }
}

/// The job ids of a round: on stdout as `key=id` lines for scripts, in words on stderr.
fn say_round(round: &slurm::Submitted, out_dir: &std::path::Path) {
    if let Some(r) = &round.references {
        eprintln!("submitted references job {r} (the missing reference minima)");
    }
    if let Some(a) = &round.array {
        eprintln!("submitted array job {a} (shards {})", slurm::array_spec(&round.tasks));
    }
    eprintln!(
        "submitted merge job {} (starts once every shard succeeded; merges into {})",
        round.merge,
        out_dir.display()
    );
    let mut ids = String::new();
    for (k, v) in [("references_job", &round.references), ("array_job", &round.array)] {
        if let Some(v) = v {
            ids += &format!("{k}={v}\n");
        }
    }
    ids += &format!("merge_job={}\n", round.merge);
    let _ = super::stdout::out(format_args!("{ids}"));
}

fn say_unfinished(dir: &std::path::Path, shards: &[(usize, slurm::ShardState)]) {
    for (i, state) in shards {
        let log = slurm::script::logs_dir(dir).join(format!("shard-{i}.out"));
        eprintln!("shard {i}: {} (log: {})", say_state(state), log.display());
    }
}

/// `--wait`: the merge's exit code, or 2 with what failed.
fn waited(submission: &slurm::Submission, round: &slurm::Submitted) -> Result<ExitCode> {
    let dir = &submission.commands.out;
    match slurm::wait(&slurm::scheduler::Slurm, submission, round, POLL)? {
        slurm::Waited::Merged(code) => {
            eprintln!("merge job {} exited with {code}", round.merge);
            Ok(ExitCode::from(u8::try_from(code).unwrap_or(2)))
        }
        slurm::Waited::ShardsFailed(shards) => {
            say_unfinished(dir, &shards);
            eprintln!(
                "the merge job {} could never start and was cancelled; `mapbench submit --resume {}` resubmits the \
                 shards that did not finish",
                round.merge,
                dir.display()
            );
            Ok(ExitCode::from(2))
        }
        slurm::Waited::MergeLost(shards) => {
            say_unfinished(dir, &shards);
            eprintln!(
                "the merge job {} left the queue without an exit code (cancelled or killed; see {}); `mapbench submit \
                 --resume {}` submits what is left",
                round.merge,
                slurm::script::logs_dir(dir).display(),
                dir.display()
            );
            Ok(ExitCode::from(2))
        }
    }
}
