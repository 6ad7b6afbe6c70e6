use super::*;
use crate::plan::Task;
use crate::report::compare::{to_html, to_markdown};
use crate::run_folder::meta::Meta;
use crate::run_folder::Status;
use serde_json::json;

/// A converged run: `time_s` with `repeats` and its spread, `time_norm` = time_s / 2.
fn row(dataset: &str, solver: &str, iterations: usize, t: (f64, f64, f64), repeats: usize) -> SummaryRow {
    SummaryRow {
        dataset: dataset.into(),
        task: Task::Param,
        energy: "sd".into(),
        solver: solver.into(),
        iterations: Some(iterations),
        final_energy: Some(2.0),
        status: Status::Ok,
        flips: Some(0),
        time_s: Some(t.0),
        time_s_min: Some(t.1),
        time_s_max: Some(t.2),
        repeats: Some(repeats),
        time_norm: Some(t.0 / 2.0),
        ..Default::default()
    }
}

fn meta(max_iters: usize, repeat: usize) -> Meta {
    let energy = |e: &str| json!({"param": {"energy": {"name": e}, "settings": {"solver": {"stop": {"max_iters": max_iters, "grad_tol": 1e-3}}}}});
    // The config as written: `[stop]` only when the batch set it.
    let mut config = json!({"name": "n", "datasets": ["d"]});
    if max_iters != 1000 {
        config["stop"] = json!({"max_iters": max_iters});
    }
    serde_json::from_value(json!({
        "config": config,
        "settings_per_energy": {"sd": energy("sd"), "bconf": energy("bconf")},
        "repeat": repeat, "jobs": 1, "git_revision": "0123456789abcdef0123", "git_dirty": true, "host": "h",
    }))
    .unwrap()
}

fn side(name: &str, rows: Vec<SummaryRow>) -> Side {
    Side { name: name.into(), rows, meta: Some(meta(1000, 3)) }
}

const SPREAD: (f64, f64, f64) = (1.0, 0.9, 1.1);

#[test]
fn exit_codes_no_change_regression_and_nothing_shared() {
    let a = side("A", vec![row("d", "kp", 10, SPREAD, 3), row("d", "cm", 8, SPREAD, 3)]);
    let same = compare(&a, &a, CompareOptions::default());
    assert_eq!((same.exit_code(), same.pairs.len(), same.regressions()), (0, 2, 0));
    let b = side("B", vec![row("d", "kp", 11, SPREAD, 3), row("d", "cm", 7, SPREAD, 3)]);
    let c = compare(&a, &b, CompareOptions::default());
    assert_eq!((c.exit_code(), c.regressions(), c.improvements()), (1, 1, 1));
    // The iteration tolerance is check's per-record one, given for every run.
    let tolerant = CompareOptions { iterations_tolerance: 1, ..CompareOptions::default() };
    assert_eq!(compare(&a, &b, tolerant).exit_code(), 0);
    // Worse status and higher energy, by the same rules.
    let worse = GatedRun { status: Status::NotConverged, ..GatedRun::from(&a.rows[0]) };
    let mut nc = a.rows[0].clone();
    nc.status = worse.status;
    let c = compare(&a, &side("B", vec![nc]), CompareOptions::default());
    assert_eq!((c.exit_code(), c.pairs[0].changes[0].metric), (1, "status"));
    let mut higher = a.rows[0].clone();
    higher.final_energy = Some(2.0 * (1.0 + 1e-5));
    assert_eq!(compare(&a, &side("B", vec![higher.clone()]), CompareOptions::default()).exit_code(), 1);
    let loose = CompareOptions { energy_rtol: 1e-4, ..CompareOptions::default() };
    assert_eq!(compare(&a, &side("B", vec![higher]), loose).exit_code(), 0);
    // No run in both: exit 2, whatever else.
    let other = side("C", vec![row("e", "kp", 10, SPREAD, 3)]);
    let c = compare(&a, &other, CompareOptions::default());
    assert_eq!((c.exit_code(), c.only_a.len(), c.only_b.len()), (2, 2, 1));
    assert!(to_markdown(&c).contains("(exit 2)"));
}

