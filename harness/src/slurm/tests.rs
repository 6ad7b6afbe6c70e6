use super::scheduler::{Queued, Scheduler};
use super::*;
use std::cell::RefCell;

/// A scheduler that records what it is given and answers `queued` from a script of states.
#[derive(Default)]
struct Fake {
    submitted: RefCell<Vec<(Vec<String>, PathBuf)>>,
    cancelled: RefCell<Vec<String>>,
    /// Answers of successive `queued` calls (the last one repeats).
    queue: RefCell<Vec<Vec<Queued>>>,
}

impl Scheduler for Fake {
    fn submit(&self, args: &[String], script: &Path) -> Result<String> {
        let mut s = self.submitted.borrow_mut();
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

#[test]
fn waiting_ends_with_the_merge_or_cancels_a_merge_that_can_never_start() {
    let dir = tempfile::tempdir().unwrap();
    let p = prepare(&request(dir.path(), 2), || Ok(0.2)).unwrap();
    write(&p).unwrap();
    let out = dir.path().join("night");
    let mut sub = p.submission;
    let fake = Fake::default();
    let round = submit(&fake, &mut sub, &[1, 2], false).unwrap();
    assert_eq!(fake.submitted.borrow().len(), 2, "no references job when none is asked");
    let merge = round.merge.clone();
    // queued, running, gone with its exit code
    *fake.queue.borrow_mut() =
        vec![vec![queued(&merge, "PENDING", "Dependency")], vec![queued(&merge, "RUNNING", "None")], vec![]];
    std::fs::write(script::merge_exit(&out), "0\n").unwrap();
    assert_eq!(wait(&fake, &sub, &round, Duration::ZERO).unwrap(), Waited::Merged(0));
    // gone without an exit code
    std::fs::remove_file(script::merge_exit(&out)).unwrap();
    assert_eq!(wait(&fake, &sub, &round, Duration::ZERO).unwrap(), Waited::MergeLost);
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
    let p = prepare(&request(dir.path(), 3), || Ok(0.2)).unwrap();
    write(&p).unwrap();
    let out = dir.path().join("night");
    let mut sub = p.submission;
    let fake = Fake::default();
    let first = submit(&fake, &mut sub, &[1, 2, 3], false).unwrap();
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
    *fake.queue.borrow_mut() = vec![vec![queued(&task3, "RUNNING", "None")]];
    let e = resume(&fake, &out).unwrap_err().to_string();
    assert!(e.contains(&format!("still queued or running: {task3} (RUNNING)")), "{e}");
    // only the merge that can never start is left: cancelled, shards 2 and 3 resubmitted
    *fake.queue.borrow_mut() = vec![vec![queued(&first.merge, "PENDING", "DependencyNeverSatisfied")]];
    let r = resume(&fake, &out).unwrap();
    assert_eq!(r.cancelled, std::slice::from_ref(&first.merge));
    assert_eq!(r.shards.iter().map(|s| s.0).collect::<Vec<_>>(), [2, 3]);
    let round = r.round.unwrap();
    assert_eq!(round.tasks, [2, 3]);
    let calls = fake.submitted.borrow();
    assert!(calls[calls.len() - 2].0.contains(&"--array=2-3".to_string()), "{:?}", calls[calls.len() - 2]);
    assert_eq!(Submission::read(&out).unwrap().jobs.len(), 2);
    drop(calls);

    // every shard complete and merged: nothing to do
    *fake.queue.borrow_mut() = vec![vec![]];
    run_shard(&sub, 3);
    std::fs::write(
        &meta,
        std::fs::read_to_string(&meta).unwrap().replace("\"interrupted\": true", "\"interrupted\": false"),
    )
    .unwrap();
    std::fs::write(script::merge_exit(&out), "0\n").unwrap();
    let r = resume(&fake, &out).unwrap();
    assert!(r.shards.is_empty() && r.round.is_none());
    // complete shards whose merge failed: the merge alone again
    std::fs::write(script::merge_exit(&out), "2\n").unwrap();
    let r = resume(&fake, &out).unwrap();
    let round = r.round.unwrap();
    assert!(round.tasks.is_empty() && round.array.is_none());
    assert!(!fake.submitted.borrow().last().unwrap().0.iter().any(|a| a.starts_with("--dependency")));

    // a config changed since: refused
    let text = std::fs::read_to_string(&sub.commands.config).unwrap().replace("\"cm\"", "\"slim\"");
    std::fs::write(&sub.commands.config, text).unwrap();
    let e = format!("{:#}", resume(&fake, &out).unwrap_err());
    assert!(e.contains("cannot resume") && e.contains("plan it again"), "{e}");
}
