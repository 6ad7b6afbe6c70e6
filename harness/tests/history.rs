//! The history database end to end: `run` and `merge` append their batch, the
//! `history` verb renders the trend page, `--no-history` writes nothing, a database this
//! build cannot use costs the batch nothing but the exit code, and `sqlite3` reads the file.

use crate::common;

use common::{mapbench, read_csv, text, write_config};
use mapbench::history::HistoryDb;
use std::path::Path;
use std::process::Command;

const CONFIG: &str =
    "name = \"h\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\", \"cm\"]\n";

/// `git` in `dir` with a fixed identity (the batches' revisions come from the config's folder).
fn git(dir: &Path, args: &[&str]) {
    let o = Command::new("git")
        .args(["-c", "user.name=t", "-c", "user.email=t@example.org", "-c", "commit.gpgsign=false"])
        .args(args)
        .current_dir(dir)
        .output()
        .expect("git runs");
    assert!(o.status.success(), "git {args:?}: {}", text(&o));
}

/// The short revision of this checkout, which the binary under test was built from.
fn code_rev() -> String {
    head(&common::repo_root())[..7].to_string()
}

fn head(dir: &Path) -> String {
    let o = Command::new("git").args(["rev-parse", "HEAD"]).current_dir(dir).output().unwrap();
    String::from_utf8_lossy(&o.stdout).trim().to_string()
}

#[test]
fn three_batches_of_one_config_make_three_nights_on_the_trend_page() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(tmp.path(), CONFIG);
    git(tmp.path(), &["init", "-q"]);
    let mut revisions = Vec::new();
    for night in 1..=3 {
        std::fs::write(tmp.path().join("notes.txt"), format!("night {night}\n")).unwrap();
        git(tmp.path(), &["add", "."]);
        git(tmp.path(), &["commit", "-q", "-m", &format!("night {night}")]);
        revisions.push(head(tmp.path())[..7].to_string());
        let out = tmp.path().join(format!("night{night}"));
        let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp.path());
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        let db = tmp.path().join("reports/history.sqlite");
        let said = format!("history: batch {night} (2 runs of h) appended to {}", db.display());
        assert!(text(&o).contains(&said), "{}", text(&o));
        // The run's report links to the trend page `run` rendered next to the database.
        let index = std::fs::read_to_string(out.join("index.html")).unwrap();
        assert!(index.contains("href=\"../reports/history-trend/h/index.html\""), "{index}");
        let trend = std::fs::read_to_string(tmp.path().join("reports/history-trend/h/index.html")).unwrap();
        // A trend is drawn from the third night on; before, the page says why there is none.
        assert_eq!(trend.contains("so far: a trend is drawn from 3 on"), night < 3, "{trend}");
    }
    let db = tmp.path().join("reports/history.sqlite");
    let h = HistoryDb::open_existing(&db).unwrap();
    let batches = h.batches(Some("h"), None).unwrap();
    assert_eq!(batches.len(), 3);
    // The revision is the code's, set when the binary was built (this checkout's), whatever
    // repository holds the config; the config folder's is in meta.json apart.
    let code = head(&common::repo_root())[..7].to_string();
    // (a `+` marks a build whose code differed from its revision)
    let shown: Vec<String> = batches.iter().map(|b| b.short_revision().trim_end_matches('+').to_string()).collect();
    assert_eq!(shown, [code.clone(), code.clone(), code]);
    for (night, rev) in revisions.iter().enumerate() {
        let meta = std::fs::read_to_string(tmp.path().join(format!("night{}/meta.json", night + 1))).unwrap();
        let meta: serde_json::Value = serde_json::from_str(&meta).unwrap();
        assert!(meta["config_git_revision"].as_str().is_some_and(|r| r.starts_with(rev.as_str())), "{meta}");
    }
    assert_eq!(batches[0].config_hash, batches[1].config_hash, "same config, same hash");
    assert_eq!(h.runs(batches[1].id).unwrap().len(), 2);

    let o = mapbench(&["history", "--out", "trend", "--last", "5"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("trend page of 3 batches (3 plots)"), "{}", text(&o));
    let page = std::fs::read_to_string(tmp.path().join("trend/index.html")).unwrap();
    for needle in [code_rev().as_str(), "h: 3 batches", "What changed: batch 3", "../night1/index.html"] {
        assert!(page.contains(needle), "{needle} not in the trend page:\n{page}");
    }
    for png in ["h__sd__solved.png", "h__sd__iterations.png", "h__sd__time.png"] {
        let bytes = std::fs::read(tmp.path().join("trend/plots").join(png)).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{png}");
    }
    // the same iterations twice: nothing changed but (maybe) the times, which are not listed
    assert!(page.contains("No change in iterations, status or final energy"), "{page}");
    the_trend_of_a_batch_is_its_report(&page, &tmp.path().join("night3"), 3);
    let o = mapbench(&["history", "--config", "nope", "--out", "t2"], tmp.path());
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("no batch of config \"nope\""), "{}", text(&o));

    // the sqlite3 CLI reads the file (skipped, saying so, where it is not installed)
    match Command::new("sqlite3").arg("-version").output() {
        Ok(v) if v.status.success() => {
            let q =
                "SELECT b.git_revision, count(*), sum(r.iterations) FROM runs r JOIN batches b ON b.id = r.batch_id \
                     GROUP BY b.id ORDER BY b.id";
            let o = Command::new("sqlite3").arg(&db).arg(q).output().unwrap();
            assert!(o.status.success(), "{}", text(&o));
            let out = String::from_utf8_lossy(&o.stdout);
            let lines: Vec<&str> = out.lines().collect();
            assert_eq!(lines.len(), 3, "{out}");
            assert!(lines[0].starts_with(&code_rev()) && lines[0].contains("|2|"), "{out}");
            let v = Command::new("sqlite3").arg(&db).arg("PRAGMA user_version").output().unwrap();
            assert_eq!(String::from_utf8_lossy(&v.stdout).trim(), mapbench::history::SCHEMA_VERSION.to_string());
        }
        _ => eprintln!("skipped the sqlite3 check: no sqlite3 binary on PATH"),
    }
}

