//! Everything of a run folder that is derived from its CSVs: each run's `energy_minus_best`
//! against its (dataset, energy) group, the paper-style tables, the plots and `index.html`
//! pointing at them. `run` and `merge` end here, and `report RUN_DIR` re-renders from the
//! CSVs alone.

pub mod batch;
pub mod corpus;
pub mod html;
pub mod plots;
pub mod tables;

use crate::plan::Task;
use crate::run_folder::read_run;
use crate::run_folder::{iteration_csv, run_stem, write_atomic, Status, SummaryRow};
use anyhow::Result;
use batch::Batch;
use std::collections::BTreeMap;
use std::path::Path;
use tables::Table;

/// Re-derive everything from `summary` rows and the per-iteration CSVs in `run_dir`.
pub fn refresh(run_dir: &Path, summary: &[SummaryRow]) -> Result<()> {
    fill_best(run_dir, summary)?;
    let batch = Batch::read(run_dir);
    let tables = tables(&labelled(summary), &batch);
    for (stem, table) in &tables {
        table.write(&run_dir.join("tables"), stem)?;
    }
    let plots = plots::render_all(run_dir, summary)?;
    html::write_index(run_dir, summary, &tables, &plots, &batch)
}

/// Builds one table from the summary, `None` when it does not apply.
type TableFn = fn(&[SummaryRow]) -> Option<Table>;

/// The per-iteration rows of each run of a (dataset, energy) group, by run stem, with the
/// reference minimum the run is judged by.
type Group = Vec<(String, Vec<solvers::solver::IterationRecord>, Option<f64>)>;

/// Every table that applies to these runs, with its file stem: the paper-shaped mean tables
/// first, the corpus aggregates next to them, then the per-mesh and cost tables.
pub fn tables(summary: &[SummaryRow], batch: &Batch) -> Vec<(String, Table)> {
    let means: [(&str, TableFn); 2] = [("param", tables::param_table), ("deform", tables::deform_table)];
    let rest: [(&str, TableFn); 5] = [
        ("per_mesh", tables::per_mesh_table),
        ("projection", tables::projection_table),
        ("smoothness", tables::smoothness_table),
        ("authalic", tables::authalic_table),
        ("scaling", tables::scaling_table),
    ];
    let build = |(stem, f): &(&str, TableFn)| f(summary).map(|t| (stem.to_string(), t));
    let mut out: Vec<(String, Table)> = means.iter().filter_map(build).collect();
    out.extend(tables::aggregates_table(summary, batch).map(|t| (tables::AGGREGATES.to_string(), t)));
    out.extend(rest.iter().filter_map(build));
    out
}

/// The rows as tables and profiles name them: a run that clamped SLIM weights (issue 18:
/// SLIM outside the energies it is defined for, opted in with `[solver.slim] clamp_weights`)
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

/// Rewrite `energy_minus_best` of every run with the best energy any finished run of its
/// (dataset, energy) group reached (design.md: "energy minus the best energy over all
/// solvers"). Runs finish in any order, in shards or resumed, so this is done once they are
/// all on disk. Files whose content would not change are left alone.
pub fn fill_best(run_dir: &Path, summary: &[SummaryRow]) -> Result<()> {
    let mut groups: BTreeMap<(&str, &str), Group> = BTreeMap::new();
    for s in summary.iter().filter(|s| finished(s)) {
        let stem = run_stem(&s.dataset, &s.energy, &s.solver);
        let rows = read_run(run_dir, s)?.rows;
        groups.entry((&s.dataset, &s.energy)).or_default().push((stem, rows, s.ref_energy));
    }
    for runs in groups.values() {
        let best = runs
            .iter()
            .flat_map(|(_, r, _)| r.iter().map(|x| x.energy))
            .filter(|e| e.is_finite())
            .fold(f64::INFINITY, f64::min);
        if !best.is_finite() {
            continue;
        }
        for (stem, rows, e_star) in runs {
            let path = run_dir.join("runs").join(format!("{stem}.csv"));
            let bytes = iteration_csv(rows, best, *e_star)?;
            if std::fs::read(&path).ok().as_deref() != Some(&bytes[..]) {
                write_atomic(&path, &bytes)?;
            }
        }
    }
    Ok(())
}

