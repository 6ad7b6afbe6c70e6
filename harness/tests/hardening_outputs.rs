//! Output paths: what a verb writes where its user said goes through a symlink,
//! FIFO or device instead of replacing it, `-` is standard output, and a run folder's own
//! files are never overwritten.

use crate::common;

use common::*;
use std::path::{Path, PathBuf};

const TWO_RUNS: &str =
    "name = \"o\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\", \"cm\"]\nmaps = \"all\"\n";

/// A finished two-run batch in `tmp/out`.
fn two_runs(tmp: &Path) -> (PathBuf, PathBuf) {
    let cfg = write_config(tmp, TWO_RUNS);
    let out = tmp.join("out");
    let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-history"], tmp);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    (cfg, out)
}

#[test]
fn symlinks_are_written_through_and_dash_is_standard_output() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, out) = two_runs(tmp.path());
    let dir = out.to_str().unwrap();
    // baseline --write through a link: the link stays, its target gets the baseline
    let (target, link) = (tmp.path().join("base.json"), tmp.path().join("link.json"));
    std::fs::write(&target, "").unwrap();
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let o = mapbench(&["baseline", dir, "--write", link.to_str().unwrap()], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    let written: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&target).unwrap()).unwrap();
    assert_eq!(written["runs"].as_array().unwrap().len(), 2);
    // `-`: the baseline, the OBJ and the comparison page on standard output, and no file `-`
    let o = mapbench(&["baseline", dir, "--write", "-"], tmp.path());
    let stdout: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(stdout, written);
    let o = mapbench(&["map", dir, "bumpy_1k__sd__cm", "--obj", "-"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let obj = String::from_utf8(o.stdout).unwrap();
    assert!(obj.lines().filter(|l| l.starts_with("vt ")).count() > 900, "{}", &obj[..200.min(obj.len())]);
    let o = mapbench(&["compare", dir, dir, "--html", "-"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let page = String::from_utf8(o.stdout).unwrap();
    assert!(page.starts_with("<!doctype html>") && !page.contains("| run |"), "{}", &page[..200.min(page.len())]);
    assert!(!tmp.path().join("-").exists());
}

#[test]
fn a_run_folders_own_files_are_never_overwritten() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, out) = two_runs(tmp.path());
    let dir = out.to_str().unwrap();
    let summary = std::fs::read(out.join("summary.csv")).unwrap();
    let own = |f: &str| out.join(f).to_str().unwrap().to_string();
    let refused = |args: &[&str]| {
        let o = mapbench(args, tmp.path());
        let log = text(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {log}");
        assert!(log.contains("own files") || log.contains("a run folder"), "{args:?}: {log}");
    };
    refused(&["compare", dir, dir, "--html", &own("summary.csv")]);
    refused(&["baseline", dir, "--write", &own("meta.json")]);
    refused(&["map", dir, "bumpy_1k__sd__*", "--obj", &own("runs/bumpy_1k__sd__cm.csv")]);
    refused(&["map", dir, "--out", &own("plots")]);
    refused(&["history", "--db", &tmp.path().join("h.sqlite").to_string_lossy(), "--out", dir]);
    // through a link to a run folder's file too
    let link = tmp.path().join("page.html");
    std::os::unix::fs::symlink(out.join("index.html"), &link).unwrap();
    refused(&["compare", dir, dir, "--html", link.to_str().unwrap()]);
    assert_eq!(std::fs::read(out.join("summary.csv")).unwrap(), summary);
    // a new file inside the run folder is not one of its own
    let o = mapbench(&["compare", dir, dir, "--html", &own("compare.html")], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}
