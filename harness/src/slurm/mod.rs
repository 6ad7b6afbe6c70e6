//! `mapbench submit`: a batch on a Slurm cluster. The runs are split into shards balanced by
//! their expected time ([`costs`], [`crate::plan::balance`]) and written to
//! `DIR/slurm/shards.json`; an array job runs a shard per task (`run --shard-plan`), and a
//! merge job, which Slurm starts only once every task succeeded, merges the shards into `DIR`
//! and appends the batch to the history once. A job that computes the missing reference
//! minima runs first when the stores lack some.
//!
//! `DIR/slurm/` holds everything of the submission: the plan, the job scripts, the shards'
//! run folders (`shard-I-of-N`), their logs and exit codes, and `submission.json` (what was
//! submitted, with the job ids), from which `submit --resume DIR` resubmits the shards that
//! are missing or incomplete, then the merge.

pub mod costs;
pub mod scheduler;
pub mod script;

use crate::history::HistoryChoice;
use crate::plan::balance;
use crate::plan::config::LoadedConfig;
use crate::plan::shard_plan::{PlannedShard, PlannedShardRun, ShardPlanFile, SHARD_PLAN_VERSION};
use crate::plan::Plan;
use crate::run_folder::meta::Meta;
use crate::run_folder::{read_summary, run_stem, write_atomic};
use anyhow::{bail, Context, Result};
use scheduler::{Queued, Scheduler};
use script::Commands;
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The version of `submission.json`.
pub const SUBMISSION_VERSION: u32 = 1;

/// What `submit CONFIG` was asked.
#[derive(Clone, Debug)]
pub struct Request {
    pub config: PathBuf,
    pub shards: usize,
    /// The folder the shards are merged into (default `reports/<name>`).
    pub out: Option<PathBuf>,
    pub only: Vec<String>,
    pub repeat: Option<usize>,
    pub cpus_per_task: usize,
    /// Extra `sbatch` arguments for every job (`--partition=...`, `--time=...`).
    pub sbatch: Vec<String>,
    pub history: HistoryChoice,
}

/// One `sbatch` round: the jobs of a submission or of a resume.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Submitted {
    pub references: Option<String>,
    /// The array job and its tasks (shard indices); `None` when every shard was complete.
    pub array: Option<String>,
    pub tasks: Vec<usize>,
    pub merge: String,
    pub submitted_unix: u64,
}

/// `DIR/slurm/submission.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Submission {
    pub version: u32,
    pub commands: Commands,
    pub sbatch: Vec<String>,
    pub config_name: String,
    pub jobs: Vec<Submitted>,
}

impl Submission {
    fn path(out: &Path) -> PathBuf {
        script::slurm_dir(out).join("submission.json")
    }

    pub fn read(out: &Path) -> Result<Submission> {
        let path = Submission::path(out);
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("{}: cannot read (not a folder `mapbench submit` wrote)", path.display()))?;
        let s: Submission =
            serde_json::from_str(&text).with_context(|| format!("{}: not a submission record", path.display()))?;
        if s.version != SUBMISSION_VERSION {
            bail!("{}: submission version {} (this mapbench reads {SUBMISSION_VERSION})", path.display(), s.version);
        }
        Ok(s)
    }

    fn write(&self) -> Result<()> {
        let text = serde_json::to_string_pretty(self)? + "\n";
        write_atomic(&Submission::path(&self.commands.out), text.as_bytes())
    }
}

/// A submission planned and written, not yet submitted.
pub struct Prepared {
    pub submission: Submission,
    pub plan_file: ShardPlanFile,
    /// The (dataset, energy) groups whose reference minimum no store holds.
    pub missing_references: Vec<(String, String)>,
    /// Lines for the user (datasets skipped, shards reduced).
    pub notices: Vec<String>,
}

/// The plan of `config` as `run` resolves it with `--only` and `--repeat`.
pub fn resolve_plan(config: &Path, only: &[String], repeat: Option<usize>) -> Result<Plan> {
    let mut plan = Plan::resolve(LoadedConfig::load(config)?, only)?;
    if let Some(r) = repeat {
        crate::plan::config::check_repeat(r).context("--repeat")?;
        plan.repeat = r;
    }
    Ok(plan)
}