#[test]
fn times_are_flagged_only_outside_the_spread_and_never_gated_by_default() {
    let a = side("A", vec![row("d", "kp", 10, SPREAD, 3), row("d", "cm", 8, SPREAD, 3)]);
    // kp: 1.4x slower but the intervals overlap; cm: 1.2x, disjoint.
    let b = side("B", vec![row("d", "kp", 10, (1.4, 1.05, 1.6), 3), row("d", "cm", 8, (1.2, 1.15, 1.3), 3)]);
    let c = compare(&a, &b, CompareOptions::default());
    assert_eq!(c.unit, TimeMeasure::Norm);
    let flags: Vec<_> = c.pairs.iter().map(|p| p.time.unwrap().change).collect();
    assert_eq!(flags, [None, Some(TimeChange::Slower)]);
    assert!((c.pairs[1].time.unwrap().ratio().unwrap() - 1.2).abs() < 1e-12);
    assert_eq!((c.exit_code(), c.times(TimeChange::Slower)), (0, 1), "times are not gated");
    let md = to_markdown(&c);
    assert!(md.contains("spreads disjoint") && md.contains("Times are never gated"), "{md}");
    // In time_norm units (time_s / 2 here), spread scaled alike.
    assert!(md.contains("| 0.500 (0.450–0.550) | 0.600 (0.575–0.650) | 1.20 | slower"), "{md}");
    // --time-regressions: a slower time is a regression.
    let gated = CompareOptions { time_regressions: true, ..CompareOptions::default() };
    assert_eq!(compare(&a, &b, gated).exit_code(), 1);
    // Faster beyond the spread: labelled, never a regression.
    let fast = side("B", vec![row("d", "kp", 10, (0.5, 0.45, 0.55), 3)]);
    let c = compare(&a, &fast, gated);
    assert_eq!((c.pairs[0].time.unwrap().change, c.exit_code()), (Some(TimeChange::Faster), 0));
}

#[test]
fn single_samples_use_asvs_factor_and_seconds_without_time_norm() {
    let one = |t: f64| row("d", "kp", 10, (t, t, t), 1);
    let a = side("A", vec![one(1.0)]);
    for (t, flag) in [(1.09, None), (1.11, Some(TimeChange::Slower)), (0.9, Some(TimeChange::Faster))] {
        let c = compare(&a, &side("B", vec![one(t)]), CompareOptions::default());
        assert_eq!(c.pairs[0].time.unwrap().change, flag, "{t}");
    }
    let c = compare(&a, &side("B", vec![one(1.2)]), CompareOptions::default());
    assert!(to_markdown(&c).contains("single sample, ratio beyond 1.1"));
    // A folder without time_norm: both compare time_s.
    let mut old = one(1.2);
    old.time_norm = None;
    let c = compare(&a, &side("B", vec![old]), CompareOptions::default());
    assert_eq!(c.unit, TimeMeasure::Seconds);
    assert!(to_markdown(&c).contains("| 1.00 | 1.20 | 1.20 | slower"));
    // A run without a time (failed) has none to compare.
    let failed = SummaryRow { status: Status::Failed, time_s: None, time_norm: None, ..one(1.0) };
    let c = compare(&a, &side("B", vec![failed]), CompareOptions::default());
    assert_eq!((c.pairs[0].time, c.exit_code()), (None, 1));
}

#[test]
fn runs_on_one_side_only_are_listed() {
    let a = side("A", vec![row("d", "kp", 10, SPREAD, 3), row("gone", "kp", 5, SPREAD, 3)]);
    let b = side("B", vec![row("d", "kp", 10, SPREAD, 3), row("new", "cm", 7, SPREAD, 3)]);
    let c = compare(&a, &b, CompareOptions::default());
    assert_eq!(c.exit_code(), 0, "a run on one side only is not a regression");
    let md = to_markdown(&c);
    let only_a = md.find("### Only in A").unwrap();
    let only_b = md.find("### Only in B").unwrap();
    assert!(md[only_a..only_b].contains("| gone | param | sd | kp | 5 | ok |"), "{md}");
    assert!(md[only_b..].contains("| new | param | sd | cm | 7 | ok |"), "{md}");
    assert!(md.contains("1 only in A, 1 only in B"));
}

