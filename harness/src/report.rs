//! The report of a run folder: the plots, then `index.html` pointing at them. The single
//! entry point for `run` (after the batch) and the `report RUN_DIR` verb.

use crate::output::SummaryRow;
use crate::tables::Table;
use anyhow::Result;
use std::path::Path;

/// Render `plots/*.png` and write `index.html` in `run_dir`; `tables` are (file stem, table)
/// as written under `tables/`.
// Wired into `run` and `report RUN_DIR` by the CLI's owner; until then only tests call it.
#[allow(dead_code)]
pub fn render_report(run_dir: &Path, summaries: &[SummaryRow], tables: &[(String, Table)]) -> Result<()> {
    let plots = crate::plots::render_all(run_dir, summaries)?;
    crate::html::write_index(run_dir, summaries, tables, &plots)
}
