//! `export-system` and `time-system`: Newton systems written out and timed.

use super::args::{ExportSystemArgs, KernelArg, OrderingArg, TimeSystemArgs};
use super::stdout::out;
use anyhow::{Context, Result};
use mapbench::export;
use mapbench::plan::config::LoadedConfig;
use mapbench::plan::Plan;
use std::process::ExitCode;

/// `export-system`: the Newton system of each selected run at an iteration, as Matrix Market.
pub(crate) fn export_system(a: ExportSystemArgs) -> Result<ExitCode> {
    let cfg = LoadedConfig::load(&a.config)?;
    // Before the registry: a config of another task is refused for what it is.
    export::check_task(&cfg)?;
    let plan = Plan::resolve(cfg, &a.only.globs)?;
    mapbench::output::check_folder(&a.out)?;
    for n in &plan.notices {
        eprintln!("{n}");
    }
    let files = export::export_systems(&plan, a.iteration, &a.out)?;
    eprintln!("wrote {} systems to {}", files.len(), a.out.display());
    Ok(ExitCode::SUCCESS)
}

/// `time-system`: our sparse Cholesky on an exported system; one JSON line.
pub(crate) fn time_system(a: TimeSystemArgs) -> Result<ExitCode> {
    let ordering = match a.ordering {
        OrderingArg::Metis => solvers::linear::ordering::Ordering::Metis,
        OrderingArg::Amd => solvers::linear::ordering::Ordering::Amd,
    };
    let sys = export::read_matrix_market(&a.matrix)?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(a.threads.into()).build()?;
    let t = pool
        .install(|| export::time_system(&sys, ordering, a.repeat, a.kernel == KernelArg::Faer))
        .with_context(|| a.matrix.display().to_string())?;
    out(format_args!("{}\n", serde_json::to_string(&t)?))?;
    Ok(ExitCode::SUCCESS)
}
