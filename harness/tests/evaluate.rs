//! `mapbench evaluate`: a run's own maps score as the run says, in both map formats; the
//! frames against a closed form (the identity map of a planar mesh is an isometry); a mirror
//! image is all flips; maps of another mesh are refused with the reason.

use crate::common;

use common::*;
use std::path::Path;

fn score(args: &[&str], dir: &Path) -> serde_json::Value {
    let mut a = vec!["evaluate", "--json"];
    a.extend(args);
    let o = mapbench(&a, dir);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn a_runs_maps_score_its_final_energy_and_gradient_in_both_formats() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"e\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\", \"nh\"]\nsolvers = [\"kp-newton\"]\nmaps = \"all\"\n\
         [energy.nh]\nmu = 0.3\n",
    );
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", "out"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let (h, rows) = read_csv(&tmp.path().join("out/summary.csv"));
    let col = |n: &str| h.iter().position(|x| x == n).unwrap();
    assert_eq!(rows.len(), 2);
    for r in &rows {
        let energy = &r[col("energy")];
        let run = format!("bumpy_1k__{energy}__kp-newton");
        let uv = format!("out/uv/{run}.uv.gz");
        let params: &[&str] = if energy == "nh" { &["--param", "mu=0.3"] } else { &[] };
        let mut args = vec!["out/meshes/bumpy_1k.obj.gz", uv.as_str(), "--energy", energy];
        args.extend(params);
        let s = score(&args, tmp.path());
        let final_energy: f64 = r[col("final_energy")].parse().unwrap();
        let grad_norm: f64 = r[col("grad_norm")].parse().unwrap();
        let e = s["energy_value"].as_f64().unwrap();
        assert!((e - final_energy).abs() <= 1e-13 * final_energy, "{run}: {e} vs {final_energy}");
        let g = s["grad_norm"].as_f64().unwrap();
        assert!((g - grad_norm).abs() <= 1e-9 * grad_norm, "{run}: |grad| {g} vs {grad_norm}");
        assert_eq!(s["flips"], 0, "{run}");
        assert!(s["sigma_min"].as_f64().unwrap() > 0.0 && s["sigma_max"].as_f64().unwrap() >= 1.0, "{run}");
        assert_eq!(s["energy"]["name"], energy.as_str());
        // the batch's reference minimum and gap, as summary.csv has them
        let e_star: f64 = r[col("ref_energy")].parse().unwrap();
        let scale: f64 = r[col("gap_scale")].parse().unwrap();
        assert_eq!(s["reference"]["e_star"].as_f64(), Some(e_star), "{run}");
        assert_eq!(s["reference"]["above"].as_f64(), Some(e - e_star));
        assert_eq!(s["reference"]["gap"].as_f64(), Some((e - e_star) / scale));
        let gap: f64 = r[col("final_gap")].parse().unwrap();
        assert!((s["reference"]["gap"].as_f64().unwrap() - gap).abs() <= 1e-9 * gap.abs().max(1e-12), "{run}");

        // the same map as `mapbench map` writes it: the same numbers
        let obj = format!("{run}.obj");
        let o = mapbench(&["map", "out", &run, "--obj", &obj], tmp.path());
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        args[1] = obj.as_str();
        assert_eq!(
            score(&args, tmp.path()),
            serde_json::Value::Object({
                let mut m = s.as_object().unwrap().clone();
                m.insert("map".into(), obj.clone().into());
                m
            })
        );
    }
    // other parameters than the batch ran: no reference
    let o = mapbench(
        &["evaluate", "--json", "out/meshes/bumpy_1k.obj.gz", "out/uv/bumpy_1k__nh__kp-newton.uv.gz", "--energy", "nh"],
        tmp.path(),
    );
    let s: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(s["reference"], serde_json::Value::Null, "{s}");
    // a stored map read against another mesh: its checksum says so
    let (p, f) = grid(1.0);
    write_obj(&tmp.path().join("grid.obj"), &p, None, &f);
    let o = mapbench(&["evaluate", "grid.obj", "out/uv/bumpy_1k__sd__kp-newton.uv.gz"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("a map of a mesh with 1076 vertices"), "{}", text(&o));
}

