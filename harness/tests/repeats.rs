//! A batch run again: repeats round-robin (medians, spreads, a timed-out run replayed), shards
//! merged with their calibrations, and `--resume` rerunning only what changed.

use crate::common;

use common::*;
use std::path::PathBuf;

#[test]
fn repeats_run_round_robin_reproduce_the_iterates_and_report_median_min_max() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("quad.obj"), QUAD_OBJ).unwrap();
    // every run is repeated: by default which are depends on their times (tested below)
    let cfg = write_config(
        tmp.path(),
        "name = \"rep\"\nrepeat = 3\nrepeat_runs = \"all\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\", \"cm\"]\n\
         [[dataset]]\nname = \"broken\"\npath = \"quad.obj\"\n",
    );
    let out = tmp.path().join("out");
    let run = |extra: &[&str]| {
        let args = [&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--jobs", "1"], extra].concat();
        let o = mapbench(&args, tmp.path());
        assert_eq!(o.status.code(), Some(1), "the broken mesh fails its runs: {}", text(&o));
        text(&o)
    };
    let log = run(&[]);
    // every run once, then every run again: the repeat lines alternate between the solvers
    let repeats: Vec<&str> = log.lines().filter(|l| l.trim_start().starts_with("repeat ")).map(str::trim).collect();
    assert_eq!(
        repeats.iter().map(|l| l.split(':').next().unwrap()).collect::<Vec<_>>(),
        [
            "repeat 1/3 bumpy_1k__sd__kp-newton",
            "repeat 1/3 bumpy_1k__sd__cm",
            "repeat 2/3 bumpy_1k__sd__kp-newton",
            "repeat 2/3 bumpy_1k__sd__cm"
        ],
        "{log}"
    );
    let (h, rows) = read_csv(&out.join("summary.csv"));
    let col = |name: &str| h.iter().position(|x| x == name).unwrap();
    let num = |r: &Vec<String>, c: &str| r[col(c)].parse::<f64>().unwrap();
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("meta.json")).unwrap()).unwrap();
    // a sample before the first round, between the rounds and after the last
    let samples: Vec<f64> =
        meta["calibration"]["samples_s"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert_eq!(samples.len(), 4, "{meta}");
    let cal = meta["calibration_median_s"].as_f64().unwrap();
    for r in rows.iter().filter(|r| r[col("dataset")] == "bumpy_1k") {
        assert_eq!(r[col("status")], "ok");
        assert_eq!(r[col("repeats")], "3");
        let (t, lo, hi) = (num(r, "time_s"), num(r, "time_s_min"), num(r, "time_s_max"));
        assert!(lo <= t && t <= hi && lo > 0.0, "{r:?}");
        assert!((num(r, "time_norm") - t / cal).abs() <= 1e-12 * t / cal, "{r:?}");
    }
    // a failed run is not repeated and has no times
    for r in rows.iter().filter(|r| r[col("dataset")] == "broken") {
        assert_eq!(
            (r[col("status")].as_str(), r[col("repeats")].as_str(), r[col("time_norm")].as_str()),
            ("failed", "", "")
        );
    }
    // the per-iteration CSV's rows are those of every repeat (checked equal), times their medians
    let (ih, irows) = read_csv(&out.join("runs/bumpy_1k__sd__cm.csv"));
    assert_eq!(irows.len(), num(&rows[1], "iterations") as usize + 1);
    assert!(ih.iter().any(|c| c == "t_iter_s"));
    // --resume keeps every finished run, repeats, normalized times and all
    let before = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let log = run(&["--resume"]);
    assert_eq!(log.matches("resumed, ").count(), 4, "the failed runs too: {log}");
    assert!(!log.contains("repeat 1/3"), "resumed runs are not repeated: {log}");
    let again = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert_eq!(again, before);
    // a resumed run without a normalized time (a folder of an older version, or whose
    // calibration failed) keeps none: this batch's calibration did not see its machine
    let sidecar = out.join("runs/bumpy_1k__sd__cm.json");
    let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&sidecar).unwrap()).unwrap();
    json["summary"]["time_norm"] = serde_json::Value::Null;
    std::fs::write(&sidecar, serde_json::to_string(&json).unwrap()).unwrap();
    let log = run(&["--resume"]);
    assert_eq!(log.matches("resumed, ").count(), 4, "{log}");
    let (_, rows) = read_csv(&out.join("summary.csv"));
    let cm = rows.iter().find(|r| r[col("solver")] == "cm" && r[col("dataset")] == "bumpy_1k").unwrap();
    assert_eq!((cm[col("repeats")].as_str(), cm[col("time_norm")].as_str()), ("3", ""), "{cm:?}");
    // another repeat count is another measurement: nothing is resumed
    let log = run(&["--resume", "--repeat", "2"]);
    assert_eq!(log.matches("resumed, ").count(), 0, "{log}");
    let (_, rows) = read_csv(&out.join("summary.csv"));
    assert_eq!(rows[0][col("repeats")], "2");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--repeat", "0"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--repeat") && text(&o).contains("give 1 to 100"), "{}", text(&o));
}

