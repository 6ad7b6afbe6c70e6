//! `provenance`: the line a Results page shows under a table made from a batch.

use anyhow::{Context, Result};
use mapbench::run_folder::meta::Meta;
use std::path::PathBuf;
use std::process::ExitCode;

/// One line per run folder (relative config paths against the current folder).
pub fn print(run_dirs: &[PathBuf]) -> Result<ExitCode> {
    let here = std::env::current_dir().context("the current folder")?;
    for dir in run_dirs {
        let meta = Meta::read(dir)?;
        super::stdout::out(format_args!("{}: {}\n", dir.display(), meta.provenance_line(&here)))?;
    }
    Ok(ExitCode::SUCCESS)
}