/// Plan the shards of `req` and write `DIR/slurm/` (plan, scripts, `submission.json` with no
/// jobs yet). `calibrate` times the calibration workload when the history cannot give the
/// scale of its times. A folder that holds a submission already is refused (`--resume` it).
pub fn prepare(req: &Request, calibrate: impl FnOnce() -> Result<f64>) -> Result<Prepared> {
    if req.shards == 0 {
        bail!("--shards must be at least 1");
    }
    if req.cpus_per_task == 0 {
        bail!("--cpus-per-task must be at least 1");
    }
    let config = crate::paths::absolute(&req.config);
    let plan = resolve_plan(&config, &req.only, req.repeat)?;
    let name = plan.config.config.name.clone();
    let out = crate::paths::absolute(&req.out.clone().unwrap_or_else(|| PathBuf::from("reports").join(&name)));
    check_sbatch_args(&req.sbatch)?;
    // A dry run's record (no jobs) may be planned again; a record that cannot be read may not.
    let submitted = match Submission::read(&out) {
        Ok(s) => !s.jobs.is_empty(),
        Err(_) => Submission::path(&out).exists(),
    };
    if submitted {
        bail!(
            "{}: holds a submission already: `mapbench submit --resume {}` completes it; to start over, delete {} \
             (or give each batch its own --out, as a nightly does)",
            out.display(),
            out.display(),
            script::slurm_dir(&out).display()
        );
    }
    // The merge will write there: a folder of another batch is refused now, not at the end.
    let identity = crate::run_folder::reuse::Identity {
        config: name.clone(),
        plan: plan.runs.iter().map(|r| r.stem.clone()).collect(),
        shard: None,
    };
    crate::run_folder::reuse::check(&out, &identity, false)?;
    let mut notices = plan.notices.clone();
    let shards = req.shards.min(plan.runs.len());
    if shards < req.shards {
        notices.push(format!("--shards {}: the batch has {} runs, so {shards} shards", req.shards, plan.runs.len()));
    }
    let history = req.history.apply(plan.history.clone().unwrap_or_default());
    let past = costs::past_times(history.as_deref())?;
    let costs = costs::costs(&plan, &past, calibrate)?;
    let split = balance::plan(&costs.seconds, shards);
    let plan_file = shard_plan_file(&plan, &config, &costs, &split, history.as_deref());
    let commands = Commands {
        mapbench: std::env::current_exe().context("the path of this mapbench")?,
        config,
        out: out.clone(),
        workdir: std::env::current_dir().context("the working directory")?,
        shards,
        only: req.only.clone(),
        repeat: req.repeat,
        cpus_per_task: req.cpus_per_task,
        history: match &req.history {
            HistoryChoice::Path(p) => HistoryChoice::Path(crate::paths::absolute(p)),
            other => other.clone(),
        },
        meshes: std::env::var_os(crate::plan::registry::MESHES_ENV).map(|m| crate::paths::absolute(Path::new(&m))),
    };
    let submission = Submission {
        version: SUBMISSION_VERSION,
        commands,
        sbatch: req.sbatch.clone(),
        config_name: name,
        jobs: vec![],
    };
    let missing_references = crate::judge::reference::missing(&plan)?;
    Ok(Prepared { submission, plan_file, missing_references, notices })
}

/// `sbatch` options `submit` sets itself: given through `--sbatch` they would break the chain
/// of jobs (`--dependency`), the shards (`--array`) or where the logs are (`--output`).
const OWN_SBATCH: [&str; 6] = ["--array", "-a", "--dependency", "-d", "--output", "-o"];

/// Refuse an `--sbatch` argument that is one of `OWN_SBATCH`.
pub fn check_sbatch_args(args: &[String]) -> Result<()> {
    for a in args {
        let name = a.split('=').next().unwrap_or(a);
        let short = OWN_SBATCH.iter().any(|o| o.len() == 2 && a.starts_with(o));
        if OWN_SBATCH.contains(&name) || short {
            bail!("--sbatch {a}: submit sets the array, the dependencies and the log files itself");
        }
    }
    Ok(())
}