#[test]
fn a_repeat_of_a_timed_out_run_replays_its_iterations() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"t\"\ntimeout = \"0.001s\"\nrepeat = 2\nrepeat_runs = \"all\"\ndatasets = [\"bumpy_5k\"]\nenergies = [\"sd\"]\n\
         solvers = [\"slim\"]\n",
    );
    let out = tmp.path().join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    assert_eq!(
        [&rows[0][col("stop_reason")], &rows[0][col("status")], &rows[0][col("repeats")]],
        ["timeout", "not_converged", "2"],
        "{rows:?}"
    );
}

/// By default the repeats go to the runs whose time decides a ranking: `kp-newton` reaches its
/// target and is repeated; plain `newton`'s factorization fails at once (a breakdown), its time
/// ranks nothing and it keeps its one sample; the report says how many were repeated.
#[test]
fn only_the_runs_whose_time_ranks_are_repeated() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"r\"\nrepeat = 3\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\", \"newton\"]\n",
    );
    let out = tmp.path().join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-history"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let of = |solver: &str| rows.iter().find(|r| r[col("solver")] == solver).unwrap();
    assert_eq!([&of("kp-newton")[col("stop_reason")], &of("kp-newton")[col("repeats")]], ["target", "3"]);
    assert_eq!([&of("newton")[col("stop_reason")], &of("newton")[col("repeats")]], ["linear_solve_failed", "1"]);
    let index = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(index.contains("1 of the 2 runs were repeated 3 times"), "{index}");
}

#[test]
fn shards_with_repeats_merge_with_every_shards_calibration() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"m\"\nrepeat = 2\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\", \"cm\"]\n",
    );
    let shards: Vec<PathBuf> = (1..=2)
        .map(|i| {
            let out = tmp.path().join(format!("s{i}"));
            let args = ["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--shard", &format!("{i}/2")];
            let o = mapbench(&args, tmp.path());
            assert_eq!(o.status.code(), Some(0), "{}", text(&o));
            out
        })
        .collect();
    let merged = tmp.path().join("merged");
    let o = mapbench(
        &["merge", shards[0].to_str().unwrap(), shards[1].to_str().unwrap(), "--out", merged.to_str().unwrap()],
        tmp.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (h, rows) = read_csv(&merged.join("summary.csv"));
    let col = |name: &str| h.iter().position(|x| x == name).unwrap();
    assert!(rows.iter().all(|r| r[col("repeats")] == "2" && !r[col("time_norm")].is_empty()), "{rows:?}");
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(merged.join("meta.json")).unwrap()).unwrap();
    assert_eq!(meta["calibration"]["samples_s"].as_array().unwrap().len(), 6, "3 samples per shard: {meta}");
    // shards of another repeat count are not one batch
    let other = tmp.path().join("other");
    let args = ["run", cfg.to_str().unwrap(), "--out", other.to_str().unwrap(), "--shard", "2/2", "--repeat", "1"];
    assert_eq!(mapbench(&args, tmp.path()).status.code(), Some(0));
    let o = mapbench(&["merge", shards[0].to_str().unwrap(), other.to_str().unwrap(), "--out", "x"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--repeat"), "{}", text(&o));
}

#[test]
fn resume_reruns_nothing_that_finished_and_everything_whose_settings_changed() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("quad.obj"), QUAD_OBJ).unwrap();
    let body = "name = \"r\"\ndatasets = [\"cap_2k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\", \"cm\"]\n\
                [[dataset]]\nname = \"broken\"\npath = \"quad.obj\"\n";
    let cfg = write_config(tmp.path(), body);
    let out = tmp.path().join("out");
    let run = |extra: &[&str]| {
        let o =
            mapbench(&[&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], extra].concat(), tmp.path());
        // exit 1 whenever the broken mesh is in the batch (resumed or not)
        let broken_in = !extra.contains(&"--only");
        assert_eq!(o.status.code(), Some(if broken_in { 1 } else { 0 }), "{}", text(&o));
        (text(&o), std::fs::read_to_string(out.join("summary.csv")).unwrap())
    };
    let (_, first) = run(&[]);
    let csv = std::fs::read_to_string(out.join("runs/cap_2k__sd__cm.csv")).unwrap();
    let (log, again) = run(&["--resume"]);
    assert_eq!(log.matches("resumed, ").count(), 4, "{log}");
    assert_eq!(again, first, "the resumed summary is the finished one, timings included");
    assert_eq!(std::fs::read_to_string(out.join("runs/cap_2k__sd__cm.csv")).unwrap(), csv);
    // a setting that changes results invalidates every run
    write_config(tmp.path(), &format!("{body}[stop]\nmax_iters = 3\n"));
    let (log, _) = run(&["--resume"]);
    assert_eq!(log.matches("resumed, ").count(), 0, "{log}");
    assert!(log.contains("cap_2k sd cm: ran (max_iters), 3 iterations"), "{log}");
    // another plan (--only keeps 2 of the 4 runs) is refused: the other 2 would stay behind
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--only", "cap_2k*"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("a run folder of another batch (another plan: 4 runs, this batch 2"), "{}", text(&o));
    // without --resume everything runs again
    let (log, _) = run(&[]);
    assert_eq!(log.matches("resumed, ").count(), 0, "{log}");
}
