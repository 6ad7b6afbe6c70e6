//! The summary's reader and writer, against hand-made rows and files.

use super::*;
use solvers::solver::StopReason;

/// Task, status and stop reason are enums up to the file: their column strings are
/// written and read back to the same values, a failed run's reason as `error`.
#[test]
fn typed_columns_round_trip_through_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let row = |task, status, stop_reason| SummaryRow {
        dataset: "m".into(),
        task,
        energy: "sd".into(),
        solver: "cm".into(),
        status,
        stop_reason,
        ..Default::default()
    };
    let mut skipped = row(Task::Param, Status::Skipped, Some(RunStop::Skipped));
    skipped.error = "slim is not defined for nh: its reweighting ...".into();
    let mut rows = vec![
        row(Task::Param, Status::Ok, Some(StopReason::GradientTolerance.into())),
        row(Task::Deform, Status::NotConverged, Some(StopReason::Timeout.into())),
        row(Task::Authalic, Status::Failed, None),
        skipped,
    ];
    (rows[0].shifted_iters, rows[0].clamped_iters, rows[0].cg_capped_iters) = (Some(2), Some(0), Some(5));
    write_summary(&dir.path().join("summary.csv"), &rows).unwrap();
    let text = std::fs::read_to_string(dir.path().join("summary.csv")).unwrap();
    let cells: Vec<Vec<&str>> = text.lines().skip(1).map(|l| l.split(',').collect()).collect();
    let col = |name: &str| SUMMARY_COLUMNS.iter().position(|c| *c == name).unwrap();
    let column = |name: &str| cells.iter().map(|r| r[col(name)]).collect::<Vec<_>>();
    assert_eq!(column("task"), ["param", "deform", "authalic", "param"]);
    assert_eq!(column("status"), ["ok", "not_converged", "failed", "skipped"]);
    assert_eq!(column("stop_reason"), ["grad_tol", "timeout", "error", "skipped"]);
    assert_eq!(read_summary(dir.path()).unwrap(), rows);
    let bad = text.replace("timeout", "timed_out");
    std::fs::write(dir.path().join("summary.csv"), bad).unwrap();
    let e = read_summary(dir.path()).unwrap_err().to_string();
    assert!(e.contains("summary.csv: line 3: unknown stop reason 'timed_out'"), "{e}");
}

/// `cg_capped_iters` round-trips, after `verdict` and before `gap_scale` and the target
/// columns; a summary written before the column existed reads it as empty.
#[test]
fn cg_capped_iters_round_trips_and_an_older_file_reads_without_it() {
    let dir = tempfile::tempdir().unwrap();
    let row = |solver: &str, capped| SummaryRow {
        dataset: "sack_1k".into(),
        energy: "sarap".into(),
        solver: solver.into(),
        status: Status::Ok,
        cg_capped_iters: capped,
        to_targets: vec![ToTarget { tau: 1e-6, iters: Some(4), time_s: Some(0.25) }],
        ..Default::default()
    };
    let rows = vec![row("kp-newton-cg", Some(210)), row("kp-newton", None)];
    let path = dir.path().join("summary.csv");
    write_summary(&path, &rows).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let at = header.iter().position(|c| *c == "cg_capped_iters").unwrap();
    assert_eq!(
        (header[at - 1], header[at + 1], header[at + 2], header[at + 3]),
        ("verdict", "gap_scale", "verified_snapshots", "peak_growth_mb")
    );
    let cells: Vec<Vec<&str>> = text.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!((cells[0][at], cells[1][at]), ("210", ""));
    assert_eq!(read_summary(dir.path()).unwrap(), rows);
    // the file as written before the column: every line without its cell
    let older: String = text
        .lines()
        .map(|l| {
            let mut c: Vec<&str> = l.split(',').collect();
            c.remove(at);
            c.join(",") + "\n"
        })
        .collect();
    std::fs::write(&path, older).unwrap();
    let back = read_summary(dir.path()).unwrap();
    assert_eq!(back.iter().map(|r| r.cg_capped_iters).collect::<Vec<_>>(), [None, None]);
    assert_eq!(back[0].to_targets, rows[0].to_targets);
}

/// `gap_scale`, `verified_snapshots` and `peak_growth_mb` round-trip as the last fixed
/// columns; a summary written before they existed reads them as empty.
#[test]
fn gap_scale_round_trips_and_an_older_file_reads_without_it() {
    let dir = tempfile::tempdir().unwrap();
    let row = |solver: &str, scale| SummaryRow {
        dataset: "archer".into(),
        task: Task::Deform,
        energy: "sd".into(),
        solver: solver.into(),
        status: Status::Ok,
        gap_scale: scale,
        verified_snapshots: scale.map(|_| 12),
        peak_growth_mb: scale.map(|_| 41.5),
        cpu_s: scale.map(|_| 1.25),
        confined: scale.map(|_| "writes reads tracing".to_string()),
        ..Default::default()
    };
    let rows = vec![row("kp-newton", Some(0.2103)), row("aqp", None)];
    let path = dir.path().join("summary.csv");
    write_summary(&path, &rows).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.lines().next().unwrap().ends_with(
        ",cg_capped_iters,gap_scale,verified_snapshots,peak_growth_mb,start_energy,ideal_energy,ref_certified,\
         polished_energy,repeats_differ,cpu_s,confined,rule_grad_tol_iters,rule_grad_tol_time_s,\
         rule_grad_tol_energy,rule_energy_decrease_iters,rule_energy_decrease_time_s,rule_energy_decrease_energy"
    ));
    assert_eq!(read_summary(dir.path()).unwrap(), rows);
    // A file written before the last columns (the rules' 6, the yardstick's 5, the sandbox's
    // 2) reads them as empty.
    for (cut_columns, left) in [(14, (Some(0.2103), Some(12))), (16, (None, None))] {
        let cut = |l: &str| l.rsplitn(cut_columns + 1, ',').nth(cut_columns).unwrap().to_string() + "\n";
        let older: String = text.lines().map(cut).collect();
        std::fs::write(&path, older).unwrap();
        let back = read_summary(dir.path()).unwrap();
        assert_eq!((back[0].gap_scale, back[0].verified_snapshots), left);
        assert_eq!((back[0].peak_growth_mb, back[1].peak_growth_mb), (None, None));
    }
}

