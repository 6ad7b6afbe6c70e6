//! `mapbench submit` end to end. Without a cluster: `--dry-run` plans balanced shards and
//! writes the scripts. On a live Slurm cluster (ignored by default; `.ci/run` brings one up
//! with `scripts/slurm/local_cluster.sh up` and runs them): the SD and exp-SD runs of
//! `configs/ci.toml` (a third of the batch, the chained start included) in 3 shards against a
//! plain `run` of them (the same runs, bit-identical iterates, one history batch), and
//! a cancelled shard: `merge` refuses the incomplete set, `submit --resume` completes it.

use crate::common;

use common::{read_csv, repo_root, text};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// `mapbench ARGS` in `dir` with the environment as it is (the shared corpus when set: the
/// jobs see the `MAPBENCH_MESHES` that `submit` saw).
fn mapbench(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mapbench")).args(args).current_dir(dir).output().expect("the binary runs")
}

fn ci_config() -> String {
    repo_root().join("configs/ci.toml").display().to_string()
}

#[test]
fn a_dry_run_plans_balanced_shards_and_writes_the_scripts() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("night");
    let o = common::mapbench(
        &["submit", &ci_config(), "--shards", "4", "--out", out.to_str().unwrap(), "--dry-run", "--no-history"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    assert!(t.contains("216 runs of ci in 4 shards"), "{t}");
    assert!(t.contains("nothing submitted"), "{t}");
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("slurm/shards.json")).unwrap()).unwrap();
    let shards = plan["shards"].as_array().unwrap();
    assert_eq!(shards.len(), 4);
    let mut all: Vec<&str> =
        shards.iter().flat_map(|s| s["runs"].as_array().unwrap().iter().map(|r| r["run"].as_str().unwrap())).collect();
    assert_eq!(all.len(), 216);
    all.sort_unstable();
    all.dedup();
    assert_eq!(all.len(), 216, "every run in one shard");
    let (bound, makespan) = (plan["lower_bound_s"].as_f64().unwrap(), plan["makespan_s"].as_f64().unwrap());
    assert!(makespan >= bound && makespan <= 1.05 * bound, "{makespan} against {bound}");
    let array = std::fs::read_to_string(out.join("slurm/array.sh")).unwrap();
    assert!(array.contains("--shard \"$i/4\"") && array.contains(" --no-history"), "{array}");
    let merge = std::fs::read_to_string(out.join("slurm/merge.sh")).unwrap();
    assert!(merge.contains("slurm/shard-4-of-4'"), "{merge}");
    // the folder is not a run folder yet; a dry run may be planned again, a run shard of it
    // runs its own runs only
    assert!(!out.join("summary.csv").exists());
    let o = common::mapbench(
        &["submit", &ci_config(), "--shards", "2", "--out", out.to_str().unwrap(), "--dry-run", "--no-history"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
    let shard = out.join("slurm/shard-2-of-2");
    let plan_file = out.join("slurm/shards.json");
    let o = common::mapbench(
        &[
            "run",
            &ci_config(),
            "--shard-plan",
            plan_file.to_str().unwrap(),
            "--shard",
            "2/2",
            "--out",
            shard.to_str().unwrap(),
            "--only",
            "strip_thin__*",
            "--no-history",
        ],
        dir.path(),
    );
    // --only makes another batch than the one planned: refused, naming the plan
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("is not in the batch of"), "{}", text(&o));
}

/// The runs of a run folder: per run its summary row without the columns that measure time or
/// memory (or which run shared a symbolic analysis, which depends on what ran beside it),
/// and its per-iteration rows without the time columns.
/// A run's summary cells (column, value) and its per-iteration rows.
type RunResults = (Vec<(String, String)>, Vec<Vec<String>>);

