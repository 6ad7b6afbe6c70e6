//! Signals (issue 41): SIGTERM, what Slurm sends at a job's time limit and on `scancel`, at
//! any moment of a batch, METIS's orderings included, stops it cleanly: exit 143, the report
//! written, `interrupted: true` in meta.json.

mod common;

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