#[test]
fn differing_settings_head_the_output() {
    let a = side("A", vec![row("d", "kp", 10, SPREAD, 3)]);
    let mut b = side("B", vec![row("d", "kp", 5, SPREAD, 3)]);
    b.meta = Some(meta(5, 1));
    let c = compare(&a, &b, CompareOptions::default());
    let d = c.settings.as_ref().unwrap();
    let line = |s: &str| d.iter().find(|x| x.setting == s).map(|x| (x.a.as_str(), x.b.as_str()));
    assert_eq!(line("repeat"), Some(("3", "1")));
    assert_eq!(line("config.stop.max_iters"), Some(("(unset)", "5")));
    // Both energies moved alike: one line.
    assert_eq!(line("settings[bconf, sd].param.settings.solver.stop.max_iters"), Some(("1000", "5")));
    assert_eq!(d.len(), 3, "{d:?}");
    let md = to_markdown(&c);
    let first = md.find("### ").unwrap();
    assert!(md[first..].starts_with("### Settings that differ"), "{md}");
    assert!(md.contains("| repeat | 3 | 1 |") && md.contains("| git revision | 0123456789ab (dirty) |"), "{md}");
    // Identical settings, and a folder without meta.json, say so.
    assert!(to_markdown(&compare(&a, &a, CompareOptions::default())).contains("### Settings\n\nThe same in both"));
    b.meta = None;
    let c = compare(&a, &b, CompareOptions::default());
    assert_eq!(c.settings, None);
    assert!(to_markdown(&c).contains("Not compared: a folder has no meta.json."));
    // An energy in one batch only is one line, not one per key.
    let mut m = meta(1000, 3);
    m.settings_per_energy.as_mut().unwrap().remove("bconf");
    let d = settings_diff(&meta(1000, 3), &m);
    assert_eq!(d, [SettingDiff { setting: "settings[bconf]".into(), a: "(in the batch)".into(), b: "(unset)".into() }]);
}

#[test]
fn html_is_one_escaped_page_and_markdown_cells_keep_their_pipes() {
    let mut a = side("A<&>|", vec![row("d", "kp", 10, SPREAD, 3)]);
    a.meta.as_mut().unwrap().config["name"] = json!("x|<y>");
    let b = side("B", vec![row("d", "kp", 12, SPREAD, 3)]);
    let c = compare(&a, &b, CompareOptions::default());
    let html = to_html(&c);
    assert!(html.starts_with("<!doctype html>\n<html lang=\"en\">") && html.ends_with("</body>\n</html>\n"));
    for (open, close) in [("<table>", "</table>"), ("<tr>", "</tr>"), ("<h3>", "</h3>"), ("<p>", "</p>")] {
        assert_eq!(html.matches(open).count(), html.matches(close).count(), "{open}");
    }
    assert!(html.contains("A&lt;&amp;&gt;|") && html.contains("x|&lt;y&gt;") && !html.contains("<y>"));
    assert!(html.contains("<td><b>regression: iterations</b></td>"), "{html}");
    let md = to_markdown(&c);
    assert!(md.contains("| config.name | x\\|<y> | n |"), "{md}");
}

#[test]
fn a_folder_listing_a_run_twice_is_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let r = row("d", "kp", 10, SPREAD, 3);
    run_folder::write_summary(&run_folder::summary_csv(dir.path()), &[r.clone(), r]).unwrap();
    let e = format!("{:#}", Side::load(dir.path()).unwrap_err());
    assert!(e.contains("summary.csv: run d param sd kp appears twice"), "{e}");
    let bad = CompareOptions { energy_rtol: -1.0, ..CompareOptions::default() };
    let e = format!("{:#}", compare_folders(dir.path(), dir.path(), bad).unwrap_err());
    assert!(e.contains("--energy-rtol") && e.contains("non-negative"), "{e}");
}

/// Found by review: the revision was cut at byte 12, a panic inside a multi-byte character.
#[test]
fn a_non_ascii_revision_is_shortened_by_characters() {
    let m = Meta { git_revision: Some("ééééééééééééééé".into()), ..Meta::default() };
    let p = provenance(Some(&m), None);
    assert_eq!(p[0], ("git revision".to_string(), "éééééééééééé".to_string(), "-".to_string()));
}