/// The rules' events: written and read back; a folder written before their columns reads a
/// run its own rule ended as that rule's event at its last row, and nothing for the others.
#[test]
fn the_rules_events_round_trip_and_an_older_folder_reads_its_stop_as_one() {
    let dir = tempfile::tempdir().unwrap();
    let run = |solver: &str, stop: StopReason| SummaryRow {
        dataset: "d".into(),
        task: Task::Param,
        energy: "sd".into(),
        solver: solver.into(),
        status: Status::Ok,
        iterations: Some(40),
        time_s: Some(2.0),
        final_energy: Some(2.5),
        stop_reason: Some(RunStop::Solver(stop)),
        ..Default::default()
    };
    let mut went_on = run("kp-newton", StopReason::Target);
    (went_on.rule_grad_tol_iters, went_on.rule_grad_tol_time_s, went_on.rule_grad_tol_energy) =
        (Some(12), Some(0.5), Some(2.6));
    let rows = vec![went_on.clone(), run("slim", StopReason::EnergyDecrease), run("aqp", StopReason::NoDecrease)];
    let path = dir.path().join("summary.csv");
    write_summary(&path, &rows).unwrap();
    let back = read_summary(dir.path()).unwrap();
    assert_eq!(back[0], went_on);
    let stop = |r: &SummaryRow| r.rule_stop().map(|e| (e.rule, e.iters, e.time_s, e.energy));
    assert_eq!(stop(&back[0]), Some((StopRule::GradientTolerance, 12, Some(0.5), Some(2.6))));
    assert_eq!(stop(&back[1]), Some((StopRule::EnergyDecrease, 40, Some(2.0), Some(2.5))));
    assert_eq!(stop(&back[2]), None);
    // without the six columns: the stop of the run its rule ended is the event
    let text = std::fs::read_to_string(&path).unwrap();
    let cut = |l: &str| l.rsplitn(7, ',').nth(6).unwrap().to_string() + "\n";
    std::fs::write(&path, text.lines().map(cut).collect::<String>()).unwrap();
    let old = read_summary(dir.path()).unwrap();
    assert_eq!(stop(&old[0]), None, "a target end has no rule's event to read");
    assert_eq!(stop(&old[1]), Some((StopRule::EnergyDecrease, 40, Some(2.0), Some(2.5))));
}

#[test]
fn the_header_is_exactly_the_design_columns() {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.serialize(SummaryRow::default()).unwrap();
    let s = String::from_utf8(w.into_inner().unwrap()).unwrap();
    assert_eq!(s.lines().next().unwrap(), SUMMARY_COLUMNS.join(","));
}

#[test]
fn verdict_names_are_distinct_and_snake_case() {
    let names: std::collections::HashSet<&str> = Verdict::ALL.iter().map(|v| v.as_str()).collect();
    assert_eq!(names.len(), Verdict::ALL.len());
    for v in Verdict::ALL {
        assert_eq!(serde_json::to_value(v).unwrap(), v.as_str());
    }
}

/// A summary has the target columns of every energy; `meta.json` says which are a row's own,
/// so a SARAP row judged at 1e-3 only does not read an empty 1e-6 as never reached (the
/// claims and the gate read a row's last target as its tightest).
#[test]
fn a_row_reads_back_the_targets_of_its_energy_only() {
    let dir = tempfile::tempdir().unwrap();
    let to = |tau, iters: Option<usize>| ToTarget { tau, iters, time_s: iters.map(|i| i as f64) };
    let row = |energy: &str, to_targets| SummaryRow {
        dataset: "cow".into(),
        energy: energy.into(),
        solver: "kp-newton".into(),
        status: Status::Ok,
        to_targets,
        ..Default::default()
    };
    let rows = vec![row("sd", vec![to(1e-3, Some(5)), to(1e-6, None)]), row("sarap", vec![to(1e-3, Some(9))])];
    write_summary(&dir.path().join("summary.csv"), &rows).unwrap();
    // without meta.json (or its targets) every column is every row's
    let back = read_summary(dir.path()).unwrap();
    assert_eq!(back[1].to_targets, [to(1e-3, Some(9)), to(1e-6, None)]);
    let meta = crate::run_folder::meta::Meta {
        targets: Some(vec![1e-3, 1e-6]),
        targets_per_energy: Some([("sarap".to_string(), vec![1e-3])].into()),
        ..Default::default()
    };
    meta.write(dir.path()).unwrap();
    assert_eq!(read_summary(dir.path()).unwrap(), rows);
}
