//! `mapbench compare RUN_A RUN_B` end to end: real batches of one config with different
//! `max_iters` (a real regression), its exit codes 0/1/2, the settings heading the output,
//! the time flags on hand-made folders, and `--html`.

use crate::common;
use common::{mapbench, text, write_config};
use mapbench::plan::Task;
use mapbench::run_folder::{self, Status, SummaryRow};
use std::path::Path;

/// A run folder of hand-made rows written by the run folder's own writer (no meta.json).
fn folder(dir: &Path, rows: &[SummaryRow]) {
    run_folder::write_summary(&run_folder::summary_csv(dir), rows).unwrap();
}

fn row(solver: &str, t: (f64, f64, f64), repeats: usize) -> SummaryRow {
    SummaryRow {
        dataset: "m".into(),
        task: Task::Param,
        energy: "sd".into(),
        solver: solver.into(),
        iterations: Some(10),
        final_energy: Some(2.0),
        status: Status::Ok,
        flips: Some(0),
        time_s: Some(t.0),
        time_s_min: Some(t.1),
        time_s_max: Some(t.2),
        repeats: Some(repeats),
        ..Default::default()
    }
}

#[test]
fn a_lower_max_iters_is_a_regression_headed_by_the_setting() {
    let tmp = tempfile::tempdir().unwrap();
    let body = "datasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\", \"cm\"]\n";
    let a = write_config(tmp.path(), &format!("name = \"a\"\n{body}"));
    let o = mapbench(&["run", a.to_str().unwrap(), "--out", "A", "--jobs", "1"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let b = write_config(tmp.path(), &format!("name = \"b\"\n{body}[stop]\nmax_iters = 3\n"));
    let o = mapbench(&["run", b.to_str().unwrap(), "--out", "B", "--jobs", "1"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));

    let o = mapbench(&["compare", "A", "A"], tmp.path());
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(t.contains("2 runs in both folders: 0 regressions") && t.contains("The same in both meta.json"), "{t}");

    let o = mapbench(&["compare", "A", "B", "--html", "out/cmp.html"], tmp.path());
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    let stdout = String::from_utf8_lossy(&o.stdout);
    // The differing settings come first, then the regressions: capped at 3, kp-newton and cm
    // (8 iterations each on bumpy_1k from the common start) no longer converge.
    let settings = stdout.find("### Settings that differ").unwrap();
    assert_eq!(stdout.find("### "), Some(settings), "{stdout}");
    assert!(stdout.contains("| config.stop.max_iters | (unset) | 3 |"), "{stdout}");
    assert!(stdout.contains("| settings[sd].param.settings.solver.stop.max_iters | 1000 | 3 |"), "{stdout}");
    let regressions = stdout.find("### Regressions").unwrap();
    assert!(settings < regressions);
    assert!(stdout.contains("| bumpy_1k param sd kp-newton | status | ok | not_converged |"), "{stdout}");
    assert!(stdout.contains("| bumpy_1k | param | sd | cm | 8 | 3 | ok | not_converged |"), "{stdout}");
    // time_norm: both batches are calibrated.
    assert!(stdout.contains("Times compare time_norm") && stdout.contains("Times are never gated"), "{stdout}");
    let html = std::fs::read_to_string(tmp.path().join("out/cmp.html")).unwrap();
    assert!(html.starts_with("<!doctype html>") && html.ends_with("</html>\n"));
    assert_eq!(html.matches("<table>").count(), html.matches("</table>").count());
    assert!(html.contains("<h3>Settings that differ</h3>") && html.contains("not_converged"));
    // Raising the cap back: the status improves, but by check's rule more iterations are a
    // regression whatever the status (3 capped -> 8 converged).
    let o = mapbench(&["compare", "B", "A"], tmp.path());
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(t.contains("| bumpy_1k param sd kp-newton | iterations | 3 | 8 | +5 |"), "{t}");
    assert!(t.contains("| bumpy_1k param sd kp-newton | status | not_converged | ok |"), "{t}");

    // A folder sharing no run with A: exit 2, both sides listed.
    folder(&tmp.path().join("C"), &[row("kp-newton", (1.0, 1.0, 1.0), 1)]);
    let o = mapbench(&["compare", "A", "C"], tmp.path());
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.contains("### Only in A") && t.contains("### Only in B") && t.contains("| m | param | sd | kp-newton |"));
    assert!(t.contains("Not compared: a folder has no meta.json"), "{t}");
    // Not a run folder: exit 2 naming the file.
    let o = mapbench(&["compare", "A", "nowhere"], tmp.path());
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("nowhere/summary.csv"), "{}", text(&o));
}

