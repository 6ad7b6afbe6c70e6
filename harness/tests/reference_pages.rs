//! The reference pages against the code: the columns page documents exactly the columns the
//! CSV writers write, the protocol page every key of `problem.json`, the config page every key,
//! solver option, energy parameter and default the parser accepts, the statuses page every
//! value the code writes, and the history schema page the migrations. (The links, examples and
//! commands of every page are `docs.rs`'s.)

use crate::common;

use common::{mapbench, prose, repo_root};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The protocol's `problem.json` table has a row for every key the harness writes and no
/// other: the problem folders of a `param` and a `deform` run (with its handles) of a solver
/// that does nothing, kept with `keep_problem`.
#[test]
fn the_protocol_page_lists_every_key_of_problem_json() {
    let page = std::fs::read_to_string(repo_root().join("peers/PROTOCOL.md")).unwrap();
    let documented = first_cells(&page, "What the harness writes");
    let tmp = tempfile::tempdir().unwrap();
    let registry = repo_root().join("datasets.toml").display().to_string();
    let mut written = BTreeSet::new();
    for (task, dataset) in [("param", "bumpy_1k"), ("deform", "planar_bar_2k")] {
        let cfg = tmp.path().join(format!("{task}.toml"));
        std::fs::write(
            &cfg,
            format!(
                "registry = {registry:?}\nname = \"{task}\"\ntask = \"{task}\"\ndatasets = [\"{dataset}\"]\n\
                 energies = [\"sd\"]\nsolvers = [\"nothing\"]\n[external.nothing]\ncommand = [\"true\"]\n\
                 tasks = [\"{task}\"]\nenergies = [\"sd\"]\nkeep_problem = true\n"
            ),
        )
        .unwrap();
        let o = mapbench(&["run", cfg.to_str().unwrap(), "--out", task, "--no-history"], tmp.path());
        let spec = tmp.path().join(format!("{task}/external/{dataset}__sd__nothing/problem.json"));
        let text =
            std::fs::read_to_string(&spec).unwrap_or_else(|e| panic!("{}: {e}\n{}", spec.display(), common::text(&o)));
        let spec: serde_json::Value = serde_json::from_str(&text).unwrap();
        written.extend(spec.as_object().unwrap().keys().cloned());
    }
    assert!(written.contains("handles"), "the deform problem has its handles: {written:?}");
    assert_eq!(documented, written, "peers/PROTOCOL.md: the keys of problem.json");
}

/// The columns page has a row for every column the CSV writers write (the summary's, the
/// per-iteration files' and each solver's extra ones), and no other.
#[test]
fn the_columns_page_documents_every_column_written_and_no_other() {
    let page = std::fs::read_to_string(repo_root().join("docs/src/reference/columns.md")).unwrap();
    let documented: BTreeSet<String> = page
        .lines()
        .filter_map(|l| l.strip_prefix("| `"))
        .filter_map(|l| l.split_once('`').map(|(c, _)| c.to_string()))
        .collect();
    let mut written: BTreeSet<String> = mapbench::run_folder::SUMMARY_COLUMNS.iter().map(|c| c.to_string()).collect();
    written.extend(["iters_to_<tau>".to_string(), "time_to_<tau>".to_string()]);
    written.extend(mapbench::run_folder::ITERATION_COLUMNS.iter().map(|c| c.to_string()));
    for s in solvers::tasks::catalogue::SOLVERS {
        written.extend(s.extra_columns.iter().map(|c| c.to_string()));
    }
    let missing: Vec<&String> = written.difference(&documented).collect();
    let stale: Vec<&String> = documented.difference(&written).collect();
    assert!(missing.is_empty(), "columns written but not documented in docs/src/reference/columns.md: {missing:?}");
    assert!(stale.is_empty(), "columns documented but never written: {stale:?}");
}

