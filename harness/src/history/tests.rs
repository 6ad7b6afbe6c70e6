//! The history database on real files in a temporary folder: schema versions and migrations,
//! one transaction per batch, the queries and the trend page's folder (the page itself is the
//! report's: `report::trend`).

use super::*;
use crate::paths::relative_link;
use crate::plan::Task;
use crate::run_folder::{Status, SummaryRow};
use rusqlite::Connection;
use solvers::solver::StopReason;

fn run(dataset: &str, solver: &str, iterations: usize, energy: f64) -> RunRow {
    RunRow::from_summary(&SummaryRow {
        dataset: dataset.into(),
        task: Task::Param,
        energy: "sd".into(),
        solver: solver.into(),
        iterations: Some(iterations),
        converged: true,
        stop_reason: Some(StopReason::GradientTolerance.into()),
        final_energy: Some(energy),
        time_s: Some(0.5),
        time_norm: Some(1.25),
        status: Status::Ok,
        peak_rss_mb: Some(96.5),
        cg_capped_iters: (solver == "kp-newton-cg").then_some(3),
        to_targets: vec![crate::run_folder::summary::ToTarget {
            tau: 1e-6,
            iters: iterations.checked_sub(1),
            time_s: Some(0.4),
        }],
        ..Default::default()
    })
}

fn batch(config: &str, rev: &str, started: i64) -> BatchRow {
    BatchRow {
        config_name: config.into(),
        config_hash: "0123456789abcdef".into(),
        started_unix: Some(started),
        ended_unix: Some(started + 60),
        git_revision: Some(rev.into()),
        git_dirty: Some(false),
        host: Some("node".into()),
        cores: Some(2),
        jobs: Some(2),
        threads_per_run: Some(1),
        repeats: Some(1),
        calibration_median_s: Some(0.5),
        calibration_spread: Some(0.05),
        run_dir: "/tmp/r".into(),
        recorded_unix: started + 61,
        source: Source::Run,
        ..Default::default()
    }
}

fn count(path: &Path, table: &str) -> i64 {
    Connection::open(path).unwrap().query_row(&format!("SELECT count(*) FROM {table}"), [], |r| r.get(0)).unwrap()
}

#[test]
fn a_new_database_gets_the_current_schema_and_round_trips_a_batch() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sub/h.sqlite");
    let mut db = HistoryDb::open_or_create(&path).unwrap();
    assert_eq!(db.version().unwrap(), SCHEMA_VERSION);
    let mut failed = run("b", "cm", 0, 0.0);
    (failed.status, failed.stop_reason, failed.iterations, failed.final_energy) = (Status::Failed, None, None, None);
    let runs = vec![run("a", "kp-newton", 7, 2.01), run("a", "kp-newton-cg", 9, 2.01), failed];
    assert_eq!(runs[1].cg_capped_iters, Some(3));
    assert_eq!(
        (runs[1].target_tau, runs[1].iters_to_target, runs[1].time_s_to_target),
        (Some(1e-6), Some(8), Some(0.4))
    );
    let id = db.insert_batch(&batch("param", "abcdef0123", 100), &runs, &[]).unwrap();
    let back = db.runs(id).unwrap();
    let expect: Vec<RunRow> = runs.iter().map(|r| RunRow { batch_id: id, ..r.clone() }).collect();
    assert_eq!(back, expect);
    let b = db.batches(Some("param"), None).unwrap();
    assert_eq!((b.len(), b[0].id, b[0].short_revision()), (1, id, "abcdef0".to_string()));
    assert_eq!(b[0], BatchRow { id, ..batch("param", "abcdef0123", 100) });
    // The failed run's stop reason is stored as summary.csv writes it.
    let stop: String = Connection::open(&path)
        .unwrap()
        .query_row("SELECT stop_reason FROM runs WHERE dataset = 'b'", [], |r| r.get(0))
        .unwrap();
    assert_eq!(stop, "error");
}