/// The shards of `split` as `shards.json`.
fn shard_plan_file(
    plan: &Plan,
    config: &Path,
    costs: &costs::Costs,
    split: &balance::ShardPlan,
    history: Option<&Path>,
) -> ShardPlanFile {
    let shards: Vec<PlannedShard> = split
        .shards
        .iter()
        .enumerate()
        .map(|(s, runs)| PlannedShard {
            index: s + 1,
            predicted_s: split.loads[s],
            runs: runs
                .iter()
                .map(|&i| PlannedShardRun {
                    run: plan.runs[i].stem.clone(),
                    predicted_s: costs.seconds[i],
                    source: costs.sources[i],
                })
                .collect(),
        })
        .collect();
    let from_history = costs.sources.iter().filter(|s| **s == crate::plan::shard_plan::CostSource::History).count();
    let estimated = costs.sources.iter().filter(|s| **s == crate::plan::shard_plan::CostSource::Estimate).count();
    ShardPlanFile {
        version: SHARD_PLAN_VERSION,
        config: config.to_path_buf(),
        config_name: plan.config.config.name.clone(),
        plan_hash: crate::plan::shard_plan::plan_hash(plan),
        only: plan.only.clone(),
        repeat: plan.repeat,
        runs: plan.runs.len(),
        calibration_s: costs.calibration_s,
        calibration_source: costs.calibration_source.clone(),
        history: history.map(Path::to_path_buf),
        from_history,
        estimated,
        lower_bound_s: split.lower_bound,
        makespan_s: split.makespan(),
        shards,
    }
}

/// Write `DIR/slurm/`: the plan, the three scripts and `submission.json`.
pub fn write(p: &Prepared) -> Result<()> {
    let c = &p.submission.commands;
    let dir = script::slurm_dir(&c.out);
    clear_stale(&dir)?;
    std::fs::create_dir_all(script::logs_dir(&c.out)).with_context(|| format!("{}: cannot create", dir.display()))?;
    p.plan_file.write(&script::shards_json(&c.out))?;
    for (name, text) in scripts(c) {
        write_atomic(&dir.join(name), text.as_bytes())?;
    }
    p.submission.write()
}

/// A dry run's leftovers go before a new plan: its shard folders and exit codes would
/// otherwise be resumed (`run --resume`) as this batch's.
fn clear_stale(dir: &Path) -> Result<()> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Ok(()) };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let path = e.path();
        let shard_folder = name.starts_with("shard-") && name.contains("-of-") && path.is_dir();
        let removed = if shard_folder {
            std::fs::remove_dir_all(&path)
        } else if name.ends_with(".exit") {
            std::fs::remove_file(&path)
        } else {
            continue;
        };
        removed.with_context(|| format!("{}: cannot remove the earlier plan's files", path.display()))?;
    }
    Ok(())
}