/// The keys a config section accepts, as the parser lists them when it refuses an unknown one
/// (`section` is the table header with what it needs, empty for the top level).
fn accepted_keys(section: &str) -> BTreeSet<String> {
    let text = format!("name = \"k\"\nsolvers = [\"kp-newton\"]\n{section}\nzz_not_a_key = 1\n");
    let e = match mapbench::plan::config::LoadedConfig::parse(&text, Path::new("k.toml")) {
        Ok(_) => panic!("{section}: an unknown key was accepted"),
        Err(e) => format!("{e:#}"),
    };
    let list = e.split("expected one of ").nth(1).or_else(|| e.split("expected ").nth(1)).unwrap_or_default();
    let list = list.lines().next().unwrap_or_default();
    list.split('`').skip(1).step_by(2).map(str::to_string).collect()
}

/// The config keys page lists, per section, exactly the keys the parser accepts there.
#[test]
fn the_config_page_lists_every_key_the_parser_accepts() {
    let page = std::fs::read_to_string(repo_root().join("docs/src/reference/config.md")).unwrap();
    let mut documented: std::collections::BTreeMap<String, BTreeSet<String>> = Default::default();
    let mut heading = String::new();
    for line in prose(&page) {
        if let Some(h) = line.strip_prefix("## ") {
            heading = h.to_string();
        } else if let Some(cell) = line.strip_prefix("| `") {
            if let Some((key, _)) = cell.split_once('`') {
                documented.entry(heading.clone()).or_default().insert(key.to_string());
            }
        }
    }
    let sections = [
        ("Top level", ""),
        ("`[[dataset]]`: inline datasets", "[[dataset]]\nname = \"a\"\npath = \"a.obj\""),
        ("`[stop]`", "[stop]"),
        ("`[line_search]`", "[line_search]"),
        ("`[linear]`", "[linear]"),
        ("`[init]`", "[init]"),
        ("`[deform]`", "[deform]"),
        ("`[authalic]`", "[authalic]"),
        ("`[external.<name>]`", "[external.x]\ncommand = [\"x\"]\ntasks = [\"param\"]\nenergies = [\"sd\"]"),
    ];
    for (heading, section) in sections {
        let accepted = accepted_keys(section);
        assert!(!accepted.is_empty(), "{heading}: the parser's list of keys was not found");
        let mut on_page = documented.get(heading).cloned().unwrap_or_else(|| panic!("no section {heading:?}"));
        // the top-level table names the sections too
        if section.is_empty() {
            on_page
                .extend(accepted.iter().filter(|k| documented.keys().any(|h| h.contains(&format!("[{k}")))).cloned());
        }
        assert_eq!(on_page, accepted, "docs/src/reference/config.md section {heading}");
    }
}

/// The backticked names in the first cell of each table body row (not the header) under
/// `## {heading}` of `page`.
fn first_cells(page: &str, heading: &str) -> BTreeSet<String> {
    let mut inside = false;
    let mut body = false;
    let mut out = BTreeSet::new();
    for line in prose(page) {
        if !line.starts_with('|') {
            body = false;
        }
        if let Some(h) = line.strip_prefix("## ") {
            inside = h.trim() == heading;
        } else if line.starts_with("| ---") || line.starts_with("|---") {
            body = true;
        } else if inside && body && line.starts_with("| ") {
            let cell = line[2..].split(" | ").next().unwrap_or_default();
            out.extend(cell.split('`').skip(1).step_by(2).map(str::to_string));
        }
    }
    out
}

/// The statuses page lists exactly the values the code writes in `status`, `stop_reason` and
/// `verdict`, and every start map.
#[test]
fn the_statuses_page_lists_every_value_the_code_writes() {
    use mapbench::run_folder::summary::Verdict;
    use mapbench::run_folder::Status;
    use solvers::solver::{StartMap, StopReason};
    let page = std::fs::read_to_string(repo_root().join("docs/src/reference/statuses.md")).unwrap();
    let set = |v: Vec<&str>| v.into_iter().map(str::to_string).collect::<BTreeSet<String>>();
    let statuses = set([Status::Ok, Status::Budget, Status::NotConverged, Status::Failed, Status::Skipped]
        .map(|s| s.as_str())
        .to_vec());
    assert_eq!(first_cells(&page, "Status"), statuses);
    // the solvers' reasons, and the harness's: a skipped run's `skipped`, a failed one's `error`
    let mut reasons = set(StopReason::ALL.iter().map(|r| r.as_str()).collect());
    reasons.extend([mapbench::run_folder::SKIPPED_STOP.to_string(), mapbench::run_folder::FAILED_STOP.to_string()]);
    assert_eq!(first_cells(&page, "Stop reasons"), reasons);
    assert_eq!(first_cells(&page, "Verdicts"), set(Verdict::ALL.map(|v| v.as_str()).to_vec()));
    for m in StartMap::ALL {
        assert!(page.contains(&format!("`{}`", m.as_str())), "start {} is not on the page", m.as_str());
    }
}

