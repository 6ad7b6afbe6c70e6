//! The `mapbench` binary end to end, in temporary folders.

use crate::common;

use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

#[test]
fn a_broken_mesh_fails_its_runs_and_the_batch_goes_on() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("quad.obj"), QUAD_OBJ).unwrap();
    let cfg = write_config(
        tmp.path(),
        r#"name = "t"
datasets = ["bumpy_1k"]
energies = ["sd"]
solvers = ["kp-newton"]
[[dataset]]
name = "broken"
path = "quad.obj"
"#,
    );
    let out = tmp.path().join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let (header, rows) = read_csv(&out.join("summary.csv"));
    assert_eq!(header.join(","), "dataset,task,energy,solver,vertices,faces,iterations,converged,stop_reason,init_energy,final_energy,grad_norm,time_s,ms_per_vertex,iter_ms_median,project_ms_median,solve_ms_median,flips,status,error,area_ratio_sd,area_ratio_mad,authalic_energy,folded,analysis_s,analysis_shared,repeats,time_s_min,time_s_max,time_norm,shifted_iters,clamped_iters,peak_rss_mb,start,ref_energy,ref_source,final_gap,verdict,cg_capped_iters,gap_scale,verified_snapshots,peak_growth_mb,start_energy,ideal_energy,ref_certified,polished_energy,repeats_differ,cpu_s,confined,rule_grad_tol_iters,rule_grad_tol_time_s,rule_grad_tol_energy,rule_energy_decrease_iters,rule_energy_decrease_time_s,rule_energy_decrease_energy,iters_to_1e-3,time_to_1e-3,iters_to_1e-6,time_to_1e-6");
    assert_eq!(rows.len(), 2);
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let good = &rows[0];
    assert_eq!(good[col("dataset")], "bumpy_1k");
    assert_eq!(good[col("status")], "ok");
    // it went on to its target; its rule held on the way, at or before the end
    assert_eq!(good[col("stop_reason")], "target");
    let rule: usize = good[col("rule_grad_tol_iters")].parse().unwrap();
    assert!(rule <= good[col("iterations")].parse::<usize>().unwrap(), "{good:?}");
    assert_eq!(good[col("flips")], "0");
    // the OS's resident memory of the run (Linux: /proc), at least the loaded mesh and binary
    if cfg!(target_os = "linux") {
        let mb: f64 = good[col("peak_rss_mb")].parse().unwrap();
        assert!(mb > 1.0 && mb < 4096.0, "{mb}");
    }
    let bad = &rows[1];
    assert_eq!(bad[col("status")], "failed");
    assert!(bad[col("error")].contains("quad.obj") && bad[col("error")].contains("4 vertices"), "{:?}", bad);
    // per-iteration CSV with the design columns; the best run's last row is 0 above the best
    let (h, it) = read_csv(&out.join("runs/bumpy_1k__sd__kp-newton.csv"));
    assert_eq!(
        h.join(","),
        "iter,energy,energy_minus_best,grad_norm,step,neg_eig,indefinite_elems,flips,t_assemble_s,t_project_s,t_solve_s,t_linesearch_s,t_iter_s,t_cum_s,shift,ls_evals,gap,t_record_s"
    );
    assert_eq!(it.len() - 1, good[col("iterations")].parse::<usize>().unwrap());
    assert_eq!(it.last().unwrap()[2].parse::<f64>().unwrap(), 0.0);
    // judged: from the common start to the reference minimum (computed by this batch, or
    // lowered by the run), gap 1 at the start and within 1e-6 at the end
    assert_eq!(good[col("start")], "tutte-scaled");
    assert_eq!(good[col("verdict")], "solved");
    assert!(["reference", "batch"].contains(&good[col("ref_source")].as_str()), "{good:?}");
    // the span: the start's distance or the minimum's own distortion, the smaller (here the
    // distortion, SD's excess over 2, far below the Tutte start's)
    let num = |name: &str| good[col(name)].parse::<f64>().unwrap();
    assert_eq!((num("start_energy"), num("ideal_energy")), (num("init_energy"), 2.0));
    let span = mapbench::convergence::span(num("start_energy"), num("ref_energy"), num("ideal_energy"));
    assert_eq!(num("gap_scale"), span);
    assert_eq!(span, num("ref_energy") - 2.0);
    assert_eq!(it[0][16].parse::<f64>().unwrap(), (num("init_energy") - num("ref_energy")) / span);
    let last_gap: f64 = it.last().unwrap()[16].parse().unwrap();
    assert!(last_gap <= 1e-6 && good[col("final_gap")].parse::<f64>().unwrap() == last_gap, "{last_gap}");
    assert!(!good[col("iters_to_1e-6")].is_empty() && !good[col("time_to_1e-6")].is_empty(), "{good:?}");
    assert!(out.join("runs/broken__sd__kp-newton.csv").is_file());
    // the final map, exported as a classic OBJ that tobj reads: the source mesh's vertices and
    // faces, the stored UVs bit for bit, no flipped triangle; none for a failed run
    let stored = mapbench::run_folder::map::read(&out, "bumpy_1k", "bumpy_1k__sd__kp-newton").unwrap().unwrap();
    let obj_path = tmp.path().join("exported.obj");
    let o = mapbench(
        &["map", out.to_str().unwrap(), "bumpy_1k__sd__kp-newton", "--obj", obj_path.to_str().unwrap()],
        tmp.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (models, _) =
        tobj::load_obj(&obj_path, &tobj::LoadOptions { single_index: true, ..Default::default() }).unwrap();
    assert_eq!(models.len(), 1);
    let m = &models[0].mesh;
    let src = solvers::generate::generate("bumpy_1k").unwrap();
    assert_eq!((m.positions.len() / 3, m.indices.len() / 3), (src.n_vertices(), src.n_faces()));
    // single_index keeps the order here: every corner is `i/i`, so vertex i is position i.
    let pos: Vec<[f64; 3]> = m.positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    assert_eq!(pos, src.positions);
    let uv: Vec<[f64; 2]> = m.texcoords.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    assert!(uv.iter().flatten().zip(stored.uv.iter().flatten()).all(|(a, b)| a.to_bits() == b.to_bits()));
    assert_eq!(uv.len(), stored.uv.len());
    let faces: Vec<[usize; 3]> =
        m.indices.chunks_exact(3).map(|f| [f[0] as usize, f[1] as usize, f[2] as usize]).collect();
    assert_eq!(faces, src.faces);
    for g in &faces {
        let p = g.map(|i| uv[i]);
        let cross = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
        assert!(cross > 0.0);
    }
    assert!(!out.join("uv/broken__sd__kp-newton.uv.gz").exists());
    // the failed run has no map: the export says so (exit 2)
    let o = mapbench(&["map", out.to_str().unwrap(), "--out", tmp.path().join("all").to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "a failed run has no map to miss: {}", text(&o));
    assert!(tmp.path().join("all/bumpy_1k__sd__kp-newton.obj").is_file());
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("meta.json")).unwrap()).unwrap();
    assert_eq!(meta["config"]["name"], "t");
    assert!(meta["ended_unix"].as_u64().is_some());
}

