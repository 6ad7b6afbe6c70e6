//! Everything of a run folder that is derived from its CSVs, which it reads and never writes:
//! the paper-style tables, the plots and `index.html` pointing at them. `run` and `merge` end
//! here, and `report RUN_DIR` re-renders from the CSVs alone ([`Renderer`] is what `run` and `merge` are handed). Besides, the pages of the
//! layer below: the history's trend page (`trend`) and `compare`'s output (`compare`).

pub mod batch;
pub mod changes;
pub mod compare;
pub mod corpus;
pub mod count;
pub mod html;
pub mod label;
pub mod plots;
mod select;
pub mod tables;
pub mod target;
pub mod trend;

use crate::history::{HistoryDb, HistoryError};
use crate::run_folder::SummaryRow;
use anyhow::Result;
use batch::Batch;
use label::labelled;
use std::path::Path;
use tables::Table;
use target::at_target;

/// The pages `run` and `merge` end with: the run folder's report ([`refresh`]) and, after a
/// history append, the config's trend page ([`trend::render`]).
pub struct Renderer;

impl crate::run::Pages for Renderer {
    fn report(&self, dir: &Path, rows: &[SummaryRow]) -> Result<()> {
        refresh(dir, rows)
    }

    fn trend(&self, history: &HistoryDb, config: &str, dir: &Path) -> Result<(), HistoryError> {
        trend::render(history, Some(config), None, dir).map(|_| ())
    }
}

/// Re-derive the tables, plots and `index.html` from `summary` rows and the per-iteration CSVs
/// in `run_dir` (which it reads, never writes).
pub fn refresh(run_dir: &Path, summary: &[SummaryRow]) -> Result<()> {
    let batch = Batch::read(run_dir);
    // Tables rank what the harness judged (the plots make the same view for their rankings; the
    // status matrix shows both the run's own stop and its target).
    let tables = tables(&labelled(&at_target(summary)), &batch);
    for (stem, table) in &tables {
        table.write(&run_dir.join("tables"), stem)?;
    }
    let plots = plots::render_all(run_dir, summary)?;
    plots::explorer::write(run_dir, batch.config.as_deref().unwrap_or("run"), summary)?;
    html::write_index(run_dir, summary, &tables, &plots, &batch)
}

/// Builds one table from the summary, `None` when it does not apply.
type TableFn = fn(&[SummaryRow]) -> Option<Table>;

/// Every table that applies to these runs (as [`at_target`] ranks them), with its file stem:
/// the paper-shaped mean tables first, the harness's verdicts and the corpus aggregates next to
/// them, then the per-mesh and cost tables.
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
    out.extend(tables::verdict_table(summary).map(|t| (tables::VERDICTS.to_string(), t)));
    out.extend(tables::aggregates_table(summary, batch).map(|t| (tables::AGGREGATES.to_string(), t)));
    out.extend(rest.iter().filter_map(build));
    out
}

#[cfg(test)]
mod tests {
    use super::target::{tightest_target, to_target};
    use super::*;
    use crate::judge::verdict::Verdict;
    use crate::plan::Task;
    use crate::run_folder::summary::ToTarget;
    use crate::run_folder::{Status, SummaryRow};

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

    /// A judged param run on `d` (sd): its own stop at `own` (iterations, seconds), the 1e-6
    /// target at `to` when it reached it; 5 repeats within ±1%, time_norm = 2 × time_s and
    /// 10 ms per vertex per second.
    fn judged(d: &str, s: &str, own: (usize, f64), to: Option<(usize, f64)>, v: Verdict) -> SummaryRow {
        let t = own.1;
        SummaryRow {
            iterations: Some(own.0),
            time_s: Some(t),
            time_s_min: Some(0.99 * t),
            time_s_max: Some(1.01 * t),
            repeats: Some(5),
            time_norm: Some(2.0 * t),
            ms_per_vertex: Some(10.0 * t),
            final_energy: Some(2.0),
            flips: Some(0),
            verdict: Some(v),
            status: if v == Verdict::Solved { Status::Ok } else { Status::NotConverged },
            to_targets: vec![
                ToTarget { tau: 1e-3, iters: to.map(|x| x.0 / 2), time_s: to.map(|x| x.1 / 2.0) },
                ToTarget { tau: 1e-6, iters: to.map(|x| x.0), time_s: to.map(|x| x.1) },
            ],
            ..param(d, "sd", s, None)
        }
    }

    fn close(a: Option<f64>, b: f64) -> bool {
        a.is_some_and(|a| (a - b).abs() < 1e-12)
    }