/// The trend page's numbers of batch `id` are those of its report's aggregates table
/// (`folder/tables/aggregates.csv`): solved / runs and both shifted geometric means per solver.
fn the_trend_of_a_batch_is_its_report(page: &str, folder: &Path, id: usize) {
    let (head, rows) = read_csv(&folder.join("tables/aggregates.csv"));
    let col = |prefix: &str| head.iter().position(|h| h.starts_with(prefix)).unwrap();
    let (solver, runs, solved, iterations, time) =
        (col("solver"), col("runs"), col("solved"), col("sgm iterations"), col("sgm time"));
    // The totals table of the energy: its head names the solvers, batch `id`'s row their cells.
    let table = &page[page.find("per batch: solved / runs").expect("a totals table")..];
    let table = &table[..table.find("</table>").unwrap()];
    let heads: Vec<&str> = table.split("<th>").skip(1).map(|c| &c[..c.find("</th>").unwrap()]).collect();
    let start = table.find(&format!("<tr><td class=\"k\">{id} <code>")).expect("the batch's row");
    let row = &table[start..start + table[start..].find("</tr>").unwrap()];
    let cells: Vec<&str> = row.split("<td>").skip(1).map(|c| &c[..c.find("</td>").unwrap()]).collect();
    assert_eq!(heads.len(), cells.len(), "{row}");
    assert_eq!(rows.len(), heads.len(), "one aggregate per solver");
    for r in &rows {
        let k = heads.iter().position(|h| *h == r[solver]).unwrap_or_else(|| panic!("{} not on the page", r[solver]));
        let report_time = r[time].trim_end_matches('†');
        let want = format!("{}/{}<br><small>{} it, {}</small>", r[solved], r[runs], r[iterations], report_time);
        assert_eq!(cells[k], want, "{}: the trend says {}, the report {want}", r[solver], cells[k]);
    }
}