// The report's reading of the task and status strings, in one place (the tables and plots
// filter and mark runs through these).

/// The run failed: no iterations to show, left out of means and curves.
fn failed(r: &SummaryRow) -> bool {
    r.status == Status::Failed
}

/// The pair was not run (outside the solver's declared energies): no files, left out of
/// means, aggregates, profiles and curves, and never ranked.
fn skipped(r: &SummaryRow) -> bool {
    r.status == Status::Skipped
}

/// The run ran to a stop (converged or not): it has iterations, curves and a map to show.
fn finished(r: &SummaryRow) -> bool {
    matches!(r.status, Status::Ok | Status::NotConverged)
}

/// The run converged (other finished runs are marked `*` or drawn dashed).
fn converged(r: &SummaryRow) -> bool {
    r.status == Status::Ok
}

/// An authalic run: its maps show area ratios, it has no distortion energy to compare.
fn is_authalic(r: &SummaryRow) -> bool {
    r.task == Task::Authalic
}

/// A `param` or `deform` run: a distortion energy minimized by the Newton-type solvers.
fn is_param_or_deform(r: &SummaryRow) -> bool {
    matches!(r.task, Task::Param | Task::Deform)
}

/// First-appearance order, so rows and columns follow summary.csv.
pub(crate) fn unique<'a>(items: impl Iterator<Item = &'a str>) -> Vec<&'a str> {
    let mut out: Vec<&str> = Vec::new();
    for i in items {
        if !out.contains(&i) {
            out.push(i);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run_folder::SummaryRow;

    fn param(d: &str, e: &str, s: &str, clamped: Option<usize>) -> SummaryRow {
        SummaryRow {
            dataset: d.into(),
            task: Task::Param,
            energy: e.into(),
            solver: s.into(),
            vertices: Some(100),
            iterations: Some(20),
            time_s: Some(0.5),
            clamped_iters: clamped,
            status: Status::Ok,
            ..Default::default()
        }
    }

    #[test]
    fn tables_name_slim_runs_that_clamped_weights_slim_clamped() {
        let rows = vec![
            param("a", "sd", "slim", Some(0)),
            param("a", "barap", "slim", Some(7)),
            param("a", "sd", "kp-newton", None),
            param("a", "barap", "kp-newton", None),
        ];
        let tables = tables(&labelled(&rows), &Batch::default());
        let (_, t) = tables.iter().find(|(stem, _)| stem == "param").expect("a param table");
        let names: Vec<&str> = t.rows.iter().map(|r| r[0].as_str()).collect();
        assert_eq!(names, ["slim", "slim (clamped)", "kp-newton"]);
        // plain slim has only its sd run; the clamped one only barap.
        let col = |e: &str| t.columns.iter().position(|c| c == e).unwrap();
        assert_eq!((t.rows[0][col("barap")].as_str(), t.rows[1][col("sd")].as_str()), ("", ""));
        assert!(!t.rows[1][col("barap")].is_empty());
        // Per-mesh and aggregates tables name it the same way.
        let stems: Vec<&str> = tables.iter().map(|(s, _)| s.as_str()).collect();
        assert!(stems.contains(&"per_mesh") && stems.contains(&tables::AGGREGATES), "{stems:?}");
        for (stem, t) in tables.iter().filter(|(s, _)| ["param", "per_mesh", tables::AGGREGATES].contains(&s.as_str()))
        {
            let text = t.to_markdown();
            assert!(text.contains("slim (clamped)"), "{stem}: {text}");
        }
        // The rows keep their files' names.
        assert_eq!(rows[1].solver, "slim");
    }
}
