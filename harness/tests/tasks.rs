//! A batch of each task end to end: `authalic` (its metrics, the budget status, the table 1
//! shape), `deform` (generated, file and rule handles; every shared shape, with and without
//! the smoothness term) and the smoothness table.

use crate::common;

use common::*;
use std::process::Command;

#[test]
fn an_authalic_batch_writes_metrics_extra_columns_and_the_table_1_shape() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("two.obj"), TWO_LOOPS_OBJ).unwrap();
    let cfg = write_config(
        tmp.path(),
        r#"name = "auth"
task = "authalic"
datasets = ["bumpy_1k"]
solvers = ["sem", "aem-cg", "aem-cg-safe"]
[stop]
max_iters = 20
[[dataset]]
name = "two"
path = "two.obj"
"#,
    );
    let out = tmp.path().join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(1), "the two-component mesh fails: {}", text(&o));
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    assert_eq!(rows.len(), 6);
    for r in &rows[..3] {
        assert_eq!(r[col("energy")], "authalic");
        assert_eq!(r[col("iterations")], "20");
        assert_eq!(r[col("stop_reason")], "max_iters");
        // the fixed budget of the protocol spent: a result, not a failure to converge
        assert_eq!(r[col("status")], "budget");
        assert_eq!(r[col("folded")], "0");
        let e: f64 = r[col("authalic_energy")].parse().unwrap();
        assert!(e > 0.0 && e < r[col("init_energy")].parse::<f64>().unwrap());
        assert_eq!(r[col("final_energy")], r[col("authalic_energy")]);
        assert!(r[col("area_ratio_sd")].parse::<f64>().unwrap() > 0.0);
    }
    for r in &rows[3..] {
        assert_eq!(r[col("status")], "failed");
        assert!(r[col("error")].contains("two.obj"), "{:?}", r);
    }
    let (h, it) = read_csv(&out.join("runs/bumpy_1k__authalic__aem-cg-safe.csv"));
    assert_eq!(
        h[14..].join(","),
        "shift,ls_evals,gap,t_record_s,image_area,stretch_energy,ascent,wolfe,backtracks,restarted,fold_rejects,quad_fallback"
    );
    assert_eq!(it.len(), 21);
    let table = std::fs::read_to_string(out.join("tables/authalic.md")).unwrap();
    assert!(table.contains("| bumpy_1k |") && table.contains("AEM-CG-safe E_A"), "{table}");
    // the runs at their budget compete: the row's best is bold
    assert!(table.contains("**"), "{table}");
    assert!(out.join("tables/authalic.html").is_file());
    assert!(text(&o).contains("6 runs: 0 ok, 3 at their budget, 0 not converged, 3 failed"), "{}", text(&o));
    // with a tolerance rule the budget is a cap: a run that reaches it did not converge
    let capped = write_config(
        tmp.path(),
        "name = \"auth\"\ntask = \"authalic\"\ndatasets = [\"bumpy_1k\"]\nsolvers = [\"aem-cg\"]\n\
         [stop]\nmax_iters = 5\ngrad_tol = 1e-14\n",
    );
    let out = tmp.path().join("capped");
    let o = mapbench(&["run", capped.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    assert_eq!((rows[0][col("stop_reason")].as_str(), rows[0][col("status")].as_str()), ("max_iters", "not_converged"));
}

/// A planar 4 x 4 vertex grid (z = 0), counter-clockwise faces.
fn grid_obj() -> String {
    let mut s = String::new();
    for j in 0..4 {
        for i in 0..4 {
            s += &format!("v {i} {j} 0\n");
        }
    }
    for j in 0..3 {
        for i in 0..3 {
            let (a, b, c, d) = (j * 4 + i + 1, j * 4 + i + 2, (j + 1) * 4 + i + 2, (j + 1) * 4 + i + 1);
            s += &format!("f {a} {b} {c}\nf {a} {c} {d}\n");
        }
    }
    s
}

#[test]
fn a_deform_batch_runs_generated_file_and_rule_handles() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("grid.obj"), grid_obj()).unwrap();
    std::fs::write(
        tmp.path().join("grid.p2p.json"),
        r#"{"p2p_sets": [{"src_vertex": [0, 3], "dst": [[0.0, 0.0], [3.5, 0.5]]}]}"#,
    )
    .unwrap();
    let cfg = write_config(
        tmp.path(),
        r#"name = "def"
task = "deform"
datasets = ["planar_bar_2k"]
energies = ["sd", "nh"]
solvers = ["kp-newton", "cm"]
[[dataset]]
name = "grid_file"
path = "grid.obj"
handles = "grid.p2p.json"
[[dataset]]
name = "grid_rule"
path = "grid.obj"
handles_rule = "twist"
[[dataset]]
name = "grid_none"
path = "grid.obj"
"#,
    );
    let out = tmp.path().join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(1), "grid_none has no handles: {}", text(&o));
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    assert_eq!(rows.len(), 16);
    for r in &rows[..12] {
        assert_eq!(r[col("status")], "ok", "{r:?}");
        // from the rest pose to the target, the deform default's rule (|grad| <= 1e-6) held on the way
        assert_eq!((r[col("stop_reason")].as_str(), r[col("start")].as_str()), ("target", "rest"), "{r:?}");
        assert!(!r[col("rule_grad_tol_iters")].is_empty(), "{r:?}");
        assert_eq!(r[col("flips")], "0");
    }
    for r in &rows[12..] {
        assert_eq!(r[col("status")], "failed");
        assert!(r[col("error")].contains("grid.obj: no handles"), "{r:?}");
    }
    let table = std::fs::read_to_string(out.join("tables/deform.md")).unwrap();
    assert!(table.contains("| it/t | sd | nh |") && table.contains("| kp-newton |"), "{table}");
}

