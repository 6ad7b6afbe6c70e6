//! `check`, `compare` and `baseline`: a run folder against a baseline or another folder.

use super::args::{BaselineArgs, CheckArgs, CompareArgs};
use super::stdout::out;
use anyhow::Result;
use mapbench::gate::{check, compare};
use mapbench::output::Output;
use mapbench::report;
use std::process::ExitCode;

/// `check`: exit 1 on a regression, 2 when a baseline run is missing.
pub(crate) fn check(a: CheckArgs) -> Result<ExitCode> {
    let base = check::Baseline::load(&a.baseline)?;
    let cmp = check::compare(&base, &check::read_summary(&a.run_dir)?);
    out(format_args!("{}", check::render(&cmp)))?;
    Ok(ExitCode::from(cmp.exit_code()))
}

/// `compare`: what changed from one run folder to another, as Markdown and optionally HTML.
pub(crate) fn compare(a: CompareArgs) -> Result<ExitCode> {
    let options = compare::CompareOptions {
        energy_rtol: a.energy_rtol,
        iterations_tolerance: a.iterations_tolerance,
        time_regressions: a.time_regressions,
    };
    let html = a.html.map(Output::from);
    if let Some(h) = &html {
        h.check()?;
    }
    let cmp = compare::compare_folders(&a.run_a, &a.run_b, options)?;
    // `--html -`: the page on standard output instead of the Markdown.
    if html.as_ref() != Some(&Output::Stdout) {
        out(format_args!("{}", report::compare::to_markdown(&cmp)))?;
    }
    if let Some(h) = html {
        h.write(report::compare::to_html(&cmp).as_bytes())?;
        eprintln!("wrote the comparison page to {h}");
    }
    Ok(ExitCode::from(cmp.exit_code()))
}

/// `baseline`: a run folder's summary as the gate's baseline JSON.
pub(crate) fn baseline(a: BaselineArgs) -> Result<ExitCode> {
    let write = Output::from(a.write);
    write.check()?;
    let base = check::make_baseline(&a.run_dir)?;
    let json = serde_json::to_string_pretty(&base)? + "\n";
    write.write(json.as_bytes())?;
    eprintln!("wrote {} runs to {write}", base.runs.len());
    Ok(ExitCode::SUCCESS)
}