/// A run that cannot be inserted (here: the same run twice) rolls back the whole batch.
#[test]
fn a_failed_insert_mid_batch_leaves_no_partial_batch() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("h.sqlite");
    let mut db = HistoryDb::open_or_create(&path).unwrap();
    db.insert_batch(&batch("param", "aaaaaaa", 1), &[run("a", "cm", 3, 2.0)], &[]).unwrap();
    let runs = [run("a", "kp-newton", 7, 2.0), run("b", "kp-newton", 5, 2.0), run("a", "kp-newton", 7, 2.0)];
    let e = db.insert_batch(&batch("param", "bbbbbbb", 2), &runs, &[]).unwrap_err();
    assert!(matches!(&e, HistoryError::Run { run, .. } if run == "a__sd__kp-newton"), "{e}");
    assert!(e.to_string().contains("h.sqlite: run a__sd__kp-newton: UNIQUE constraint failed"), "{e}");
    drop(db);
    assert_eq!((count(&path, "batches"), count(&path, "runs")), (1, 1));
}

/// A database written by the first schema (v1, made here by hand with its own SQL) is
/// migrated on open: its rows are kept and the new column gets its default.
#[test]
fn an_older_schema_is_migrated_in_place() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("h.sqlite");
    {
        let c = Connection::open(&path).unwrap();
        c.execute_batch(db::MIGRATIONS[0]).unwrap();
        c.execute_batch(
            "INSERT INTO batches (id, config_name, config_hash, run_dir, recorded_unix, git_revision) \
             VALUES (1, 'param', 'h', '/x', 5, '1234567abc');
             INSERT INTO runs (batch_id, dataset, task, energy, solver, iterations, status, stop_reason) \
             VALUES (1, 'a', 'param', 'sd', 'cm', 9, 'ok', 'grad_tol');
             PRAGMA user_version = 1;",
        )
        .unwrap();
    }
    let db = HistoryDb::open_existing(&path).unwrap();
    assert_eq!(db.version().unwrap(), SCHEMA_VERSION);
    let b = db.batches(None, None).unwrap();
    assert_eq!((b.len(), b[0].source, b[0].short_revision()), (1, Source::Run, "1234567".to_string()));
    let r = db.runs(1).unwrap();
    assert_eq!(
        (
            r[0].iterations,
            r[0].status,
            r[0].stop_reason.clone(),
            r[0].peak_rss_mb,
            r[0].cg_capped_iters,
            r[0].target_tau
        ),
        (Some(9), Status::Ok, Some(StopReason::GradientTolerance.into()), None, None, None)
    );
    // version 0 (an empty file, as `sqlite3 FILE` or `touch` leaves it) becomes a history
    // when a batch is appended, and is left alone by a reader
    for (name, make) in [("vacuumed", true), ("zero_bytes", false)] {
        let empty = dir.path().join(format!("{name}.sqlite"));
        if make {
            Connection::open(&empty).unwrap().execute_batch("VACUUM").unwrap();
        } else {
            std::fs::write(&empty, b"").unwrap();
        }
        let size = std::fs::metadata(&empty).unwrap().len();
        let e = HistoryDb::open_existing(&empty).err().unwrap();
        assert!(matches!(e, HistoryError::Empty { .. }) && e.to_string().contains("not a history yet"), "{e}");
        assert_eq!(std::fs::metadata(&empty).unwrap().len(), size, "{name}: the reader wrote to it");
        assert_eq!(HistoryDb::open_or_create(&empty).unwrap().version().unwrap(), SCHEMA_VERSION);
    }
}

#[test]
fn a_negative_schema_version_is_refused_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("neg.sqlite");
    Connection::open(&path).unwrap().execute_batch("PRAGMA user_version = -5;").unwrap();
    for e in [HistoryDb::open_or_create(&path).err().unwrap(), HistoryDb::open_existing(&path).err().unwrap()] {
        assert!(matches!(e, HistoryError::BadVersion { found: -5, .. }), "{e}");
        assert!(e.to_string().contains("neg.sqlite: history schema version -5 is negative"), "{e}");
    }
    let v: i64 = Connection::open(&path).unwrap().pragma_query_value(None, "user_version", |r| r.get(0)).unwrap();
    assert_eq!(v, -5, "left alone");
}