#[test]
fn no_history_writes_nothing_and_shards_leave_the_append_to_merge() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(tmp.path(), CONFIG);
    let out = tmp.path().join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-history"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(!tmp.path().join("reports").exists(), "--no-history wrote reports/");
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("meta.json")).unwrap()).unwrap();
    assert!(meta["history"].is_null(), "{meta}");
    assert!(!std::fs::read_to_string(out.join("index.html")).unwrap().contains("History:"));

    let shards: Vec<String> = (1..=2)
        .map(|i| {
            let s = tmp.path().join(format!("s{i}"));
            let args = ["run", cfg.to_str().unwrap(), "--out", s.to_str().unwrap(), "--shard", &format!("{i}/2")];
            let o = mapbench(&args, tmp.path());
            assert_eq!(o.status.code(), Some(0), "{}", text(&o));
            assert!(text(&o).contains("a --shard batch is not appended"), "{}", text(&o));
            s.display().to_string()
        })
        .collect();
    // (shards may add the references they compute to the store beside the history; this
    // config's are in the committed seed)
    assert!(!tmp.path().join("reports/history.sqlite").exists(), "a shard wrote the history");
    let db = tmp.path().join("nightly.sqlite");
    let o =
        mapbench(&["merge", &shards[0], &shards[1], "--out", "merged", "--history", db.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let h = HistoryDb::open_existing(&db).unwrap();
    let b = h.batches(None, None).unwrap();
    assert_eq!((b.len(), b[0].source), (1, mapbench::history::Source::Merge));
    assert_eq!(h.runs(b[0].id).unwrap().len(), 2);
    assert!(tmp.path().join("nightly-trend/h/index.html").is_file());
    let index = std::fs::read_to_string(tmp.path().join("merged/index.html")).unwrap();
    assert!(index.contains("href=\"../nightly-trend/h/index.html\""), "{index}");
}

/// A history this build cannot use (a newer schema) is a warning and exit 2; the run folder
/// is complete. The config's `history` key resolves against the config's folder.
#[test]
fn a_history_that_cannot_be_written_keeps_the_run_folder_and_exits_2() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::create_dir(tmp.path().join("cfg")).unwrap();
    let cfg = write_config(&tmp.path().join("cfg"), &format!("history = \"db/h.sqlite\"\n{CONFIG}"));
    let db = tmp.path().join("cfg/db/h.sqlite");
    std::fs::create_dir_all(db.parent().unwrap()).unwrap();
    rusqlite::Connection::open(&db).unwrap().execute_batch("PRAGMA user_version = 99").unwrap();
    let out = tmp.path().join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("warning: history not updated:") && text(&o).contains("schema version 99 is newer"),
        "{}",
        text(&o)
    );
    assert_eq!(common::read_csv(&out.join("summary.csv")).1.len(), 2);
    assert!(out.join("index.html").is_file());
    assert!(!tmp.path().join("reports").exists());
}

/// The history's benchmark (docs/src/results/benchmarks.md): 30 nights of one run folder (`MAPBENCH_BENCH_RUN`, e.g. a
/// `configs/param.toml` run) appended with distinct revisions and start times into
/// `MAPBENCH_BENCH_DB`; prints the database size and how long the trend page took. Run with
/// `cargo test -p mapbench --test suite -- --ignored --nocapture history::thirty`.
#[test]
#[ignore = "a benchmark: needs MAPBENCH_BENCH_RUN (a run folder) and MAPBENCH_BENCH_DB"]
fn thirty_simulated_batches() {
    use mapbench::history::{batch_row, read_meta, RunRow};
    use mapbench::report::trend;
    let (Some(run), Some(db)) = (std::env::var_os("MAPBENCH_BENCH_RUN"), std::env::var_os("MAPBENCH_BENCH_DB")) else {
        eprintln!("skipped: set MAPBENCH_BENCH_RUN and MAPBENCH_BENCH_DB");
        return;
    };
    let (run, db) = (Path::new(&run), Path::new(&db));
    assert!(!db.exists(), "{}: exists; give a new file", db.display());
    let meta = read_meta(run).unwrap();
    let rows: Vec<RunRow> = mapbench::run_folder::read_summary(run).unwrap().iter().map(RunRow::from_summary).collect();
    let mut h = HistoryDb::open_or_create(db).unwrap();
    let t0 = std::time::Instant::now();
    for night in 0..30i64 {
        let mut b = batch_row(run, &meta).unwrap();
        b.git_revision = Some(format!("{:07x}{}", 0x1000000 + night * 7919, "0".repeat(33)));
        b.started_unix = b.started_unix.map(|s| s + night * 86_400);
        h.insert_batch(&b, &rows, &[]).unwrap();
    }
    let insert = t0.elapsed().as_secs_f64();
    let size = std::fs::metadata(db).unwrap().len();
    let out = db.with_extension("trend");
    let t1 = std::time::Instant::now();
    let page = trend::render(&h, None, None, &out).unwrap();
    eprintln!(
        "30 batches x {} runs: {} bytes ({:.1} KiB per batch); 30 inserts {:.3} s; trend page ({} plots) {:.2} s",
        rows.len(),
        size,
        size as f64 / 30.0 / 1024.0,
        insert,
        page.plots.len(),
        t1.elapsed().as_secs_f64()
    );
    assert_eq!(page.batches, 30);
}

