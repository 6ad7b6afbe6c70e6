use super::timing::seconds;
use super::*;
use crate::judge::verdict::Verdict;
use crate::report::plots::tests::{png_size, tiny_run};
use crate::report::plots::PlotKind;
use crate::run_folder::summary::RefSource;

fn table(title: &str) -> Table {
    Table {
        title: title.into(),
        columns: vec!["a".into(), "b".into()],
        rows: vec![vec!["1".into(), "x<y".into()]],
        caption: "what the numbers are".into(),
        bold: Vec::new(),
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
    assert_eq!(shown, 12);
    // Every run CSV is linked (the failed run's too), and every map OBJ.
    for stem in ["tiny__sd__kp-newton", "tiny__sd__slim", "tiny__sd__cm", "disk__authalic__aem-cg"] {
        assert!(html.contains(&format!("href=\"runs/{stem}.csv\"")), "{stem}");
    }
    for file in ["uv/tiny__sd__kp-newton.uv.gz", "uv/tiny__sd__slim.uv.gz", "meshes/tiny.obj.gz"] {
        assert!(html.contains(&format!("href=\"{file}\"")), "{file}");
    }
    // tiny_run leaves disk's map in the format of older folders.
    assert!(html.contains("href=\"uv/disk__authalic__aem-cg.obj\""));
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
    assert!(html.contains("Each run was repeated 5 times"), "repeats stated");
    assert!(html.contains("median 0.510 s over 3 samples, spread 3.9%"), "calibration stated");
    assert!(!html.contains("class=\"warn\""), "steady machine: no warning");
    // The time spread in the cell, the repeats in its tooltip, the shifted iterations in both.
    assert!(html.contains("0.250 s (0.240–0.310), 2 shifted, 4 CG-capped"), "spread, shifts, caps in the cell");
    assert!(html.contains("4 steps stopped CG at max_cg_iters"), "caps in the tooltip");
    assert!(html.contains("time = median of 5 repeats, min–max 0.240 s–0.310 s"));
    assert!(html.contains("2 iterations solved with a Tikhonov shift above the base"));
    // The skipped pair: grey, with its reason, counted, and in the tables as skipped.
    assert!(html.contains("<td class=\"skipped\" title=\"skipped: akvf is not defined for sd here\">"));
    assert!(html.contains("5 runs: 2 ok, 1 not converged, 1 failed, 1 skipped"));
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
    assert!(html.contains("time = a single sample"));
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
    let tables = crate::report::tables(&crate::report::at_target(&rows), &Batch::default());
    write_index(p, &rows, &tables, &plots, &Batch::default()).unwrap();
    let html = std::fs::read_to_string(p.join("index.html")).unwrap();
    assert!(html.contains("<b>ok</b><br><small>2 it, 0.200 s to 1e-6</small>"), "the solved cell");
    assert!(html.contains(
        "solved (own stop: grad_tol); reached the 1e-6 target at iteration 2 (0.200 s); its own stop: 3 it, 0.250 s"
    ));
    assert!(
        html.contains("<b>stopped above target</b><br><small>gap 3.2e-4; 3 it, 0.250 s</small>"),
        "the verdict cell"
    );
    assert!(html.contains("not solved: stopped above target; final gap 3.200e-4; own stop: max_iters"));
    // The legend explains the verdicts; the batch's references are named.
    for words in
        ["<b>other minimum</b> = ", "<b>unfinished</b> = ", "<b>flipped</b> = ", "to the target</i> (“to 1e-6”"]
    {
        assert!(html.contains(words), "{words}");
    }
    assert!(html.contains("E* from this batch (ref_source = batch) for 1 group: tiny / sd."));
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
    assert!(html.contains("<b>other minimum</b><br><small>gap 3.2e-4; 3 it, 0.250 s</small>"));
    assert!(html.contains("<b>flipped</b><br><small>gap 0.0e0; 2 it, 0.200 s to 1e-6</small>"));
    assert!(html.contains("not solved: flipped; 4 flipped triangles"));
    assert!(!html.contains("E* from this batch"), "stored references: no line");
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
fn formats_dates_and_seconds() {
    assert_eq!(utc(0), "1970-01-01 00:00:00 UTC");
    assert_eq!(utc(951_782_400), "2000-02-29 00:00:00 UTC");
    assert_eq!(seconds(0.04312), "0.0431 s");
    assert_eq!(seconds(6.594), "6.59 s");
    assert_eq!(seconds(123.4), "123 s");
}
