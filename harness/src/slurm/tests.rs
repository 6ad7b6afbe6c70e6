use super::scheduler::{Queued, Scheduler};
use super::*;
use std::cell::RefCell;

/// A scheduler that records what it is given and answers `queued` from a script of states.
#[derive(Default)]
struct Fake {
    /// `submit` fails from this call on (1-based), as a refusing sbatch.
    fail_from: Option<usize>,
    submitted: RefCell<Vec<(Vec<String>, PathBuf)>>,
    cancelled: RefCell<Vec<String>>,
    /// Answers of successive `queued` calls (the last one repeats).
    queue: RefCell<Vec<Vec<Queued>>>,
}

impl Scheduler for Fake {
    fn submit(&self, args: &[String], script: &Path) -> Result<String> {
        let mut s = self.submitted.borrow_mut();
        if self.fail_from.is_some_and(|n| s.len() + 1 >= n) {
            anyhow::bail!("sbatch: error: Batch job submission failed: Invalid job array specification");
        }
        s.push((args.to_vec(), script.to_path_buf()));
        Ok((100 + s.len()).to_string())
    }
    fn queued(&self, _ids: &[String]) -> Result<Vec<Queued>> {
        let mut q = self.queue.borrow_mut();
        Ok(if q.len() > 1 { q.remove(0) } else { q.first().cloned().unwrap_or_default() })
    }
    fn cancel(&self, id: &str) -> Result<()> {
        self.cancelled.borrow_mut().push(id.to_string());
        Ok(())
    }
}

fn queued(id: &str, state: &str, reason: &str) -> Queued {
    Queued { id: id.into(), state: state.into(), reason: reason.into() }
}

const CONFIG: &str = "name = \"t\"\ndatasets = [\"bumpy_1k\", \"strip_thin\"]\nenergies = [\"sd\"]\n\
                      solvers = [\"kp-newton\", \"cm\"]\n[stop]\nmax_iters = 5\n";

fn request(dir: &Path, shards: usize) -> Request {
    let config = dir.join("t.toml");
    let registry = Path::new(env!("CARGO_MANIFEST_DIR")).join("../datasets.toml");
    std::fs::write(&config, format!("registry = {:?}\n{CONFIG}", registry.display().to_string())).unwrap();
    Request {
        config,
        shards,
        out: Some(dir.join("night")),
        only: vec![],
        repeat: None,
        cpus_per_task: 2,
        sbatch: vec!["--partition=short".into()],
        history: HistoryChoice::Off,
    }
}

#[test]
fn array_specs_are_slurm_lists() {
    assert_eq!(array_spec(&[1, 2, 3]), "1-3");
    assert_eq!(array_spec(&[5, 2]), "2,5");
    assert_eq!(array_spec(&[4, 1, 2, 2]), "1-2,4");
    assert_eq!(array_spec(&[7]), "7");
}

#[test]
fn a_submission_plans_every_run_once_and_chains_its_jobs() {
    let dir = tempfile::tempdir().unwrap();
    let req = request(dir.path(), 9);
    let p = prepare(&req, || Ok(0.2)).unwrap();
    // 4 runs: at most 4 shards, said
    assert_eq!(p.plan_file.shards.len(), 4);
    assert!(p.notices.iter().any(|n| n.contains("--shards 9: the batch has 4 runs, so 4 shards")), "{:?}", p.notices);
    let mut all: Vec<&str> = p.plan_file.shards.iter().flat_map(|s| s.runs.iter().map(|r| r.run.as_str())).collect();
    all.sort_unstable();
    assert_eq!(all, ["bumpy_1k__sd__cm", "bumpy_1k__sd__kp-newton", "strip_thin__sd__cm", "strip_thin__sd__kp-newton"]);
    assert_eq!(p.plan_file.calibration_s, 0.2);
    assert_eq!(p.plan_file.estimated, 4);
    assert!(describe(&p.plan_file).contains("4 runs of t in 4 shards"), "{}", describe(&p.plan_file));
    write(&p).unwrap();
    let out = dir.path().join("night");
    for f in ["shards.json", "array.sh", "merge.sh", "references.sh", "submission.json"] {
        assert!(out.join("slurm").join(f).is_file(), "{f}");
    }
    // a stale exit code of an earlier round goes
    std::fs::write(script::shard_exit(&out, 3), "143\n").unwrap();
    let fake = Fake::default();
    let mut sub = p.submission;
    let round = submit(&fake, &mut sub, &[1, 2, 3, 4], true).unwrap();
    assert!(!script::shard_exit(&out, 3).exists());
    assert_eq!(round.references.as_deref(), Some("101"));
    assert_eq!((round.array.as_deref(), round.merge.as_str()), (Some("102"), "103"));
    let calls = fake.submitted.borrow();
    let names: Vec<String> = calls.iter().map(|c| c.1.file_name().unwrap().to_string_lossy().into_owned()).collect();
    assert_eq!(names, ["references.sh", "array.sh", "merge.sh"]);
    let args = |i: usize| calls[i].0.join(" ");
    assert!(args(1).contains("--array=1-4 --dependency=afterany:101 --partition=short"), "{}", args(1));
    assert!(args(1).contains("--cpus-per-task=2") && args(1).contains("logs/shard-%a.out"), "{}", args(1));
    assert!(args(2).ends_with("--dependency=afterok:102 --partition=short"), "{}", args(2));
    // recorded, and a second submission into the folder is refused
    assert_eq!(Submission::read(&out).unwrap().jobs, [round]);
    let e = prepare(&req, || Ok(0.2)).err().unwrap().to_string();
    assert!(e.contains("holds a submission already"), "{e}");
}