#[test]
fn only_filters_runs_by_glob() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"o\"\ndatasets = [\"bumpy_1k\", \"cap_2k\"]\nenergies = [\"sd\", \"bconf\"]\nsolvers = [\"kp-newton\", \"cm\"]\n",
    );
    let out = tmp.path().join("out");
    let args = ["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--only", "*__sd__kp-newton"];
    let o = mapbench(&[&args[..], &["--only", "cap_2k__bconf__*"]].concat(), tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let stem = |r: &Vec<String>| {
        ["dataset", "energy", "solver"].map(|k| r[header.iter().position(|h| h == k).unwrap()].clone()).join("__")
    };
    let stems: Vec<String> = rows.iter().map(stem).collect();
    assert_eq!(
        stems,
        ["bumpy_1k__sd__kp-newton", "cap_2k__sd__kp-newton", "cap_2k__bconf__kp-newton", "cap_2k__bconf__cm"]
    );
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--only", "cow*"], tmp.path());
    assert_ne!(o.status.code(), Some(0));
    assert!(text(&o).contains("--only cow* selects no run"), "{}", text(&o));
}

#[test]
fn a_run_past_its_timeout_stops_with_reason_timeout() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"t\"\ntimeout = \"0.001s\"\ndatasets = [\"bumpy_5k\"]\nenergies = [\"sd\"]\nsolvers = [\"slim\"]\n",
    );
    let out = tmp.path().join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "a timeout is not a failure: {}", text(&o));
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    assert_eq!(rows[0][col("stop_reason")], "timeout");
    assert_eq!(rows[0][col("status")], "not_converged");
    assert_eq!(rows[0][col("iterations")], "0", "the deadline passed before the first iteration ended");
}