#[test]
fn a_newer_or_foreign_database_is_refused_with_a_clear_error_and_left_alone() {
    let dir = tempfile::tempdir().unwrap();
    let newer = dir.path().join("newer.sqlite");
    Connection::open(&newer).unwrap().execute_batch("CREATE TABLE future (x); PRAGMA user_version = 99;").unwrap();
    let e = HistoryDb::open_or_create(&newer).err().unwrap();
    assert!(matches!(e, HistoryError::Newer { found: 99, supported: SCHEMA_VERSION, .. }), "{e}");
    let want = format!("newer.sqlite: history schema version 99 is newer than this mapbench's ({SCHEMA_VERSION})");
    assert!(e.to_string().contains(&want), "{e}");
    let foreign = dir.path().join("foreign.sqlite");
    Connection::open(&foreign).unwrap().execute_batch("CREATE TABLE notes (x)").unwrap();
    let e = HistoryDb::open_or_create(&foreign).err().unwrap();
    assert!(matches!(e, HistoryError::Foreign { .. }), "{e}");
    // neither was touched
    let c = Connection::open(&foreign).unwrap();
    let tables: i64 = c.query_row("SELECT count(*) FROM sqlite_master WHERE type = 'table'", [], |r| r.get(0)).unwrap();
    assert_eq!(tables, 1);
    let missing = dir.path().join("none.sqlite");
    assert!(matches!(HistoryDb::open_existing(&missing).err().unwrap(), HistoryError::Missing { .. }));
    assert!(!missing.exists());
}

#[test]
fn last_n_keeps_the_latest_batches_of_each_config_in_time_order() {
    let dir = tempfile::tempdir().unwrap();
    let mut db = HistoryDb::open_or_create(&dir.path().join("h.sqlite")).unwrap();
    // inserted out of time order: the query orders by start time
    for (config, t) in [("p", 30), ("p", 10), ("q", 5), ("p", 20), ("q", 6)] {
        db.insert_batch(&batch(config, &format!("rev{t}"), t), &[run("a", "cm", 1, 1.0)], &[]).unwrap();
    }
    let got: Vec<(String, Option<i64>)> =
        db.batches(None, Some(2)).unwrap().into_iter().map(|b| (b.config_name, b.started_unix)).collect();
    let want = [("p", 20), ("p", 30), ("q", 5), ("q", 6)].map(|(c, t)| (c.to_string(), Some(t)));
    assert_eq!(got, want);
    assert_eq!(db.batches(Some("q"), Some(1)).unwrap().len(), 1);
    assert_eq!(db.batch_count().unwrap(), 5);
}

/// The hash follows what ran (config, settings, plan, repeats), not where the history is.
#[test]
fn the_config_hash_ignores_the_history_key_only() {
    let meta = serde_json::json!({
        "config": {"name": "p", "solvers": ["cm"]}, "settings_per_energy": {"sd": {"x": 1}},
        "plan": ["a__sd__cm"], "only": [], "repeat": 1
    });
    let hash = |v: &serde_json::Value| config_hash(&serde_json::from_value(v.clone()).unwrap());
    let h = hash(&meta);
    assert_eq!(h.len(), 16);
    let mut other = meta.clone();
    other["config"]["history"] = "elsewhere.sqlite".into();
    assert_eq!(hash(&other), h);
    for (k, v) in [("repeat", serde_json::json!(3)), ("plan", serde_json::json!(["a__sd__kp-newton"]))] {
        let mut m = meta.clone();
        m[k] = v;
        assert_ne!(hash(&m), h, "{k}");
    }
}

#[test]
fn paths_resolve_and_links_are_relative() {
    assert_eq!(resolve_path(None, Path::new("configs")), PathBuf::from("reports/history.sqlite"));
    assert_eq!(resolve_path(Some(Path::new("h.db")), Path::new("configs")), PathBuf::from("configs/h.db"));
    assert_eq!(trend_dir(Path::new("reports/history.sqlite"), "param"), PathBuf::from("reports/history-trend/param"));
    let page = trend_dir(Path::new("/r/history.sqlite"), "param").join("index.html");
    assert_eq!(relative_link(Path::new("/r/param"), &page), "../history-trend/param/index.html");
    assert_eq!(
        relative_link(Path::new("/r/history-trend/param"), Path::new("/tmp/x/./y/../index.html")),
        "../../../tmp/x/index.html"
    );
    assert_eq!(HistoryChoice::from_flags(Some("a".into()), false).apply("b".into()), Some(PathBuf::from("a")));
    assert_eq!(HistoryChoice::from_flags(None, true).apply("b".into()), None);
    assert_eq!(HistoryChoice::from_flags(None, false).apply("b".into()), Some(PathBuf::from("b")));
}
