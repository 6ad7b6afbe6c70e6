//! The book's Results pages and what makes them (`configs/results/pages.toml`, which
//! `scripts/results.py` reruns): every page is listed, every config it lists exists, loads and
//! selects runs, the page names it, and the page names the revision its numbers were measured
//! at — but for the pages not yet measured again since revisions were recorded, which are
//! listed here so that the list can only shrink.

use crate::common;

use common::repo_root;
use mapbench::plan::config::LoadedConfig;
use mapbench::plan::Plan;
use std::collections::BTreeSet;

/// Pages whose numbers all predate recorded revisions (each keeps them as dated history and
/// says how to measure them again). A page measured again leaves this list.
const NOT_YET_REMEASURED: &[&str] = &[];

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    page: Vec<Page>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Page {
    name: String,
    #[serde(default)]
    shared: bool,
    #[serde(default)]
    batch: Vec<Batch>,
    #[serde(default)]
    command: Vec<Command>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Batch {
    config: String,
    #[serde(default)]
    only: Vec<String>,
    #[allow(dead_code)]
    repeat: Option<usize>,
    #[allow(dead_code)]
    jobs: Option<usize>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Command {
    run: Vec<String>,
}

fn manifest() -> Manifest {
    let path = repo_root().join("configs/results/pages.toml");
    toml::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A git revision as the pages write it: `revision` and at least 7 hex digits.
fn names_a_revision(text: &str) -> bool {
    text.match_indices("revision ").any(|(i, m)| {
        let rest = text[i + m.len()..].trim_start_matches('`');
        rest.chars().take_while(|c| c.is_ascii_hexdigit()).count() >= 7
    })
}

#[test]
fn every_results_page_is_made_by_configs_that_exist_and_names_them_and_its_revision() {
    let root = repo_root();
    let pages: BTreeSet<String> = std::fs::read_dir(root.join("docs/src/results"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .filter(|p| p != "about")
        .collect();
    let manifest = manifest();
    let listed: BTreeSet<String> = manifest.page.iter().map(|p| p.name.clone()).collect();
    assert_eq!(listed, pages, "configs/results/pages.toml lists every page of docs/src/results but about.md");
    let shared = std::env::var_os("MAPBENCH_MESHES").is_some();
    for page in &manifest.page {
        let file = root.join(format!("docs/src/results/{}.md", page.name));
        let text = std::fs::read_to_string(&file).unwrap();
        assert!(!page.batch.is_empty() || !page.command.is_empty(), "{}: nothing makes it", page.name);
        for batch in &page.batch {
            let path = root.join(&batch.config);
            assert!(text.contains(&batch.config), "{} does not name {}", file.display(), batch.config);
            let cfg = LoadedConfig::load(&path).unwrap_or_else(|e| panic!("{}: {e:#}", path.display()));
            // the runs it selects exist (the shared corpus's only where it is installed)
            if shared || !page.shared {
                let plan = Plan::resolve(cfg, &batch.only).unwrap_or_else(|e| panic!("{}: {e:#}", path.display()));
                assert!(!plan.runs.is_empty(), "{}: no run", path.display());
            }
        }
        for command in &page.command {
            let shown = command.run.join(" ");
            assert!(text.contains(&shown), "{} does not show the command `{shown}`", file.display());
        }
        let pending = NOT_YET_REMEASURED.contains(&page.name.as_str());
        assert_eq!(
            names_a_revision(&text),
            !pending,
            "{}: a measured page names its revision (`mapbench provenance`); one in NOT_YET_REMEASURED does not",
            file.display()
        );
    }
}

#[test]
fn a_revision_is_seven_hex_digits_after_the_word() {
    assert!(names_a_revision("2026-12-05, revision 856182c, `configs/param.toml`"));
    assert!(names_a_revision("at revision `5518345` (working tree)"));
    assert!(!names_a_revision("revision not recorded"));
    assert!(!names_a_revision("revision 85618"));
}