/// Issue 35: the truncated steps whose CG stopped at its cap are counted like shifted
/// systems. With `max_cg_iters = 1` on the sack in SARAP, `kp-newton-cg`'s
/// `cg_capped_iters` is the number of its rows marked `cg_capped = 1` (some); `kp-newton`,
/// without truncated steps, leaves the column empty.
#[test]
fn cg_capped_steps_are_counted_in_a_batch() {
    let tmp = tempfile::tempdir().unwrap();
    let body = "name = \"cap\"\ndatasets = [\"sack_1k\"]\nenergies = [\"sarap\"]\n\
                solvers = [\"kp-newton\", \"kp-newton-cg\"]\n[solver.kp-newton-cg]\nmax_cg_iters = 1\n\
                [stop]\nmax_iters = 30\n";
    let cfg = write_config(tmp.path(), body);
    let out = tmp.path().join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-history"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let row = |solver: &str| rows.iter().find(|r| r[col("solver")] == solver).unwrap();
    assert_eq!(row("kp-newton")[col("cg_capped_iters")], "");
    let counted: usize = row("kp-newton-cg")[col("cg_capped_iters")].parse().unwrap();
    let (h, it) = read_csv(&out.join("runs/sack_1k__sarap__kp-newton-cg.csv"));
    let c = h.iter().position(|x| x == "cg_capped").unwrap();
    assert_eq!(it[0][c], "NaN");
    let marked = it[1..].iter().filter(|r| r[c] == "1.0").count();
    assert!(counted > 0 && counted == marked, "{counted} counted, {marked} rows marked");
}

