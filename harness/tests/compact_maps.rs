//! The run folder's compact maps end to end: `maps = "best" | "all" | "none"`, `--resume`,
//! `report` on them and on a folder of the older one-OBJ-per-map format, and `map`.

use crate::common;

use common::*;
use std::path::{Path, PathBuf};

const THREE_RUNS: &str =
    "name = \"m\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\", \"cm\", \"slim\"]\n";

fn run(tmp: &Path, extra_config: &str, args: &[&str]) -> (PathBuf, PathBuf, String) {
    let cfg = write_config(tmp, &format!("{THREE_RUNS}{extra_config}"));
    let out = tmp.join("out");
    let mut a = vec!["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()];
    a.extend(args);
    let o = mapbench(&a, tmp);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    (cfg, out, text(&o))
}

/// The file names in `dir/sub`, sorted (empty when the folder is absent).
fn names(dir: &Path, sub: &str) -> Vec<String> {
    let mut v: Vec<String> = match std::fs::read_dir(dir.join(sub)) {
        Ok(rd) => rd.map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect(),
        Err(_) => Vec::new(),
    };
    v.sort();
    v
}

fn map_pngs(out: &Path) -> Vec<String> {
    names(out, "plots").into_iter().filter(|n| n.ends_with("__map.png")).collect()
}

/// The solver of the converged run with the lowest final energy (first in order on a tie).
fn best_solver(out: &Path) -> String {
    let (h, rows) = read_csv(&out.join("summary.csv"));
    let col = |n: &str| h.iter().position(|x| x == n).unwrap();
    let mut best: Option<(f64, String)> = None;
    for r in rows.iter().filter(|r| r[col("status")] == "ok") {
        let e: f64 = r[col("final_energy")].parse().unwrap();
        if best.as_ref().is_none_or(|(b, _)| e < *b) {
            best = Some((e, r[col("solver")].clone()));
        }
    }
    best.unwrap().1
}

#[test]
fn by_default_one_map_per_dataset_and_energy_is_kept_and_resume_keeps_it() {
    let tmp = tempfile::tempdir().unwrap();
    let (cfg, out, _) = run(tmp.path(), "", &[]);
    let best = best_solver(&out);
    let stem = format!("bumpy_1k__sd__{best}");
    assert_eq!(names(&out, "uv"), [format!("{stem}.uv.gz")]);
    assert_eq!(names(&out, "meshes"), ["bumpy_1k.obj.gz"]);
    assert_eq!(map_pngs(&out), [format!("{stem}__map.png")]);
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("meta.json")).unwrap()).unwrap();
    assert_eq!(meta["maps"], "best");
    let kept = std::fs::read(out.join(format!("uv/{stem}.uv.gz"))).unwrap();
    // --resume reuses every run (the maps that were not kept are not wanted) and keeps the map.
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--resume"], tmp.path());
    let log = text(&o);
    assert_eq!(o.status.code(), Some(0), "{log}");
    assert_eq!(log.matches("resumed, ").count(), 3, "{log}");
    assert_eq!(std::fs::read(out.join(format!("uv/{stem}.uv.gz"))).unwrap(), kept);
    assert_eq!(map_pngs(&out), [format!("{stem}__map.png")]);
    // A run whose map was not kept: `map` says how to get it, exit 2.
    let other = ["kp-newton", "cm", "slim"].into_iter().find(|s| *s != best).unwrap();
    let o = mapbench(&["map", out.to_str().unwrap(), &format!("bumpy_1k__sd__{other}"), "--obj", "x.obj"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("maps = \"best\"") && text(&o).contains("--only"), "{}", text(&o));
    assert!(!tmp.path().join("x.obj").exists());
    // A glob selecting several maps cannot go to one file.
    let o = mapbench(&["map", out.to_str().unwrap(), "nomatch*", "--obj", "x.obj"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("no run matches nomatch*"), "{}", text(&o));
}

#[test]
fn all_keeps_every_map_and_the_same_map_as_best() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, out, _) = run(tmp.path(), "maps = \"all\"\n", &[]);
    let stems = ["kp-newton", "cm", "slim"].map(|s| format!("bumpy_1k__sd__{s}"));
    let mut want: Vec<String> = stems.iter().map(|s| format!("{s}.uv.gz")).collect();
    want.sort();
    assert_eq!(names(&out, "uv"), want);
    assert_eq!(map_pngs(&out).len(), 3);
    let best = best_solver(&out);
    let all = std::fs::read(out.join(format!("uv/bumpy_1k__sd__{best}.uv.gz"))).unwrap();
    // The same batch with the default keeps that very file (runs are deterministic).
    let tmp2 = tempfile::tempdir().unwrap();
    let (_, out2, _) = run(tmp2.path(), "", &[]);
    assert_eq!(std::fs::read(out2.join(format!("uv/bumpy_1k__sd__{best}.uv.gz"))).unwrap(), all);
    // Every map exports to a folder.
    let dir = tmp.path().join("objs");
    let o = mapbench(&["map", out.to_str().unwrap(), "--out", dir.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert_eq!(names(tmp.path(), "objs").len(), 3);
}

/// `maps_keep` keeps the named solvers' maps beside the best, and the report shows them side
/// by side under their group; merge keeps them too. Wrong uses are refused.
#[test]
fn maps_keep_shows_named_solvers_maps_beside_the_best() {
    let tmp = tempfile::tempdir().unwrap();
    let (cfg, out, _) = run(tmp.path(), "maps_keep = [\"slim\"]\n", &[]);
    let best = best_solver(&out);
    assert_ne!(best, "slim", "slim stops first on bumpy_1k");
    let mut want = vec![format!("bumpy_1k__sd__{best}.uv.gz"), "bumpy_1k__sd__slim.uv.gz".to_string()];
    want.sort();
    assert_eq!(names(&out, "uv"), want);
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let maps = &html[html.find("<div class=\"maps\">").expect("the maps of the group")..];
    let maps = &maps[..maps.find("</div>").unwrap()];
    assert_eq!(maps.matches("<figure>").count(), 2, "{maps}");
    assert!(maps.contains("bumpy_1k__sd__slim__map.png") && maps.contains(&format!("bumpy_1k__sd__{best}__map.png")));
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("meta.json")).unwrap()).unwrap();
    assert_eq!(meta["maps_keep"], serde_json::json!(["slim"]));
    // Two shards merged keep the same maps.
    let shards: Vec<PathBuf> = (1..=2).map(|i| tmp.path().join(format!("s{i}"))).collect();
    for (i, dir) in shards.iter().enumerate() {
        let shard = format!("{}/2", i + 1);
        let o = mapbench(
            &["run", cfg.to_str().unwrap(), "--out", dir.to_str().unwrap(), "--shard", &shard, "--no-history"],
            tmp.path(),
        );
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    }
    let merged = tmp.path().join("merged");
    let o = mapbench(
        &[
            "merge",
            shards[0].to_str().unwrap(),
            shards[1].to_str().unwrap(),
            "--out",
            merged.to_str().unwrap(),
            "--no-history",
        ],
        tmp.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert_eq!(names(&merged, "uv"), want);
    // Refused: a solver not in the config, and maps_keep with maps other than best.
    for (extra, says) in [
        ("maps_keep = [\"aqp\"]\n", "maps_keep names \"aqp\", not a solver of this config"),
        ("maps = \"all\"\nmaps_keep = [\"slim\"]\n", "maps_keep applies to maps = \"best\""),
    ] {
        let cfg = write_config(tmp.path(), &format!("{THREE_RUNS}{extra}"));
        let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", "never"], tmp.path());
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(text(&o).contains(says), "{}", text(&o));
        assert!(!tmp.path().join("never").exists());
    }
}

