//! Fuzzing: every input the fuzzer once crashed on (`fuzz/regressions/<target>/`) and
//! every seed (`fuzz/seeds/<target>/`) goes through the same code as the fuzz target
//! (`mapbench::fuzzing`), which must return, accepting or rejecting it, never panic.

use std::path::{Path, PathBuf};

type Target = fn(&[u8]) -> anyhow::Result<()>;

const TARGETS: [(&str, Target); 5] = [
    ("obj", mapbench::fuzzing::obj),
    ("config", mapbench::fuzzing::config),
    ("registry", mapbench::fuzzing::registry),
    ("handles", mapbench::fuzzing::handles),
    ("baseline", mapbench::fuzzing::baseline),
];

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz")
}

/// The files of `fuzz/<kind>/<target>/`, sorted (none when the folder is absent).
fn inputs(kind: &str, target: &str) -> Vec<PathBuf> {
    let Ok(dir) = std::fs::read_dir(fuzz_dir().join(kind).join(target)) else { return Vec::new() };
    let mut files: Vec<PathBuf> = dir.map(|e| e.unwrap().path()).filter(|p| p.is_file()).collect();
    files.sort();
    files
}

/// Feed every file of `fuzz/<kind>/*/` to its target; a rejection must name the input.
/// Returns the number of files and the names of the rejected ones.
fn feed(kind: &str) -> (usize, Vec<String>) {
    let (mut n, mut rejected) = (0, Vec::new());
    for (target, run) in TARGETS {
        for path in inputs(kind, target) {
            let data = std::fs::read(&path).unwrap();
            let outcome = std::panic::catch_unwind(|| run(&data));
            match outcome {
                Ok(Ok(())) => {}
                Ok(Err(e)) => {
                    rejected.push(path.file_name().unwrap().to_string_lossy().into_owned());
                    let msg = format!("{e:#}");
                    assert!(
                        msg.contains(mapbench::fuzzing::SOURCE),
                        "{}: message without the file: {msg}",
                        path.display()
                    );
                }
                Err(_) => panic!("fuzz target {target} panics on {}", path.display()),
            }
            n += 1;
        }
    }
    (n, rejected)
}

#[test]
fn fuzz_regression_inputs_return_without_panicking() {
    let (n, _) = feed("regressions");
    assert!(n > 0, "no regression inputs under {}", fuzz_dir().join("regressions").display());
}

#[test]
fn fuzz_seeds_return_and_the_real_ones_are_accepted() {
    let (_, rejected) = feed("seeds");
    // Every target has seeds, and the real files among them (configs, registry, baselines,
    // handles, meshes) are accepted: the targets reach past the parsers.
    for (target, _) in TARGETS {
        assert!(!inputs("seeds", target).is_empty(), "no seeds for {target}");
    }
    // The two meshes that are no disk (a closed surface, a bow-tie with a repeated face).
    assert_eq!(rejected, ["bowtie.obj", "tetra.obj"]);
}
