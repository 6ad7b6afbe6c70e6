use super::status::status_matrix;
use super::timing::seconds;
use super::*;
use crate::judge::verdict::Verdict;
use crate::report::plots::tests::{png_size, tiny_run};
use crate::report::plots::PlotKind;
use crate::run_folder::summary::RefSource;
use crate::run_folder::Status;

fn table(title: &str) -> Table {
    Table {
        title: title.into(),
        columns: vec!["a".into(), "b".into()],
        rows: vec![vec!["1".into(), "x<y".into()]],
        caption: "what the numbers are".into(),
        bold: Vec::new(),
        layout: Default::default(),
    }
}

#[test]
fn index_links_every_run_plot_and_table_and_escapes_errors() {
    let (dir, rows) = tiny_run();
    let p = dir.path();
    let tables = vec![("deform".to_string(), table("Deform & friends")), ("authalic".to_string(), table("AEM"))];
    let plots = crate::report::plots::render_all(p, &rows).unwrap();
    write_index(p, &rows, &tables, &plots, &Batch::read(p)).unwrap();
    let html = std::fs::read_to_string(p.join("index.html")).unwrap();
    assert!(html.contains("<title>mapbench: tiny-config</title>"));
    for t in ["Deform &amp; friends", "AEM"] {
        assert!(html.contains(&format!(">{t}</h3>")), "table title {t}");
    }
    assert!(html.contains("<td>x&lt;y</td>"));
    // Every PNG written is shown, and is a PNG.
    let mut shown = 0;
    for entry in std::fs::read_dir(p.join("plots")).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(html.contains(&format!("<img src=\"plots/{name}\"")), "{name} not shown");
        assert!(png_size(&p.join("plots").join(&name)).0 > 0);
        shown += 1;
    }
    assert_eq!(shown, 15);
    // The cells link to their problem's plots; the folders of the runs' files are linked
    // with their counts (tiny_run leaves disk's map in the format of older folders).
    assert_eq!(html.matches("<a href=\"#problem-tiny__sd\"><b>").count(), 3, "the three tiny runs' cells");
    for (folder, count) in
        [("runs/", "4 <code>.csv</code>"), ("uv/", "2 <code>.uv.gz</code>"), ("meshes/", "1 <code>.obj.gz</code>")]
    {
        assert!(html.contains(&format!("{count} files in <a href=\"{folder}\">")), "{folder}");
    }
    assert!(html.contains("1 <code>.obj</code> files in <a href=\"uv/\">"));
    assert!(html.contains("factorization failed: pivot &lt; 0 &amp; NaN in &lt;K&gt;"));
    assert!(!html.contains("<K>"));
    assert!(html.contains("0123456789abcdef0123456789abcdef01234567 (dirty"));
    assert!(html.contains("2023-11-14 22:13:20 UTC"));
    assert!(html.contains("not converged: max_iters"));
    // Self-contained: no script, no absolute or network links.
    assert!(!html.contains("<script") && !html.contains("http://") && !html.contains("https://"));
    assert!(!html.contains("href=\"/") && !html.contains("src=\"/"));
}

