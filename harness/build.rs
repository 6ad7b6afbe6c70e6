//! Records the toolchain, the versions of the numeric crates and the code's git revision
//! (with whether the code differs from it, and a hash of the difference) for `meta.json`,
//! the history and the `--resume` keys: the binary says what it was built from, wherever the
//! config it runs lives.

use std::process::Command;

fn main() {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let version = Command::new(rustc)
        .arg("--version")
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=MAPBENCH_RUSTC={version}");
    // The versions Cargo.lock pins for the crates that decide numbers and speed.
    let lock = std::fs::read_to_string("../Cargo.lock").unwrap_or_default();
    let wanted = ["faer", "nalgebra", "rayon", "plotters"];
    let mut found = Vec::new();
    let mut name = None;
    for line in lock.lines() {
        if let Some(n) = line.strip_prefix("name = ") {
            name = Some(n.trim_matches('"').to_string());
        } else if let (Some(v), Some(n)) = (line.strip_prefix("version = "), name.take()) {
            if wanted.contains(&n.as_str()) {
                found.push(format!("{n} {}", v.trim_matches('"')));
            }
        }
    }
    println!("cargo:rustc-env=MAPBENCH_CRATES={}", found.join(", "));
    println!("cargo:rerun-if-changed=../Cargo.lock");
    println!("cargo:rerun-if-env-changed=RUSTC");
    revision();
}

/// The code's paths: what a build is made of.
const CODE: [&str; 4] = ["solvers", "harness", "Cargo.toml", "Cargo.lock"];

/// `MAPBENCH_GIT_REVISION` (empty outside a git checkout), `MAPBENCH_GIT_DIRTY` (`true` when
/// the code's paths differ from it, untracked files included) and `MAPBENCH_GIT_DIFF` (FNV-1a
/// over the difference, so two dirty builds of one revision differ in their `--resume` keys).
fn revision() {
    let git = |args: &[&str]| {
        Command::new("git").current_dir("..").args(args).output().ok().filter(|o| o.status.success()).map(|o| o.stdout)
    };
    let text = |b: Vec<u8>| String::from_utf8_lossy(&b).trim().to_string();
    let rev = git(&["rev-parse", "HEAD"]).map(text).unwrap_or_default();
    let (mut dirty, mut hash) = (String::new(), String::new());
    if !rev.is_empty() {
        let mut args = vec!["status", "--porcelain", "--untracked-files=all", "--"];
        args.extend(CODE);
        let status = git(&args).unwrap_or_default();
        dirty = (!status.is_empty()).to_string();
        if !status.is_empty() {
            let mut h: u64 = 0xcbf29ce484222325;
            let mut eat = |bytes: &[u8]| {
                for &b in bytes {
                    h = (h ^ u64::from(b)).wrapping_mul(0x100000001b3);
                }
            };
            let mut diff = vec!["diff", "HEAD", "--"];
            diff.extend(CODE);
            eat(&git(&diff).unwrap_or_default());
            for line in String::from_utf8_lossy(&status).lines() {
                if let Some(path) = line.strip_prefix("?? ") {
                    eat(path.as_bytes());
                    eat(&std::fs::read(format!("../{path}")).unwrap_or_default());
                }
            }
            hash = format!("{h:016x}");
        }
        // Rerun when the revision moves or the code changes.
        if let Some(dir) = git(&["rev-parse", "--git-dir"]).map(text) {
            let dir = if std::path::Path::new(&dir).is_absolute() { dir } else { format!("../{dir}") };
            println!("cargo:rerun-if-changed={dir}/HEAD");
            println!("cargo:rerun-if-changed={dir}/index");
        }
        if let Some(common) = git(&["rev-parse", "--git-common-dir"]).map(text) {
            let common = if std::path::Path::new(&common).is_absolute() { common } else { format!("../{common}") };
            println!("cargo:rerun-if-changed={common}/refs/heads");
            println!("cargo:rerun-if-changed={common}/packed-refs");
        }
        for p in CODE {
            println!("cargo:rerun-if-changed=../{p}");
        }
    }
    println!("cargo:rustc-env=MAPBENCH_GIT_REVISION={rev}");
    println!("cargo:rustc-env=MAPBENCH_GIT_DIRTY={dirty}");
    println!("cargo:rustc-env=MAPBENCH_GIT_DIFF={hash}");
}