#[test]
fn times_are_flagged_outside_the_spread_or_beyond_asvs_factor_and_gated_only_on_request() {
    let tmp = tempfile::tempdir().unwrap();
    // fast: overlapping spreads (1.3x, noise); slow: disjoint (1.2x); single: one sample, 1.15x.
    folder(
        &tmp.path().join("A"),
        &[row("fast", (1.0, 0.9, 1.1), 5), row("slow", (1.0, 0.9, 1.1), 5), row("single", (1.0, 1.0, 1.0), 1)],
    );
    folder(
        &tmp.path().join("B"),
        &[row("fast", (1.3, 1.05, 1.5), 5), row("slow", (1.2, 1.15, 1.3), 5), row("single", (1.15, 1.15, 1.15), 1)],
    );
    let o = mapbench(&["compare", "A", "B"], tmp.path());
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "times are not gated: {t}");
    assert!(t.contains("2 slower and 0 faster times (not gated)"), "{t}");
    assert!(t.contains("| m param sd slow | 1.00 (0.900–1.10) | 1.20 (1.15–1.30) | 1.20 | slower | spreads disjoint |"));
    assert!(t.contains("| m param sd single | 1.00 | 1.15 | 1.15 | slower | single sample, ratio beyond 1.1 |"));
    assert!(!t.contains("| m param sd fast | 1.000"), "overlapping spreads are not a change: {t}");
    assert!(t.contains("Times compare time_s"), "no time_norm in hand-made folders: {t}");
    let o = mapbench(&["compare", "A", "B", "--time-regressions"], tmp.path());
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("Time changes (slower gated)"));
}

/// `check` against a baseline of A and `compare A B` judge a run whose final energy was NaN
/// (not converged) and is finite now (ok) alike, and the reverse too (`compare`
/// called the first a regression, `check` an improvement, since the baseline wrote NaN as null).
#[test]
fn check_and_compare_share_the_rule_for_nan_energies() {
    let tmp = tempfile::tempdir().unwrap();
    let nan_run =
        SummaryRow { final_energy: Some(f64::NAN), status: Status::NotConverged, ..row("cm", (1.0, 1.0, 1.0), 1) };
    folder(&tmp.path().join("nan"), &[nan_run]);
    folder(&tmp.path().join("ok"), &[row("cm", (1.0, 1.0, 1.0), 1)]);
    for (a, b, code, needle) in [("nan", "ok", 0, "finite again"), ("ok", "nan", 1, "not finite")] {
        let o = mapbench(&["compare", a, b], tmp.path());
        let t = text(&o);
        assert_eq!(o.status.code(), Some(code), "compare {a} {b}: {t}");
        let (x, y) = if code == 0 { ("NaN", "2.0000000000") } else { ("2.0000000000", "NaN") };
        assert!(t.contains(&format!("| final_energy | {x} | {y} | {needle} |")), "compare {a} {b}: {t}");
        let base = tmp.path().join(format!("{a}.json"));
        let o = mapbench(&["baseline", a, "--write", base.to_str().unwrap()], tmp.path());
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        let o = mapbench(&["check", b, "--baseline", base.to_str().unwrap()], tmp.path());
        let t = text(&o);
        assert_eq!(o.status.code(), Some(code), "check {b} against {a}: {t}");
        assert!(t.contains(needle), "check {b} against {a}: {t}");
    }
}

/// Negative and NaN times are a corrupt summary, refused by file, line and column; a zero
/// time is no measurement: no ratio, never flagged (a -35x "ratio", exit 0).
#[test]
fn negative_and_nan_times_are_refused_and_zero_has_no_ratio() {
    let tmp = tempfile::tempdir().unwrap();
    folder(&tmp.path().join("A"), &[row("cm", (1.0, 1.0, 1.0), 1)]);
    for (name, t) in [("neg", (-35.0, -35.0, -35.0)), ("nan", (f64::NAN, 1.0, 1.0))] {
        folder(&tmp.path().join(name), &[row("cm", t, 1)]);
        let o = mapbench(&["compare", "A", name], tmp.path());
        let log = text(&o);
        assert_eq!(o.status.code(), Some(2), "{log}");
        assert!(log.contains(&format!("{name}/summary.csv: line 2: column")) && log.contains("`time_s`"), "{log}");
    }
    let mut min = row("cm", (1.0, -1.0, 1.0), 3);
    min.time_norm = Some(0.5);
    folder(&tmp.path().join("min"), &[min]);
    let log = text(&mapbench(&["compare", "A", "min"], tmp.path()));
    assert!(log.contains("`time_s_min`: `-1`"), "{log}");
    folder(&tmp.path().join("zero"), &[row("cm", (0.0, 0.0, 0.0), 1)]);
    let o = mapbench(&["compare", "A", "zero"], tmp.path());
    let log = text(&o);
    assert_eq!(o.status.code(), Some(0), "{log}");
    assert!(log.contains("0 slower and 0 faster times") && !log.contains("| 0.00 |"), "{log}");
}
