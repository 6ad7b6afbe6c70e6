//! Run-folder hardening: corrupt CSVs are refused by file and
//! line, `--resume` re-runs a run with a missing file, and a run whose
//! files cannot be written fails alone.

use crate::common;

use common::*;
use std::path::{Path, PathBuf};

const TWO_RUNS: &str =
    "name = \"h\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\", \"cm\"]\n";

/// A finished two-run batch in `tmp/out`.
fn two_runs(tmp: &Path) -> (PathBuf, PathBuf) {
    let cfg = write_config(tmp, TWO_RUNS);
    let out = tmp.join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    (cfg, out)
}

/// `report` on `out` fails with exit 2 and a message containing every one of `needles`.
fn report_refuses(out: &Path, needles: &[&str]) {
    let o = mapbench(&["report", out.to_str().unwrap()], out);
    let log = text(&o);
    assert_eq!(o.status.code(), Some(2), "{log}");
    for n in needles {
        assert!(log.contains(n), "`{n}` not in: {log}");
    }
}

#[test]
fn report_names_the_file_and_line_of_a_corrupt_iteration_csv_or_summary() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, out) = two_runs(tmp.path());
    let csv = out.join("runs/bumpy_1k__sd__cm.csv");
    let good = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = good.lines().collect();
    assert!(lines.len() >= 4, "{good}");
    let name = "runs/bumpy_1k__sd__cm.csv";
    let last = lines.len();

    // cut in the middle of the last row (its last cell parses as a shorter number)
    std::fs::write(&csv, &good[..good.len() - 2]).unwrap();
    report_refuses(&out, &[name, &format!("line {last}")]);
    // cut in the middle of the last row, so that it has too few cells
    let cut = good.len() - 1 - lines[last - 1].len() / 2;
    std::fs::write(&csv, &good[..cut]).unwrap();
    report_refuses(&out, &[name, &format!("line {last}")]);
    // a cell that is not a number: the file, the line and the column
    let mut bad: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
    let mut cells: Vec<&str> = lines[2].split(',').collect();
    cells[1] = "abc";
    bad[2] = cells.join(",");
    std::fs::write(&csv, bad.join("\n") + "\n").unwrap();
    report_refuses(&out, &[name, "line 3", "energy", "abc"]);
    // binary content
    std::fs::write(&csv, [0xffu8, 0xfe, 0x00, 0x01, b',', 0x80, b'\n', 0xc3, 0x28, b'\n']).unwrap();
    report_refuses(&out, &[name, "line 1"]);
    // truncated at a row boundary: one row short (iteration 0 has a row too)
    std::fs::write(&csv, lines[..last - 1].join("\n") + "\n").unwrap();
    report_refuses(&out, &[name, &format!("{} rows", last - 2), &format!("{} iterations", last - 2)]);
    // intact again: the report renders
    std::fs::write(&csv, &good).unwrap();
    let o = mapbench(&["report", out.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));

    let summary = out.join("summary.csv");
    let good = std::fs::read_to_string(&summary).unwrap();
    // the last row cut before its last cell: it would read as a row without that value
    let trimmed = good.trim_end_matches('\n');
    let cut = trimmed.rfind(',').unwrap() + 1;
    std::fs::write(&summary, &good[..cut]).unwrap();
    report_refuses(&out, &["summary.csv", "line 3"]);
    // a cell that is not a number
    let mut rows: Vec<String> = good.lines().map(String::from).collect();
    let mut cells: Vec<String> = good.lines().nth(1).unwrap().split(',').map(String::from).collect();
    cells[4] = "many".into();
    rows[1] = cells.join(",");
    std::fs::write(&summary, rows.join("\n") + "\n").unwrap();
    report_refuses(&out, &["summary.csv", "line 2", "vertices", "many"]);
    // binary content
    std::fs::write(&summary, [0xffu8, 0xfe, 0x00, b'\n', 0x80, b'\n']).unwrap();
    report_refuses(&out, &["summary.csv", "line 1"]);
    // empty: not a summary of no runs
    std::fs::write(&summary, "").unwrap();
    report_refuses(&out, &["summary.csv", "line 1", "no column `dataset`"]);
}

#[test]
fn resume_reruns_a_finished_run_whose_map_was_deleted() {
    let tmp = tempfile::tempdir().unwrap();
    // Every map kept: each finished run must have its own.
    let cfg = write_config(tmp.path(), &format!("{TWO_RUNS}maps = \"all\"\n"));
    let out = tmp.path().join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let map = out.join("uv/bumpy_1k__sd__cm.uv.gz");
    let obj = std::fs::read(&map).unwrap();
    std::fs::remove_file(&map).unwrap();
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--resume"], tmp.path());
    let log = text(&o);
    assert_eq!(o.status.code(), Some(0), "{log}");
    assert_eq!(log.matches("resumed, ").count(), 1, "{log}");
    assert!(log.contains("bumpy_1k sd kp-newton: resumed, ran (target)"), "{log}");
    assert!(log.contains("bumpy_1k sd cm: ran (target)"), "{log}");
    // the map is back, and the same (the solvers are deterministic)
    assert_eq!(std::fs::read(&map).unwrap(), obj);
    assert!(out.join("plots/bumpy_1k__sd__cm__map.png").is_file());
}

#[test]
fn a_run_whose_files_cannot_be_written_fails_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(tmp.path(), TWO_RUNS);
    let out = tmp.path().join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // A folder where the first run's CSV goes, and no map of it from the first batch.
    let blocked = out.join("runs/bumpy_1k__sd__kp-newton.csv");
    std::fs::remove_file(&blocked).unwrap();
    std::fs::create_dir_all(&blocked).unwrap();
    let _ = std::fs::remove_file(out.join("uv/bumpy_1k__sd__kp-newton.uv.gz"));
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp.path());
    let log = text(&o);
    assert_eq!(o.status.code(), Some(1), "{log}");
    let mut r = csv::Reader::from_path(out.join("summary.csv")).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let rows: Vec<csv::StringRecord> = r.records().map(Result::unwrap).collect();
    assert_eq!(rows.len(), 2, "{log}");
    assert_eq!(&rows[0][col("solver")], "kp-newton");
    assert_eq!(&rows[0][col("status")], "failed");
    assert!(rows[0][col("error")].contains("runs/bumpy_1k__sd__kp-newton.csv"), "{:?}", rows[0]);
    assert_eq!(&rows[1][col("status")], "ok", "{log}");
    assert!(out.join("runs/bumpy_1k__sd__cm.csv").is_file());
    assert!(out.join("index.html").is_file());
    // nothing half-written is left behind, and no map of the failed run
    let tmp_files = std::fs::read_dir(out.join("runs"))
        .unwrap()
        .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().contains(".tmp"))
        .count();
    assert_eq!(tmp_files, 0);
    assert!(!out.join("uv/bumpy_1k__sd__kp-newton.uv.gz").exists());
    // once the folder is gone, --resume runs the failed run again and reuses the other
    std::fs::remove_dir(&blocked).unwrap();
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--resume"], tmp.path());
    let log = text(&o);
    assert_eq!(o.status.code(), Some(0), "{log}");
    assert_eq!(log.matches("resumed, ").count(), 1, "{log}");
    assert!(log.contains("bumpy_1k sd kp-newton: ran (target)"), "{log}");
}
