//! `run` hardening, second pass (issue 41): `--jobs` bounded like `threads_per_run`, output
//! folders of another batch refused, interrupted repeats kept for `--resume`.

mod common;

use common::*;

const ONE_RUN: &str = "name = \"j\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\"]\n";

#[test]
fn jobs_beyond_four_times_the_cores_are_refused_before_anything_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(tmp.path(), ONE_RUN);
    let out = tmp.path().join("out");
    let cores = std::thread::available_parallelism().unwrap().get();
    for jobs in [(4 * cores + 1).to_string(), "100000".into(), u64::MAX.to_string()] {
        let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--jobs", &jobs], tmp.path());
        let log = text(&o);
        assert_eq!(o.status.code(), Some(2), "--jobs {jobs}: {log}");
        assert!(log.contains(&format!("--jobs {jobs} is more than 4 x the {cores} cores")), "{log}");
        assert!(!out.exists(), "--jobs {jobs} wrote {}", out.display());
    }
    // at the bound, one run: it runs on the machine's cores, not on --jobs threads
    let o = mapbench(
        &["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--jobs", &(4 * cores).to_string()],
        tmp.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("meta.json")).unwrap()).unwrap();
    assert_eq!(meta["threads_per_run"], cores, "{meta}");
}
