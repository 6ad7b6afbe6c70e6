//! One plot of a run folder: the PNG's file, its title, its (dataset, energy) and what it
//! shows.

/// What a plot shows.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PlotKind {
    /// `energy_minus_best` vs iteration, log y.
    EnergyIter,
    /// `energy_minus_best` vs cumulative time, log y.
    EnergyTime,
    /// `neg_eig` vs iteration.
    NegEigIter,
    /// The final map of one solver's run, colored by per-triangle distortion.
    Map { solver: String },
    /// Median time per iteration vs vertices over all datasets of an energy, log-log (the
    /// composite-majorization paper's Figure 6 shape).
    ScalingTime,
    /// Iterations vs vertices over all datasets of an energy, log x.
    ScalingIterations,
    /// Dolan–Moré performance profile of iterations over the datasets of an energy.
    ProfileIterations,
    /// Dolan–Moré performance profile of time over the datasets of an energy.
    ProfileTime,
    /// Moré–Wild data profile over the datasets of an energy: the fraction solved within a
    /// budget of time.
    ProfileData,
}

impl PlotKind {
    /// A performance profile (shown with the corpus aggregates, not with the curves).
    pub fn is_profile(&self) -> bool {
        matches!(self, PlotKind::ProfileIterations | PlotKind::ProfileTime | PlotKind::ProfileData)
    }
}

/// The `dataset` of the plots that span every dataset.
pub const ALL_DATASETS: &str = "all datasets";

/// One PNG written under the run folder.
#[derive(Clone, Debug, PartialEq)]
pub struct Plot {
    /// Path relative to the run folder, e.g. `plots/bumpy_1k__sd__energy_iter.png`.
    pub file: String,
    pub title: String,
    pub dataset: String,
    pub energy: String,
    pub kind: PlotKind,
}