/// What `run` says of the history is what happened: a trend page that cannot be
/// rendered is its own warning after "appended" (exit 0: the batch is in), meta.json records
/// the outcome and the report links no page; a `--resume` of the complete folder is not
/// appended again; a failed append leaves `history` null in meta.json.
#[test]
fn the_history_outcome_is_said_and_recorded_as_it_happened() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(tmp.path(), CONFIG);
    let db = tmp.path().join("h.sqlite");
    // a file where the trend page's folder would go
    std::fs::write(tmp.path().join("h-trend"), "in the way").unwrap();
    let out = tmp.path().join("out");
    let args = ["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--history", db.to_str().unwrap()];
    let o = mapbench(&args, tmp.path());
    let log = text(&o);
    assert_eq!(o.status.code(), Some(0), "{log}");
    assert!(log.contains("history: batch 1 (2 runs of h) appended to") && !log.contains("not updated"), "{log}");
    assert!(log.contains("warning: the trend page was not rendered:") && log.contains("--config h --out DIR"), "{log}");
    let meta = |out: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(out.join("meta.json")).unwrap()).unwrap()
    };
    let m = meta(&out);
    assert_eq!(m["history_outcome"]["outcome"], "appended", "{m}");
    assert_eq!(m["history_outcome"]["batch_id"], 1);
    assert!(m["history_outcome"]["trend"].is_null() && m["history_outcome"]["trend_error"].is_string(), "{m}");
    assert_eq!(m["history"], db.display().to_string());
    assert!(!std::fs::read_to_string(out.join("index.html")).unwrap().contains("History:"));

    // every run resumed from the appended batch: not appended twice, however often resumed
    std::fs::remove_file(tmp.path().join("h-trend")).unwrap();
    for _ in 0..2 {
        let o = mapbench(&[&args[..], &["--resume"]].concat(), tmp.path());
        let log = text(&o);
        assert_eq!(o.status.code(), Some(0), "{log}");
        assert!(log.contains("as batch 1 (appended by an earlier batch of this folder); not appended again"), "{log}");
        assert_eq!(HistoryDb::open_existing(&db).unwrap().batches(None, None).unwrap().len(), 1);
        let m = meta(&out);
        assert_eq!(
            (&m["history_outcome"]["outcome"], &m["history_outcome"]["batch_id"]),
            (&"already_in".into(), &1.into())
        );
        assert_eq!(m["history"], db.display().to_string(), "the batch is in the history");
    }
    // a new batch is appended, and its page is rendered and linked
    let o = mapbench(&args, tmp.path());
    assert!(text(&o).contains("history: batch 2 (2 runs of h)"), "{}", text(&o));
    assert!(std::fs::read_to_string(out.join("index.html")).unwrap().contains("href=\"../h-trend/h/index.html\""));

    // a failed append: exit 2, meta.json says failed, no link
    rusqlite::Connection::open(&db).unwrap().execute_batch("PRAGMA user_version = 10").unwrap();
    let o = mapbench(&args, tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let m = meta(&out);
    assert_eq!(m["history_outcome"]["outcome"], "failed", "{m}");
    assert!(m["history"].is_null() && !text(&o).contains("appended to"), "{m}");
    assert!(!std::fs::read_to_string(out.join("index.html")).unwrap().contains("History:"));
}

