//! Bad configs and registries end before any run starts (exit 2, naming the entry), and
//! nothing is ever written outside the run folder, whatever a name says.

use crate::common;

use common::*;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Every path under `dir`, relative to it.
fn walk(dir: &Path) -> BTreeSet<PathBuf> {
    let mut out = BTreeSet::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            out.insert(p.strip_prefix(dir).unwrap().to_path_buf());
            if p.is_dir() {
                stack.push(p);
            }
        }
    }
    out
}

const TRIANGLES: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 0\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n";

#[test]
fn unsafe_names_stop_the_batch_before_any_byte_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let work = tmp.path().join("a").join("b");
    std::fs::create_dir_all(&work).unwrap();
    std::fs::write(work.join("m.obj"), TRIANGLES).unwrap();
    let abs_root = std::env::temp_dir().join(format!("mapbench-escape-{}", std::process::id()));
    let abs = format!("{}/x", abs_root.display());
    let long = "x".repeat(300);
    let reg = repo_root().join("datasets.toml");
    let inline = |name: &str| {
        format!(
            "name = \"t\"\nregistry = {:?}\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\"]\n[[dataset]]\nname = {name:?}\npath = \"m.obj\"\n",
            reg.display().to_string()
        )
    };
    let mut cases: Vec<(String, String, &str)> = [
        ("../../ESCAPED", "path separator"),
        (abs.as_str(), "path separator"),
        ("a/b", "path separator"),
        ("a\nb", "U+000A"),
        ("", "is empty"),
        ("..", "'..'"),
        (long.as_str(), "bytes"),
    ]
    .into_iter()
    .map(|(n, why)| (format!("inline {n:?}"), inline(n), why))
    .collect();
    // A registry entry, as a user or scripts/prepare_datasets.py might write it.
    std::fs::write(work.join("reg.toml"), "[[dataset]]\nname = \"../../ESCAPED\"\ngenerator = \"bumpy_1k\"\n").unwrap();
    cases.push((
        "registry entry".into(),
        "name = \"t\"\nregistry = \"reg.toml\"\ndatasets = [\"../../ESCAPED\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\"]\n"
            .into(),
        "path separator",
    ));
    // A long name that passes alone but not with this config's longest solver name.
    let near = "y".repeat(190);
    cases.push(("run name too long".into(), inline(&near).replace("kp-newton", "kp-newton-noscale"), "shorten it"));

    let before = walk(tmp.path());
    for (label, body, why) in &cases {
        let cfg = work.join("c.toml");
        std::fs::write(&cfg, body).unwrap();
        let before_cfg = walk(tmp.path());
        let o = mapbench(&["run", "c.toml", "--out", "out", "--jobs", "1"], &work);
        assert_eq!(o.status.code(), Some(2), "{label}: {}", text(&o));
        let msg = text(&o);
        assert!(msg.contains("c.toml") && msg.contains(why), "{label}: {msg}");
        assert_eq!(walk(tmp.path()), before_cfg, "{label}: files appeared");
        // export-system resolves the same plan and refuses the same names.
        let o = mapbench(&["export-system", "c.toml", "--out", "sys"], &work);
        assert_eq!(o.status.code(), Some(2), "{label}: {}", text(&o));
        assert_eq!(walk(tmp.path()), before_cfg, "{label}: export-system wrote files");
    }
    assert!(!abs_root.exists(), "{} was created", abs_root.display());
    let after: BTreeSet<PathBuf> = walk(tmp.path()).into_iter().filter(|p| !p.ends_with("c.toml")).collect();
    assert_eq!(after, before.into_iter().filter(|p| !p.ends_with("c.toml")).collect());
}