fn scripts(c: &Commands) -> [(&'static str, String); 3] {
    [("array.sh", c.array_script()), ("merge.sh", c.merge_script()), ("references.sh", c.references_script())]
}

/// What a plan looks like, for the terminal: per shard its runs and expected time, and the
/// bound no split can beat.
pub fn describe(f: &ShardPlanFile) -> String {
    let mut s = format!(
        "{} runs of {} in {} shards (expected times: {} from the history, {} estimated; scale {:.3} s from {})\n",
        f.runs,
        f.config_name,
        f.shards.len(),
        f.from_history,
        f.estimated,
        f.calibration_s,
        f.calibration_source
    );
    for sh in &f.shards {
        s += &format!("  shard {:>3}: {:>5} runs, {:>9.1} s expected\n", sh.index, sh.runs.len(), sh.predicted_s);
    }
    let over = if f.lower_bound_s > 0.0 { 100.0 * (f.makespan_s / f.lower_bound_s - 1.0) } else { 0.0 };
    s += &format!(
        "expected makespan {:.1} s; no split can finish before {:.1} s (the longest run, or the work spread evenly): \
         {over:.1}% above it\n",
        f.makespan_s, f.lower_bound_s
    );
    s
}

/// Submit the jobs of `sub` for the shards `tasks` (all of them at first; the incomplete ones
/// on `--resume`; none when only the merge is left): the references job first when
/// `references`, the array after it, the merge after every task succeeded. Stale exit codes
/// of what is resubmitted go first. The round is recorded in `submission.json`.
pub fn submit(sched: &dyn Scheduler, sub: &mut Submission, tasks: &[usize], references: bool) -> Result<Submitted> {
    let mut queued: Vec<String> = Vec::new();
    let round = submit_round(sched, sub, tasks, references, &mut queued);
    match round {
        Ok(round) => {
            sub.jobs.push(round.clone());
            sub.write()?;
            Ok(round)
        }
        // A round is whole or not at all: what it queued before the failure is cancelled, so
        // no shard runs twice when the submission is made again.
        Err(e) => {
            let failed: Vec<String> = queued.iter().filter(|id| sched.cancel(id).is_err()).cloned().collect();
            match (queued.is_empty(), failed.is_empty()) {
                (true, _) => Err(e),
                (false, true) => Err(e.context(format!("cancelled the jobs it had submitted: {}", queued.join(", ")))),
                (false, false) => Err(e.context(format!(
                    "could not cancel the jobs it had submitted: {} (scancel them)",
                    failed.join(", ")
                ))),
            }
        }
    }
}

fn submit_round(
    sched: &dyn Scheduler,
    sub: &Submission,
    tasks: &[usize],
    references: bool,
    queued: &mut Vec<String>,
) -> Result<Submitted> {
    let c = sub.commands.clone();
    let dir = script::slurm_dir(&c.out);
    for i in tasks {
        remove_if_there(&script::shard_exit(&c.out, *i))?;
    }
    remove_if_there(&script::merge_exit(&c.out))?;
    let logs = script::logs_dir(&c.out);
    let common = |job: &str, log: &str| -> Vec<String> {
        vec![
            format!("--job-name=mapbench-{}-{job}", sub.config_name),
            format!("--output={}", logs.join(log).display()),
            format!("--cpus-per-task={}", c.cpus_per_task),
            // a resubmitted shard's log follows the earlier attempt's
            "--open-mode=append".into(),
        ]
    };
    let with_user = |mut args: Vec<String>| {
        args.extend(sub.sbatch.iter().cloned());
        args
    };
    let mut sbatch = |args: Vec<String>, script: &str| -> Result<String> {
        let id = sched.submit(&with_user(args), &dir.join(script))?;
        queued.push(id.clone());
        Ok(id)
    };
    let references = match references && !tasks.is_empty() {
        true => Some(sbatch(common("references", "references-%j.out"), "references.sh")?),
        false => None,
    };
    let array = if tasks.is_empty() {
        None
    } else {
        let mut args = common("shards", "shard-%a.out");
        args.push(format!("--array={}", array_spec(tasks)));
        if let Some(r) = &references {
            // The shards compute a reference the job could not themselves.
            args.push(format!("--dependency=afterany:{r}"));
        }
        Some(sbatch(args, "array.sh")?)
    };
    let mut args = common("merge", "merge-%j.out");
    if let Some(a) = &array {
        args.push(format!("--dependency=afterok:{a}"));
    }
    let merge = sbatch(args, "merge.sh")?;
    Ok(Submitted { references, array, tasks: tasks.to_vec(), merge, submitted_unix: now_unix() })
}

fn remove_if_there(p: &Path) -> Result<()> {
    match std::fs::remove_file(p) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            Err(e).with_context(|| format!("{}: cannot remove", p.display()))
        }
        _ => Ok(()),
    }
}

fn now_unix() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs())
}

/// `1-3`, `2,5`, `1-2,4`: Slurm's `--array` list of the shard indices.
pub fn array_spec(tasks: &[usize]) -> String {
    let mut sorted = tasks.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < sorted.len() {
        let mut j = i;
        while j + 1 < sorted.len() && sorted[j + 1] == sorted[j] + 1 {
            j += 1;
        }
        parts.push(if j > i { format!("{}-{}", sorted[i], sorted[j]) } else { sorted[i].to_string() });
        i = j + 1;
    }
    parts.join(",")
}

/// Where a shard's run folder stands.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ShardState {
    /// Every run of the shard is in its folder and its batch ended.
    Complete,
    /// No run folder (the task never ran, or failed before its first file).
    Missing,
    /// Some runs are missing, or the batch was stopped (`done` of `of` runs finished).
    Incomplete { done: usize, of: usize },
    /// Its `meta.json` or `summary.csv` cannot be read (the error names the file).
    Unreadable(String),
}