/// The schema page has every column of both tables as the migrations make them (the runs'
/// named, or `summary.csv`'s of the same name) and one row per schema version.
#[test]
fn the_history_schema_page_matches_the_migrations() {
    use mapbench::history::{HistoryDb, SCHEMA_VERSION};
    let page = std::fs::read_to_string(repo_root().join("docs/src/reference/history-schema.md")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("h.sqlite");
    drop(HistoryDb::open_or_create(&db).unwrap());
    let c = rusqlite::Connection::open(&db).unwrap();
    let columns = |table: &str| -> BTreeSet<String> {
        let mut s = c.prepare(&format!("PRAGMA table_info({table})")).unwrap();
        s.query_map([], |r| r.get::<_, String>(1)).unwrap().map(|r| r.unwrap()).collect()
    };
    assert_eq!(first_cells(&page, "`batches`"), columns("batches"), "batches");
    let named = first_cells(&page, "`runs`");
    let summary: BTreeSet<&str> = mapbench::run_folder::SUMMARY_COLUMNS.into_iter().collect();
    for col in columns("runs") {
        let keyed = ["batch_id", "dataset", "task", "energy", "solver"].contains(&col.as_str());
        assert!(
            named.contains(&col) || summary.contains(col.as_str()) || keyed,
            "runs.{col} is neither on the page nor a summary.csv column"
        );
    }
    assert!(page.contains(&format!("Schema version {SCHEMA_VERSION} ")), "the page's schema version");
    let versions: Vec<i64> =
        prose(&page).iter().filter_map(|l| l.strip_prefix("| ")?.split(" |").next()?.trim().parse().ok()).collect();
    assert_eq!(versions, (0..=SCHEMA_VERSION).collect::<Vec<_>>(), "one row per schema version");
}

/// The keys listed after "expected" in a refusal of the unknown key `zz_not_a_key` in `table`
/// of a config of `task` running `solver` on `energy`.
fn accepted_options(task: &str, solver: &str, energy: &str, table: &str) -> BTreeSet<String> {
    let energies = if task == "authalic" { String::new() } else { format!("energies = [\"{energy}\"]\n") };
    let text =
        format!("name = \"k\"\ntask = \"{task}\"\ndatasets = [\"d\"]\nsolvers = [\"{solver}\"]\n{energies}{table}\nzz_not_a_key = 1\n");
    let e = match mapbench::plan::config::LoadedConfig::parse(&text, Path::new("k.toml")) {
        Ok(_) => panic!("{table}: an unknown key was accepted"),
        Err(e) => format!("{e:#}"),
    };
    assert!(e.contains("zz_not_a_key"), "{table}: refused for another reason: {e}");
    let list = e.split("expected ").nth(1).unwrap_or_default();
    let list = list.lines().next().unwrap_or_default();
    list.split('`').skip(1).step_by(2).filter(|k| *k != "name").map(str::to_string).collect()
}

/// The `[solver.<name>]` and `[energy.<name>]` tables of the config page list exactly the keys
/// each solver's options and each energy's parameters accept.
#[test]
fn the_config_page_lists_every_solver_option_and_energy_parameter() {
    let page = std::fs::read_to_string(repo_root().join("docs/src/reference/config.md")).unwrap();
    // rows `| `[solver.x]` | `key` | ...` under the two sections
    let rows = |heading: &str, prefix: &str| {
        let mut out: std::collections::BTreeMap<String, BTreeSet<String>> = Default::default();
        let mut inside = false;
        for line in prose(&page) {
            if let Some(h) = line.strip_prefix("## ") {
                inside = h.trim() == heading;
            } else if inside && line.starts_with("| ") {
                let cells: Vec<&str> = line.split(" | ").collect();
                let (Some(table), Some(key)) = (cells.first(), cells.get(1)) else { continue };
                let table = table.trim_start_matches("| ").to_string();
                let key = key.trim_matches('`').to_string();
                let name = table.split(prefix).nth(1).and_then(|t| t.split(']').next()).unwrap_or("*").to_string();
                if table.starts_with('`') || table.starts_with("any") {
                    out.entry(if table.starts_with("any") { "*".into() } else { name }).or_default().insert(key);
                }
            }
        }
        out
    };
    let solvers_doc = rows("`[solver.<name>]`", "[solver.");
    let mut with_options = 0;
    for s in solvers::tasks::catalogue::SOLVERS {
        let task = s.tasks[0].as_str();
        let accepted = accepted_options(task, s.name, "sd", &format!("[solver.{}]", s.name));
        let documented = solvers_doc.get(s.name).cloned().unwrap_or_default();
        assert_eq!(documented, accepted, "docs/src/reference/config.md: the options of [solver.{}]", s.name);
        with_options += usize::from(!accepted.is_empty());
    }
    assert!(with_options >= 4, "only {with_options} solvers with options found: the refusal's list was not read");
    let energies_doc = rows("`[energy.<name>]`", "[energy.");
    for e in solvers::energy::ENERGY_NAMES {
        let mut accepted = accepted_options("param", "kp-newton", e, &format!("[energy.{e}]"));
        accepted.retain(|k| !k.starts_with("smoothness") && k != "start");
        let documented = energies_doc.get(*e).cloned().unwrap_or_default();
        assert_eq!(documented, accepted, "docs/src/reference/config.md: the parameters of [energy.{e}]");
        with_options += usize::from(!accepted.is_empty());
    }
    assert!(with_options >= 8, "the energies' parameters were not read");
    let any: BTreeSet<String> = ["smoothness", "smoothness_projection", "start", "targets"].map(String::from).into();
    assert_eq!(energies_doc.get("*").cloned().unwrap_or_default(), any, "the keys of any energy");
}

/// Each default the config page states for a top-level key as a value (`"param"`, `[]`, `1`,
/// ...) is a value the config accepts for that key.
#[test]
fn every_default_on_the_config_page_is_accepted() {
    let page = std::fs::read_to_string(repo_root().join("docs/src/reference/config.md")).unwrap();
    let mut inside = false;
    let mut checked = 0;
    for line in prose(&page) {
        if let Some(h) = line.strip_prefix("## ") {
            inside = h.trim() == "Top level";
            continue;
        }
        let cells: Vec<&str> = line.split(" | ").collect();
        let (true, Some(key), Some(default)) = (inside, cells.first(), cells.get(2)) else { continue };
        let Some(key) = key.strip_prefix("| `").and_then(|k| k.strip_suffix('`')) else { continue };
        let value = default.trim().trim_matches('`');
        if format!("v = {value}").parse::<toml::Table>().is_err() {
            continue;
        }
        let base: BTreeMap<&str, &str> = [
            ("name", "\"d\""),
            ("datasets", "[\"bumpy_1k\"]"),
            ("energies", "[\"sd\"]"),
            ("solvers", "[\"kp-newton\"]"),
        ]
        .into();
        let mut config = format!("{key} = {value}\n");
        for (k, v) in base.iter().filter(|(k, _)| **k != key) {
            config += &format!("{k} = {v}\n");
        }
        // a config needs datasets or inline ones: an empty list comes with an inline dataset
        config += "[[dataset]]\nname = \"inline\"\npath = \"inline.obj\"\n";
        if let Err(e) = mapbench::plan::config::LoadedConfig::parse(&config, Path::new("d.toml")) {
            panic!("docs/src/reference/config.md: `{key}` defaults to `{value}`, which a config refuses: {e:#}");
        }
        checked += 1;
    }
    assert!(checked >= 4, "{checked} defaults checked");
}