#[test]
fn a_batch_whose_datasets_are_all_skipped_says_which_and_why() {
    let tmp = tempfile::tempdir().unwrap();
    let reg = repo_root().join("datasets.toml");
    std::fs::write(
        tmp.path().join("c.toml"),
        format!(
            "name = \"t\"\nregistry = {:?}\ndatasets = [\"camelhead\", \"horse\"]\nenergies = [\"sd\"]\nsolvers = [\"cm\"]\n",
            reg.display().to_string()
        ),
    )
    .unwrap();
    let o = mapbench(&["run", "c.toml", "--out", "out"], tmp.path());
    let msg = text(&o);
    assert_eq!(o.status.code(), Some(2), "{msg}");
    assert!(!msg.contains("--only"), "{msg}");
    assert!(
        msg.contains("every selected dataset was skipped")
            && msg.contains("camelhead: MAPBENCH_MESHES is not set")
            && msg.contains("horse: MAPBENCH_MESHES is not set"),
        "{msg}"
    );
}

#[test]
fn conflicting_handles_fail_the_run_naming_the_file_and_vertex() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("m.obj"), TRIANGLES).unwrap();
    std::fs::write(
        tmp.path().join("h.p2p.json"),
        r#"{"p2p_sets": [{"src_vertex": [0, 2, 0], "dst": [[0.0, 0.0], [1.2, 1.0], [0.5, 0.0]]},
                         {"src_vertex": [0, 2, 0], "dst": [[0.0, 0.0], [1.2, 1.0], [0.0, 0.0]]}]}"#,
    )
    .unwrap();
    let cfg = |set: usize| {
        format!(
            "name = \"t\"\ntask = \"deform\"\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\"]\n[[dataset]]\nname = \"m\"\npath = \"m.obj\"\nhandles = \"h.p2p.json\"\nhandles_set = {set}\n"
        )
    };
    std::fs::write(tmp.path().join("c.toml"), cfg(0)).unwrap();
    let o = mapbench(&["run", "c.toml", "--out", "out", "--jobs", "1"], tmp.path());
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let summary = std::fs::read_to_string(tmp.path().join("out/summary.csv")).unwrap();
    assert!(
        summary.contains("failed")
            && summary.contains("h.p2p.json (set 0)")
            && summary.contains("handle 2 pulls vertex 0 to [0.5, 0.0], but handle 0 pulls it to [0.0, 0.0]"),
        "{summary}"
    );
    // The same handle repeated is harmless.
    std::fs::write(tmp.path().join("c.toml"), cfg(1)).unwrap();
    let o = mapbench(&["run", "c.toml", "--out", "out1", "--jobs", "1"], tmp.path());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

#[test]
fn a_config_name_or_summary_row_cannot_point_outside_the_run_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let work = tmp.path().join("w");
    std::fs::create_dir_all(&work).unwrap();
    std::fs::write(work.join("m.obj"), TRIANGLES).unwrap();
    let body = "name = \"t\"\nenergies = [\"sd\"]\nsolvers = [\"cm\"]\n[[dataset]]\nname = \"m\"\npath = \"m.obj\"\n";
    // The config name is the default run folder, reports/<name>.
    std::fs::write(work.join("c.toml"), body.replace("name = \"t\"", "name = \"../../up\"")).unwrap();
    let o = mapbench(&["run", "c.toml"], &work);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("config name \"../../up\" contains a path separator"), "{}", text(&o));
    assert!(!work.join("reports").exists() && !tmp.path().join("up").exists());

    std::fs::write(work.join("c.toml"), body).unwrap();
    let o = mapbench(&["run", "c.toml", "--out", "out", "--jobs", "1"], &work);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // A hand-edited summary row: `report` would write plots named after it.
    let summary = work.join("out/summary.csv");
    let edited = std::fs::read_to_string(&summary).unwrap().replace("\nm,param", "\n../../m,param");
    std::fs::write(&summary, edited).unwrap();
    let before = walk(tmp.path());
    let o = mapbench(&["report", "out"], &work);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("summary.csv: line 2") && text(&o).contains("dataset name \"../../m\""), "{}", text(&o));
    assert_eq!(walk(tmp.path()), before);
}
