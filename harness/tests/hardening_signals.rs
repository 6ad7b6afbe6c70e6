//! Signals: SIGTERM, what Slurm sends at a job's time limit and on `scancel`, at
//! any moment of a batch, METIS's orderings included, stops it cleanly: exit 143, the report
//! written, `interrupted: true` in meta.json.

use crate::common;

use common::*;
use std::io::BufRead;
use std::process::{Command, Stdio};
use std::time::Duration;

/// scripts/sigterm_loop.sh's batch: three runs of `--shard 2/3`, each on a new generated mesh
/// and so with a METIS ordering of its own (bumpy_50k's is about 0.4 s, half a second into
/// the second run on this kind of machine).
const SHARDED: &str = "name = \"sig\"\ndatasets = [\"bumpy_1k\", \"bumpy_50k\", \"bumpy_5k\"]\nenergies = [\"sd\"]\n\
     solvers = [\"kp-newton\", \"fp-newton-4x4\", \"cm\"]\n[stop]\nmax_iters = 3\n";

#[test]
fn sigterm_during_metis_orderings_stops_cleanly_every_time() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(tmp.path(), SHARDED);
    // 20 signals from 300 to 775 ms after the first run's line: the second run's mesh, Tutte
    // map and METIS ordering, then its iterations. Before the signal thread, 4 in 4 tries at
    // 500 ms crashed (exit 139).
    for k in 0..20u64 {
        let out = tmp.path().join(format!("out{k}"));
        let mut child = Command::new(env!("CARGO_BIN_EXE_mapbench"))
            .args(["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()])
            .args(["--shard", "2/3", "--jobs", "1", "--no-history"])
            .current_dir(tmp.path())
            .env_remove("MAPBENCH_MESHES")
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut log = String::new();
        let mut sent = false;
        for line in std::io::BufReader::new(child.stderr.take().unwrap()).lines() {
            let line = line.unwrap();
            if !sent && line.starts_with("[1/3]") {
                std::thread::sleep(Duration::from_millis(300 + 25 * k));
                let kill = Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap();
                assert!(kill.success());
                sent = true;
            }
            log.push_str(&line);
            log.push('\n');
        }
        let status = child.wait().unwrap();
        assert!(sent, "try {k}: no first run: {log}");
        assert_eq!(status.code(), Some(143), "try {k} ({status}): {log}");
        assert!(out.join("index.html").is_file(), "try {k}: no report: {log}");
        let meta: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("meta.json")).unwrap()).unwrap();
        assert_eq!(meta["interrupted"], true, "try {k}: {log}");
        assert!(meta["ended_unix"].is_u64(), "try {k}: {meta}");
    }
}