#[test]
fn none_writes_no_map_and_the_report_still_renders() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, out, _) = run(tmp.path(), "maps = \"none\"\n", &[]);
    assert!(!out.join("uv").exists() && !out.join("meshes").exists());
    assert!(map_pngs(&out).is_empty());
    assert!(names(&out, "plots").iter().any(|n| n.ends_with("energy_iter.png")));
    let o = mapbench(&["report", out.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(html.contains("energy_iter.png") && !html.contains("__map.png"));
    let o = mapbench(&["map", out.to_str().unwrap(), "--out", "objs"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("maps = \"none\""), "{}", text(&o));
}

#[test]
fn a_folder_of_the_older_format_still_reports_and_exports() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, out, _) = run(tmp.path(), "", &[]);
    let stem = format!("bumpy_1k__sd__{}", best_solver(&out));
    // Rewrite the folder as older versions left it: one OBJ per map, no mesh copy.
    // (`map` writes no file into a run folder's own `uv/`: the OBJ is moved there.)
    let (obj, legacy) = (tmp.path().join("legacy.obj"), out.join(format!("uv/{stem}.obj")));
    let o = mapbench(&["map", out.to_str().unwrap(), &stem, "--obj", obj.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    std::fs::rename(&obj, &legacy).unwrap();
    let stored = mapbench::run_folder::map::read(&out, "bumpy_1k", &stem).unwrap().unwrap();
    std::fs::remove_file(out.join(format!("uv/{stem}.uv.gz"))).unwrap();
    std::fs::remove_dir_all(out.join("meshes")).unwrap();
    std::fs::remove_dir_all(out.join("plots")).unwrap();
    let o = mapbench(&["report", out.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert_eq!(map_pngs(&out), [format!("{stem}__map.png")]);
    // The older map is counted in its folder's line of the files section.
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(page.contains("1 <code>.obj</code> files in <a href=\"uv/\">"), "{page}");
    assert_eq!(mapbench::run_folder::map::read(&out, "bumpy_1k", &stem).unwrap(), Some(stored));
}