/// The state of shard `index` of the submission in `out`, by its folder and the runs the plan
/// gives it.
pub fn shard_state(out: &Path, plan: &ShardPlanFile, index: usize) -> ShardState {
    let dir = script::shard_dir(out, index, plan.shards.len());
    if !crate::run_folder::meta_json(&dir).exists() {
        return ShardState::Missing;
    }
    let meta = match Meta::read(&dir) {
        Ok(m) => m,
        Err(e) => return ShardState::Unreadable(e.to_string()),
    };
    let planned: BTreeSet<&str> = plan.shards[index - 1].runs.iter().map(|r| r.run.as_str()).collect();
    // A run recorded failed is done: the shard ran it to its end.
    let done = match read_summary(&dir) {
        Ok(rows) => {
            rows.iter().filter(|r| planned.contains(run_stem(&r.dataset, &r.energy, &r.solver).as_str())).count()
        }
        Err(e) if crate::run_folder::summary_csv(&dir).exists() => return ShardState::Unreadable(e.to_string()),
        Err(_) => 0,
    };
    let ended = meta.ended_unix.is_some() && meta.interrupted != Some(true);
    if ended && done == planned.len() {
        ShardState::Complete
    } else {
        ShardState::Incomplete { done, of: planned.len() }
    }
}

/// How waiting for a submission ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Waited {
    /// The merge job ran; its exit code.
    Merged(i32),
    /// Some shard task failed or was cancelled, so the merge could never start (it was
    /// cancelled): the shards that did not finish, with their states.
    ShardsFailed(Vec<(usize, ShardState)>),
    /// The merge job left the queue without an exit code (cancelled by hand, or by Slurm
    /// when its dependency failed on a cluster that kills such jobs, or killed at its time
    /// limit), with the shards that did not finish.
    MergeLost(Vec<(usize, ShardState)>),
}

/// Consecutive `squeue` failures `wait` rides out (a busy controller) before giving up.
const QUEUE_RETRIES: usize = 10;

/// Wait for `round`'s merge job: poll the queue every `poll` until the merge has left it. A
/// merge that can never start (a shard task failed) is cancelled and the shards' states are
/// returned.
pub fn wait(sched: &dyn Scheduler, sub: &Submission, round: &Submitted, poll: Duration) -> Result<Waited> {
    let out = &sub.commands.out;
    let plan = ShardPlanFile::read(&script::shards_json(out))?;
    let mut failures = 0;
    loop {
        let queued = match sched.queued(std::slice::from_ref(&round.merge)) {
            Ok(q) => {
                failures = 0;
                q
            }
            Err(_) if failures < QUEUE_RETRIES => {
                failures += 1;
                std::thread::sleep(poll);
                continue;
            }
            Err(e) => return Err(e.context(format!("{} times in a row", QUEUE_RETRIES + 1))),
        };
        match queued.iter().find(|q| base_id(&q.id) == round.merge) {
            Some(q) if q.never_starts() => {
                sched.cancel(&round.merge)?;
                return Ok(Waited::ShardsFailed(unfinished(out, &plan)));
            }
            Some(_) => std::thread::sleep(poll),
            None => {
                return Ok(match read_exit(&script::merge_exit(out)) {
                    Some(code) => Waited::Merged(code),
                    None => Waited::MergeLost(unfinished(out, &plan)),
                });
            }
        }
    }
}

/// The shards whose folder is not complete, with their states.
pub fn unfinished(out: &Path, plan: &ShardPlanFile) -> Vec<(usize, ShardState)> {
    (1..=plan.shards.len())
        .map(|i| (i, shard_state(out, plan, i)))
        .filter(|(_, s)| *s != ShardState::Complete)
        .collect()
}

/// `123` of `123_4` or `123_[1-3]`.
fn base_id(id: &str) -> &str {
    id.split('_').next().unwrap_or(id)
}

fn read_exit(p: &Path) -> Option<i32> {
    std::fs::read_to_string(p).ok()?.trim().parse().ok()
}

