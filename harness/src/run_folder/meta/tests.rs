use super::*;
use crate::run_folder::keep::Maps;
use serde_json::{json, Value};
use std::path::Path;

/// A `meta.json` as the code before the schema number wrote it (an authalic batch,
/// its plan cut to two runs).
const OLD: &str = r#"{
  "calibration": {
    "samples_s": [
      0.580998115,
      0.446278822
    ],
    "workload": "kp-newton sd, 4 iterations on generated bumpy_10k"
  },
  "calibration_median_s": 0.5136384685,
  "calibration_spread": 0.2622842743718678,
  "config": {
    "datasets": [
      "bumpy_5k",
      "cap_2k",
      "strip_thin",
      "short_boundary_3k",
      "human_face"
    ],
    "name": "ci-authalic",
    "solvers": [
      "sem",
      "aem-cg",
      "aem-cg-safe"
    ],
    "stop": {
      "max_iters": 100
    },
    "task": "authalic"
  },
  "config_path": "configs/ci-authalic.toml",
  "cores": 2,
  "crates": "faer 0.24.4, nalgebra 0.35.0, plotters 0.3.7, rayon 1.12.0",
  "ended_unix": 1796388439,
  "git_dirty": false,
  "git_revision": "59e0c17842716ee41ed4f9a7ad6dd5e464f8b884",
  "history": "/tmp/reports/history.sqlite",
  "history_outcome": {
    "batch_id": 2,
    "config": "ci-authalic",
    "db": "/tmp/reports/history.sqlite",
    "outcome": "appended",
    "runs": 15,
    "trend": "/tmp/reports/history-trend/ci-authalic/index.html",
    "trend_error": null
  },
  "host": "vm",
  "interrupted": false,
  "jobs": 2,
  "linear_ordering": "metis",
  "mapbench_version": "0.1.0",
  "maps": "best",
  "meshes_dir": "/work/shared/meshes",
  "only": [],
  "plan": [
    "bumpy_5k__authalic__sem",
    "bumpy_5k__authalic__aem-cg"
  ],
  "references": [],
  "repeat": 1,
  "resume": false,
  "rustc": "rustc 1.95.0 (59807616e 2026-04-14)",
  "settings_per_energy": {
    "authalic": {
      "authalic": {
        "alpha0": 2.0,
        "armijo_c": 0.0001,
        "fold_guard": "boundary",
        "init_steps": 5,
        "max_backtracks": 30,
        "sem_stop_on_increase": false,
        "stop": {
          "energy_decrease_tol": 0.0,
          "grad_tol": 0.0,
          "max_iters": 100
        },
        "wolfe_c2": 0.45
      }
    }
  },
  "shard": null,
  "started_unix": 1796388429,
  "stop_per_energy": {
    "authalic": {
      "energy_decrease_tol": 0.0,
      "grad_tol": 0.0,
      "max_iters": 100
    }
  },
  "targets": [],
  "threads_per_run": 1
}"#;

#[test]
fn an_old_file_parses_and_writes_back_the_same_keys_and_values() {
    let meta = Meta::parse(Path::new("old/meta.json"), OLD).unwrap();
    assert_eq!(meta.version, None);
    assert_eq!(meta.config_name(), Some("ci-authalic"));
    assert_eq!(meta.plan.as_ref().map(Vec::len), Some(2));
    assert_eq!(meta.stop_per_energy.as_ref().unwrap()["authalic"].max_iters, Some(100));
    assert!(meta.history_outcome.is_some() && meta.calibration.is_some());
    let old: Value = serde_json::from_str(OLD).unwrap();
    assert_eq!(serde_json::to_value(&meta).unwrap(), old);
}

#[test]
fn a_written_file_reads_back_equal_with_its_version() {
    let dir = tempfile::tempdir().unwrap();
    let meta = Meta::parse(Path::new("old/meta.json"), OLD).unwrap();
    meta.write(dir.path()).unwrap();
    let back = Meta::read(dir.path()).unwrap();
    assert_eq!(back.version, Some(VERSION));
    assert_eq!(back, Meta { version: Some(VERSION), ..meta });
    // The keys on disk: the old ones and the version.
    let text = std::fs::read_to_string(dir.path().join("meta.json")).unwrap();
    let mut on_disk: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(on_disk.as_object_mut().unwrap().remove("version"), Some(json!(VERSION)));
    assert_eq!(on_disk, serde_json::from_str::<Value>(OLD).unwrap());
}

#[test]
fn a_partial_file_parses_and_a_merged_one_keeps_its_shards() {
    let meta: Meta =
        serde_json::from_value(json!({"maps": "none", "merged_from": [{"dir": "/s/1", "shard": "1/2"}]})).unwrap();
    assert_eq!(meta.maps, Some(Maps::None));
    assert_eq!(meta.merged_from.as_ref().map(|m| m[0].shard.as_deref()), Some(Some("1/2")));
    assert_eq!(meta.config, Value::Null);
    assert_eq!(meta.plan, None);
}

#[test]
fn a_newer_version_or_bad_json_is_an_error_naming_the_file() {
    let path = Path::new("run/meta.json");
    let e = Meta::parse(path, r#"{"version": 99, "plan": 3}"#).unwrap_err();
    assert!(matches!(e, MetaError::Version { found: 99, .. }), "{e}");
    let msg = e.to_string();
    assert!(msg.contains("run/meta.json") && msg.contains("version 99"), "{msg}");
    let e = Meta::parse(path, r#"{"version": "one"}"#).unwrap_err().to_string();
    assert!(e.contains("run/meta.json") && e.contains("version"), "{e}");
    let e = Meta::parse(path, "{").unwrap_err().to_string();
    assert!(e.starts_with("run/meta.json: "), "{e}");
    let dir = tempfile::tempdir().unwrap();
    let e = Meta::read(dir.path()).unwrap_err().to_string();
    assert!(e.contains("meta.json: cannot read"), "{e}");
}
