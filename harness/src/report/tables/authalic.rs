//! Area-preserving (authalic) disk maps.

use super::ranking::{self, comparable_at_budget, lowest};
use super::table::Table;
use crate::plan::Task;
use crate::report::select::{finished, is_authalic, unique};
use crate::run_folder::timed::Timed;
use crate::run_folder::SummaryRow;
use solvers::tasks::catalogue;

/// The AEM paper's Table 1 shape: per mesh, for each solver the SD of the area ratios, the
/// normalized authalic energy, the time and the number of folded triangles. `None` when no
/// authalic run finished.
///
/// Bold: the lowest area ratio SD and E_A of the row. The solvers run a fixed iteration
/// budget, as in the paper, so the comparable runs ([`comparable_at_budget`]) are those that
/// converged or used the whole budget; a run that stopped early, failed or was skipped is
/// never bold.
pub fn authalic_table(rows: &[SummaryRow]) -> Option<Table> {
    let done: Vec<&SummaryRow> =
        rows.iter().filter(|r| is_authalic(r) && finished(r) && r.authalic_energy.is_some()).collect();
    // The catalogue's authalic solvers, in its order, with its labels.
    let present: Vec<(&str, &str)> = catalogue::SOLVERS
        .iter()
        .filter(|e| e.runs(Task::Authalic) && done.iter().any(|r| r.solver == e.name))
        .map(|e| (e.name, e.label))
        .collect();
    if present.is_empty() {
        return None;
    }
    let mut columns = vec!["dataset".to_string(), "vertices".into(), "faces".into()];
    for (_, l) in &present {
        columns.extend([format!("{l} area ratio SD"), format!("{l} E_A"), format!("{l} time_s"), format!("{l} folds")]);
    }
    let datasets = unique(done.iter().map(|r| r.dataset.as_str()));
    let sci = |v: Option<f64>| v.map(|x| format!("{x:.2e}")).unwrap_or_default();
    let (mut out, mut bold) = (Vec::new(), Vec::new());
    for (i, d) in datasets.into_iter().enumerate() {
        let runs: Vec<&&SummaryRow> = done.iter().filter(|r| r.dataset == d).collect();
        // Bold the lowest area ratio SD and E_A of the row among the comparable runs.
        for (k, f) in [|r: &SummaryRow| r.area_ratio_sd, |r: &SummaryRow| r.authalic_energy].iter().enumerate() {
            let vals: Vec<Option<f64>> = present
                .iter()
                .map(|(s, _)| {
                    runs.iter().find(|r| r.solver == *s).filter(|r| comparable_at_budget(r)).and_then(|r| f(r))
                })
                .collect();
            bold.extend(lowest(&vals, ranking::equal).into_iter().map(|j| (i, 3 + 4 * j + k)));
        }
        let count = |f: fn(&SummaryRow) -> Option<usize>| runs.first().and_then(|r| f(r)).map(|v| v.to_string());
        let mut row =
            vec![d.to_string(), count(|r| r.vertices).unwrap_or_default(), count(|r| r.faces).unwrap_or_default()];
        for (s, _) in &present {
            match runs.iter().find(|r| r.solver == *s) {
                Some(r) => row.extend([
                    sci(r.area_ratio_sd),
                    sci(r.authalic_energy),
                    Timed::time_s(r).map(|t| t.text()).unwrap_or_default(),
                    r.folded.map(|f| f.to_string()).unwrap_or_default(),
                ]),
                None => row.extend(std::iter::repeat_n(String::new(), 4)),
            }
        }
        out.push(row);
    }
    let mut iters: Vec<usize> = done.iter().filter_map(|r| r.iterations).collect();
    iters.sort_unstable();
    iters.dedup();
    let iters = iters.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(", ");
    Some(Table {
        title: "Area-preserving disk maps (AEM paper, Table 1)".into(),
        columns,
        rows: out,
        caption: format!(
            "Iterations: {iters}. Area ratio SD = population standard deviation of r = (|f(t)|/A(f)) / (|t|/|S|) \
             over faces; E_A = normalized authalic energy (Eq. 4); time = whole run including the initial map \
             (the median over repeats, min–max in parentheses); folds = faces with non-positive image area. \
             Bold = lowest of the row among the runs that converged or ran the whole iteration budget (the \
             paper's fixed-budget comparison); a run that stopped early (line search, non-finite values, \
             energy increase, timeout), failed or was skipped is never bold."
        ),
        bold,
        layout: Default::default(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Task;
    use crate::report::tables::tests::row;
    use crate::run_folder::Status;
    use solvers::solver::StopReason;

    #[test]
    fn authalic_table_has_the_shape_of_table_1() {
        let auth = |d: &str, s: &str, sd: f64, e: f64| SummaryRow {
            dataset: d.into(),
            task: Task::Authalic,
            energy: "authalic".into(),
            solver: s.into(),
            vertices: Some(10),
            faces: Some(12),
            iterations: Some(100),
            time_s: Some(1.234),
            status: Status::NotConverged,
            stop_reason: Some(StopReason::MaxIterations.into()),
            area_ratio_sd: Some(sd),
            authalic_energy: Some(e),
            folded: Some(0),
            ..Default::default()
        };
        let rows = vec![
            auth("face", "sem", 1.11e-3, 3.66e-6),
            auth("face", "aem-cg", 2.1e-4, 1.28e-7),
            auth("hand", "aem-cg", 0.02, 1e-3),
        ];
        let t = authalic_table(&rows).unwrap();
        assert_eq!(t.columns.len(), 3 + 8);
        assert_eq!(t.columns[3], "SEM area ratio SD");
        assert_eq!(
            t.rows[0],
            ["face", "10", "12", "1.11e-3", "3.66e-6", "1.23", "0", "2.10e-4", "1.28e-7", "1.23", "0"]
        );
        assert_eq!(t.rows[1][3..7], ["", "", "", ""]);
        assert_eq!(t.bold, [(0, 7), (0, 8), (1, 7), (1, 8)], "AEM-CG has the lower SD and E_A");
        assert!(t.caption.starts_with("Iterations: 100."));
        assert!(authalic_table(&[row("a", "kp-newton", 1.0, 1.0)]).is_none());
        assert!(t.caption.contains("never bold"), "{}", t.caption);
        // An AEM-CG run that stopped early (energy increase) is not comparable with one that
        // ran the budget, however low its SD: SEM is bold on "face" now.
        let mut early = rows.clone();
        early[1].stop_reason = Some(StopReason::EnergyIncreased.into());
        early[1].iterations = Some(7);
        assert_eq!(authalic_table(&early).unwrap().bold, [(0, 3), (0, 4), (1, 7), (1, 8)]);
        // Repeats show their spread.
        early[0].repeats = Some(3);
        (early[0].time_s_min, early[0].time_s_max) = (Some(1.2), Some(1.3));
        assert_eq!(authalic_table(&early).unwrap().rows[0][5], "1.23 (1.20–1.30)");
    }
}