#[test]
fn index_states_repeats_calibration_spreads_shifts_and_skipped_pairs() {
    let (dir, mut rows) = tiny_run();
    let p = dir.path();
    for r in rows.iter_mut().filter(|r| r.status != Status::Failed) {
        (r.repeats, r.time_s_min, r.time_s_max) = (Some(5), Some(0.24), Some(0.31));
    }
    rows[0].shifted_iters = Some(2);
    rows[0].cg_capped_iters = Some(4);
    rows.push(SummaryRow {
        dataset: "tiny".into(),
        task: crate::plan::Task::Param,
        energy: "sd".into(),
        solver: "akvf".into(),
        status: Status::Skipped,
        error: "akvf is not defined for sd here".into(),
        ..Default::default()
    });
    let calibration = |samples: Vec<f64>| Batch {
        calibration: Some(crate::calibration::Calibration { workload: "kp-newton sd".into(), samples_s: samples }),
        ..Default::default()
    };
    let page = |rows: &[SummaryRow], batch: &Batch| {
        write_index(p, rows, &crate::report::tables(rows, batch), &[], batch).unwrap();
        std::fs::read_to_string(p.join("index.html")).unwrap()
    };
    let html = page(&rows, &calibration(vec![0.50, 0.51, 0.52]));
    assert!(html.contains("3 of the 3 runs were repeated 5 times"), "repeats stated");
    assert!(html.contains("median 0.510 s over 3 samples, spread 3.9%"), "calibration stated");
    assert!(!html.contains("class=\"warn\""), "steady machine: no warning");
    // The time spread in the cell, the repeats in its tooltip, the shifted iterations in both.
    // The cell: iterations (+: some regularized or capped) over the median time; the rest in
    // its tooltip.
    assert!(html.contains("<b>3+</b><br><small>0.25</small>"), "iterations marked, time in the cell");
    assert!(html.contains("4 it CG capped"), "caps in the tooltip");
    assert!(html.contains("5 repeats 0.240–0.310 s"));
    assert!(html.contains("2 it shifted"));
    // The skipped pair: grey, with its reason, counted, and in the tables as skipped.
    assert!(html.contains(
        "<td class=\"skipped\" title=\"skipped: akvf is not defined for sd here\"><b>skip</b><br><small>[2]</small>"
    ));
    // The reasons once each, numbered, under the matrix.
    assert!(html.contains(
        "<li>failed: factorization failed: pivot &lt; 0 &amp; NaN in &lt;K&gt;<small> (1 cell)</small></li>"
    ));
    assert!(html.contains("<li>skipped: akvf is not defined for sd here<small> (1 cell)</small></li>"));
    assert!(html.contains("5 runs: 2 converged, 1 not converged, 1 failed, 1 skipped"));
    assert!(html.contains("<td>skipped</td>"), "the per-mesh table marks the skipped pair");
    assert!(html.contains("id=\"table-aggregates\""), "the aggregates table is on the page");
    // An unsteady machine: a visible warning with the samples.
    let html = page(&rows, &calibration(vec![0.50, 0.40, 0.60]));
    assert!(html.contains("<p class=\"warn\"><b>Warning: the machine changed speed during this batch.</b>"));
    assert!(html.contains("spread by 40.0%, more than 10%"));
    // No calibration, single samples: said so.
    for r in &mut rows {
        (r.repeats, r.time_s_min, r.time_s_max) = (Some(1), r.time_s, r.time_s);
    }
    let html = page(&rows, &Batch::default());
    assert!(html.contains("Each run was timed once (repeat = 1)"));
    assert!(html.contains("No machine calibration in meta.json"));
    assert!(html.contains("; 1 sample"));
}

#[test]
fn the_fastest_solved_run_of_a_row_is_framed_ties_on_overlap_included() {
    let run = |solver: &str, status: Status, t: f64| SummaryRow {
        dataset: "cow".into(),
        task: crate::plan::Task::Param,
        energy: "sd".into(),
        solver: solver.into(),
        iterations: Some(10),
        time_s: Some(t),
        time_s_min: Some(t * 0.95),
        time_s_max: Some(t * 1.05),
        repeats: Some(3),
        status,
        ..Default::default()
    };
    let framed = |rows: &[SummaryRow]| {
        let mut html = String::new();
        status_matrix(&mut html, std::path::Path::new("/nonexistent"), rows, &[], &[], &[]);
        html.split("<td class=\"").skip(1).filter(|c| c.starts_with("ok fast")).count()
    };
    // newton stopped fastest but unsolved: never framed; cm is, and kp-newton ties with it.
    let mut rows = vec![
        run("newton", Status::NotConverged, 0.01),
        run("cm", Status::Ok, 1.0),
        run("kp-newton", Status::Ok, 1.02),
        run("slim", Status::Ok, 3.0),
    ];
    assert_eq!(framed(&rows), 2);
    rows[2].time_s = Some(1.5);
    (rows[2].time_s_min, rows[2].time_s_max) = (Some(1.4), Some(1.6));
    assert_eq!(framed(&rows), 1);
}