/// A submission of `shards` shards planned, written and submitted (every shard, no references
/// job) to a fake scheduler in `dir`: its folder, record, scheduler and round.
fn submitted(dir: &Path, shards: usize) -> (PathBuf, Submission, Fake, Submitted) {
    let p = prepare(&request(dir, shards), || Ok(0.2)).unwrap();
    write(&p).unwrap();
    let mut sub = p.submission;
    let fake = Fake::default();
    let tasks: Vec<usize> = (1..=shards).collect();
    let round = submit(&fake, &mut sub, &tasks, false).unwrap();
    (dir.join("night"), sub, fake, round)
}

#[test]
fn waiting_ends_with_the_merge_or_cancels_a_merge_that_can_never_start() {
    let dir = tempfile::tempdir().unwrap();
    let (out, sub, fake, round) = submitted(dir.path(), 2);
    assert_eq!(fake.submitted.borrow().len(), 2, "no references job when none is asked");
    let merge = round.merge.clone();
    // queued, running, gone with its exit code
    *fake.queue.borrow_mut() =
        vec![vec![queued(&merge, "PENDING", "Dependency")], vec![queued(&merge, "RUNNING", "None")], vec![]];
    std::fs::write(script::merge_exit(&out), "0\n").unwrap();
    assert_eq!(wait(&fake, &sub, &round, Duration::ZERO).unwrap(), Waited::Merged(0));
    // gone without an exit code
    std::fs::remove_file(script::merge_exit(&out)).unwrap();
    let lost = wait(&fake, &sub, &round, Duration::ZERO).unwrap();
    assert_eq!(lost, Waited::MergeLost(vec![(1, ShardState::Missing), (2, ShardState::Missing)]));
    // a shard failed: the merge never starts, it is cancelled and every shard reported
    *fake.queue.borrow_mut() = vec![vec![queued(&merge, "PENDING", "DependencyNeverSatisfied")]];
    let Waited::ShardsFailed(shards) = wait(&fake, &sub, &round, Duration::ZERO).unwrap() else { panic!() };
    assert_eq!(shards, [(1, ShardState::Missing), (2, ShardState::Missing)]);
    assert_eq!(*fake.cancelled.borrow(), [merge]);
}

/// A shard folder made by the real `run` (the shard's runs of the plan), for `resume`.
fn run_shard(sub: &Submission, index: usize) {
    let c = &sub.commands;
    let plan = resolve_plan(&c.config, &c.only, c.repeat).unwrap();
    let file = ShardPlanFile::read(&script::shards_json(&c.out)).unwrap();
    let shard = crate::plan::select::Shard { index, count: c.shards };
    let opts = crate::run::RunOptions {
        shard: Some(shard),
        shard_runs: Some(file.runs_of(shard, &plan).unwrap()),
        jobs: Some(1),
        ..Default::default()
    };
    let mut plan = plan;
    plan.history = None;
    // As `--no-history`: nothing written outside the test's folder (the stores' default is
    // beside the history database of the working directory).
    plan.references.iter_mut().for_each(|r| r.persist = false);
    let progress = crate::run::progress::Lines;
    crate::run::run_batch(
        &plan,
        &script::shard_dir(&c.out, index, c.shards),
        &opts,
        &progress,
        &crate::report::Renderer,
    )
    .unwrap();
}