/// Issue 18's honest labels in a batch: pairs outside a solver's definition are skipped with
/// the reason (no rows, no map, not a failure) and `--resume` keeps them; `[solver.slim]
/// clamp_weights = true` runs slim's, counting the clamped weights; every Newton-type row
/// records the shift of its system.
#[test]
fn skipped_pairs_clamped_weights_and_shifts_in_a_batch() {
    let tmp = tempfile::tempdir().unwrap();
    let body = "name = \"l\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\", \"nh\", \"bconf\"]\n\
                solvers = [\"kp-newton\", \"slim\", \"cm\"]\n[energy.bconf]\nk = 1.5\n[stop]\nmax_iters = 50\n";
    let cfg = write_config(tmp.path(), body);
    let out = tmp.path().join("out");
    let run = |extra: &[&str]| {
        let o =
            mapbench(&[&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], extra].concat(), tmp.path());
        assert_eq!(o.status.code(), Some(0), "skipped runs are not failures: {}", text(&o));
        let (header, rows) = read_csv(&out.join("summary.csv"));
        let rows: Vec<std::collections::BTreeMap<String, String>> =
            rows.into_iter().map(|r| header.iter().cloned().zip(r).collect()).collect();
        (text(&o), rows)
    };
    let stem =
        |r: &std::collections::BTreeMap<String, String>| format!("{}__{}__{}", r["dataset"], r["energy"], r["solver"]);
    let (log, rows) = run(&[]);
    // 6 ran (which of them the harness calls solved is another test's), 3 skipped
    assert!(log.contains("9 runs: ") && log.contains(", 0 failed, 3 skipped"), "{log}");
    let skipped: Vec<String> = rows.iter().filter(|r| r["status"] == "skipped").map(stem).collect();
    assert_eq!(skipped, ["bumpy_1k__nh__slim", "bumpy_1k__bconf__slim", "bumpy_1k__bconf__cm"]);
    for r in rows.iter().filter(|r| r["status"] == "skipped") {
        let s = stem(r);
        assert_eq!(
            (r["stop_reason"].as_str(), r["iterations"].as_str(), r["converged"].as_str()),
            ("skipped", "", "false")
        );
        assert!(
            r["error"].contains("is not defined for") || r["error"].contains("is not convex"),
            "{s}: {}",
            r["error"]
        );
        assert_eq!(r["vertices"], rows[0]["vertices"]);
        let (_, it) = read_csv(&out.join(format!("runs/{s}.csv")));
        assert!(it.is_empty() && !out.join(format!("uv/{s}.uv.gz")).exists(), "{s}");
    }
    assert!(log.contains("bumpy_1k nh slim: skipped: slim is not defined for nh: "), "{log}");
    // shifts: KP's systems factorize at the base shift; row 0 has no system
    for r in rows.iter().filter(|r| r["status"] == "ok") {
        let s = stem(r);
        assert_eq!(r["shifted_iters"], "0", "{s}");
        assert_eq!(r["clamped_iters"], if r["solver"] == "slim" { "0" } else { "" }, "{s}");
        let (header, it) = read_csv(&out.join(format!("runs/{s}.csv")));
        let shift = header.iter().position(|h| h == "shift").unwrap();
        assert_eq!(header[shift - 1], "t_cum_s");
        assert_eq!(it[0][shift], "", "{s}");
        assert!(it[1..].iter().all(|row| row[shift] == "1e-10"), "{s}: {it:?}");
        if r["solver"] == "slim" {
            assert_eq!(header.last().unwrap(), "clamped");
            assert_eq!(it[0].last().unwrap(), "NaN");
            assert!(it[1..].iter().all(|row| row.last().unwrap() == "0.0"), "{s}");
        }
    }
    // resumed as they are
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let (log, _) = run(&["--resume"]);
    assert_eq!(log.matches("resumed, ").count(), 9, "{log}");
    assert_eq!(std::fs::read_to_string(out.join("summary.csv")).unwrap(), summary);
    // the opt-in: slim's runs change key and run (clamping), cm's refusal stays skipped, the
    // other solvers' runs are resumed
    write_config(tmp.path(), &format!("{body}[solver.slim]\nclamp_weights = true\n"));
    let (log, rows) = run(&["--resume"]);
    assert_eq!(log.matches("resumed, ").count(), 6, "{log}");
    let slim_nh = rows.iter().find(|r| stem(r) == "bumpy_1k__nh__slim").unwrap();
    assert_ne!(slim_nh["status"], "skipped");
    assert!(slim_nh["clamped_iters"].parse::<usize>().unwrap() > 0, "{slim_nh:?}");
    let (_, it) = read_csv(&out.join("runs/bumpy_1k__nh__slim.csv"));
    assert!(it[1].last().unwrap().parse::<f64>().unwrap() > 0.0, "{:?}", it[1]);
    let skipped: Vec<String> = rows.iter().filter(|r| r["status"] == "skipped").map(stem).collect();
    assert_eq!(skipped, ["bumpy_1k__bconf__cm"]);
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("meta.json")).unwrap()).unwrap();
    // the table as given in the config; each run's settings carry their own solver's
    assert_eq!(meta["config"]["solver"]["slim"]["clamp_weights"], true, "{meta}");
    assert_eq!(meta["settings_per_energy"]["nh"]["param"]["settings"]["solver"]["options"], serde_json::json!({}));
}

/// The columns of a run folder that do not depend on timing: summary.csv's results and every
/// per-iteration CSV without its time columns, by file name.
type Table = Vec<Vec<String>>;

fn results(out: &Path) -> (Table, Vec<(String, Table)>) {
    let (h, rows) = read_csv(&out.join("summary.csv"));
    let keep = ["dataset", "energy", "solver", "iterations", "init_energy", "final_energy", "grad_norm", "status"];
    let summary =
        rows.iter().map(|r| keep.iter().map(|k| r[h.iter().position(|x| x == k).unwrap()].clone()).collect()).collect();
    let mut runs: Vec<(String, Table)> = std::fs::read_dir(out.join("runs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .map(|p| {
            let (h, rows) = read_csv(&p);
            let cols: Vec<usize> = (0..h.len()).filter(|&i| !h[i].starts_with("t_")).collect();
            let rows = rows.iter().map(|r| cols.iter().map(|&i| r[i].clone()).collect()).collect();
            (p.file_name().unwrap().to_string_lossy().into_owned(), rows)
        })
        .collect();
    runs.sort();
    (summary, runs)
}

