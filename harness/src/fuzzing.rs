//! What each fuzz target (`fuzz/`, see docs/src/design/testing.md) does with one input. The bodies
//! live here, not in the targets, so the regression tests (`harness/tests/hardening_fuzz.rs`)
//! feed the checked-in crash inputs to exactly the code the fuzzer ran.
//!
//! Each function takes raw bytes and returns `Ok` when the reader accepted them (and the
//! steps after it ran), or the reader's error message. Neither is a finding: a panic, a hang
//! or a huge allocation is. Nothing is read from or written to disk.

use crate::gate::check::{compare, render, Baseline, GatedRun};
use crate::plan::config::LoadedConfig;
use crate::plan::registry::{resolve_inline, Registry};
use crate::plan::Plan;
use anyhow::{Context, Result};
use std::path::Path;
use std::time::Instant;

/// The file name every input is reported under (errors must name it).
pub const SOURCE: &str = "fuzz-input";

fn text(data: &[u8]) -> Result<&str> {
    std::str::from_utf8(data).with_context(|| format!("{SOURCE}: not UTF-8"))
}

/// The OBJ reader, then the validation every task runs on a mesh before solving.
pub fn obj(data: &[u8]) -> Result<()> {
    let mesh = solvers::mesh::obj::parse_obj(SOURCE, data)?;
    // A disk for param/authalic, any manifold for deform: both paths of the validator.
    solvers::mesh::validate(&mesh, false);
    solvers::mesh::validate(&mesh, true).into_result()?;
    Ok(())
}

/// The config reader and everything that turns a config into runs without touching disk:
/// the settings of every energy and the run plan over the inline datasets.
pub fn config(data: &[u8]) -> Result<()> {
    let cfg = LoadedConfig::parse(text(data)?, Path::new(SOURCE))?;
    crate::plan::energy_settings(&cfg)?;
    let datasets = resolve_inline(&cfg, &[])?;
    // A config of registry datasets only has no runs without the registry.
    if !datasets.is_empty() {
        let plan = Plan::with_datasets(cfg, datasets, Vec::new(), &[])?;
        // As the runner does: the deadline of a run is now + timeout.
        if let Some(t) = plan.timeout {
            let _deadline = Instant::now() + t;
        }
    } else if let Some(t) = cfg.config.timeout_secs()? {
        let _deadline = Instant::now() + std::time::Duration::from_secs_f64(t);
    }
    Ok(())
}

/// The dataset registry reader, then a selection of every entry by name and by tag.
pub fn registry(data: &[u8]) -> Result<()> {
    let reg = Registry::parse(text(data)?, Path::new(SOURCE))?;
    let mut selectors: Vec<String> = reg.dataset.iter().map(|e| e.name.clone()).collect();
    selectors.extend(reg.dataset.iter().flat_map(|e| e.tags.iter().map(|t| format!("tag:{t}"))));
    reg.select(&selectors)?;
    Ok(())
}

/// The `*.p2p.json` handles reader, for the first sets and one far out of range.
pub fn handles(data: &[u8]) -> Result<()> {
    let text = text(data)?;
    let mut first = Ok(());
    for set in [0, 1, 2, usize::MAX] {
        let r = crate::plan::handles::parse_p2p(text, Path::new(SOURCE), set).map(|_| ());
        if set == 0 {
            first = r;
        }
    }
    first
}

/// The baseline reader, then `check`'s comparison and report: each baseline run against the
/// numbers of the next run (so every metric moves in both directions).
pub fn baseline(data: &[u8]) -> Result<()> {
    let base = Baseline::parse(text(data)?, Path::new(SOURCE))?;
    let n = base.runs.len();
    let now: Vec<GatedRun> = (0..n)
        .map(|i| {
            let other = &base.runs[(i + 1) % n];
            GatedRun {
                iterations: other.iterations,
                final_energy: other.final_energy,
                status: other.status,
                flips: other.flips,
                time_s: other.time_s,
                ..base.runs[i].clone()
            }
        })
        .collect();
    render(&compare(&base, &now));
    render(&compare(&base, &base.runs));
    Ok(())
}
