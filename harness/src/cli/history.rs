//! `history`: the trend page of the history database and the nightly's gate.

use super::args::HistoryArgs;
use super::stdout::out;
use anyhow::Result;
use mapbench::gate::check;
use mapbench::{history, report};
use std::process::ExitCode;

/// `history --out DIR`: the trend page; with `--fail-on-regression`, the gate's exit code.
pub(crate) fn history(a: HistoryArgs) -> Result<ExitCode> {
    if a.last == Some(0) {
        anyhow::bail!("--last must be at least 1");
    }
    mapbench::output::check_folder(&a.out)?;
    let h = history::HistoryDb::open_existing(&a.db)?;
    let page = report::trend::render(&h, a.config.as_deref(), a.last, &a.out)?;
    eprintln!("trend page of {} batches ({} plots): {}", page.batches, page.plots.len(), page.index.display());
    match a.config.filter(|_| a.fail_on_regression) {
        Some(config) => latest_changes(&h, &config),
        None => Ok(ExitCode::SUCCESS),
    }
}

/// `history --fail-on-regression`: what changed in `config`'s latest batch since the one
/// before it, as `check` prints it; exit 1 on a regression, 2 when runs went missing.
fn latest_changes(h: &history::HistoryDb, config: &str) -> Result<ExitCode> {
    let Some(latest) = h.batches(Some(config), Some(1))?.pop() else {
        anyhow::bail!("no batch of config {config:?} in {}", h.path().display());
    };
    match report::changes::since_previous(h, config, latest.id)? {
        Some(report::changes::Since::Previous(ch)) => {
            let settings = if ch.settings_differ() {
                "note: the two batches ran different configs or plans (config hash differs): changes may come \
                 from the settings, not the code\n"
            } else {
                ""
            };
            out(format_args!(
                "batch {} ({}) since batch {} ({}):\n{settings}{}",
                ch.after.id,
                ch.after.short_revision(),
                ch.before.id,
                ch.before.short_revision(),
                check::render(&ch.comparison)
            ))?;
            // The papers' claims are findings, not regressions: said, not failed on.
            for c in &ch.claims_lost {
                out(format_args!("claim stopped holding: {} ({}): {}\n", c.claim, c.rule.as_str(), c.why))?;
            }
            // As `check`: 2 when runs of the previous batch are missing, 1 on a regression.
            Ok(ExitCode::from(ch.comparison.exit_code()))
        }
        _ => {
            out(format_args!("batch {} is the first of config {config}: nothing to compare with\n", latest.id))?;
            Ok(ExitCode::SUCCESS)
        }
    }
}