#[test]
fn status_cells_show_the_target_the_verdict_and_the_gap() {
    use crate::run_folder::summary::ToTarget;
    let (dir, mut rows) = tiny_run();
    let p = dir.path();
    let to = |iters: Option<usize>, time_s: Option<f64>| {
        vec![ToTarget { tau: 1e-3, iters: Some(1), time_s: Some(0.1) }, ToTarget { tau: 1e-6, iters, time_s }]
    };
    // kp-newton solved 1e-6 at iteration 2 (0.2 s) and stopped at 3 (0.25 s); slim's own
    // rule stopped it above the target, whose E* it lowered.
    (rows[0].verdict, rows[0].to_targets, rows[0].final_gap) =
        (Some(Verdict::Solved), to(Some(2), Some(0.2)), Some(0.0));
    (rows[1].verdict, rows[1].to_targets, rows[1].final_gap) =
        (Some(Verdict::StoppedAboveTarget), to(None, None), Some(3.2e-4));
    for r in &mut rows[..2] {
        (r.ref_energy, r.ref_source) = (Some(4.0), Some(RefSource::Batch));
    }
    let plots = crate::report::plots::render_all(p, &rows).unwrap();
    let tables = crate::report::tables(&crate::report::target::at_target(&rows), &Batch::default());
    write_index(p, &rows, &tables, &plots, &Batch::default()).unwrap();
    let html = std::fs::read_to_string(p.join("index.html")).unwrap();
    assert!(html.contains("<b>2</b><br><small>0.20</small>"), "the solved cell counts to the target");
    assert!(html.contains("solved at 1e-6, ended: grad_tol; 1e-6 target at it 2, 0.200 s; ended at 3 it, 0.250 s"));
    assert!(html.contains("<b>above</b><br><small>3e-4</small>"), "the verdict cell: verdict and gap");
    assert!(html.contains("not solved at 1e-6: stopped above target; gap 3.200e-4; ended: max_iters"));
    // The legend explains the verdicts; the batch's references are named.
    for words in [
        "<b>above</b> = a stop rule ended it above the target",
        "<b>other</b> = other minimum",
        "<b>budget</b> = out of budget",
        "<b>stalled</b> = it ended stationary",
        "<b>broke</b> = the method broke down",
        "<b>flipped</b> = ",
        "the iterations and time <i>to the target</i>",
    ] {
        assert!(html.contains(words), "{words}");
    }
    assert!(html.contains("No reference minimum for 1 group: tiny / sd. E* is the batch&#39;s best final energy"));
    // The data profile sits with the performance profiles, explained.
    assert!(html.contains("<img src=\"plots/profile__sd__data.png\""));
    assert!(html.contains("Moré–Wild data profiles (Moré and Wild 2009, “data profile”): d_s(α)"));
    assert!(html.contains("Costs: iterations and time to the 1e-6 target"));
    assert!(html.contains("id=\"table-verdicts\""), "the verdicts table");
    // Another verdict and a flipped run that reached the target.
    rows[1].verdict = Some(Verdict::OtherMinimum);
    (rows[0].verdict, rows[0].status, rows[0].flips) = (Some(Verdict::Flipped), Status::NotConverged, Some(4));
    for r in &mut rows[..2] {
        r.ref_source = Some(RefSource::Reference);
    }
    write_index(p, &rows, &[], &[], &Batch::default()).unwrap();
    let html = std::fs::read_to_string(p.join("index.html")).unwrap();
    assert!(html.contains("<b>other</b><br><small>3e-4</small>"));
    assert!(html.contains("<b>flipped</b><br><small>0e0</small>"));
    assert!(html.contains("not solved at 1e-6: flipped; 4 flipped triangles"));
    assert!(!html.contains("No reference minimum"), "stored references: no line");
    // An uncertified reference marks its group's cells; a repeat that differed is flagged.
    for r in &mut rows[..2] {
        r.ref_certified = Some(false);
    }
    rows[1].repeats_differ = Some("repeat 2 does not reproduce repeat 1 (first difference at iteration 3)".into());
    write_index(p, &rows, &[], &[], &Batch::default()).unwrap();
    let html = std::fs::read_to_string(p.join("index.html")).unwrap();
    assert!(html.contains("<b>other†≠</b><br><small>3e-4</small>"), "both marks");
    assert!(html.contains("† E* uncertified"));
    assert!(html.contains("≠ repeat 2 does not reproduce repeat 1"));
}