/// The deform shapes of the shared corpus (`tag:deform` also holds the generated ones).
const SHARED_DEFORM: [&str; 7] = ["archer", "rex", "raptor", "alligator", "octopus_2d", "robot_2d", "worm_2d"];

/// Run a `deform` config over `tag:deform` with SD and NH (mu/kappa = 0.25, Figure 4) plus
/// `extra` TOML, and check that every run, shared shapes included, is ok without flips.
/// Returns the summary, or `None` (skipped) without `MAPBENCH_MESHES`.
fn shared_deform_batch(extra: &str) -> Option<(Vec<String>, Vec<Vec<String>>)> {
    let Ok(meshes) = std::env::var("MAPBENCH_MESHES") else {
        eprintln!("MAPBENCH_MESHES not set: shared deform shapes skipped");
        return None;
    };
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        &format!(
            "name = \"defs\"\ntask = \"deform\"\ndatasets = [\"tag:deform\"]\nenergies = [\"sd\", \"nh\"]\n\
             solvers = [\"kp-newton\"]\n{extra}"
        ),
    );
    let out = tmp.path().join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_mapbench"))
        .args(["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()])
        // In the temporary folder: the default history database is reports/ of the cwd.
        .current_dir(tmp.path())
        .env("MAPBENCH_MESHES", meshes)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    for name in SHARED_DEFORM {
        assert_eq!(rows.iter().filter(|r| r[col("dataset")] == name).count(), 2, "{name}");
    }
    for r in &rows {
        // Its own rule converged; under the default gradient rule the harness calls it solved
        // too (under the paper's decrease rule the released bar SD stops above the target).
        assert_eq!(r[col("converged")], "true", "{r:?}");
        if !extra.contains("energy_decrease_tol") {
            assert_eq!(r[col("status")], "ok", "{r:?}");
        }
        assert_eq!(r[col("flips")], "0", "{r:?}");
        eprintln!(
            "{} {}: {} iterations, {} s",
            r[col("dataset")],
            r[col("energy")],
            r[col("iterations")],
            r[col("time_s")]
        );
    }
    Some((header, rows))
}

#[test]
fn deform_converges_on_every_shared_shape_with_sd_and_nh() {
    // SD and NH converge on every shape of the shared corpus with its handles, without flips.
    shared_deform_batch("[energy.nh]\nmu = 0.2\nkappa = 0.8\n");
}

/// The same with the smoothness term (w = 0.25, Figure 6). About 3 min in release (the runs go
/// on to the target; raptor spends its 1100 iterations, 60 s each: its SD rule holds at 1009), so
/// it is ignored by default; CI runs it with
/// `MAPBENCH_MESHES=... cargo test --release -p mapbench --test suite -- --ignored tasks::deform_with_smoothness`.
#[test]
#[ignore = "minutes: run with --ignored and MAPBENCH_MESHES"]
fn deform_with_smoothness_converges_on_every_shared_shape_with_sd_and_nh() {
    // The paper's deform rule (Section 6.2): what is tested is that each run converges by it.
    let extra =
        "[stop]\nmax_iters = 1100\nenergy_decrease_tol = 1e-6\ngrad_tol = 1e-10\n[energy.sd]\nsmoothness = 0.25\n\
                 [energy.nh]\nmu = 0.2\nkappa = 0.8\nsmoothness = 0.25\n";
    let Some((header, rows)) = shared_deform_batch(extra) else { return };
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    for r in &rows {
        // The paper's rule held on every run (its trajectory up to that event is the run the
        // rule would have stopped); past it, going on to the 1e-6 target is a study of its own:
        // most reach it, others end at another minimum, stall, break down at round-off or spend
        // the 1100 iterations (raptor SD: a gap near 1e-2 of the span). Each end
        // is judged: a verdict for every run.
        let held: usize = r[col("rule_energy_decrease_iters")].parse().unwrap_or_else(|_| panic!("{r:?}"));
        assert!(held <= r[col("iterations")].parse::<usize>().unwrap(), "{r:?}");
        assert!(!r[col("verdict")].is_empty(), "{r:?}");
    }
}

#[test]
fn a_smoothness_batch_writes_the_table_7_shape() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"sm\"\ntask = \"deform\"\ndatasets = [\"planar_bar_2k\"]\nenergies = [\"sd\"]\n\
         solvers = [\"kp-newton\", \"kp-newton-eig8\"]\n[energy.sd]\nsmoothness = 0.25\n",
    );
    let out = tmp.path().join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    assert!(rows.iter().all(|r| r[col("status")] == "ok" && r[col("flips")] == "0"), "{rows:?}");
    let table = std::fs::read_to_string(out.join("tables/smoothness.md")).unwrap();
    assert!(table.contains("| planar_bar_2k | sd |") && table.contains("numeric_project_ms"), "{table}");
}
