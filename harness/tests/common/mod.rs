//! What the `mapbench` binary's end-to-end tests share: running it in a folder, its output,
//! configs on the repository's registry, CSVs, and a batch stopped by a signal.
// Each test file uses part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// One quad face: not a triangle mesh.
pub const QUAD_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
/// Two triangles apart: a mesh of two components.
pub const TWO_LOOPS_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 0\nv 6 5 0\nv 5 6 0\nf 1 2 3\nf 4 5 6\n";

/// `mapbench ARGS` in `dir`, without the shared corpus.
pub fn mapbench(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mapbench"))
        .args(args)
        .current_dir(dir)
        .env_remove("MAPBENCH_MESHES")
        .output()
        .expect("the binary runs")
}

pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Standard output then standard error.
pub fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

/// A config `c.toml` in `dir` using the repository's registry.
pub fn write_config(dir: &Path, body: &str) -> PathBuf {
    let reg = repo_root().join("datasets.toml");
    let path = dir.join("c.toml");
    std::fs::write(&path, format!("registry = {:?}\n{body}", reg.display().to_string())).unwrap();
    path
}

/// Header and rows of a CSV file.
pub fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let mut r = csv::Reader::from_path(path).unwrap();
    let header = r.headers().unwrap().iter().map(String::from).collect();
    let rows = r.records().map(|x| x.unwrap().iter().map(String::from).collect()).collect();
    (header, rows)
}

/// A 12-run batch sent `signal` (`INT`, `TERM`, ...) once two runs are on disk; checks what
/// every clean stop must leave: the exit code `code`, the finished runs complete on disk with
/// no temporary file, the report, `interrupted: true` in meta.json, and a `--resume` that runs
/// exactly the rest.
pub fn interrupted_batch_is_kept_and_resumed(signal: &str, code: i32) {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(
        tmp.path(),
        "name = \"i\"\ndatasets = [\"bumpy_1k\", \"cap_2k\"]\nenergies = [\"sd\", \"bconf\"]\n\
         solvers = [\"kp-newton\", \"cm\", \"slim\"]\nmaps = \"all\"\n",
    );
    let out = tmp.path().join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_mapbench"))
        .args(["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--jobs", "1"])
        .current_dir(tmp.path())
        .env_remove("MAPBENCH_MESHES")
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    let lines = || std::fs::read_to_string(out.join("summary.csv")).map(|s| s.lines().count()).unwrap_or(0);
    while lines() < 3 {
        assert!(child.try_wait().unwrap().is_none(), "the batch ended early");
        assert!(t0.elapsed().as_secs() < 120, "no run finished");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let kill = Command::new("kill").args([&format!("-{signal}"), &child.id().to_string()]).status().unwrap();
    assert!(kill.success());
    let o = child.wait_with_output().unwrap();
    let log = text(&o);
    assert_eq!(o.status.code(), Some(code), "{log}");
    assert!(log.contains("interrupted:") && log.contains("not run (`--resume` runs them)"), "{log}");
    let (header, rows) = read_csv(&out.join("summary.csv"));
    let done = rows.len();
    assert!((2..12).contains(&done), "{done} runs done: {log}");
    let status = header.iter().position(|h| h == "status").unwrap();
    for r in &rows {
        let stem = format!("{}__{}__{}", r[0], r[2], r[3]);
        let (_, it) = read_csv(&out.join(format!("runs/{stem}.csv")));
        // slim is not defined for bconf: skipped, with no rows and no map
        if r[status] == "skipped" {
            assert!(it.is_empty() && !out.join(format!("uv/{stem}.uv.gz")).exists(), "{stem}");
            continue;
        }
        assert_eq!(it.len() - 1, r[6].parse::<usize>().unwrap(), "{stem}");
        assert!(out.join(format!("uv/{stem}.uv.gz")).is_file(), "{stem}");
    }
    let leftovers = |d: &str| {
        std::fs::read_dir(out.join(d))
            .unwrap()
            .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().contains(".tmp"))
            .count()
    };
    assert_eq!((leftovers("runs"), leftovers("uv"), leftovers(".")), (0, 0, 0));
    assert!(out.join("index.html").is_file() && out.join("tables/param.md").is_file());
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("meta.json")).unwrap()).unwrap();
    assert_eq!(meta["interrupted"], true);
    assert!(meta["ended_unix"].is_u64(), "{meta}");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--resume"], tmp.path());
    let log = text(&o);
    assert_eq!(o.status.code(), Some(0), "{log}");
    assert_eq!(log.matches("resumed, ").count(), done, "{log}");
    let (_, rows) = read_csv(&out.join("summary.csv"));
    assert_eq!(rows.len(), 12);
}

/// Lines outside fenced code blocks.
pub fn prose(text: &str) -> Vec<&str> {
    let mut inside = false;
    text.lines()
        .filter(|l| {
            if l.trim_start().starts_with("```") {
                inside = !inside;
                return false;
            }
            !inside
        })
        .collect()
}
