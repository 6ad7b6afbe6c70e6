//! Everything a solver run needs besides the problem.

use super::options::RawOptions;
use super::stop::StopSettings;
use crate::line_search::LineSearchSettings;
use crate::linear::{AnalysisCache, LinearSettings};
use std::sync::Arc;

/// Everything a solver run needs besides the problem.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Settings {
    /// The stopping rules.
    pub stop: StopSettings,
    /// The line search's parameters.
    pub line_search: LineSearchSettings,
    /// The linear solver's shift, scaling and ordering.
    pub linear: LinearSettings,
    /// The run's solver's own options (`[solver.<name>]`) as given, e.g. SLIM's weight
    /// clamping; its catalogue entry reads them (null: none given).
    pub options: RawOptions,
    /// Symbolic analyses shared with the other runs on the same mesh (`None`: analyse
    /// privately). Sharing never changes results, only the setup time.
    #[serde(skip)]
    pub analyses: Option<Arc<AnalysisCache>>,
}