/// A planar 3x3 grid of side `side` (8 faces, counter-clockwise).
fn grid(side: f64) -> (Vec<[f64; 2]>, Vec<[usize; 3]>) {
    let p = (0..9).map(|k| [side * (k % 3) as f64 / 2.0, side * (k / 3) as f64 / 2.0]).collect();
    let mut f = Vec::new();
    for i in 0..2 {
        for j in 0..2 {
            let v = 3 * i + j;
            f.push([v, v + 1, v + 4]);
            f.push([v, v + 4, v + 3]);
        }
    }
    (p, f)
}

fn write_obj(path: &Path, p: &[[f64; 2]], uv: Option<&[[f64; 2]]>, f: &[[usize; 3]]) {
    let mut s = String::new();
    for q in p {
        s += &format!("v {} {} 0\n", q[0], q[1]);
    }
    for q in uv.unwrap_or(&[]) {
        s += &format!("vt {} {}\n", q[0], q[1]);
    }
    for t in f {
        let [a, b, c] = t.map(|k| k + 1);
        s += &if uv.is_some() { format!("f {a}/{a} {b}/{b} {c}/{c}\n") } else { format!("f {a} {b} {c}\n") };
    }
    std::fs::write(path, s).unwrap();
}

#[test]
fn the_identity_map_of_a_planar_mesh_is_an_isometry_in_the_source_frame() {
    let tmp = tempfile::tempdir().unwrap();
    let (p, f) = grid(7.0);
    write_obj(&tmp.path().join("mesh.obj"), &p, None, &f);
    write_obj(&tmp.path().join("id.obj"), &p, Some(&p), &f);
    let s = score(&["mesh.obj", "id.obj", "--frame", "source"], tmp.path());
    assert!((s["energy_value"].as_f64().unwrap() - 2.0).abs() < 1e-12, "{s}");
    assert!(s["grad_norm"].as_f64().unwrap() < 1e-12, "{s}");
    for k in ["sigma_min", "sigma_max"] {
        assert!((s[k].as_f64().unwrap() - 1.0).abs() < 1e-12, "{s}");
    }
    // the same map as an external solver's text snapshot
    let text: String = p.iter().map(|q| format!("{:?} {:?}\n", q[0], q[1])).collect();
    std::fs::write(tmp.path().join("id.uv"), text).unwrap();
    let t = score(&["mesh.obj", "id.uv", "--frame", "source"], tmp.path());
    assert_eq!(t["energy_value"], s["energy_value"]);
    // read in the area-1 frame, the same coordinates are 7 times too large: sigma = 7,
    // SD = (49 + 1/49)
    let s = score(&["mesh.obj", "id.obj"], tmp.path());
    assert!((s["sigma_min"].as_f64().unwrap() - 7.0).abs() < 1e-12, "{s}");
    assert!((s["energy_value"].as_f64().unwrap() - (49.0 + 1.0 / 49.0)).abs() < 1e-10, "{s}");
    // the mirror image inverts every face: the barrier is infinite, no gradient
    let mirror: Vec<[f64; 2]> = p.iter().map(|q| [-q[0], q[1]]).collect();
    write_obj(&tmp.path().join("mirror.obj"), &p, Some(&mirror), &f);
    let s = score(&["mesh.obj", "mirror.obj", "--frame", "source"], tmp.path());
    assert_eq!(s["flips"], 8);
    assert_eq!(s["energy_value"], serde_json::Value::Null, "inf has no JSON number: {s}");
    assert_eq!(s["grad_norm"], serde_json::Value::Null);
    assert!((s["sigma_min"].as_f64().unwrap() + 1.0).abs() < 1e-12, "{s}");
}

