//! Paper-style tables computed from `summary.csv` rows, written as `.csv`, `.md`, `.html` and
//! `.tex`: the [`Table`] type and its writers in `table.rs` and `latex.rs`, the builders grouped
//! by what they compare.

mod aggregates;
mod authalic;
mod comparison;
mod latex;
mod projection;
pub mod ranking;
mod scaling;
mod table;
mod verdicts;

pub use aggregates::{aggregates_table, AGGREGATES};
pub use authalic::authalic_table;
pub use comparison::{deform_table, param_table, per_mesh_table};
pub use projection::{projection_table, smoothness_table};
pub use scaling::scaling_table;
pub use table::{Layout, Table};
pub use verdicts::{verdict_table, VERDICTS};

#[cfg(test)]
pub(super) mod tests {
    use crate::run_folder::{Status, SummaryRow};

    /// A finished `param`-like run with the per-iteration projection and solve medians.
    pub(crate) fn row(d: &str, s: &str, p: f64, sv: f64) -> SummaryRow {
        SummaryRow {
            dataset: d.into(),
            energy: "sd".into(),
            solver: s.into(),
            vertices: Some(100),
            iterations: Some(5),
            project_ms_median: Some(p),
            solve_ms_median: Some(sv),
            status: Status::Ok,
            ..Default::default()
        }
    }
}
