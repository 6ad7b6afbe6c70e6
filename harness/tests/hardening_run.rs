//! `run` hardening, second pass: `--jobs` bounded like `threads_per_run`, output
//! folders of another batch refused, interrupted repeats kept for `--resume`.

use crate::common;

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

const TWO_RUNS: &str =
    "name = \"m\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\", \"cm\"]\n";

/// The two shards of a two-run batch, `s1` and `s2` in `tmp`.
fn two_shards(tmp: &std::path::Path) -> [String; 2] {
    let cfg = write_config(tmp, TWO_RUNS);
    [1, 2].map(|i| {
        let s = tmp.join(format!("s{i}"));
        let args = ["run", cfg.to_str().unwrap(), "--out", s.to_str().unwrap(), "--shard", &format!("{i}/2")];
        let o = mapbench(&args, tmp);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        s.display().to_string()
    })
}

/// Nothing named `.out.merging-*` (or anything else) beside `out` but the shards.
fn leftovers(tmp: &std::path::Path) -> Vec<String> {
    std::fs::read_dir(tmp)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("merging"))
        .collect()
}

#[test]
fn merge_appends_only_complete_batches_names_the_shards_files_and_leaves_nothing_half_done() {
    let tmp = tempfile::tempdir().unwrap();
    let [s1, s2] = two_shards(tmp.path());
    let db = tmp.path().join("h.sqlite");
    let hist = ["--history", db.to_str().unwrap()];
    // one shard of two: merged (exit 2), not appended
    let o = mapbench(&[&["merge", &s1, "--out", "part"], &hist[..]].concat(), tmp.path());
    let log = text(&o);
    assert_eq!(o.status.code(), Some(2), "{log}");
    assert!(log.contains("not appended to the history: 1 planned runs are in no shard"), "{log}");
    assert!(!db.exists(), "an incomplete batch created the history");
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(tmp.path().join("part/meta.json")).unwrap()).unwrap();
    assert_eq!(meta["history_outcome"]["outcome"], "not_appended", "{meta}");

    // a shard's CSV cut short: the error names the shard's file, no folder is left
    let csv = tmp.path().join("s2/runs/bumpy_1k__sd__cm.csv");
    let good = std::fs::read_to_string(&csv).unwrap();
    let cut: String = good.lines().take(3).map(|l| format!("{l}\n")).collect();
    std::fs::write(&csv, cut).unwrap();
    let o = mapbench(&[&["merge", &s1, &s2, "--out", "all"], &hist[..]].concat(), tmp.path());
    let log = text(&o);
    assert_eq!(o.status.code(), Some(2), "{log}");
    assert!(log.contains(&format!("{}: 2 rows", csv.display())), "{log}");
    assert!(!tmp.path().join("all").exists() && leftovers(tmp.path()).is_empty(), "{:?}", leftovers(tmp.path()));
    assert!(!db.exists());

    // whole again: merged and appended
    std::fs::write(&csv, good).unwrap();
    let o = mapbench(&[&["merge", &s1, &s2, "--out", "all"], &hist[..]].concat(), tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("history: batch 1 (2 runs of m) appended"), "{}", text(&o));
    // merged again into its own folder: replaced, a file of the user's beside it kept, and
    // the same shards' batch not appended twice
    std::fs::write(tmp.path().join("all/notes.txt"), "mine").unwrap();
    let o = mapbench(&[&["merge", &s1, &s2, "--out", "all"], &hist[..]].concat(), tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        text(&o).contains("as batch 1 (appended by an earlier batch of this folder); not appended again"),
        "{}",
        text(&o)
    );
    assert_eq!(mapbench::history::HistoryDb::open_existing(&db).unwrap().batches(None, None).unwrap().len(), 1);
    assert_eq!(std::fs::read_to_string(tmp.path().join("all/notes.txt")).unwrap(), "mine");
    assert!(tmp.path().join("all/index.html").is_file() && leftovers(tmp.path()).is_empty());
}

#[test]
fn a_folder_of_another_batch_is_refused_and_cleaned_with_force() {
    let tmp = tempfile::tempdir().unwrap();
    let [s1, s2] = two_shards(tmp.path());
    let other = tmp.path().join("other.toml");
    let body = "name = \"n\"\ndatasets = [\"cap_2k\"]\nenergies = [\"sd\"]\nsolvers = [\"cm\"]\n";
    std::fs::write(&other, std::fs::read_to_string(write_config(tmp.path(), body)).unwrap()).unwrap();
    let out = tmp.path().join("out");
    let run = |extra: &[&str]| {
        mapbench(&[&["run", other.to_str().unwrap(), "--out", out.to_str().unwrap()], extra].concat(), tmp.path())
    };
    assert_eq!(run(&[]).status.code(), Some(0));
    // merging m's shards into n's folder: refused, untouched
    let o = mapbench(&["merge", &s1, &s2, "--out", out.to_str().unwrap(), "--no-history"], tmp.path());
    let log = text(&o);
    assert_eq!(o.status.code(), Some(2), "{log}");
    assert!(
        log.contains("a run folder of another batch (config \"n\", not \"m\")") && log.contains("--force"),
        "{log}"
    );
    assert!(out.join("runs/cap_2k__sd__cm.csv").is_file());
    // --force: m's batch replaces n's, and its page lists only m's runs
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let o = mapbench(&["merge", &s1, &s2, "--out", out.to_str().unwrap(), "--no-history", "--force"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let index = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(index.contains("bumpy_1k") && !index.contains("cap_2k"), "n's runs are still listed");
    assert!(!out.join("runs/cap_2k__sd__cm.csv").exists() && out.join("notes.txt").is_file());
    // and back: `run` of n into m's folder is refused, with --force it cleans
    let o = run(&[]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("config \"m\", not \"n\""), "{}", text(&o));
    let o = run(&["--force"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("--force: deleted the results of another batch"), "{}", text(&o));
    let index = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(index.contains("cap_2k") && !index.contains("bumpy_1k"), "m's runs are still listed");
    assert!(!out.join("runs/bumpy_1k__sd__cm.csv").exists() && out.join("notes.txt").is_file());
    // a folder mapbench did not write is never a run's
    let o = mapbench(&["run", other.to_str().unwrap(), "--out", tmp.path().to_str().unwrap(), "--force"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("not empty and not a mapbench run folder"), "{}", text(&o));
}