fn results(dir: &Path) -> BTreeMap<String, RunResults> {
    let timed = |c: &str| {
        c.contains("time")
            || c.contains("_ms")
            || c.starts_with("ms_")
            || c.starts_with("t_")
            || c.starts_with("peak_")
            || c.starts_with("analysis")
    };
    let (header, rows) = read_csv(&dir.join("summary.csv"));
    let mut out = BTreeMap::new();
    for row in rows {
        let stem = format!("{}__{}__{}", row[0], row[2], row[3]);
        let kept: Vec<(String, String)> =
            header.iter().zip(&row).filter(|(c, _)| !timed(c)).map(|(c, v)| (c.clone(), v.clone())).collect();
        let csv = dir.join("runs").join(format!("{stem}.csv"));
        let iterations = if csv.is_file() {
            let (h, rs) = read_csv(&csv);
            let keep: Vec<usize> = (0..h.len()).filter(|&i| !timed(&h[i])).collect();
            rs.iter().map(|r| keep.iter().map(|&i| r[i].clone()).collect()).collect()
        } else {
            Vec::new()
        };
        out.insert(stem, (kept, iterations));
    }
    out
}

fn assert_same_results(plain: &Path, merged: &Path) {
    let (a, b) = (results(plain), results(merged));
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>(), "the same runs");
    let mut iterates = 0;
    for (stem, (row, its)) in &a {
        let (row_b, its_b) = &b[stem];
        assert_eq!(row, row_b, "{stem}: the summary row");
        assert_eq!(its, its_b, "{stem}: the iterates");
        iterates += its.len();
    }
    assert!(iterates > 1000, "{iterates} iterates compared");
    // the maps kept are the same files, byte for byte
    for entry in std::fs::read_dir(plain.join("uv")).unwrap() {
        let p = entry.unwrap().path();
        let other = merged.join("uv").join(p.file_name().unwrap());
        assert_eq!(std::fs::read(&p).unwrap(), std::fs::read(&other).unwrap(), "{}", p.display());
    }
}

fn batches(db: &Path) -> Vec<(String, String, i64)> {
    let c = rusqlite::Connection::open(db).unwrap();
    let mut s = c
        .prepare("SELECT b.config_name, b.source, count(r.dataset) FROM batches b JOIN runs r ON r.batch_id = b.id GROUP BY b.id")
        .unwrap();
    s.query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?))).unwrap().map(|r| r.unwrap()).collect()
}

/// `key=value` lines of `submit`'s standard output.
fn job_ids(o: &Output) -> BTreeMap<String, String> {
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .filter_map(|l| l.split_once('=').map(|(k, v)| (k.to_string(), v.to_string())))
        .collect()
}