/// What `submit --resume DIR` found and did.
#[derive(Debug)]
pub struct Resumed {
    /// Shards resubmitted, with the state they were in.
    pub shards: Vec<(usize, ShardState)>,
    /// Merge jobs of earlier rounds that could never start and were cancelled.
    pub cancelled: Vec<String>,
    /// The new round, `None` when there was nothing to do (every shard complete and merged).
    pub round: Option<Submitted>,
    /// The submission with the new round recorded.
    pub submission: Submission,
}

/// Resubmit the shards of the submission in `out` whose folder is missing or incomplete, then
/// the merge. Refused while a job of the submission still runs or waits (it might complete
/// them), but a merge that can never start (its shards failed) is cancelled first. The plan
/// is checked against the config as it is now: a changed config is refused.
pub fn resume(sched: &dyn Scheduler, out: &Path, sbatch: Option<Vec<String>>) -> Result<Resumed> {
    let out = crate::paths::absolute(out);
    let mut sub = Submission::read(&out)?;
    if let Some(args) = sbatch {
        check_sbatch_args(&args)?;
        sub.sbatch = args;
    }
    let plan_file = ShardPlanFile::read(&script::shards_json(&out))?;
    same_environment(&sub.commands)?;
    let c = &sub.commands;
    let plan = resolve_plan(&c.config, &c.only, c.repeat)?;
    plan_file
        .runs_of(crate::plan::select::Shard { index: 1, count: plan_file.shards.len() }, &plan)
        .with_context(|| format!("{}: cannot resume", script::shards_json(&out).display()))?;
    let ids: Vec<String> = sub
        .jobs
        .iter()
        .flat_map(|j| j.references.iter().chain(j.array.iter()).chain(std::iter::once(&j.merge)).cloned())
        .collect();
    let queued: Vec<Queued> = sched.queued(&ids)?;
    let never = |q: &Queued| q.never_starts() && sub.jobs.iter().any(|j| j.merge == base_id(&q.id));
    let active: Vec<String> = queued.iter().filter(|q| !never(q)).map(|q| format!("{} ({})", q.id, q.state)).collect();
    if !active.is_empty() {
        bail!(
            "{}: jobs of this submission are still queued or running: {}; wait for them or scancel them first",
            out.display(),
            active.join(", ")
        );
    }
    let mut cancelled = Vec::new();
    for q in queued.iter().filter(|q| never(q)) {
        sched.cancel(&q.id)?;
        cancelled.push(q.id.clone());
    }
    let shards = unfinished(&out, &plan_file);
    let merged = read_exit(&script::merge_exit(&out)) == Some(0);
    if shards.is_empty() && merged {
        return Ok(Resumed { shards, cancelled, round: None, submission: sub });
    }
    let tasks: Vec<usize> = shards.iter().map(|(i, _)| *i).collect();
    // The scripts again, as this mapbench writes them (the same commands).
    for (name, text) in scripts(c) {
        write_atomic(&script::slurm_dir(&out).join(name), text.as_bytes())?;
    }
    let references = wants_references(&sub.commands, &plan)?;
    let round = submit(sched, &mut sub, &tasks, references)?;
    Ok(Resumed { shards, cancelled, round: Some(round), submission: sub })
}

/// Whether a job should compute reference minima before the shards: some are missing and the
/// batch may write the store (not with `--no-history`, under which nothing is written outside
/// the run folders: each shard then computes its own).
pub fn wants_references(c: &Commands, plan: &Plan) -> Result<bool> {
    Ok(c.history != HistoryChoice::Off && !crate::judge::reference::missing(plan)?.is_empty())
}

/// `--resume` resolves the plan as the jobs do: from the directory and with the meshes folder
/// `submit` recorded, so it sees the same datasets and stores.
fn same_environment(c: &Commands) -> Result<()> {
    let here = std::env::current_dir().context("the working directory")?;
    let meshes = std::env::var_os(crate::plan::registry::MESHES_ENV).map(|m| crate::paths::absolute(Path::new(&m)));
    if here != c.workdir || meshes != c.meshes {
        let shown = |m: &Option<PathBuf>| m.as_ref().map_or("unset".to_string(), |p| p.display().to_string());
        bail!(
            "resume from where the batch was submitted: in {} with {}={} (here: {} with {})",
            c.workdir.display(),
            crate::plan::registry::MESHES_ENV,
            shown(&c.meshes),
            here.display(),
            shown(&meshes)
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests;
