//! What keeps README, the book (`docs/`), the external-solver protocol (`peers/PROTOCOL.md`)
//! and the changelog true: every link between them resolves (anchors included), every TOML
//! example parses as the config or registry it shows and every JSON one as what it shows, and
//! the columns page documents exactly the columns the CSV writers write, the other reference
//! pages what the code accepts and writes, the changelog the file formats' versions, and every
//! command-line example names flags the binary's `--help` lists and scripts that run. The
//! generated reference pages (CLI, solvers) are checked by the binary's own tests.

use crate::common;

use common::{prose, repo_root};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};

/// README, the protocol, the changelog and every page of the book, with their text.
fn docs() -> Vec<(PathBuf, String)> {
    let mut files = ["README.md", "CHANGELOG.md", "peers/PROTOCOL.md"].map(|f| repo_root().join(f)).to_vec();
    let mut stack = vec![repo_root().join("docs/src")];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "md") {
                files.push(p);
            }
        }
    }
    files.sort();
    files.into_iter().map(|p| (p.clone(), std::fs::read_to_string(&p).unwrap())).collect()
}

/// Fenced code blocks: (language, body).
fn code_blocks(text: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut current: Option<(String, String)> = None;
    for line in text.lines() {
        let fence = line.trim_start().strip_prefix("```");
        match (&mut current, fence) {
            (None, Some(lang)) => current = Some((lang.trim().to_string(), String::new())),
            (Some(_), Some(_)) => out.extend(current.take()),
            (Some((_, body)), None) => {
                body.push_str(line);
                body.push('\n');
            }
            (None, None) => {}
        }
    }
    out
}

/// The id mdBook gives a heading: lower case, letters, digits, `-` and `_` kept, spaces as `-`.
fn heading_id(heading: &str) -> String {
    heading
        .trim()
        .chars()
        .filter_map(|c| match c {
            c if c.is_alphanumeric() || c == '_' || c == '-' => Some(c.to_lowercase().next().unwrap_or(c)),
            c if c.is_whitespace() => Some('-'),
            _ => None,
        })
        .collect()
}

fn anchors(text: &str) -> BTreeSet<String> {
    prose(text).iter().filter_map(|l| l.strip_prefix('#')).map(|h| heading_id(h.trim_start_matches('#'))).collect()
}

/// `[text](target)` links of a line.
fn links(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(i) = rest.find("](") {
        let after = &rest[i + 2..];
        let Some(end) = after.find(')') else { break };
        out.push(after[..end].to_string());
        rest = &after[end..];
    }
    out
}

