//! Per-iteration cost tables: the Hessian projection against the linear solve, without and
//! with the smoothness term.

use super::table::{Layout, Table};
use crate::report::select::{finished, unique};
use crate::run_folder::SummaryRow;
use solvers::tasks::catalogue;

/// The solvers whose per-element projection the projection table compares (Table 5); their
/// column labels come from the catalogue.
const PROJECTIONS: [&str; 3] = ["kp-newton", "fp-newton-4x4", "fp-newton-6x6"];

/// The complex-view paper's Table 5 shape: per mesh and energy, the median per-iteration time
/// of each projection next to the linear solve, and their ratio. `None` when no run of a
/// projection solver finished.
pub fn projection_table(rows: &[SummaryRow]) -> Option<Table> {
    let present: Vec<(&str, &str)> = PROJECTIONS
        .iter()
        .copied()
        .filter(|s| rows.iter().any(|r| r.solver == *s && finished(r)))
        .map(|s| (s, catalogue::find(s).map_or(s, |e| e.label)))
        .collect();
    if present.is_empty() {
        return None;
    }
    let mut columns = vec!["dataset".to_string(), "energy".into(), "vertices".into(), "solve_ms".into()];
    for (_, l) in &present {
        columns.push(format!("{l}_project_ms"));
        columns.push(format!("{l}_project/solve"));
    }
    let groups = unique(rows.iter().map(|r| (r.dataset.as_str(), r.energy.as_str())));
    let ms = |v: f64| format!("{v:.3}");
    let mut out = Vec::new();
    for (d, e) in groups {
        let runs: Vec<&SummaryRow> = rows
            .iter()
            .filter(|r| r.dataset == d && r.energy == e && finished(r) && r.iterations.unwrap_or(0) > 0)
            .collect();
        let of = |s: &str| runs.iter().find(|r| r.solver == s).copied();
        // The solve costs the same for every strategy (same pattern): report the median over them.
        let mut solves: Vec<f64> =
            present.iter().filter_map(|(s, _)| of(s).and_then(|r| r.solve_ms_median)).collect::<Vec<_>>();
        let Some(solve) = crate::stats::median(&mut solves) else { continue };
        let vertices = runs.first().and_then(|r| r.vertices).map(|v| v.to_string()).unwrap_or_default();
        let mut row = vec![d.to_string(), e.to_string(), vertices, ms(solve)];
        for (s, _) in &present {
            match of(s).and_then(|r| r.project_ms_median.zip(r.solve_ms_median)) {
                Some((p, sv)) => {
                    row.push(ms(p));
                    row.push(format!("{:.3}", p / sv));
                }
                None => row.extend(["".to_string(), "".to_string()]),
            }
        }
        out.push(row);
    }
    Some(Table {
        title: "Per-iteration projection vs linear solve (complex-view paper, Table 5)".into(),
        columns,
        rows: out,
        caption: "Median over iterations of one run each: projection = per-element Hessian modification \
                  including M^T K M; solve = numeric Cholesky factorization plus triangular solves; \
                  project/solve uses the same run's solve time."
            .into(),
        bold: Vec::new(),
        layout: Layout { keys: 4, group: 2 },
    })
}

/// The complex-view paper's Table 7 shape: per mesh and energy with a smoothness term, the
/// median per-iteration linear solve next to the Hessian projection with the analytic 8x8
/// edge projection (`kp-newton`) and the numeric one (`kp-newton-eig8`). `None` unless a
/// `kp-newton-eig8` run finished.
pub fn smoothness_table(rows: &[SummaryRow]) -> Option<Table> {
    let ok = |r: &&SummaryRow| finished(r) && r.iterations.unwrap_or(0) > 0;
    if !rows.iter().filter(ok).any(|r| r.solver == "kp-newton-eig8") {
        return None;
    }
    let groups = unique(rows.iter().filter(ok).map(|r| (r.dataset.as_str(), r.energy.as_str())));
    let ms = |v: Option<f64>| v.map(|v| format!("{v:.3}")).unwrap_or_default();
    let ratio = |a: Option<f64>, b: Option<f64>| a.zip(b).map(|(a, b)| format!("{:.3}", a / b)).unwrap_or_default();
    let mut out = Vec::new();
    for (d, e) in groups {
        let of = |s: &str| rows.iter().filter(ok).find(|r| r.dataset == d && r.energy == e && r.solver == s);
        let (an, nu) = (of("kp-newton"), of("kp-newton-eig8"));
        let mut solves: Vec<f64> = [an, nu].iter().flatten().filter_map(|r| r.solve_ms_median).collect();
        let solve = crate::stats::median(&mut solves);
        let (pa, pn) = (an.and_then(|r| r.project_ms_median), nu.and_then(|r| r.project_ms_median));
        let vertices = an.or(nu).and_then(|r| r.vertices).map(|v| v.to_string()).unwrap_or_default();
        out.push(vec![
            d.to_string(),
            e.to_string(),
            vertices,
            ms(solve),
            ms(pa),
            ratio(pa, solve),
            ms(pn),
            ratio(pn, solve),
            ms(an.and_then(|r| r.iter_ms_median)),
            ms(nu.and_then(|r| r.iter_ms_median)),
        ]);
    }
    Some(Table {
        title: "Smoothness term: projection vs linear solve (complex-view paper, Table 7)".into(),
        columns: [
            "dataset",
            "energy",
            "vertices",
            "solve_ms",
            "analytic_project_ms",
            "analytic/solve",
            "numeric_project_ms",
            "numeric/solve",
            "analytic_iter_ms",
            "numeric_iter_ms",
        ]
        .map(String::from)
        .to_vec(),
        rows: out,
        caption: "Medians over iterations: project = all per-element (6x6 face and 8x8 edge) Hessian \
                  projections of an iteration; analytic = kp-newton (Section 4.3 / Appendix B), numeric = \
                  kp-newton-eig8 (eigen-decomposition of every 8x8 edge block)."
            .into(),
        bold: Vec::new(),
        layout: Layout::default(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::tables::tests::row;

    #[test]
    fn projection_table_has_one_row_per_mesh_and_ratios() {
        let rows = vec![
            row("a", "kp-newton", 1.0, 10.0),
            row("a", "fp-newton-6x6", 4.0, 12.0),
            row("b", "kp-newton", 2.0, 8.0),
        ];
        let t = projection_table(&rows).unwrap();
        assert_eq!(
            t.columns,
            [
                "dataset",
                "energy",
                "vertices",
                "solve_ms",
                "KP_project_ms",
                "KP_project/solve",
                "FP6_project_ms",
                "FP6_project/solve"
            ]
        );
        assert_eq!(t.rows[0], ["a", "sd", "100", "11.000", "1.000", "0.100", "4.000", "0.333"]);
        assert_eq!(t.rows[1], ["b", "sd", "100", "8.000", "2.000", "0.250", "", ""]);
        let md = t.to_markdown();
        assert!(md.contains("| a | sd | 100 |"));
        assert!(md.contains(&format!("\n|{}\n", "---|".repeat(8))), "{md}");
        assert!(t.to_html().contains("<td>0.333</td>"));
        assert!(projection_table(&[row("a", "cm", 1.0, 1.0)]).is_none());
    }
}