#[test]
fn a_plot_without_its_file_is_left_out() {
    let (dir, rows) = tiny_run();
    let mut plots = crate::report::plots::render_all(dir.path(), &rows).unwrap();
    std::fs::remove_file(dir.path().join(&plots[0].file)).unwrap();
    plots.push(Plot {
        file: "plots/never_written.png".into(),
        title: "x".into(),
        dataset: "tiny".into(),
        energy: "sd".into(),
        kind: PlotKind::EnergyIter,
    });
    write_index(dir.path(), &rows, &[], &plots, &Batch::default()).unwrap();
    let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
    assert!(!html.contains(&plots[0].file) && !html.contains("never_written"));
    assert!(html.contains(&format!("<img src=\"{}\"", plots[1].file)));
}

#[test]
fn formats_seconds() {
    // the dates: crate::utc's tests
    assert_eq!(seconds(0.04312), "0.0431 s");
    assert_eq!(seconds(6.594), "6.59 s");
    assert_eq!(seconds(123.4), "123 s");
    assert_eq!(
        [0.004312, 0.2149, 6.594, 12.4, 123.4, 0.0, 4.3e-5, 123456.0].map(super::timing::brief),
        ["0.0043", "0.21", "6.6", "12", "123", "0.00", "4e-5", "123456"]
    );
}

/// The widest line of a status cell (characters): 20 solvers of such columns fit one
/// 1400-pixel screen.
const CELL_CHARS: usize = 7;

/// The visible lines of each `<td>` / `<th>` of the first `<table class="status">`: tags
/// dropped, `<br>` and `<wbr>` as line breaks, entities as one character.
fn status_cells(html: &str, tag: &str) -> Vec<Vec<String>> {
    let start = html.find("<table class=\"status\">").expect("a status matrix");
    let table = &html[start..start + html[start..].find("</table>").unwrap()];
    let open = format!("<{tag}");
    let close = format!("</{tag}>");
    let mut out = Vec::new();
    for piece in table.split(&open).skip(1) {
        let body = &piece[piece.find('>').unwrap() + 1..piece.find(&close).unwrap()];
        let body = body.replace("<wbr>", "\n").replace("<br>", "\n");
        let mut text = String::new();
        let mut in_tag = false;
        for c in body.chars() {
            match c {
                '<' => in_tag = true,
                '>' => in_tag = false,
                c if !in_tag => text.push(c),
                _ => {}
            }
        }
        for (entity, c) in [("&amp;", "&"), ("&lt;", "<"), ("&gt;", ">"), ("&quot;", "\""), ("&#39;", "'")] {
            text = text.replace(entity, c);
        }
        out.push(text.lines().map(str::to_string).collect());
    }
    out
}

