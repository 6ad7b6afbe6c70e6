//! Fixtures shared by the report's tests (a tiny run folder, PNG sizes) and the test of the
//! whole plot set.

use super::chart::CURVE_SIZE;
use super::maps::MAP_SIZE;
use super::*;
use crate::run_folder::map as mapfile;
use crate::run_folder::{iteration_csv, write_atomic};
use solvers::solver::{IterationRecord, StopReason};

/// Width and height from a PNG's signature and IHDR chunk; panics if it is not a PNG.
pub(crate) fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n", "{}: not a PNG", path.display());
    assert_eq!(&b[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    (be(16), be(20))
}

fn summary(dataset: &str, task: &str, solver: &str, status: &str, error: &str) -> SummaryRow {
    SummaryRow {
        dataset: dataset.into(),
        task: task.parse().unwrap(),
        energy: if task == "authalic" { "authalic".into() } else { "sd".into() },
        solver: solver.into(),
        iterations: Some(3),
        time_s: Some(0.25),
        converged: status == "ok",
        stop_reason: Some(
            if status == "ok" { StopReason::GradientTolerance } else { StopReason::MaxIterations }.into(),
        ),
        status: status.parse().unwrap(),
        error: error.into(),
        ..Default::default()
    }
}

fn records(energies: &[f64], neg_eig: usize) -> Vec<IterationRecord> {
    energies
        .iter()
        .enumerate()
        .map(|(i, &energy)| IterationRecord {
            iter: i,
            energy,
            neg_eig: neg_eig.saturating_sub(10 * i),
            t_cum_s: 0.01 * i as f64,
            ..Default::default()
        })
        .collect()
}

/// A run folder as the runner leaves it: dataset `tiny` (param, two solvers that finished,
/// one failed with markup in its error), dataset `disk` (authalic, one solver), CSVs, maps
/// (`flat_disk_1k` under the identity and a shear) and meta.json.
pub(crate) fn tiny_run() -> (tempfile::TempDir, Vec<SummaryRow>) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let rows = vec![
        summary("tiny", "param", "kp-newton", "ok", ""),
        summary("tiny", "param", "slim", "not_converged", ""),
        summary("tiny", "param", "cm", "failed", "factorization failed: pivot < 0 & NaN in <K>"),
        // Two iterations: the three rows written below.
        SummaryRow { iterations: Some(2), ..summary("disk", "authalic", "aem-cg", "ok", "") },
    ];
    let write = |stem: &str, bytes: Vec<u8>| write_atomic(&p.join("runs").join(format!("{stem}.csv")), &bytes);
    write("tiny__sd__kp-newton", iteration_csv(&records(&[10.0, 5.0, 4.5, 4.0], 40), 4.0, None, None).unwrap())
        .unwrap();
    write("tiny__sd__slim", iteration_csv(&records(&[10.0, 7.0, 6.0, 5.5], 40), 4.0, None, None).unwrap()).unwrap();
    write("tiny__sd__cm", iteration_csv(&records(&[10.0], 40), 10.0, None, None).unwrap()).unwrap();
    // A negative gap (the failed run's energy below the group best) must plot too.
    write("disk__authalic__aem-cg", iteration_csv(&records(&[1.0, 0.5, 0.25], 5), 0.3, None, None).unwrap()).unwrap();
    let mesh = solvers::generate::generate("flat_disk_1k").unwrap();
    let identity: Vec<f64> = mesh.positions.iter().flat_map(|q| [q[0], q[1]]).collect();
    let shear: Vec<f64> = mesh.positions.iter().flat_map(|q| [q[0] + 0.5 * q[1], q[1]]).collect();
    // `tiny`'s maps in the compact format (UVs beside one mesh copy), `disk`'s as a folder
    // from before it left them (one OBJ per map): the report reads both.
    write_atomic(&mapfile::mesh_path(p, "tiny"), &mapfile::encode_mesh(&mesh)).unwrap();
    let uv = |stem: &str, x: &[f64]| write_atomic(&mapfile::uv_path(p, stem), &mapfile::encode_uv(&mesh, x)).unwrap();
    uv("tiny__sd__kp-newton", &identity);
    uv("tiny__sd__slim", &shear);
    let legacy = mapfile::MapFile {
        source: mesh.positions.clone(),
        uv: shear.chunks_exact(2).map(|q| [q[0], q[1]]).collect(),
        faces: mesh.faces.clone(),
    };
    write_atomic(&mapfile::legacy_obj_path(p, "disk__authalic__aem-cg"), &mapfile::to_obj(&legacy)).unwrap();
    let meta = serde_json::json!({
        "config": {"name": "tiny-config", "task": "param"},
        "git_revision": "0123456789abcdef0123456789abcdef01234567", "git_dirty": true,
        "host": "testhost", "cores": 2, "started_unix": 1_700_000_000u64, "ended_unix": 1_700_000_042u64,
    });
    write_atomic(&p.join("meta.json"), meta.to_string().as_bytes()).unwrap();
    (dir, rows)
}

#[test]
fn renders_every_group_and_map_as_png_of_the_requested_size() {
    let (dir, rows) = tiny_run();
    let plots = render_all(dir.path(), &rows).unwrap();
    let files: Vec<&str> = plots.iter().map(|p| p.file.as_str()).collect();
    assert_eq!(
        files,
        [
            "plots/tiny__sd__energy_iter.png",
            "plots/tiny__sd__energy_time.png",
            "plots/tiny__sd__neg_eig_iter.png",
            "plots/tiny__sd__kp-newton__map.png",
            "plots/tiny__sd__slim__map.png",
            "plots/disk__authalic__energy_iter.png",
            "plots/disk__authalic__energy_time.png",
            "plots/disk__authalic__neg_eig_iter.png",
            "plots/disk__authalic__aem-cg__map.png",
            "plots/profile__sd__iterations.png",
            "plots/profile__sd__time.png",
            "plots/profile__sd__data.png",
            // authalic runs are judged: their solvers are profiled too
            "plots/profile__authalic__iterations.png",
            "plots/profile__authalic__time.png",
            "plots/profile__authalic__data.png",
        ]
    );
    for p in &plots {
        let want = if matches!(p.kind, PlotKind::Map { .. }) { MAP_SIZE } else { CURVE_SIZE };
        assert_eq!(png_size(&dir.path().join(&p.file)), want, "{}", p.file);
    }
    assert_eq!(plots[4].kind, PlotKind::Map { solver: "slim".into() });
}

/// A map with a non-finite coordinate in a folder (a run of an older version, a file put
/// there) leaves its picture out; the report is rendered all the same.
#[test]
fn a_map_with_a_nan_coordinate_leaves_its_picture_out_not_the_report() {
    let (dir, rows) = tiny_run();
    let p = dir.path();
    let mesh = solvers::generate::generate("flat_disk_1k").unwrap();
    let mut x: Vec<f64> = mesh.positions.iter().flat_map(|q| [q[0], q[1]]).collect();
    x[7] = f64::NAN;
    write_atomic(&mapfile::uv_path(p, "tiny__sd__slim"), &mapfile::encode_uv(&mesh, &x)).unwrap();
    let plots = render_all(p, &rows).unwrap();
    assert!(plots.iter().any(|q| q.file == "plots/tiny__sd__kp-newton__map.png"));
    assert!(!plots.iter().any(|q| q.file == "plots/tiny__sd__slim__map.png"));
}