#[test]
fn a_map_of_another_mesh_or_energy_is_refused_with_the_reason() {
    let tmp = tempfile::tempdir().unwrap();
    let (p, f) = grid(1.0);
    write_obj(&tmp.path().join("mesh.obj"), &p, None, &f);
    let (q, g) = grid(1.0);
    write_obj(&tmp.path().join("short.obj"), &q[..8], Some(&q[..8]), &g[..6]);
    let fail = |args: &[&str]| {
        let mut a = vec!["evaluate"];
        a.extend(args);
        let o = mapbench(&a, tmp.path());
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        text(&o)
    };
    assert!(fail(&["mesh.obj", "short.obj"]).contains("8 map vertices (`vt`), but mesh.obj has 9 vertices"));
    let mut swapped = g.clone();
    swapped[3] = [g[3][1], g[3][2], g[3][0]];
    write_obj(&tmp.path().join("swapped.obj"), &p, Some(&p), &swapped);
    assert!(fail(&["mesh.obj", "swapped.obj"]).contains("face 3 is not face 3 of mesh.obj"));
    // the same faces on other positions: a map made for another mesh
    let moved: Vec<[f64; 2]> = p.iter().map(|v| [v[0] * 1.5, v[1]]).collect();
    write_obj(&tmp.path().join("moved.obj"), &moved, Some(&p), &f);
    let said = fail(&["mesh.obj", "moved.obj"]);
    assert!(
        said.contains("moved.obj: vertex 1 (`v` line 2) is at [") && said.contains("(a map of another mesh?)"),
        "{said}"
    );
    assert!(fail(&["mesh.obj", "mesh.obj"]).contains("mesh.obj"));
    assert!(fail(&["mesh.obj", "swapped.obj", "--energy", "sd", "--param", "k=1"]).contains("sd has no parameters"));
    assert!(fail(&["mesh.obj", "swapped.obj", "--energy", "arap"]).contains("unknown variant `arap`"));
    assert!(fail(&["mesh.obj", "swapped.obj", "--task", "deform"]).contains("scores `param` maps so far"));
}

/// Outside a run folder, `--config` and `--dataset` find the reference minimum the config's
/// batches use: the same `E*` and gap as the run folder's, for the same mesh; another mesh or
/// other energy parameters are refused.
#[test]
fn a_configs_dataset_gives_the_reference_minimum_outside_a_run_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"e\"\ndatasets = [\"bumpy_1k\", \"cap_2k\"]\nenergies = [\"sd\"]\nsolvers = [\"slim\"]\nmaps = \"all\"\n",
    );
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", "out", "--no-history"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let mesh = "out/meshes/bumpy_1k.obj.gz";
    let obj = "bumpy.obj";
    let o = mapbench(&["map", "out", "bumpy_1k__sd__slim", "--obj", obj], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let in_folder = score(&[mesh, "out/uv/bumpy_1k__sd__slim.uv.gz"], tmp.path());
    let c = cfg.to_str().unwrap();
    let known = score(&[obj, obj, "--config", c, "--dataset", "bumpy_1k"], tmp.path());
    assert_eq!(known["energy_value"], in_folder["energy_value"]);
    assert_eq!(known["reference"]["e_star"], in_folder["reference"]["e_star"]);
    let (a, b) = (known["reference"]["gap"].as_f64().unwrap(), in_folder["reference"]["gap"].as_f64().unwrap());
    assert!((a - b).abs() <= 1e-12 * b.abs().max(1e-300), "{a} vs {b}");
    // the mesh of another dataset, another energy's parameters: refused with the reason
    let o = mapbench(&["evaluate", obj, obj, "--config", c, "--dataset", "cap_2k"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("not the mesh of dataset 'cap_2k'"), "{}", text(&o));
    let o = mapbench(&["evaluate", obj, obj, "--config", c, "--dataset", "bumpy_1k", "--energy", "nh"], tmp.path());
    assert!(text(&o).contains("no run of dataset 'bumpy_1k' with nh"), "{}", text(&o));
    let o = mapbench(&["evaluate", obj, obj, "--dataset", "bumpy_1k"], tmp.path());
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}