#[test]
fn the_status_matrix_of_20_solvers_stays_narrow_and_lists_problem_rows_first() {
    use crate::run_folder::summary::ToTarget;
    let mut names: Vec<String> =
        solvers::tasks::catalogue::names_for(crate::plan::Task::Param).iter().map(|s| s.to_string()).collect();
    names.extend(["igl-slim", "external-trust-region-6x6", "example-gd"].map(String::from));
    names.truncate(20);
    assert_eq!(names.len(), 20);
    let long = "the factorization failed at pivot 1234 of 56789: the matrix is not positive definite, \
                which happens when the element Hessians are left unprojected on a mesh with slivers";
    let mut rows = Vec::new();
    for (d, dataset) in ["calm", "bumpy", "stormy"].iter().enumerate() {
        for (k, solver) in names.iter().enumerate() {
            let base = SummaryRow {
                dataset: dataset.to_string(),
                task: crate::plan::Task::Param,
                energy: "sd".into(),
                solver: solver.clone(),
                iterations: Some(12_345),
                time_s: Some(1234.5678),
                repeats: Some(5),
                time_s_min: Some(1200.0),
                time_s_max: Some(1300.0),
                peak_rss_mb: Some(15_000.0),
                shifted_iters: Some(7),
                ..Default::default()
            };
            rows.push(match (d, k % 5) {
                // calm: every run solved, far from the top after sorting.
                (0, _) | (_, 0) => SummaryRow {
                    status: Status::Ok,
                    verdict: Some(Verdict::Solved),
                    to_targets: vec![ToTarget { tau: 1e-6, iters: Some(9_999), time_s: Some(999.9) }],
                    ..base
                },
                (_, 1) => SummaryRow { status: Status::Failed, error: format!("{long} ({solver})"), ..base },
                (_, 2) => {
                    SummaryRow { status: Status::Skipped, error: format!("{solver} is not defined for sd"), ..base }
                }
                (_, 3) => SummaryRow {
                    status: Status::NotConverged,
                    verdict: Some(Verdict::Unfinished),
                    final_gap: Some(3.25e-4),
                    ..base
                },
                _ => SummaryRow {
                    status: Status::NotConverged,
                    verdict: Some(Verdict::StoppedAboveTarget),
                    final_gap: Some(1.5e-123),
                    ..base
                },
            });
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let mut html = String::new();
    status_matrix(&mut html, dir.path(), &rows, &[], &[], &[]);
    let heads = status_cells(&html, "th");
    assert_eq!(heads.len(), 21, "the dataset column and one per solver");
    for head in &heads {
        assert!(head.iter().all(|l| l.chars().count() <= 10), "a column head wider than 10 characters: {head:?}");
    }
    let cells = status_cells(&html, "td");
    assert_eq!(cells.len(), 3 * 21);
    for cell in &cells[..] {
        for line in cell {
            assert!(line.chars().count() <= CELL_CHARS, "a cell line wider than {}: {cell:?}", CELL_CHARS);
        }
    }
    // The rows with problems first (bumpy, stormy in the summary's order), then calm.
    let firsts: Vec<&str> = cells.iter().step_by(21).map(|c| c[0].as_str()).collect();
    assert_eq!(firsts, ["bumpy", "stormy", "calm"]);
    // The reasons once each, under the table: 4 failures and 4 skips per problem row, each
    // text naming its solver, so 8 reasons of 2 cells each.
    assert_eq!(html.matches("<li>").count(), 8);
    assert_eq!(html.matches("(2 cells)</small></li>").count(), 8, "each reason counted on both rows");
}

/// Two batches of one config in a history database, the second with a made regression: its
/// first screen (`id="changes"`, before the status matrix) says so, with the solved counts
/// then and now, the new run and the problems; the first batch says it is the first.
#[test]
fn the_first_screen_shows_what_changed_since_the_previous_batch() {
    use crate::history::{record, HistoryOutcome};
    let db_dir = tempfile::tempdir().unwrap();
    let db = db_dir.path().join("history.sqlite");
    let night = |rows: &[SummaryRow], rev: &str| {
        let (dir, _) = tiny_run();
        let p = dir.path();
        let mut meta: serde_json::Value = serde_json::from_slice(&std::fs::read(p.join("meta.json")).unwrap()).unwrap();
        meta["git_revision"] = rev.into();
        std::fs::write(p.join("meta.json"), meta.to_string()).unwrap();
        crate::run_folder::write_summary(&p.join("summary.csv"), rows).unwrap();
        let r = record(&db, p).unwrap();
        let outcome = HistoryOutcome::Appended {
            db: db.clone(),
            batch_id: r.batch_id,
            runs: r.runs,
            config: r.config,
            trend: None,
            trend_error: None,
        };
        outcome.write_into(p).unwrap();
        write_index(p, rows, &[], &[], &Batch::default()).unwrap();
        (std::fs::read_to_string(p.join("index.html")).unwrap(), dir)
    };
    let (_, before) = tiny_run();
    let (first, _keep1) = night(&before, "1111111aaaa");
    assert!(first.contains("First batch of config <b>tiny-config</b> in the history"), "{first}");
    // The regression: kp-newton needs 5 iterations instead of 3; cm, failed before, converges;
    // a run that was not there.
    let mut after = before.clone();
    after[0].iterations = Some(5);
    (after[2].status, after[2].error) = (Status::Ok, String::new());
    after.push(SummaryRow { solver: "akvf".into(), ..after[0].clone() });
    let (html, _keep2) = night(&after, "2222222bbbb");
    let changes = html.find("id=\"changes\"").expect("a changes section");
    assert!(changes < html.find("id=\"status\"").unwrap(), "changes come before the status matrix");
    let section = &html[changes..html.find("</section>").unwrap()];
    for needle in [
        "5 runs: 4 converged, 1 not converged, 0 failed, 0 skipped",
        "Batch 2 (<code>2222222+</code>) since batch 1 (<code>1111111+</code>",
        // kp-newton's own rule ended it: its rule's event moved with its end
        "<b>2 regressions</b>, 1 improvement, 1 new run, 0 missing",
        "<td class=\"k\">tiny param sd kp-newton</td><td class=\"k\">rule_iters</td><td>3</td><td>5</td><td>+2</td>",
        "cm 0/1 → 1/1, akvf – → 1/1",
        "<td class=\"k\">tiny param sd kp-newton</td><td class=\"k\">iterations</td><td>3</td><td>5</td><td>+2</td><td class=\"k\">worse</td>",
        "New in the latest batch (1): tiny param sd akvf",
        "<h3>Problems (1: 1 not converged)</h3>",
        "tiny / sd / <a href=\"runs/tiny__sd__slim.csv\">slim</a>: not converged: max_iters",
        "revision <code>2222222</code>",
        "(<a href=\"#provenance\">provenance</a>)",
        "Not solved or failed per solver (1 run of 1 solver-energy pair)",
        "slim / sd: 1 of 1 unsolved (max_iters 1)",
    ] {
        assert!(section.contains(needle), "{needle}\nnot in\n{section}");
    }
    // The regression comes before the improvement.
    assert!(section.find(">worse<").unwrap() < section.find(">better<").unwrap());
    // Out of any history: said so.
    let (dir, rows) = tiny_run();
    write_index(dir.path(), &rows, &[], &[], &Batch::default()).unwrap();
    let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
    assert!(html.contains("This batch is not in a history database"), "{html}");
    // No plots here: the problem names no section, the solver links its CSV.
    assert!(html.contains(
        "<li class=\"failed\">tiny / sd / <a href=\"runs/tiny__sd__cm.csv\">cm</a>: failed: factorization failed: pivot &lt; 0"
    ));
}

/// The first screen's one count: its classes add up to the runs, each reason in words with its
/// value, the runs on a problem solved at its start and those of a solver expected to fail
/// apart, an external solver this machine cannot run named with why; the roll-up and the
/// problems count the same runs.
#[test]
fn the_first_screen_counts_every_run_once_with_its_reason() {
    use crate::external::probe::Probe;
    use crate::run_folder::meta::Stop;
    use crate::run_folder::summary::ToTarget;
    use crate::run_folder::RunStop;
    use solvers::solver::StopReason;
    let (dir, rows) = tiny_run();
    let p = dir.path();
    let judged = |solver: &str, energy: &str, verdict: Verdict, stop: StopReason| SummaryRow {
        solver: solver.into(),
        energy: energy.into(),
        status: if verdict == Verdict::Solved { Status::Ok } else { Status::NotConverged },
        verdict: Some(verdict),
        stop_reason: Some(RunStop::Solver(stop)),
        start_energy: Some(10.0),
        ref_energy: Some(2.0),
        to_targets: vec![ToTarget { tau: 1e-6, iters: (verdict == Verdict::Solved).then_some(3), time_s: None }],
        ..rows[0].clone()
    };
    let mut trivial = judged("kp-newton", "exp-sd", Verdict::Solved, StopReason::Target);
    trivial.start_energy = Some(2.0);
    let mut sarap = judged("kp-newton", "sarap", Verdict::Solved, StopReason::Target);
    sarap.to_targets[0].tau = 1e-3;
    let env = SummaryRow {
        solver: "igl-slim".into(),
        status: Status::Skipped,
        error: "version command exited with code 1: No module named 'igl'".into(),
        ..rows[0].clone()
    };
    let summaries = vec![
        judged("kp-newton", "sd", Verdict::Solved, StopReason::Target),
        sarap,
        judged("slim", "sd", Verdict::Unfinished, StopReason::MaxIterations),
        judged("aqp", "sd", Verdict::Stalled, StopReason::NoDecrease),
        judged("lbfgs", "sd", Verdict::Stalled, StopReason::NoDecrease),
        judged("newton", "sd", Verdict::BrokeDown, StopReason::LinearSolveFailed("pivot".into())),
        trivial,
        env,
    ];
    let batch = Batch {
        max_iters: [("sd".to_string(), 1000)].into(),
        stop: [("sd".to_string(), Stop { stall_window: Some(50), ..Stop::default() })].into(),
        external: vec![Probe {
            name: "igl-slim".into(),
            command: vec!["python3".into()],
            version: None,
            unavailable: Some("version command exited with code 1: No module named 'igl'".into()),
        }],
        expected_to_fail: vec!["newton".into()],
        ..Batch::default()
    };
    write_index(p, &summaries, &[], &[], &batch).unwrap();
    let html = std::fs::read_to_string(p.join("index.html")).unwrap();
    let section = &html[html.find("id=\"changes\"").unwrap()..html.find("</section>").unwrap()];
    for needle in [
        "8 runs: 2 solved at the tightest target (1e-6, sarap 1e-3), 3 not solved, 0 failed, 1 skipped; apart, 1 on \
         problems solved at their start and 1 of solvers expected to fail",
        "not solved (3): 2 stalled: no decrease in 50 iterations; 1 out of budget: 1000 iterations",
        "1 run of <b>igl-slim</b> skipped: this machine cannot run it (version command exited with code 1: No \
         module named &#39;igl&#39;)",
        "1 run on 1 problem solved at the start (its energy within round-off of E*: tiny exp-sd)",
        "1 run of the solvers the config expects to fail (<code>expected_to_fail</code>), 0 of them solved",
        "Not solved or failed per solver (3 runs of 3 solver-energy pairs)",
        "<h3>Problems (3: 1 out of budget, 2 stalled)</h3>",
    ] {
        assert!(section.contains(needle), "{needle}\nnot in\n{section}");
    }
    assert!(!section.contains("newton / sd: 1 of 1") || section.contains("Expected to fail"), "{section}");
}