/// Ctrl-C in round 2 of a `repeat = 3` batch: the message says per run how many repeats
/// finished, `summary.csv` has no row for a run with missing repeats, and `--resume` runs
/// exactly the missing repeats, ending with every run's three (such runs showed
/// as ok with `repeats=1`, and `--resume` ran all of them again).
#[test]
fn an_interrupted_repeated_batch_keeps_its_repeats_and_resume_runs_only_the_missing_ones() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"rep\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\", \"cm\", \"slim\"]\n\
         repeat = 3\nrepeat_runs = \"all\"\n",
    );
    let out = tmp.path().join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_mapbench"))
        .args(["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--jobs", "1", "--no-history"])
        .current_dir(tmp.path())
        .env_remove("MAPBENCH_MESHES")
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut log = String::new();
    let mut sent = false;
    for line in std::io::BufReader::new(child.stderr.take().unwrap()).lines() {
        let line = line.unwrap();
        // The first run's second repeat is in: the others have one.
        if !sent && line.contains("repeat 2/3") {
            let kill = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
            assert!(kill.success());
            sent = true;
        }
        log.push_str(&line);
        log.push('\n');
    }
    assert_eq!(child.wait().unwrap().code(), Some(130), "{log}");
    // Each run has 1 or 2 of its 3 repeats (kp-newton 2; the others as far as they got
    // before the signal arrived): the message lists each with its count.
    let listed = log.split("3 cut short in their repeats (").nth(1).and_then(|r| r.split(';').next());
    let listed = listed.unwrap_or_else(|| panic!("no list of runs cut short: {log}"));
    assert!(log.contains("interrupted: 0 runs finished and written"), "{log}");
    let stems = ["bumpy_1k__sd__kp-newton", "bumpy_1k__sd__cm", "bumpy_1k__sd__slim"];
    let done: Vec<usize> = stems
        .iter()
        .map(|stem| {
            let k = listed.split(", ").find_map(|e| e.strip_prefix(&format!("{stem} "))?.strip_suffix("/3"));
            k.and_then(|k| k.parse().ok()).unwrap_or_else(|| panic!("{stem} not in `{listed}`"))
        })
        .collect();
    assert_eq!(done[0], 2, "{listed}");
    assert!(done.iter().all(|k| (1..=2).contains(k)), "{listed}");
    assert_eq!(read_csv(&out.join("summary.csv")).1.len(), 0, "a row for a run with missing repeats");
    for stem in stems {
        assert!(!out.join(format!("runs/{stem}.json")).exists(), "{stem}: a sidecar of a finished run");
        assert!(out.join(format!("runs/{stem}.partial.json")).is_file(), "{stem}");
    }
    let index = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(!index.contains(".partial.") && !index.contains("bumpy_1k__sd__cm.csv"), "unfinished runs listed");

    let o = mapbench(
        &["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--jobs", "1", "--resume"],
        tmp.path(),
    );
    let log = text(&o);
    assert_eq!(o.status.code(), Some(0), "{log}");
    // Exactly the missing repeats run: a run with k of 3 prints "repeat j/3" for each of its
    // repeats k+1..3 but the last (its finished line).
    for (stem, k) in stems.iter().zip(&done) {
        assert!(log.contains(&format!("{stem}: {k} of 3 repeats resumed")), "{log}");
        let lines = (1..=3).filter(|j| log.contains(&format!("repeat {j}/3 {stem}"))).collect::<Vec<_>>();
        assert_eq!(lines, ((k + 1)..3).collect::<Vec<_>>(), "{stem}: {log}");
    }
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    assert_eq!(rows.len(), 3);
    for r in &rows {
        assert_eq!(r[col("repeats")], "3", "{r:?}");
        // went on to its target (the harness's verdict on slim is another test's)
        assert_eq!(r[col("stop_reason")], "target", "{r:?}");
        let t = |c: &str| r[col(c)].parse::<f64>().unwrap();
        assert!(t("time_s_min") <= t("time_s") && t("time_s") <= t("time_s_max"), "{r:?}");
        let stem = format!("{}__{}__{}", r[0], r[2], r[3]);
        assert!(out.join(format!("runs/{stem}.json")).is_file(), "{stem}: no sidecar");
        let partial = ["json", "csv"].map(|e| out.join(format!("runs/{stem}.partial.{e}")).exists());
        assert_eq!(partial, [false, false], "{stem}");
    }
    // the kept map (maps = "best": one per group) came from a repeat run in this batch
    assert_eq!(std::fs::read_dir(out.join("uv")).unwrap().count(), 1);
}

/// SIGTERM during the batch's first calibration sample (a KP-Newton workload on bumpy_10k,
/// with its METIS ordering, about a second before any run starts): a clean stop with no run.
#[test]
fn sigterm_during_the_calibration_stops_cleanly() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(tmp.path(), SHARDED);
    for delay_ms in [150u64, 300, 450, 600] {
        let out = tmp.path().join(format!("cal{delay_ms}"));
        let child = Command::new(env!("CARGO_BIN_EXE_mapbench"))
            .args(["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--jobs", "1", "--no-history"])
            .current_dir(tmp.path())
            .env_remove("MAPBENCH_MESHES")
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(delay_ms));
        assert!(Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap().success());
        let o = child.wait_with_output().unwrap();
        let log = text(&o);
        assert_eq!(o.status.code(), Some(143), "{delay_ms} ms: {log}");
        assert!(out.join("index.html").is_file(), "{delay_ms} ms: no report: {log}");
        let meta: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("meta.json")).unwrap()).unwrap();
        assert_eq!(meta["interrupted"], true, "{delay_ms} ms: {log}");
    }
}