#[test]
fn resume_resubmits_only_the_missing_and_incomplete_shards() {
    let dir = tempfile::tempdir().unwrap();
    let (out, sub, fake, first) = submitted(dir.path(), 3);
    run_shard(&sub, 1);
    run_shard(&sub, 2);
    // shard 2 stopped by a signal, shard 3 never ran
    let meta = script::shard_dir(&out, 2, 3).join("meta.json");
    let text = std::fs::read_to_string(&meta).unwrap().replace("\"interrupted\": false", "\"interrupted\": true");
    std::fs::write(&meta, text).unwrap();
    let plan = ShardPlanFile::read(&script::shards_json(&out)).unwrap();
    let of2 = plan.shards[1].runs.len();
    assert_eq!(shard_state(&out, &plan, 1), ShardState::Complete);
    assert_eq!(shard_state(&out, &plan, 2), ShardState::Incomplete { done: of2, of: of2 });
    assert_eq!(shard_state(&out, &plan, 3), ShardState::Missing);

    // a job of the submission still running: refused
    let task3 = format!("{}_3", first.array.as_deref().unwrap());
    *fake.queue.borrow_mut() =
        vec![vec![queued(&task3, "RUNNING", "None"), queued(&first.merge, "PENDING", "DependencyNeverSatisfied")]];
    let e = resume(&fake, &out, None).unwrap_err().to_string();
    assert!(e.contains(&format!("still queued or running: {task3} (RUNNING)")), "{e}");
    assert!(fake.cancelled.borrow().is_empty(), "nothing cancelled when resume refuses");
    // only the merge that can never start is left: cancelled, shards 2 and 3 resubmitted
    *fake.queue.borrow_mut() = vec![vec![queued(&first.merge, "PENDING", "DependencyNeverSatisfied")]];
    let r = resume(&fake, &out, None).unwrap();
    assert_eq!(r.cancelled, std::slice::from_ref(&first.merge));
    assert_eq!(r.shards.iter().map(|s| s.0).collect::<Vec<_>>(), [2, 3]);
    let round = r.round.unwrap();
    assert_eq!(round.tasks, [2, 3]);
    let calls = fake.submitted.borrow();
    assert!(calls[calls.len() - 2].0.contains(&"--array=2-3".to_string()), "{:?}", calls[calls.len() - 2]);
    assert_eq!(Submission::read(&out).unwrap().jobs.len(), 2);
    drop(calls);

    // new sbatch arguments replace the submission's; its own are refused
    *fake.queue.borrow_mut() = vec![vec![]];
    let e = resume(&fake, &out, Some(vec!["--dependency=afterok:1".into()])).unwrap_err().to_string();
    assert!(e.contains("submit sets the array, the dependencies and the log files itself"), "{e}");
    resume(&fake, &out, Some(vec!["--time=9:00:00".into()])).unwrap();
    assert!(fake.submitted.borrow().last().unwrap().0.ends_with(&["--time=9:00:00".to_string()]));
    assert_eq!(Submission::read(&out).unwrap().sbatch, ["--time=9:00:00"]);

    // every shard complete and merged: nothing to do (a run recorded failed is a finished one)
    run_shard(&sub, 3);
    let summary = crate::run_folder::summary_csv(&script::shard_dir(&out, 3, 3));
    let text = std::fs::read_to_string(&summary).unwrap();
    let failed = text.replacen(",ok,", ",failed,", 1).replacen(",not_converged,", ",failed,", 1);
    assert_ne!(failed, text);
    std::fs::write(&summary, failed).unwrap();
    std::fs::write(
        &meta,
        std::fs::read_to_string(&meta).unwrap().replace("\"interrupted\": true", "\"interrupted\": false"),
    )
    .unwrap();
    std::fs::write(script::merge_exit(&out), "0\n").unwrap();
    let r = resume(&fake, &out, None).unwrap();
    assert!(r.shards.is_empty() && r.round.is_none());
    // complete shards whose merge failed: the merge alone again
    std::fs::write(script::merge_exit(&out), "2\n").unwrap();
    let r = resume(&fake, &out, None).unwrap();
    let round = r.round.unwrap();
    assert!(round.tasks.is_empty() && round.array.is_none());
    assert!(!fake.submitted.borrow().last().unwrap().0.iter().any(|a| a.starts_with("--dependency")));

    resume_refuses_a_moved_or_changed_submission(&fake, &out, &sub);
}