/// The nightly gate: `history --fail-on-regression` says "first" and exits 0 after one batch,
/// exits 0 when the next night changed nothing, 1 with the regression named when a night needs
/// more iterations (a tighter tolerance stands in for a worse solver), and 2 when a night lost
/// runs.
#[test]
fn the_nightly_gate_on_the_history_exits_by_the_rules_of_check() {
    let tmp = tempfile::tempdir().unwrap();
    let night = |n: usize, extra: &str| {
        let cfg = write_config(tmp.path(), &format!("{CONFIG}{extra}"));
        let out = tmp.path().join(format!("n{n}"));
        let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp.path());
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        let o = mapbench(&["history", "--config", "h", "--out", "trend", "--fail-on-regression"], tmp.path());
        (o.status.code(), text(&o))
    };
    let (code, said) = night(1, "");
    assert_eq!(code, Some(0), "{said}");
    assert!(said.contains("batch 1 is the first of config h"), "{said}");
    let (code, said) = night(2, "");
    assert_eq!(code, Some(0), "{said}");
    assert!(said.contains("batch 2 (") && said.contains("0 regressions"), "{said}");
    let (code, said) = night(3, "[stop]\ngrad_tol = 1e-14\n");
    assert_eq!(code, Some(1), "{said}");
    assert!(said.contains("REGRESSIONS") && said.contains("bumpy_1k param sd kp-newton"), "{said}");
    assert!(said.contains("config hash differs"), "{said}");
    // The same settings again: nothing moved.
    let (code, said) = night(4, "[stop]\ngrad_tol = 1e-14\n");
    assert_eq!(code, Some(0), "{said}");
    let fewer = CONFIG.replace("\"kp-newton\", ", "");
    let cfg = write_config(tmp.path(), &format!("{fewer}[stop]\ngrad_tol = 1e-14\n"));
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", "n5"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = mapbench(&["history", "--config", "h", "--out", "trend", "--fail-on-regression"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("kp-newton"), "the missing run is named: {}", text(&o));
}

/// The authalic nightly's gate: at the paper's fixed budget every run is `budget`, and a night
/// whose authalic energy at the budget rose (a smaller budget stands in for a worse method) is
/// a regression of that run, named with its energy.
#[test]
fn the_nightly_gate_holds_the_authalic_energy_at_the_budget() {
    let tmp = tempfile::tempdir().unwrap();
    let night = |n: usize, budget: usize| {
        let cfg = write_config(
            tmp.path(),
            &format!(
                "name = \"a\"\ntask = \"authalic\"\ndatasets = [\"bumpy_1k\"]\nsolvers = [\"sem\", \"aem-cg\"]\n\
                 [stop]\nmax_iters = {budget}\n"
            ),
        );
        let out = tmp.path().join(format!("n{n}"));
        let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp.path());
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        let (header, rows) = read_csv(&out.join("summary.csv"));
        let status = header.iter().position(|h| h == "status").unwrap();
        assert!(rows.iter().all(|r| r[status] == "budget"), "{rows:?}");
        let o = mapbench(&["history", "--config", "a", "--out", "trend", "--fail-on-regression"], tmp.path());
        (o.status.code(), text(&o))
    };
    assert_eq!(night(1, 20).0, Some(0));
    let (code, said) = night(2, 20);
    assert_eq!(code, Some(0), "{said}");
    assert!(said.contains("0 regressions"), "{said}");
    let (code, said) = night(3, 10);
    assert_eq!(code, Some(1), "{said}");
    assert!(said.contains("REGRESSIONS") && said.contains("bumpy_1k authalic authalic aem-cg"), "{said}");
    let regressions = said.split("Improvements").next().unwrap_or_default();
    assert!(regressions.lines().any(|l| l.contains("aem-cg") && l.contains("final_energy")), "{said}");
}
