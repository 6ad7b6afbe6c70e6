//! The PNG plots of a run folder, read back from its files alone (`runs/*.csv`, the maps in `uv/`):
//! per (dataset, energy) the convergence curves of every solver (energy gap vs iteration and
//! vs time, #negative eigenvalues vs iteration, as in the complex-view paper's Figures 2-3),
//! per run the final map with each triangle colored by its distortion, and per energy the
//! scaling plots, the Dolan–Moré performance profiles and the Moré–Wild data profiles over the
//! corpus. The curves and maps read each run's files by its own summary row; the scaling plots
//! and the profiles draw the rows as the report ranks them ([`crate::report::target::at_target`]).
//! Beside them, the interactive explorer of the same curves (`explorer`).

mod canvas;
mod chart;
mod colors;
mod curves;
pub mod explorer;
mod maps;
mod plot;
mod profiles;
mod scaling;
#[cfg(test)]
pub(crate) mod tests;
pub mod trend;

pub use plot::{Plot, PlotKind, ALL_DATASETS};
pub use scaling::SCALING_MIN_SIZES;

use crate::report::label::labelled;
use crate::report::select::{finished, unique};
use crate::report::target::at_target;
use crate::run_folder::SummaryRow;
use anyhow::Result;
use rayon::prelude::*;
use std::path::Path;

/// Render every plot of a run folder into `run_dir/plots/` and return them in report order:
/// per (dataset, energy) group the three curve plots, then the maps of its runs; then the
/// scaling plots, the performance profiles and the data profile of each energy.
pub fn render_all(run_dir: &Path, summaries: &[SummaryRow]) -> Result<Vec<Plot>> {
    let solvers = unique(summaries.iter().map(|s| s.solver.as_str()));
    let groups = unique(summaries.iter().map(|s| (s.dataset.as_str(), s.energy.as_str())));
    // Scaling plots and profiles rank iterations and time to the target, as the tables do (the
    // per-run files match the rows as they are, so curves and maps read those).
    let ranked = at_target(summaries);
    // Profiles compare methods: clamped SLIM runs are their own solver there (as in the tables).
    let labelled = labelled(&ranked);
    let profile_solvers = unique(labelled.iter().map(|s| s.solver.as_str()));
    // Groups, and the plots inside a group, render in parallel (the caller's rayon pool);
    // indexed collects keep the plots in the groups' order.
    let per_group = |&group: &(&str, &str)| -> Result<Vec<Plot>> {
        let (dataset, energy) = group;
        let runs: Vec<&SummaryRow> =
            summaries.iter().filter(|s| s.dataset == dataset && s.energy == energy && finished(s)).collect();
        if runs.is_empty() {
            return Ok(Vec::new());
        }
        let mut plots = curves::render_group(run_dir, group, &runs, &solvers)?;
        plots.extend(maps::render_group(run_dir, group, &runs)?);
        Ok(plots)
    };
    let (groups, (scaling, profiles)) = rayon::join(
        || groups.par_iter().map(per_group).collect::<Result<Vec<_>>>(),
        || {
            rayon::join(
                || scaling::render_scaling(run_dir, &ranked, &solvers),
                || profiles::render_profiles(run_dir, &labelled, &profile_solvers),
            )
        },
    );
    let mut plots: Vec<Plot> = groups?.into_iter().flatten().collect();
    plots.extend(scaling?);
    plots.extend(profiles?);
    Ok(plots)
}
