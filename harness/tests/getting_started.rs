//! The "Getting started" page (docs/src/guide/getting-started.md) run as written: its files
//! are written and its commands run, in order, in a folder laid out as the repository's root
//! (the registry, the committed reference store and `peers/`), and each output block's lines
//! must be among what the commands before it printed. Blocks are marked with HTML comments,
//! which the book does not show:
//!
//! - `<!-- tutorial: file PATH -->` before a code block: its text is written to PATH;
//! - `<!-- tutorial: run -->` before an `sh` block: each line is a command (`cargo run
//!   --release --` is the binary under test); `, exit N`: the last one exits with N;
//!   `, needs numpy`: skipped with a notice when python3 has no numpy (a failure with
//!   `MAPBENCH_REQUIRE_PEERS` set, as in CI);
//! - `<!-- tutorial: output -->` before a `text` block: every line but `...` must be a line
//!   the run block printed (stdout or stderr), up to what varies between machines and runs:
//!   times, the order in which parallel runs end, the last digits of an energy, the folder.

use std::path::{Path, PathBuf};
use std::process::Command;

/// Where the page puts the repository (its absolute paths in the output).
const SHOWN_ROOT: &str = "/home/you/mapbench";

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

#[derive(Debug)]
enum Step {
    File { path: String, text: String },
    Run { commands: Vec<String>, exit: i32, needs_numpy: bool },
    Output { lines: Vec<String> },
}

/// The page's marked blocks, in order.
fn steps(page: &str) -> Vec<Step> {
    let mut out = Vec::new();
    let mut lines = page.lines();
    while let Some(line) = lines.next() {
        let Some(mark) = line.trim().strip_prefix("<!-- tutorial:").and_then(|m| m.strip_suffix("-->")) else {
            continue;
        };
        let fence = lines.next().unwrap_or_default();
        assert!(fence.starts_with("```"), "a tutorial mark is not followed by a code block: {line}");
        let body: Vec<String> = lines.by_ref().take_while(|l| !l.starts_with("```")).map(String::from).collect();
        let mut words = mark.split(',').map(str::trim);
        let kind = words.next().unwrap_or_default();
        let options: Vec<&str> = words.collect();
        let step = if let Some(path) = kind.strip_prefix("file ") {
            Step::File { path: path.trim().to_string(), text: body.join("\n") + "\n" }
        } else if kind == "run" {
            let exit = options.iter().find_map(|o| o.strip_prefix("exit ")).map_or(0, |n| n.parse().unwrap());
            let commands = body.into_iter().filter(|l| !l.trim().is_empty() && !l.starts_with('#')).collect();
            Step::Run { commands, exit, needs_numpy: options.contains(&"needs numpy") }
        } else if kind == "output" {
            Step::Output { lines: body }
        } else {
            panic!("unknown tutorial mark: {line}");
        };
        out.push(step);
    }
    out
}

/// A line with what varies between runs replaced: a run's place in the order of ending,
/// times and ratios of times, a number's digits past the fourth decimal, a number in
/// exponent notation (a gradient's norm at round-off), trailing spaces.
fn masked(line: &str) -> String {
    let tokens: Vec<&str> = line.split(' ').collect();
    let words: Vec<String> = tokens
        .iter()
        .enumerate()
        .map(|(i, w)| {
            let core = w.trim_start_matches(['(', '[']).trim_end_matches([')', ']', ',']);
            let (lead, tail) = w.split_at(w.find(core).unwrap_or(0));
            let tail = &tail[core.len()..];
            let number = !core.is_empty() && core.parse::<f64>().is_ok() && core.contains(['.', 'e']);
            if w.starts_with('[') && w.ends_with(']') && w.contains('/') {
                // [3/12] -> [_/12]
                format!("[_/{}", w.split('/').nth(1).unwrap_or_default())
            } else if number && tokens.get(i + 1).is_some_and(|n| n.trim_end_matches([',', ')']) == "s") {
                "_".to_string()
            } else if core.ends_with('x') && core[..core.len() - 1].parse::<f64>().is_ok() {
                format!("{lead}_x{tail}")
            } else if number && core.contains('e') {
                format!("{lead}_{tail}")
            } else if number {
                let (int, frac) = core.split_once('.').unwrap_or((core, ""));
                format!("{lead}{int}.{}{tail}", &frac[..frac.len().min(4)])
            } else {
                w.to_string()
            }
        })
        .collect();
    words.join(" ").trim_end().to_string()
}