    #[test]
    fn a_run_that_reached_its_target_ranks_by_iterations_and_time_to_it() {
        let r = judged("a", "cm", (30, 3.0), Some((10, 1.5)), Verdict::Solved);
        let t = to_target(&r);
        assert_eq!((t.iterations, t.time_s), (Some(10), Some(1.5)));
        // The spread, time_norm and ms per vertex scale by 1.5 / 3.
        assert!(close(t.time_s_min, 0.99 * 1.5) && close(t.time_s_max, 1.01 * 1.5), "{t:?}");
        assert!(close(t.time_norm, 3.0) && close(t.ms_per_vertex, 15.0), "{t:?}");
        assert_eq!((t.status, t.solver.as_str(), t.repeats), (Status::Ok, "cm", Some(5)));
        assert_eq!(to_target(&t), t, "a view of the view is the view");
        // Not reached (or not judged): as it ran.
        let short = judged("a", "slim", (300, 3.0), None, Verdict::StoppedAboveTarget);
        assert_eq!(to_target(&short), short);
        let authalic = SummaryRow { task: Task::Authalic, ..param("d", "authalic", "aem-cg", None) };
        assert_eq!(to_target(&authalic), authalic);
        assert_eq!(tightest_target(&[r.clone(), authalic]), Some(1e-6));
        assert_eq!(tightest_target(&[short.clone()][..0]), None);
    }

    #[test]
    fn tables_and_aggregates_rank_the_iterations_and_time_to_the_target() {
        // By their own stops kp-newton (12 it, 1.2 s) beats cm (30 it, 3.0 s); to the 1e-6
        // target cm (10 it, 1.0 s) beats kp-newton (12 it, 1.2 s).
        let rows = vec![
            judged("a", "cm", (30, 3.0), Some((10, 1.0)), Verdict::Solved),
            judged("a", "kp-newton", (12, 1.2), Some((12, 1.2)), Verdict::Solved),
            judged("a", "slim", (300, 0.6), None, Verdict::Unfinished),
        ];
        let tables = tables(&labelled(&at_target(&rows)), &Batch::default());
        let table = |stem: &str| &tables.iter().find(|(s, _)| s == stem).expect(stem).1;
        let per_mesh = table("per_mesh");
        assert_eq!(per_mesh.rows[0][6..8], ["10", "1.00 (0.990–1.01)"]);
        assert_eq!(per_mesh.rows[0][9..11], ["12", "1.20 (1.19–1.21)"]);
        assert_eq!(per_mesh.rows[0][12..14], ["300*", "0.600 (0.594–0.606)"], "slim counts as it ran");
        // cm: the fewest iterations, the shortest time, and tied on energy with kp-newton.
        assert_eq!(per_mesh.bold, [(0, 6), (0, 7), (0, 8), (0, 11)]);
        let means = table("param");
        assert_eq!(means.rows[0], ["cm", "10.0/10.0 (9.90–10.1)"]);
        assert_eq!(means.bold, [(0, 1)]);
        let agg = table(tables::AGGREGATES);
        // sgm over one dataset: cm's own 10 iterations and 2 x 1.0 calibration units.
        assert_eq!(agg.rows[0][8..10], ["10.0", "2.00 (1.98–2.02)"]);
        assert_eq!(agg.rows[1][8..10], ["12.0", "2.40 (2.38–2.42)"]);
        assert_eq!(agg.bold, [(0, 8), (0, 9)]);
        for (stem, t) in tables.iter().filter(|(s, _)| ["param", "per_mesh", tables::AGGREGATES].contains(&s.as_str()))
        {
            assert!(t.caption.contains("to the 1e-6 target (the harness's convergence test"), "{stem}: {}", t.caption);
            // the verdict's test, on the span (not a fraction of the start's distance)
            assert!(t.caption.contains("E − E* ≤ 1e-6 × span"), "{stem}: {}", t.caption);
            assert!(t.caption.contains("the span min(E0 − E*, A) with A = max(E* − E_iso"), "{stem}: {}", t.caption);
        }
        let verdicts = table(tables::VERDICTS);
        assert_eq!(verdicts.rows[2][..5], ["sd", "slim", "1", "0", "0"]);
        // Without verdicts, the captions say nothing of targets.
        let old: Vec<SummaryRow> = rows.iter().map(|r| SummaryRow { to_targets: Vec::new(), ..r.clone() }).collect();
        let tables = super::tables(&labelled(&at_target(&old)), &Batch::default());
        assert!(tables.iter().all(|(_, t)| !t.caption.contains("target")));
        assert!(!tables.iter().any(|(s, _)| s == tables::VERDICTS));
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