#[test]
fn every_link_between_the_pages_resolves() {
    let pages = docs();
    assert!(pages.len() > 20, "the book has {} pages", pages.len());
    let bases = link_bases(&pages);
    let mut bad = Vec::new();
    let mut checked = 0;
    for (path, text) in &pages {
        for line in prose(text) {
            for target in links(line) {
                let target = target.split_whitespace().next().unwrap_or_default();
                if target.contains("://") || target.starts_with("mailto:") || target.is_empty() {
                    continue;
                }
                let (file, anchor) = target.split_once('#').map_or((target, None), |(f, a)| (f, Some(a)));
                for base in &bases[&path.canonicalize().unwrap()] {
                    let dest: PathBuf = if file.is_empty() { path.clone() } else { base.join(file) };
                    checked += 1;
                    if !dest.exists() {
                        bad.push(format!("{}: {target}: no such file from {}", path.display(), base.display()));
                        continue;
                    }
                    if let Some(a) = anchor.filter(|_| dest.extension().is_some_and(|x| x == "md")) {
                        if !anchors(&std::fs::read_to_string(&dest).unwrap()).contains(a) {
                            bad.push(format!("{}: {target}: no heading #{a}", path.display()));
                        }
                    }
                }
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
    assert!(checked > 50, "{checked} links checked");
}

/// The folders each page's relative links must resolve from: its own, and that of every page
/// that includes it (`{{#include FILE}}`: mdBook renders the included text as that page's, so
/// `peers/PROTOCOL.md`'s links must resolve from `peers/` and from `docs/src/reference/`).
fn link_bases(pages: &[(PathBuf, String)]) -> HashMap<PathBuf, Vec<PathBuf>> {
    let canonical = |p: &Path| p.canonicalize().unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let mut bases: HashMap<PathBuf, Vec<PathBuf>> = HashMap::new();
    for (path, text) in pages {
        let dir = path.parent().unwrap().to_path_buf();
        bases.entry(canonical(path)).or_default().push(dir.clone());
        for line in prose(text) {
            if let Some(rest) = line.trim().strip_prefix("{{#include ") {
                let file = rest.trim_end_matches("}}").trim().split(':').next().unwrap_or_default();
                bases.entry(canonical(&dir.join(file))).or_default().push(dir.clone());
            }
        }
    }
    bases
}

#[test]
fn every_page_is_in_the_books_summary() {
    let src = repo_root().join("docs/src");
    let summary = std::fs::read_to_string(src.join("SUMMARY.md")).unwrap();
    let listed: BTreeSet<String> = links(&summary.replace('\n', " ")).into_iter().collect();
    for (path, _) in docs().iter().filter(|(p, _)| p.starts_with(&src)) {
        let rel = path.strip_prefix(&src).unwrap().to_string_lossy().into_owned();
        if rel != "SUMMARY.md" {
            assert!(listed.contains(&rel), "{rel} is not in SUMMARY.md");
        }
    }
}

/// A TOML example is a config (keys it lacks that a config needs are added), a dataset
/// registry, the corpus manifest or a paper's claims; each must parse as what it is.
#[test]
fn every_toml_example_parses_as_the_config_or_registry_it_shows() {
    let mut checked = 0;
    let mut bad = Vec::new();
    for (path, text) in docs() {
        for (lang, body) in code_blocks(&text) {
            if lang != "toml" {
                continue;
            }
            checked += 1;
            let starts = |key: &str| body.lines().any(|l| l.trim_start().starts_with(key));
            let result = if body.contains("[[claim]]") {
                let file = format!("paper = \"example\"\ntitle = \"Example\"\n{body}");
                mapbench::claims::Paper::parse("example.toml", &file).map(|_| ()).map_err(|e| e.to_string())
            } else if body.contains("[[mesh]]") {
                toml::from_str::<toml::Value>(&body).map(|_| ()).map_err(|e| e.to_string())
            } else if body.contains("[[dataset]]") && (starts("generator") || starts("file")) {
                mapbench::plan::registry::Registry::parse(&body, Path::new("example.toml"))
                    .map(|_| ())
                    .map_err(|e| format!("{e:#}"))
            } else {
                let mut config = String::new();
                if !starts("name") {
                    config += "name = \"example\"\n";
                }
                config += &body;
                mapbench::plan::config::LoadedConfig::parse(&config, Path::new("example.toml"))
                    .map(|_| ())
                    .map_err(|e| format!("{e:#}"))
            };
            if let Err(e) = result {
                bad.push(format!("{}: a toml example does not parse: {e}\n{body}", path.display()));
            }
            bad.extend(missing_peers(&body).into_iter().map(|f| format!("{}: {f}: no such file", path.display())));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n\n"));
    assert!(checked > 5, "{checked} examples checked");
}

/// The files of `peers/` an example's `[external.<name>]` commands name that do not exist
/// where a config of `configs/` finds them (command files are relative to the config's folder).
fn missing_peers(toml_text: &str) -> Vec<String> {
    let Ok(table) = toml::from_str::<toml::Table>(toml_text) else { return vec![] };
    let externals = table.get("external").and_then(|e| e.as_table()).into_iter().flat_map(|t| t.values());
    let args = externals.filter_map(|e| e.get("command")?.as_array()).flatten().filter_map(|a| a.as_str());
    args.filter(|a| a.contains("peers/") && !repo_root().join("configs").join(a).is_file()).map(String::from).collect()
}

/// Every `json` example parses, and every `jsonl` one (the protocol's `iterations.jsonl`)
/// reads as the records the harness reads.
#[test]
fn every_json_example_parses_as_what_it_shows() {
    let mut checked = 0;
    let mut bad = Vec::new();
    for (path, text) in docs() {
        for (lang, body) in code_blocks(&text) {
            let result = match lang.as_str() {
                "json" => serde_json::from_str::<serde_json::Value>(&body).map(|_| ()).map_err(|e| e.to_string()),
                "jsonl" => {
                    let dir = tempfile::tempdir().unwrap();
                    std::fs::write(dir.path().join("iterations.jsonl"), &body).unwrap();
                    mapbench::external::protocol::read_records(dir.path(), false, 1000)
                        .map(|_| ())
                        .map_err(|e| format!("{e:#}"))
                }
                _ => continue,
            };
            checked += 1;
            if let Err(e) = result {
                bad.push(format!("{}: a {lang} example does not read: {e}\n{body}", path.display()));
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n\n"));
    assert!(checked >= 1, "{checked} examples checked");
}

#[test]
fn the_readme_is_short() {
    let lines = std::fs::read_to_string(repo_root().join("README.md")).unwrap().lines().count();
    assert!(lines <= 200, "README.md has {lines} lines; the rest belongs in docs/");
}

/// The long flags `mapbench VERB --help` lists; `None` when there is no such verb.
fn verb_flags(verb: &str) -> Option<BTreeSet<String>> {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_mapbench")).args([verb, "--help"]).output().unwrap();
    if !o.status.success() {
        return None;
    }
    let help = String::from_utf8_lossy(&o.stdout).into_owned();
    Some(
        help.split(|c: char| c.is_whitespace() || c == ',' || c == '[' || c == ']')
            .filter_map(|w| w.strip_prefix("--"))
            .map(|w| w.split(['=', '<']).next().unwrap_or(w).to_string())
            .filter(|w| !w.is_empty())
            .collect(),
    )
}

/// Every `mapbench VERB --flag` in a shell block of README and the book names a verb and flags
/// the binary has (a command line continued with `\` is read whole).
#[test]
fn every_command_line_example_names_an_existing_verb_and_flag() {
    let mut verbs: std::collections::HashMap<String, Option<BTreeSet<String>>> = Default::default();
    let mut checked = 0;
    let mut bad = Vec::new();
    for (path, text) in docs() {
        for (lang, body) in code_blocks(&text) {
            // Commands only: a `text` block shows output or a synopsis.
            if !matches!(lang.as_str(), "sh" | "bash" | "console" | "shell") {
                continue;
            }
            let joined = body.replace("\\\n", " ");
            for line in joined.lines() {
                let words: Vec<&str> = line.split_whitespace().filter(|w| *w != "$").collect();
                // The command's words: after `mapbench` (or a path to it) that starts the line but
                // for environment assignments, or after `cargo run ... --`.
                let lead = words.iter().position(|w| !w.contains('=')).unwrap_or(words.len());
                let start = match words.get(lead) {
                    Some(w) if *w == "mapbench" || w.ends_with("/mapbench") => lead + 1,
                    Some(&"cargo") if words.get(lead + 1) == Some(&"run") => {
                        match words.iter().position(|w| *w == "--") {
                            Some(dash) => dash + 1,
                            None => continue,
                        }
                    }
                    _ => continue,
                };
                // to a comment, or to where the next command of a pipe or list starts
                let rest: Vec<&str> = words[start..]
                    .iter()
                    .copied()
                    .take_while(|w| !w.starts_with('#') && !["|", "||", "&&", ";", ">", "2>"].contains(w))
                    .collect();
                let Some(verb) = rest.first().filter(|v| !v.starts_with('-')) else { continue };
                let Some(flags) = verbs.entry(verb.to_string()).or_insert_with(|| verb_flags(verb)) else {
                    bad.push(format!("{}: `{line}`: no verb {verb}", path.display()));
                    continue;
                };
                for w in &rest[1..] {
                    let w = w.trim_start_matches(['[', '(', '|']);
                    let Some(flag) = w.strip_prefix("--") else { continue };
                    let flag = flag.split('=').next().unwrap_or(flag);
                    let flag = flag.trim_end_matches(|c: char| !c.is_ascii_alphanumeric() && c != '-');
                    if flag.is_empty() || flag == "help" {
                        continue;
                    }
                    if !flags.contains(flag) {
                        bad.push(format!("{}: `{line}`: {verb} has no --{flag}", path.display()));
                    }
                    checked += 1;
                }
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
    assert!(checked > 20, "{checked} flags checked");
}

/// Every script a shell example runs by its path (`scripts/x.py ...`, `peers/x.py ...`) is
/// there with its run bit, and every one it hands to an interpreter (`python3 scripts/x.py`,
/// `bash scripts/x.sh`) is there.
#[test]
fn every_script_a_command_example_runs_is_there_and_runs() {
    use std::os::unix::fs::PermissionsExt;
    let mut checked = 0;
    let mut bad = Vec::new();
    for (path, text) in docs() {
        for (lang, body) in code_blocks(&text) {
            if !matches!(lang.as_str(), "sh" | "bash" | "console" | "shell") {
                continue;
            }
            for line in body.replace("\\\n", " ").lines() {
                let words: Vec<&str> = line.split_whitespace().filter(|w| *w != "$").collect();
                let lead = words.iter().position(|w| !w.contains('=')).unwrap_or(words.len());
                let (script, direct) = match (words.get(lead), words.get(lead + 1)) {
                    (Some(&("python3" | "python" | "bash" | "sh")), Some(s)) => (*s, false),
                    (Some(s), _) => (*s, true),
                    _ => continue,
                };
                if !["scripts/", "peers/", ".ci/"].iter().any(|d| script.starts_with(d)) {
                    continue;
                }
                checked += 1;
                let file = repo_root().join(script);
                match std::fs::metadata(&file) {
                    Err(_) => bad.push(format!("{}: `{line}`: no file {script}", path.display())),
                    Ok(m) if direct && m.permissions().mode() & 0o111 == 0 => {
                        bad.push(format!("{}: `{line}`: {script} has no run bit (chmod +x)", path.display()))
                    }
                    Ok(_) => {}
                }
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
    assert!(checked > 5, "{checked} script commands checked");
}

/// Paragraphs of prose: consecutive lines outside code blocks, tables and headings, a list
/// item starting a new one.
fn paragraphs(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut current: Vec<&str> = Vec::new();
    let mut inside = false;
    for line in text.lines() {
        let fence = line.trim_start().starts_with("```");
        inside ^= fence;
        let item = ["- ", "* "].iter().any(|p| line.trim_start().starts_with(p));
        if fence || inside || line.trim().is_empty() || line.starts_with('#') || line.starts_with('|') || item {
            if !current.is_empty() {
                out.push(current.join(" "));
                current.clear();
            }
            if fence || inside || !item {
                continue;
            }
        }
        current.push(line.trim());
    }
    if !current.is_empty() {
        out.push(current.join(" "));
    }
    out
}

/// No page says a paragraph twice, and none leaves a parenthesis open (a sentence cut off in
/// an edit, such as "(n =" before a heading); code spans are left out of the count.
#[test]
fn no_paragraph_is_repeated_or_cut_off() {
    let mut bad = Vec::new();
    for (path, text) in docs() {
        let mut seen = BTreeSet::new();
        for p in paragraphs(&text) {
            let words: String = p.split('`').step_by(2).collect();
            if words.matches('(').count() != words.matches(')').count() {
                bad.push(format!("{}: a parenthesis is left open: {p}", path.display()));
            }
            if p.len() >= 100 && !seen.insert(p.clone()) {
                bad.push(format!("{}: said twice: {p}", path.display()));
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// CHANGELOG.md's table of file formats states the version each one is at in the code, and
/// names the constant and the file that state it.
#[test]
fn the_changelog_states_the_version_of_every_file_format() {
    use std::io::Read;
    let page = std::fs::read_to_string(repo_root().join("CHANGELOG.md")).unwrap();
    // the version a UV map file is written with, from its first line
    let mesh = solvers::mesh::Mesh::new("t", vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], vec![[0, 1, 2]]);
    let gz = mapbench::run_folder::map::encode_uv(&mesh, &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0]);
    let mut raw = Vec::new();
    flate2::read::GzDecoder::new(gz.as_slice()).read_to_end(&mut raw).unwrap();
    let first = String::from_utf8_lossy(raw.split(|&b| b == b'\n').next().unwrap()).into_owned();
    let uv: i64 = first.strip_prefix("mapbench uv ").and_then(|v| v.parse().ok()).unwrap_or_else(|| panic!("{first}"));
    let versions: BTreeMap<&str, i64> = [
        ("PROTOCOL", i64::from(mapbench::external::protocol::PROTOCOL)),
        ("SCHEMA_VERSION", mapbench::history::SCHEMA_VERSION),
        ("UV_MAGIC", uv),
        ("REFERENCE_VERSION", i64::from(mapbench::judge::reference::REFERENCE_VERSION)),
        ("VERSION", i64::from(mapbench::run_folder::meta::VERSION)),
        ("SUBMISSION_VERSION", i64::from(mapbench::slurm::SUBMISSION_VERSION)),
        ("SHARD_PLAN_VERSION", i64::from(mapbench::plan::shard_plan::SHARD_PLAN_VERSION)),
        ("CORPUS_VERSION", i64::from(mapbench::corpus::CORPUS_VERSION)),
    ]
    .into();
    let mut stated = BTreeMap::new();
    let mut inside = false;
    for line in prose(&page) {
        if let Some(h) = line.strip_prefix("## ") {
            inside = h.trim() == "File formats and their versions";
        } else if inside && line.starts_with("| ") && !line.starts_with("| ---") && !line.starts_with("| format") {
            let cells: Vec<&str> = line.split(" | ").collect();
            let version: i64 = cells[2].trim().parse().unwrap_or_else(|_| panic!("CHANGELOG.md: no version in {line}"));
            let names: Vec<&str> = cells[3].split('`').skip(1).step_by(2).collect();
            let [constant, file] = names[..] else { panic!("CHANGELOG.md: `CONSTANT`, `file` in {line}") };
            let source = std::fs::read_to_string(repo_root().join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
            assert!(source.contains(&format!("const {constant}:")), "CHANGELOG.md: {file} has no const {constant}");
            stated.insert(constant, version);
        }
    }
    assert_eq!(stated, versions, "CHANGELOG.md's versions (left) against the code's (right)");
}

/// CITATION.cff and the license files match Cargo.toml's version and `MIT OR Apache-2.0`.
#[test]
fn the_citation_and_the_license_files_match_cargo_toml() {
    let cargo: toml::Table = std::fs::read_to_string(repo_root().join("Cargo.toml")).unwrap().parse().unwrap();
    let package = &cargo["workspace"]["package"];
    let (version, license) = (package["version"].as_str().unwrap(), package["license"].as_str().unwrap());
    let cff = std::fs::read_to_string(repo_root().join("CITATION.cff")).unwrap();
    assert!(cff.starts_with("cff-version: 1.2.0\n"), "CITATION.cff: not CFF 1.2.0");
    assert!(cff.lines().any(|l| l == format!("version: {version}")), "CITATION.cff: version {version}");
    let licenses: Vec<&str> =
        cff.lines().skip_while(|l| *l != "license:").skip(1).map_while(|l| l.strip_prefix("  - ")).collect();
    assert_eq!(licenses.join(" OR "), license, "CITATION.cff's licenses");
    for (id, file, says) in [("MIT", "LICENSE-MIT", "MIT License"), ("Apache-2.0", "LICENSE-APACHE", "Apache License")]
    {
        assert!(license.split(" OR ").any(|l| l == id), "Cargo.toml's license: {license}");
        let text = std::fs::read_to_string(repo_root().join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert!(text.trim_start().starts_with(says), "{file}");
    }
    let mit = std::fs::read_to_string(repo_root().join("LICENSE-MIT")).unwrap();
    assert!(mit.contains("Copyright (c) 2026 the mapbench developers"), "LICENSE-MIT's copyright line");
}