fn has_numpy() -> bool {
    Command::new("python3").args(["-c", "import numpy"]).output().is_ok_and(|o| o.status.success())
}

#[test]
fn the_masks_leave_what_the_page_promises() {
    assert_eq!(
        masked("[12/12] cap_2k bconf kp-newton: ran (grad_tol), 4 iterations, E = 0.20710620, 0.10 s"),
        "[_/12] cap_2k bconf kp-newton: ran (grad_tol), 4 iterations, E = 0.2071, _ s"
    );
    assert_eq!(
        masked("timings (advisory, not gated): total 0.73 s in the baseline, 0.53 s now (0.73x)"),
        "timings (advisory, not gated): total _ s in the baseline, _ s now (_x)"
    );
    assert_eq!(
        masked("  bumpy_1k param sd kp-newton   status   ok   not_converged     "),
        "  bumpy_1k param sd kp-newton   status   ok   not_converged"
    );
    assert_eq!(
        masked("reference minimum of bump param sd: E* = 2.048633536066 (|grad| 4.7e-12), certified"),
        "reference minimum of bump param sd: E* = 2.0486 (|grad| _), certified"
    );
    // What does not vary stays: counts, iterations, verdicts.
    assert_eq!(masked("12 runs: 4 ok, 6 not converged"), "12 runs: 4 ok, 6 not converged");
}

#[test]
fn the_getting_started_page_runs_as_written() {
    let page = std::fs::read_to_string(repo_root().join("docs/src/guide/getting-started.md")).unwrap();
    let steps = steps(&page);
    assert!(steps.len() > 10, "{} tutorial steps found", steps.len());
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    // The repository's root as the page's commands see it; the store's maps are read only.
    for name in ["datasets.toml", "references.json", "references", "peers"] {
        std::os::unix::fs::symlink(repo_root().join(name), root.join(name)).unwrap();
    }
    std::fs::create_dir_all(root.join("configs/local")).unwrap();
    let binary = env!("CARGO_BIN_EXE_mapbench");
    let numpy = has_numpy();
    let mut printed: Option<Vec<String>> = None;
    for step in &steps {
        match step {
            Step::File { path, text } => {
                std::fs::write(root.join(path), text).unwrap_or_else(|e| panic!("{path}: {e}"));
            }
            Step::Run { needs_numpy: true, commands, .. } if !numpy => {
                assert!(
                    std::env::var_os("MAPBENCH_REQUIRE_PEERS").is_none(),
                    "MAPBENCH_REQUIRE_PEERS: python3 has no numpy (pip install -r peers/requirements.txt)"
                );
                eprintln!("python3 has no numpy: skipped {commands:?} (pip install -r peers/requirements.txt)");
                printed = None;
            }
            Step::Run { commands, exit, .. } => {
                let mut lines = Vec::new();
                for (i, command) in commands.iter().enumerate() {
                    let command = command.replace("cargo run --release --", binary);
                    let o = Command::new("sh")
                        .args(["-c", &command])
                        .current_dir(root)
                        .env_remove("MAPBENCH_MESHES")
                        .output()
                        .unwrap();
                    let text = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
                    let want = if i + 1 == commands.len() { *exit } else { 0 };
                    assert_eq!(o.status.code(), Some(want), "`{command}` exited otherwise:\n{text}");
                    let shown = text.replace(&root.display().to_string(), SHOWN_ROOT);
                    lines.extend(shown.lines().map(masked));
                }
                printed = Some(lines);
            }
            Step::Output { lines } => {
                let Some(printed) = &printed else { continue };
                let missing: Vec<&String> =
                    lines.iter().filter(|l| l.trim() != "..." && !printed.contains(&masked(l))).collect();
                assert!(
                    missing.is_empty(),
                    "the page shows lines its commands no longer print:\n{}\n\nthey printed:\n{}",
                    missing.iter().map(|l| l.as_str()).collect::<Vec<_>>().join("\n"),
                    printed.join("\n")
                );
            }
        }
    }
}
