//! The harness's integration tests as one binary: each file of `tests/` is a module of it, so
//! the test build links one executable instead of one per file (the book's testing page says
//! what that saves). `signals_metis.rs` stays apart: it needs its own `main`. A new file is
//! listed here; the test below fails until it is.

mod claims;
mod cli;
mod common;
mod compact_maps;
mod compare;
mod corpus;
mod docs;
mod evaluate;
mod external;
mod getting_started;
mod hardening_config;
mod hardening_fuzz;
mod hardening_mesh;
mod hardening_outputs;
mod hardening_report;
mod hardening_run;
mod hardening_signals;
mod hardware;
mod history;
mod memory;
mod reference_pages;
mod references;
mod repeats;
mod report_browser;
mod report_latex;
mod results_pages;
mod sandbox;
mod slurm;
mod tasks;

/// A test file left out of this list would never run: every file of `tests/` is a module here.
#[test]
fn every_test_file_is_a_module_of_the_suite() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let suite = std::fs::read_to_string(dir.join("suite.rs")).unwrap();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        let Some(module) = name.strip_suffix(".rs") else { continue };
        if !["suite.rs", "signals_metis.rs"].contains(&name.as_str()) {
            assert!(suite.contains(&format!("\nmod {module};\n")), "tests/{name} is not a module of tests/suite.rs");
        }
    }
}