fn squeue(ids: &str) -> String {
    let o = Command::new("squeue").args(["-h", "-r", "-o", "%i %T %r", "-j", ids]).output().unwrap();
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn wait_for(what: &str, limit: Duration, mut done: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !done() {
        assert!(t0.elapsed() < limit, "{what}: not after {limit:?}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The live test's batch: `--only` these globs of `configs/ci.toml`. exp-SD starts from the SD
/// minimum, so its shards read a reference another shard's runs share.
const LIVE_ONLY: [&str; 4] = ["--only", "*__sd__*", "--only", "*__exp-sd__*"];

fn summary_rows(dir: &Path) -> usize {
    std::fs::read_to_string(dir.join("summary.csv")).map_or(0, |t| t.lines().count().saturating_sub(1))
}

#[test]
#[ignore = "needs a live Slurm cluster (scripts/slurm/local_cluster.sh up); .ci/run runs it"]
fn live_cluster_shards_match_a_plain_run_and_a_cancelled_shard_is_resumed() {
    let dir = tempfile::tempdir().unwrap();
    let work = dir.path();
    let config = ci_config();
    let path = |p: &str| work.join(p);
    let s = |p: &PathBuf| p.display().to_string();

    // 3 shards with --wait: the merge's exit code
    let (sharded, db) = (path("sharded"), path("history.sqlite"));
    let (out, history) = (s(&sharded), s(&db));
    let mut args = vec!["submit", &config, "--shards", "3", "--out", &out, "--history", &history, "--wait"];
    args.extend(LIVE_ONLY);
    let o = mapbench(&args, work);
    assert!(o.status.success(), "{}", text(&o));
    let ids = job_ids(&o);
    assert!(ids.contains_key("array_job") && ids.contains_key("merge_job"), "{}", text(&o));
    let merged_meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(sharded.join("meta.json")).unwrap()).unwrap();
    assert_eq!(merged_meta["merged_from"].as_array().unwrap().len(), 3);

    // a plain run of the same config, on the same thread count per run
    let plain = path("plain");
    let out = s(&plain);
    let mut args = vec!["run", &config, "--out", &out, "--no-history", "--jobs", "2"];
    args.extend(LIVE_ONLY);
    let o = mapbench(&args, work);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", text(&o));
    assert_same_results(&plain, &sharded);
    let runs = summary_rows(&plain) as i64;
    assert_eq!(batches(&db), [("ci".to_string(), "merge".to_string(), runs)], "one history batch");

    // the failure path: shard 2 cancelled while it runs, under `submit --wait`
    let (cancelled, db2) = (path("cancelled"), path("history2.sqlite"));
    let waiting = Command::new(env!("CARGO_BIN_EXE_mapbench"))
        .args(["submit", &config, "--shards", "3", "--out", &s(&cancelled), "--history", &s(&db2), "--wait"])
        .args(LIVE_ONLY)
        .current_dir(work)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let record = cancelled.join("slurm/submission.json");
    wait_for("the submission", Duration::from_secs(120), || {
        std::fs::read_to_string(&record).is_ok_and(|t| t.contains("\"merge\""))
    });
    let submitted: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&record).unwrap()).unwrap();
    let array = submitted["jobs"][0]["array"].as_str().unwrap().to_string();
    let merge = submitted["jobs"][0]["merge"].as_str().unwrap().to_string();
    let shard2 = cancelled.join("slurm/shard-2-of-3");
    wait_for("shard 2's first run", Duration::from_secs(300), || summary_rows(&shard2) > 0);
    let o = Command::new("scancel").arg(format!("{array}_2")).output().unwrap();
    assert!(o.status.success(), "{}", text(&o));
    // --wait sees that the merge can never start, cancels it, names shard 2 and exits 2
    let o = waiting.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let t = text(&o);
    assert!(t.contains("shard 2: incomplete (") && !t.contains("shard 1:") && !t.contains("shard 3:"), "{t}");
    assert!(t.contains(&format!("the merge job {merge} could never start and was cancelled")), "{t}");
    wait_for("the cancelled jobs to leave the queue", Duration::from_secs(120), || {
        squeue(&format!("{array},{merge}")).trim().is_empty()
    });
    let meta2: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(shard2.join("meta.json")).unwrap()).unwrap();
    assert_eq!(meta2["interrupted"], true, "shard 2 stopped cleanly on Slurm's SIGTERM");
    // merge refuses the incomplete set, naming what is missing
    let shards: Vec<String> = (1..=3).map(|i| s(&cancelled.join(format!("slurm/shard-{i}-of-3")))).collect();
    let mut args: Vec<&str> = vec!["merge"];
    args.extend(shards.iter().map(String::as_str));
    let partial = path("partial");
    args.extend(["--out", partial.to_str().unwrap(), "--no-history"]);
    let o = mapbench(&args, work);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("planned runs are in no shard"), "{}", text(&o));
    assert!(text(&o).contains(&format!("shard {} was interrupted", shards[1])), "{}", text(&o));

    // --resume: shard 2 alone resubmitted, then the merge
    let o = mapbench(&["submit", "--resume", &s(&cancelled), "--wait"], work);
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    assert!(t.contains("shard 2: incomplete ("), "{t}");
    assert!(t.contains("(shards 2)"), "{t}");
    assert!(!t.contains("shard 1:") && !t.contains("shard 3:"), "{t}");
    assert_same_results(&plain, &cancelled);
    assert_eq!(batches(&db2), [("ci".to_string(), "merge".to_string(), runs)], "one history batch");
    // nothing left to do
    let o = mapbench(&["submit", "--resume", &s(&cancelled)], work);
    assert!(o.status.success() && text(&o).contains("nothing to resume"), "{}", text(&o));
}
