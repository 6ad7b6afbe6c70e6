//! `claims`: the papers' claims decided over run folders.

use super::args::ClaimsArgs;
use super::stdout::out;
use anyhow::Result;
use mapbench::claims::{self, render, Folder};
use std::process::ExitCode;

/// Every committed claim over the folders given: text, JSON or a Markdown table. Exit 0
/// whatever the outcomes (they are findings, not errors).
pub(crate) fn claims(a: ClaimsArgs) -> Result<ExitCode> {
    let folders = a.run_dirs.iter().map(|d| Folder::read(d)).collect::<Result<Vec<_>, _>>()?;
    let evaluated = claims::evaluate(&claims::built_in()?, &folders);
    if a.json {
        out(format_args!("{}\n", serde_json::to_string_pretty(&evaluated)?))?;
    } else if a.markdown {
        out(format_args!("{}", render::markdown(&evaluated)))?;
    } else {
        out(format_args!("{}", render::text(&evaluated)))?;
    }
    Ok(ExitCode::SUCCESS)
}
