//! The numerics' integration tests as one binary: each file of `tests/` is a module of it, so
//! the test build links one executable instead of one per file (the book's testing page says
//! what that saves). A new file is listed here; the test below fails until it is.

mod authalic_shared;
mod catalogue;
mod events;
mod first_order;
mod param_e2e;
mod settings_serde;
mod strategies;

/// A test file left out of this list would never run: every file of `tests/` is a module here.
#[test]
fn every_test_file_is_a_module_of_the_suite() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let suite = std::fs::read_to_string(dir.join("suite.rs")).unwrap();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        let Some(module) = name.strip_suffix(".rs") else { continue };
        if !["suite.rs"].contains(&name.as_str()) {
            assert!(suite.contains(&format!("\nmod {module};\n")), "tests/{name} is not a module of tests/suite.rs");
        }
    }
}