#[test]
fn jobs_shards_merge_and_report_do_not_change_results() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"d\"\ndatasets = [\"cap_2k\", \"bumpy_1k\"]\nenergies = [\"sd\", \"bconf\"]\n\
         solvers = [\"kp-newton\", \"cm\"]\n",
    );
    let run = |sub: &str, extra: &[&str]| {
        let out = tmp.path().join(sub);
        let mut args = vec!["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()];
        args.extend(extra);
        let o = mapbench(&args, tmp.path());
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        out
    };
    let one_dir = run("one", &["--jobs", "1"]);
    let one = results(&one_dir);
    assert_eq!((one.0.len(), one.1.len()), (8, 8));
    // the four runs on a mesh share one symbolic analysis: the first computes it, the others
    // reuse it, and all report the same analysis_s (left out of time_s)
    let (h, rows) = read_csv(&one_dir.join("summary.csv"));
    let col = |name: &str| h.iter().position(|x| x == name).unwrap();
    for ds in ["cap_2k", "bumpy_1k"] {
        let mine: Vec<&Vec<String>> = rows.iter().filter(|r| r[col("dataset")] == ds).collect();
        let shared: Vec<&str> = mine.iter().map(|r| r[col("analysis_shared")].as_str()).collect();
        assert_eq!(shared, ["false", "true", "true", "true"], "{ds}");
        let secs: Vec<&str> = mine.iter().map(|r| r[col("analysis_s")].as_str()).collect();
        assert!(secs.iter().all(|s| *s == secs[0] && s.parse::<f64>().unwrap() > 0.0), "{ds}: {secs:?}");
    }
    // summary.csv is in the config's order whatever order the runs finished in
    let order: Vec<String> = one.0.iter().map(|r| format!("{} {} {}", r[0], r[1], r[2])).collect();
    assert_eq!(order[..3], ["cap_2k sd kp-newton", "cap_2k sd cm", "cap_2k bconf kp-newton"]);
    // energy_minus_best is 0 at the group's best final energy
    for (_, rows) in &one.1 {
        assert!(rows.iter().all(|r| r[2].parse::<f64>().unwrap() >= 0.0));
    }
    assert_eq!(results(&run("two", &["--jobs", "2"])), one);
    // two rayon threads inside each run: the same numbers (reductions have a fixed order)
    let body = std::fs::read_to_string(&cfg).unwrap();
    std::fs::write(&cfg, format!("threads_per_run = 2\n{body}")).unwrap();
    assert_eq!(results(&run("threads", &["--jobs", "1"])), one);
    std::fs::write(&cfg, body).unwrap();
    let shards: Vec<PathBuf> = (1..=3).map(|i| run(&format!("s{i}"), &["--shard", &format!("{i}/3")])).collect();
    let (_, part) = read_csv(&shards[0].join("summary.csv"));
    assert_eq!(part.len(), 3, "shard 1/3 of 8 runs");
    let merged = tmp.path().join("merged");
    let mut args = vec!["merge".to_string()];
    args.extend(shards.iter().map(|s| s.display().to_string()));
    args.extend(["--out".into(), merged.display().to_string()]);
    let o = mapbench(&args.iter().map(String::as_str).collect::<Vec<_>>(), tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert_eq!(results(&merged), one);
    // and the same maps: each shard kept its own best of its part of a group, merge the batch's
    let maps = |dir: &Path| {
        let mut v: Vec<(String, Vec<u8>)> = ["uv", "meshes"]
            .iter()
            .flat_map(|sub| std::fs::read_dir(dir.join(sub)).unwrap())
            .map(|e| e.unwrap().path())
            .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
            .collect();
        v.sort();
        v
    };
    let kept = maps(&one_dir);
    assert_eq!(kept.len(), 4 + 2, "one map per dataset and energy, one mesh per dataset");
    assert_eq!(maps(&merged), kept);
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(merged.join("meta.json")).unwrap()).unwrap();
    assert_eq!(meta["merged_from"].as_array().unwrap().len(), 3);
    // a missing shard is reported and fails the merge with exit 2
    let o = mapbench(&["merge", shards[0].to_str().unwrap(), "--out", "partial"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("5 planned runs are in no shard"), "{}", text(&o));
    // `report` rebuilds the same tables from the CSVs alone
    let tables = |dir: &Path| {
        let mut v: Vec<(PathBuf, Vec<u8>)> = std::fs::read_dir(dir.join("tables"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .map(|p| (p.clone(), std::fs::read(&p).unwrap()))
            .collect();
        v.sort();
        v
    };
    let before = tables(&merged);
    assert!(!before.is_empty());
    std::fs::remove_dir_all(merged.join("tables")).unwrap();
    let o = mapbench(&["report", merged.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert_eq!(tables(&merged), before);
    assert_eq!(results(&merged), one);
    // the report page links every run's problem in the explorer and shows its plots
    let html = std::fs::read_to_string(merged.join("index.html")).unwrap();
    for (name, _) in &one.1 {
        let mut parts = name.trim_end_matches(".csv").split("__");
        let (d, e) = (parts.next().unwrap(), parts.next().unwrap());
        assert!(html.contains(&format!("explorer.html#p={d}__{e}")), "{name}");
    }
    assert!(html.contains(&format!("{} <code>.csv</code> files in <a href=\"runs/\">", one.1.len())));
    assert!(html.contains("plots/cap_2k__sd__energy_iter.png"));
    assert!(merged.join("plots/cap_2k__sd__energy_iter.png").is_file());
}

#[test]
fn config_errors_name_the_file_and_key_and_exit_2() {
    let tmp = tempfile::tempdir().unwrap();
    let cases = [
        ("name = \"x\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp\"]\n", "unknown solver 'kp'"),
        (
            "name = \"x\"\ndatasets = [\"nope\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\"]\n",
            "unknown dataset 'nope'",
        ),
        ("name = \"x\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\"]\nfoo = 1\n", "foo"),
    ];
    for (body, needle) in cases {
        let cfg = write_config(tmp.path(), body);
        let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", "o"], tmp.path());
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{t}");
        assert!(t.contains(needle), "{needle}: {t}");
        assert!(t.contains("c.toml"), "{t}");
    }
}

#[test]
fn shared_entries_are_skipped_with_a_notice_without_the_corpus() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"s\"\ndatasets = [\"flat_disk_1k\", \"camelhead\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\"]\n",
    );
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", "o"], tmp.path());
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(t.contains("skipping camelhead: MAPBENCH_MESHES is not set"), "{t}");
    let (_, rows) = read_csv(&tmp.path().join("o/summary.csv"));
    assert_eq!(rows.len(), 1);
}

#[test]
fn validate_reports_bad_meshes_by_name() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("two.obj"), TWO_LOOPS_OBJ).unwrap();
    std::fs::write(tmp.path().join("junk.obj"), "v 0 0\nf 1 2 x\n").unwrap();
    let o = mapbench(&["validate", "two.obj"], tmp.path());
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(t.contains("two.obj") && t.contains("2 connected components"), "{t}");
    // a deformation shape may have holes but still needs one component
    let o = mapbench(&["validate", "two.obj", "--task", "deform"], tmp.path());
    assert_eq!(o.status.code(), Some(1));
    for (file, needle) in [("junk.obj", "junk.obj"), ("missing.obj", "missing.obj")] {
        let o = mapbench(&["validate", file], tmp.path());
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{t}");
        assert!(t.contains(needle) && !t.contains("panicked"), "{t}");
    }
    let o = mapbench(&["validate", "generated:bumpy_1k"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

#[test]
fn list_shows_registry_solvers_and_energies() {
    let root = repo_root();
    let o = mapbench(&["list", "datasets"], &root);
    let t = text(&o);
    assert!(o.status.success() && t.contains("camelhead") && t.contains("generated:bumpy_10k"), "{t}");
    // Every task's solvers, with their tasks and energies.
    let o = mapbench(&["list", "solvers"], &root);
    let t = text(&o);
    let line = |name: &str| t.lines().find(|l| l.split_whitespace().next() == Some(name)).unwrap_or("").to_string();
    assert!(line("kp-newton").contains("tasks=param,deform") && line("kp-newton").contains("energies=sd,"), "{t}");
    assert!(line("cm").contains("tasks=param,deform"), "{t}");
    for s in ["sem", "aem-cg", "aem-cg-safe"] {
        assert!(line(s).contains("tasks=authalic") && line(s).contains("energies=authalic"), "{s}: {t}");
    }
    let o = mapbench(&["list", "energies"], &root);
    assert_eq!(text(&o).lines().count(), 6);
}

#[test]
fn a_reader_that_closes_the_pipe_ends_the_output_quietly() {
    // `mapbench list solvers | head -1`, made deterministic: the read end is closed before
    // the binary writes its first line, so every write meets a broken pipe.
    let (reader, writer) = std::io::pipe().expect("a pipe");
    drop(reader);
    for args in [&["list", "solvers"][..], &["validate", "generated:bumpy_1k"][..]] {
        let o = Command::new(env!("CARGO_BIN_EXE_mapbench"))
            .args(args)
            .current_dir(repo_root())
            .stdout(writer.try_clone().expect("the write end"))
            .output()
            .expect("the binary runs");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success() && !err.contains("panicked"), "{args:?}: {:?} {err}", o.status);
    }
}

#[test]
fn the_gate_passes_on_its_own_baseline_and_catches_regressions() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"g\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\", \"cm\"]\n",
    );
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", "run"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = mapbench(&["baseline", "run", "--write", "base.json"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = mapbench(&["check", "run", "--baseline", "base.json"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("2 runs compared: 0 regressions"), "{}", text(&o));

    let base: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(tmp.path().join("base.json")).unwrap()).unwrap();
    let edit = |f: &dyn Fn(&mut serde_json::Value), name: &str| {
        let mut b = base.clone();
        f(&mut b);
        std::fs::write(tmp.path().join(name), serde_json::to_string(&b).unwrap()).unwrap();
    };
    // a lowered iteration count in the baseline means this run needs more: regression
    edit(
        &|b| {
            let it = b["runs"][0]["iterations"].as_u64().unwrap();
            b["runs"][0]["iterations"] = (it - 1).into();
        },
        "lower.json",
    );
    let o = mapbench(&["check", "run", "--baseline", "lower.json"], tmp.path());
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(t.contains("REGRESSIONS") && t.contains("bumpy_1k param sd kp-newton") && t.contains("+1"), "{t}");
    // a raised one is an improvement: reported, not failed
    edit(
        &|b| {
            let it = b["runs"][1]["iterations"].as_u64().unwrap();
            b["runs"][1]["iterations"] = (it + 3).into();
        },
        "higher.json",
    );
    let o = mapbench(&["check", "run", "--baseline", "higher.json"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("Improvements"));
    // a baseline run the folder does not have: exit 2
    edit(
        &|b| {
            let mut extra = b["runs"][0].clone();
            extra["dataset"] = "cap_2k".into();
            b["runs"].as_array_mut().unwrap().push(extra);
        },
        "missing.json",
    );
    let o = mapbench(&["check", "run", "--baseline", "missing.json"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("MISSING") && text(&o).contains("cap_2k"));
}

#[test]
fn ctrl_c_keeps_finished_runs_and_resume_completes_the_batch() {
    interrupted_batch_is_kept_and_resumed("INT", 130);
}

/// What Slurm sends at a time limit: the same clean stop, exit 128 + 15.
#[test]
fn sigterm_keeps_finished_runs_writes_the_report_and_resume_completes_the_batch() {
    interrupted_batch_is_kept_and_resumed("TERM", 143);
}

#[test]
fn export_system_writes_matrix_market_that_time_system_factorizes() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"x\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\", \"cm\"]\n",
    );
    let o = mapbench(
        &["export-system", cfg.to_str().unwrap(), "--out", "sys", "--iteration", "2", "--only", "*kp-newton"],
        tmp.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let mtx = tmp.path().join("sys/bumpy_1k__sd__kp-newton__it2.mtx");
    let body = std::fs::read_to_string(&mtx).unwrap();
    assert!(body.starts_with("%%MatrixMarket matrix coordinate real symmetric"));
    let size: Vec<usize> = body.lines().nth(2).unwrap().split_whitespace().map(|t| t.parse().unwrap()).collect();
    assert_eq!(size[..2], [2 * 1076, 2 * 1076]);
    assert_eq!(body.lines().count(), 3 + size[2]);
    assert!(tmp.path().join("sys/bumpy_1k__sd__kp-newton__it2.rhs.mtx").is_file());
    assert!(!tmp.path().join("sys/bumpy_1k__sd__cm__it2.mtx").exists(), "--only applies");
    for ordering in ["metis", "amd"] {
        let o = mapbench(&["time-system", mtx.to_str().unwrap(), "--ordering", ordering, "--repeat", "2"], tmp.path());
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        let t: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!((t["n"].as_u64(), t["ordering"].as_str()), (Some(2152), Some(ordering)));
        assert!(t["factorize_ms"].as_f64().unwrap() > 0.0);
    }
    // a file that is not a lower-triangle Matrix Market is refused by name
    std::fs::write(tmp.path().join("bad.mtx"), "%%MatrixMarket\n2 2 1\n1 2 1.0\n").unwrap();
    let o = mapbench(&["time-system", "bad.mtx"], tmp.path());
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("bad.mtx") && text(&o).contains("lower triangle"), "{}", text(&o));
}