/// `resume` of a complete submission refuses to run from another folder or with a changed
/// config (the end of the test above).
fn resume_refuses_a_moved_or_changed_submission(fake: &Fake, out: &Path, sub: &Submission) {
    // resumed from elsewhere: refused, naming where
    let elsewhere = tempfile::tempdir().unwrap();
    let here = std::env::current_dir().unwrap();
    let mut moved = Submission::read(out).unwrap();
    moved.commands.workdir = elsewhere.path().to_path_buf();
    moved.write().unwrap();
    let e = resume(fake, out, None).unwrap_err().to_string();
    assert!(
        e.contains(&format!("resume from where the batch was submitted: in {}", elsewhere.path().display())),
        "{e}"
    );
    assert!(e.contains(&format!("(here: {}", here.display())), "{e}");
    moved.commands.workdir = here;
    moved.write().unwrap();

    // a config changed since (another stop rule, the same runs): refused
    let text = std::fs::read_to_string(&sub.commands.config).unwrap().replace("max_iters = 5", "max_iters = 6");
    std::fs::write(&sub.commands.config, &text).unwrap();
    let e = format!("{:#}", resume(fake, out, None).unwrap_err());
    assert!(e.contains("cannot resume") && e.contains("settings") && e.contains("changed"), "{e}");
    std::fs::write(&sub.commands.config, text.replace("max_iters = 6", "max_iters = 5")).unwrap();
    // ... or another solver
    let text = std::fs::read_to_string(&sub.commands.config).unwrap().replace("\"cm\"", "\"slim\"");
    std::fs::write(&sub.commands.config, text).unwrap();
    let e = format!("{:#}", resume(fake, out, None).unwrap_err());
    assert!(e.contains("cannot resume") && e.contains("plan it again"), "{e}");
}

#[test]
fn a_round_that_fails_half_way_cancels_what_it_queued_and_records_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let p = prepare(&request(dir.path(), 2), || Ok(0.2)).unwrap();
    write(&p).unwrap();
    let mut sub = p.submission;
    // the array is accepted, the merge refused
    let fake = Fake { fail_from: Some(2), ..Fake::default() };
    let e = format!("{:#}", submit(&fake, &mut sub, &[1, 2], false).unwrap_err());
    assert!(e.contains("cancelled the jobs it had submitted: 101") && e.contains("Invalid job array"), "{e}");
    assert_eq!(*fake.cancelled.borrow(), ["101"]);
    let out = dir.path().join("night");
    assert!(Submission::read(&out).unwrap().jobs.is_empty());
    // nothing recorded: the submission may be made again
    assert!(prepare(&request(dir.path(), 2), || Ok(0.2)).is_ok());
}

#[test]
fn submit_refuses_its_own_sbatch_options_and_a_new_plan_clears_a_dry_runs_leftovers() {
    for own in ["--array=1-3", "-a", "--dependency=afterok:1", "-dafterok:1", "--output=x", "-o"] {
        assert!(check_sbatch_args(&[own.to_string()]).is_err(), "{own}");
    }
    check_sbatch_args(&["--time=1:00:00".into(), "--partition=short".into(), "-p".into(), "short".into()]).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let p = prepare(&request(dir.path(), 2), || Ok(0.2)).unwrap();
    write(&p).unwrap();
    let out = dir.path().join("night");
    std::fs::create_dir_all(script::shard_dir(&out, 1, 2).join("runs")).unwrap();
    std::fs::write(script::shard_exit(&out, 1), "0\n").unwrap();
    let p = prepare(&request(dir.path(), 2), || Ok(0.2)).unwrap();
    write(&p).unwrap();
    assert!(!script::shard_dir(&out, 1, 2).exists() && !script::shard_exit(&out, 1).exists());
    assert!(script::shards_json(&out).is_file());
    // --no-history: no job writes the reference store
    let mut off = p.submission.commands.clone();
    off.history = HistoryChoice::Off;
    let plan = resolve_plan(&off.config, &[], None).unwrap();
    assert!(!wants_references(&off, &plan).unwrap());
}
