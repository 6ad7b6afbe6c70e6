//! The growth of the resident memory during a run, measured in a batch of one run at a time
//! (`--jobs 1`): it grows with the mesh and stays under the process's peak.

use crate::common;

use common::{mapbench, read_csv, text, write_config};

#[test]
#[cfg(target_os = "linux")]
fn one_run_at_a_time_each_run_has_its_memory_growth_and_it_grows_with_the_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write_config(
        dir.path(),
        "name = \"mem\"\ndatasets = [\"bumpy_1k\", \"bumpy_10k\"]\nenergies = [\"sd\"]\n\
         solvers = [\"kp-newton\"]\n",
    );
    let out = dir.path().join("out");
    let o = mapbench(
        &["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--jobs", "1", "--no-history"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let col = |name: &str| header.iter().position(|c| c == name).unwrap();
    let (own, all, dataset) = (col("peak_growth_mb"), col("peak_rss_mb"), col("dataset"));
    let mb =
        |r: &Vec<String>, c: usize| -> f64 { r[c].parse().unwrap_or_else(|_| panic!("{}: {:?}", header[c], r[c])) };
    let of = |d: &str| rows.iter().find(|r| r[dataset] == d).unwrap();
    for r in &rows {
        assert!(mb(r, own) > 0.0 && mb(r, own) < mb(r, all), "own {} of the process's {}", r[own], r[all]);
    }
    // Ten times the vertices: more than twice the memory (the Newton system and its factor),
    // even after reusing what the small run left in the allocator.
    let (small, large) = (mb(of("bumpy_1k"), own), mb(of("bumpy_10k"), own));
    assert!(large > 2.0 * small, "bumpy_1k {small} MB, bumpy_10k {large} MB");
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(page.contains("MB its own"), "the tooltip names it");
}
