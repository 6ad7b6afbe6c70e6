//! Mesh-input hardening end to end: `mapbench validate --task T` refuses exactly the meshes a
//! run of task `T` refuses, for the same reason, and the probe's bad meshes (clockwise planar,
//! huge coordinates, BOM, CR line ends) either work or fail with a message naming the mesh.

use crate::common;

use common::*;
use std::path::Path;

/// An `n` x `n` vertex grid over `[0, n-1]^2` times `scale`, with `z(i, j)` and faces
/// counter-clockwise in the xy-plane unless `clockwise`.
fn grid_obj(n: usize, scale: f64, clockwise: bool, z: impl Fn(usize, usize) -> f64) -> String {
    let mut s = String::new();
    for j in 0..n {
        for i in 0..n {
            s += &format!("v {:e} {:e} {:e}\n", i as f64 * scale, j as f64 * scale, z(i, j));
        }
    }
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let (a, b, c, d) = (j * n + i + 1, j * n + i + 2, (j + 1) * n + i + 2, (j + 1) * n + i + 1);
            if clockwise {
                s += &format!("f {a} {c} {b}\nf {a} {d} {c}\n");
            } else {
                s += &format!("f {a} {b} {c}\nf {a} {c} {d}\n");
            }
        }
    }
    s
}

/// A planar annulus (two boundary loops), counter-clockwise.
fn annulus_obj() -> String {
    let m = 12;
    let mut s = String::new();
    for r in [1.0, 2.0] {
        for i in 0..m {
            let t = i as f64 * std::f64::consts::TAU / m as f64;
            s += &format!("v {} {} 0\n", r * t.cos(), r * t.sin());
        }
    }
    for i in 0..m {
        let j = (i + 1) % m;
        s += &format!("f {} {} {}\nf {} {} {}\n", i + 1, m + i + 1, m + j + 1, i + 1, m + j + 1, j + 1);
    }
    s
}

/// The bad (and the formerly bad) meshes of the probe, by dataset name.
fn meshes() -> Vec<(&'static str, String)> {
    let flat = |_: usize, _: usize| 0.0;
    let mut span = grid_obj(4, 1.0, false, flat);
    span = span.replacen("v 0e0 0e0 0e0", "v -1e308 0e0 0e0", 1).replacen("v 3e0 3e0 0e0", "v 1e308 3e0 0e0", 1);
    let mut degenerate = grid_obj(4, 1.0, false, flat);
    degenerate += "v 0.5 0 0\nf 1 17 2\n";
    vec![
        ("ccw", grid_obj(4, 1.0, false, flat)),
        ("clockwise", grid_obj(4, 1.0, true, flat)),
        ("clockwise_lifted", grid_obj(4, 1.0, true, |_, _| 5.0)),
        ("bumpy", grid_obj(4, 1.0, false, |i, j| ((i * j) % 3) as f64 * 0.3)),
        ("annulus", annulus_obj()),
        ("huge", grid_obj(4, 1e300, false, flat)),
        ("tiny", grid_obj(4, 1e-300, false, flat)),
        ("span", span),
        ("degenerate", degenerate),
        ("fan", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n".to_string()),
    ]
}

/// `dataset -> (status, error)` of a run of `task` over every mesh of [`meshes`].
fn run_task(dir: &Path, task: &str) -> Vec<(String, String, String)> {
    let (energies, solvers) = match task {
        "authalic" => ("[]", "[\"sem\"]"),
        _ => ("[\"sd\"]", "[\"kp-newton\"]"),
    };
    let mut body =
        format!("name = \"{task}\"\ntask = \"{task}\"\ndatasets = []\nenergies = {energies}\nsolvers = {solvers}\n");
    if task == "authalic" {
        body += "[stop]\nmax_iters = 5\n";
    }
    for (name, _) in meshes() {
        body += &format!("[[dataset]]\nname = \"{name}\"\npath = \"{name}.obj\"\n");
        if task == "deform" {
            body += "handles_rule = \"stretch\"\n";
        }
    }
    let cfg = write_config(dir, &body);
    let out = dir.join(format!("out_{task}"));
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()], dir);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{task}: {}", text(&o));
    let mut r = csv::Reader::from_path(out.join("summary.csv")).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (d, s, e) = (col("dataset"), col("status"), col("error"));
    r.records().map(|x| x.unwrap()).map(|x| (x[d].to_string(), x[s].to_string(), x[e].to_string())).collect()
}

#[test]
fn validate_refuses_exactly_what_a_run_of_the_task_refuses() {
    let tmp = tempfile::tempdir().unwrap();
    for (name, obj) in meshes() {
        std::fs::write(tmp.path().join(format!("{name}.obj")), obj).unwrap();
    }
    // (task, meshes its runs must refuse, with a phrase of the reason); the rest must run
    let expected: [(&str, &[(&str, &str)]); 3] = [
        ("param", &[("annulus", "topological disk"), ("span", "rescale the mesh"), ("degenerate", "degenerate")]),
        (
            "deform",
            &[
                ("clockwise", "face 0 is clockwise in the plane"),
                ("clockwise_lifted", "the deform task needs a planar mesh"),
                ("bumpy", "the deform task needs a planar mesh"),
                ("span", "rescale the mesh"),
                ("degenerate", "degenerate"),
            ],
        ),
        (
            "authalic",
            &[
                ("annulus", "topological disk"),
                ("span", "rescale the mesh"),
                ("degenerate", "degenerate"),
                ("fan", "no interior vertex"),
            ],
        ),
    ];
    for (task, refused) in expected {
        let rows = run_task(tmp.path(), task);
        assert_eq!(rows.len(), meshes().len(), "{task}: {rows:?}");
        for (name, status, error) in rows {
            let file = format!("{name}.obj");
            let v = mapbench(&["validate", &file, "--task", task], tmp.path());
            let vt = text(&v);
            let label = format!("{task} {name}: run {status} ({error}); validate: {vt}");
            match refused.iter().find(|(n, _)| *n == name) {
                Some((_, reason)) => {
                    assert_eq!(status, "failed", "{label}");
                    assert_eq!(v.status.code(), Some(1), "{label}");
                    assert!(error.contains(&file) && error.contains(reason), "{label}");
                    assert!(vt.contains(&file) && vt.contains(reason), "{label}");
                    // the same reason: validate's first problem is the run's
                    let first = vt.lines().find_map(|l| l.trim().strip_prefix("- ")).expect("a problem line");
                    assert!(error.contains(first), "{label}");
                }
                None => {
                    assert_ne!(status, "failed", "{label}");
                    assert_eq!(v.status.code(), Some(0), "{label}");
                    assert!(vt.contains("no problems found"), "{label}");
                }
            }
        }
    }
}

#[test]
fn bom_and_cr_line_ends_are_read() {
    let tmp = tempfile::tempdir().unwrap();
    let obj = grid_obj(4, 1.0, false, |_, _| 0.0);
    std::fs::write(tmp.path().join("bom.obj"), format!("\u{feff}{obj}")).unwrap();
    std::fs::write(tmp.path().join("mac.obj"), obj.replace('\n', "\r")).unwrap();
    for file in ["bom.obj", "mac.obj"] {
        let o = mapbench(&["validate", file], tmp.path());
        let t = text(&o);
        assert_eq!(o.status.code(), Some(0), "{file}: {t}");
        assert!(t.contains("16 vertices, 18 faces") && t.contains("no problems found"), "{file}: {t}");
    }
}
