//! How the tables and profiles name a run's solver: a run that clamped SLIM weights is another
//! method than SLIM, `<solver> (clamped)`.

use crate::run_folder::SummaryRow;

/// The rows as tables and profiles name them: a run that clamped SLIM weights (SLIM outside
/// the energies it is defined for, opted in with `[solver.slim] clamp_weights`)
/// is another method than SLIM, so it is its own solver, `"<solver> (clamped)"`, there; its
/// files keep the plain name.
pub fn labelled(summary: &[SummaryRow]) -> Vec<SummaryRow> {
    summary
        .iter()
        .map(|r| match r.clamped_iters {
            Some(k) if k > 0 => SummaryRow { solver: clamped_label(&r.solver), ..r.clone() },
            _ => r.clone(),
        })
        .collect()
}

/// The label of a solver's runs that clamped weights.
pub fn clamped_label(solver: &str) -> String {
    format!("{solver} (clamped)")
}
