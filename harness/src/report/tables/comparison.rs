//! Solver comparisons over a task's runs: the mean iterations and time per solver and energy
//! (`param`, `deform`) and the per-mesh iterations, time and final energy.

use super::Table;
use crate::plan::Task;
use crate::report::{converged, failed, is_param_or_deform};
use crate::run_folder::SummaryRow;

/// How a solver x energy table averages its runs.
struct MeanSpec {
    task: Task,
    title: &'static str,
    /// The time of one run in the table's unit.
    time: fn(&SummaryRow) -> Option<f64>,
    time_label: &'static str,
    time_digits: usize,
}

/// The complex-view paper's Table 4 (`param`: iterations / ms per vertex) and Table 6
/// (`deform`: iterations / seconds) shape: per solver (rows) and energy (columns), the mean
/// number of iterations and the mean time over the datasets, `it/t`, including runs that did
/// not converge (marked `*`, their iterations count as run); failed runs are left out and
/// counted in the caption. The lowest mean time of each energy is bold. `None` when no run of
/// the task finished.
fn mean_table(rows: &[SummaryRow], spec: &MeanSpec) -> Option<Table> {
    let all: Vec<&SummaryRow> = rows.iter().filter(|r| r.task == spec.task).collect();
    let done: Vec<&SummaryRow> = all.iter().copied().filter(|r| !failed(r)).collect();
    if done.is_empty() {
        return None;
    }
    let mut energies: Vec<&str> = Vec::new();
    let mut solvers: Vec<&str> = Vec::new();
    for r in &all {
        if !energies.contains(&r.energy.as_str()) {
            energies.push(&r.energy);
        }
        if !solvers.contains(&r.solver.as_str()) {
            solvers.push(&r.solver);
        }
    }
    let mut columns = vec!["it/t".to_string()];
    columns.extend(energies.iter().map(|e| e.to_string()));
    let mut out = Vec::new();
    let mut times: Vec<Vec<Option<f64>>> = Vec::new();
    for s in &solvers {
        let mut row = vec![s.to_string()];
        let mut trow = Vec::new();
        for e in &energies {
            let cell: Vec<&&SummaryRow> = done.iter().filter(|r| r.solver == *s && r.energy == *e).collect();
            if cell.is_empty() {
                row.push(String::new());
                trow.push(None);
                continue;
            }
            let n = cell.len() as f64;
            let it = cell.iter().filter_map(|r| r.iterations).sum::<usize>() as f64 / n;
            let t = cell.iter().filter_map(|r| (spec.time)(r)).sum::<f64>() / n;
            let mark = if cell.iter().any(|r| !converged(r)) { "*" } else { "" };
            row.push(format!("{it:.1}/{t:.prec$}{mark}", prec = spec.time_digits));
            trow.push(Some(t));
        }
        out.push(row);
        times.push(trow);
    }
    let bold = (0..energies.len())
        .filter_map(|j| {
            let best =
                (0..solvers.len()).filter_map(|i| times[i][j].map(|t| (i, t))).min_by(|a, b| a.1.total_cmp(&b.1));
            best.map(|(i, _)| (i, j + 1))
        })
        .collect();
    let sets: std::collections::BTreeSet<&str> = done.iter().map(|r| r.dataset.as_str()).collect();
    let failed = all.len() - done.len();
    Some(Table {
        title: spec.title.into(),
        columns,
        rows: out,
        caption: format!(
            "Mean iterations / mean {} over {} datasets ({}), including runs that did not converge (* = at \
             least one, its iterations count as run); {failed} failed runs left out. Bold: the fastest solver \
             per energy.",
            spec.time_label,
            sets.len(),
            sets.into_iter().collect::<Vec<_>>().join(", ")
        ),
        bold,
    })
}

/// The complex-view paper's Table 4 shape for `param` runs: iterations / ms per vertex.
pub fn param_table(rows: &[SummaryRow]) -> Option<Table> {
    mean_table(
        rows,
        &MeanSpec {
            task: Task::Param,
            title: "Parameterization (complex-view paper, Table 4)",
            time: |r| r.ms_per_vertex,
            time_label: "run time in ms per vertex",
            time_digits: 3,
        },
    )
}

/// The complex-view paper's Table 6 shape for `deform` runs: iterations / seconds.
pub fn deform_table(rows: &[SummaryRow]) -> Option<Table> {
    mean_table(
        rows,
        &MeanSpec {
            task: Task::Deform,
            title: "Shape deformation (complex-view paper, Table 6)",
            time: |r| r.time_s,
            time_label: "run time in seconds",
            time_digits: 3,
        },
    )
}

/// The composite-majorization paper's Table 1 shape: one row per mesh and energy, for each
/// solver its iterations, run time and final energy. Runs that hit `max_iters` (or stopped
/// without converging) are marked `*`, failed runs say `failed`. Bold: per row, the fewest
/// iterations, the shortest time and the lowest energy. `None` without `param` or `deform`
/// runs.
pub fn per_mesh_table(rows: &[SummaryRow]) -> Option<Table> {
    let runs: Vec<&SummaryRow> = rows.iter().filter(|r| is_param_or_deform(r)).collect();
    if runs.is_empty() {
        return None;
    }
    let mut solvers: Vec<&str> = Vec::new();
    let mut groups: Vec<(&str, &str)> = Vec::new();
    for r in &runs {
        if !solvers.contains(&r.solver.as_str()) {
            solvers.push(&r.solver);
        }
        if !groups.contains(&(r.dataset.as_str(), r.energy.as_str())) {
            groups.push((&r.dataset, &r.energy));
        }
    }
    let mut columns = ["dataset", "energy", "# vert", "# elem", "analysis [s]"].map(String::from).to_vec();
    for s in &solvers {
        columns.extend([format!("{s} iter"), format!("{s} time [s]"), format!("{s} energy")]);
    }
    let (mut out, mut bold) = (Vec::new(), Vec::new());
    for (i, (d, e)) in groups.iter().enumerate() {
        let of = |s: &str| runs.iter().find(|r| r.dataset == *d && r.energy == *e && r.solver == s);
        let first = runs.iter().find(|r| r.dataset == *d && r.vertices.is_some());
        let count = |f: fn(&SummaryRow) -> Option<usize>| first.and_then(|r| f(r)).map(|v| v.to_string());
        let mut row = vec![
            d.to_string(),
            e.to_string(),
            count(|r| r.vertices).unwrap_or_default(),
            count(|r| r.faces).unwrap_or_default(),
            // One symbolic analysis per mesh and pattern, shared by the group's runs.
            runs.iter()
                .find_map(|r| (r.dataset == *d && r.energy == *e).then_some(r.analysis_s).flatten())
                .map(|t| format!("{t:.3}"))
                .unwrap_or_default(),
        ];
        // (iterations, time, energy) of each finished solver, for the bold marks
        let mut values: Vec<Option<(f64, f64, f64)>> = Vec::new();
        for s in &solvers {
            match of(s) {
                Some(r) if failed(r) => {
                    row.extend(["failed".to_string(), String::new(), String::new()]);
                    values.push(None);
                }
                Some(r) => {
                    let mark = if converged(r) { "" } else { "*" };
                    row.push(r.iterations.map(|i| format!("{i}{mark}")).unwrap_or_default());
                    row.push(r.time_s.map(|t| format!("{t:.2}")).unwrap_or_default());
                    row.push(r.final_energy.map(|x| format!("{x:.5}")).unwrap_or_default());
                    values.push(r.iterations.zip(r.time_s).zip(r.final_energy).map(|((i, t), x)| (i as f64, t, x)));
                }
                None => {
                    row.extend(std::iter::repeat_n(String::new(), 3));
                    values.push(None);
                }
            }
        }
        for k in 0..3 {
            let pick = |v: &(f64, f64, f64)| [v.0, v.1, v.2][k];
            let best = values.iter().flatten().map(pick).fold(f64::INFINITY, f64::min);
            // Energies tie at the printed precision: bold every solver that reaches the best.
            let ties = |x: f64| if k == 2 { format!("{x:.5}") == format!("{best:.5}") } else { x == best };
            for (j, v) in values.iter().enumerate() {
                if v.as_ref().is_some_and(|v| ties(pick(v))) {
                    bold.push((i, 5 + 3 * j + k));
                }
            }
        }
        out.push(row);
    }
    Some(Table {
        title: "Per mesh: iterations, time and final energy per solver (composite-majorization paper, Table 1)".into(),
        columns,
        rows: out,
        caption: "analysis = the symbolic analysis of the Newton system (ordering + symbolic Cholesky), done \
                  once per mesh and shared by its runs; time = whole run including the initial map, without \
                  the analysis; energy = final energy (normalized by area); \
                  * = did not converge (hit max_iters or another stop rule); bold = best of the row (fewest \
                  iterations, shortest time, lowest energy to 5 decimals)."
            .into(),
        bold,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::tables::tests::row;

    #[test]
    fn deform_table_averages_over_shapes() {
        let d = |shape: &str, e: &str, s: &str, it: usize, t: f64, status: &str| SummaryRow {
            dataset: shape.into(),
            task: Task::Deform,
            energy: e.into(),
            solver: s.into(),
            iterations: Some(it),
            time_s: Some(t),
            status: status.parse().unwrap(),
            ..Default::default()
        };
        let rows = vec![
            d("a", "sd", "kp-newton", 20, 0.5, "ok"),
            d("b", "sd", "kp-newton", 30, 0.7, "ok"),
            d("a", "sd", "akvf", 100, 2.0, "not_converged"),
            d("a", "bconf", "kp-newton", 10, 0.1, "ok"),
            d("b", "bconf", "akvf", 0, 0.0, "failed"),
        ];
        let t = deform_table(&rows).unwrap();
        assert_eq!(t.columns, ["it/t", "sd", "bconf"]);
        assert_eq!(t.rows[0], ["kp-newton", "25.0/0.600", "10.0/0.100"]);
        assert_eq!(t.rows[1], ["akvf", "100.0/2.000*", ""]);
        assert!(t.caption.contains("2 datasets (a, b)") && t.caption.contains("1 failed"), "{}", t.caption);
        // the fastest solver of each energy is bold
        assert_eq!(t.bold, [(0, 1), (0, 2)]);
        assert!(t.to_markdown().contains("| kp-newton | **25.0/0.600** | **10.0/0.100** |"));
        assert!(t.to_html().contains("<td><b>25.0/0.600</b></td>"));
        assert!(deform_table(&[row("a", "kp-newton", 1.0, 1.0)]).is_none());
        assert!(param_table(&rows).is_none());
    }

    #[test]
    fn param_table_is_table_4_in_ms_per_vertex() {
        let p = |d: &str, s: &str, it: usize, ms: f64, status: &str| SummaryRow {
            dataset: d.into(),
            task: Task::Param,
            energy: "sd".into(),
            solver: s.into(),
            iterations: Some(it),
            ms_per_vertex: Some(ms),
            time_s: Some(100.0),
            status: status.parse().unwrap(),
            ..Default::default()
        };
        let rows = vec![
            p("a", "kp-newton", 10, 0.2, "ok"),
            p("b", "kp-newton", 20, 0.4, "ok"),
            p("a", "slim", 300, 0.1, "not_converged"),
        ];
        let t = param_table(&rows).unwrap();
        assert_eq!(t.rows, [["kp-newton", "15.0/0.300"], ["slim", "300.0/0.100*"]]);
        assert_eq!(t.bold, [(1, 1)]);
        assert!(t.title.contains("Table 4"));
    }

    #[test]
    fn per_mesh_table_marks_unconverged_failed_and_best() {
        let p = |s: &str, it: usize, t: f64, e: f64, status: &str| SummaryRow {
            dataset: "cow".into(),
            task: Task::Param,
            energy: "sd".into(),
            solver: s.into(),
            vertices: Some(4540),
            faces: Some(8626),
            iterations: Some(it),
            time_s: Some(t),
            final_energy: Some(e),
            status: status.parse().unwrap(),
            analysis_s: Some(0.0312),
            ..Default::default()
        };
        let mut failed = p("akvf", 0, 0.0, 0.0, "failed");
        (failed.iterations, failed.time_s, failed.final_energy, failed.analysis_s) = (None, None, None, None);
        let rows = vec![
            p("cm", 33, 0.60, 2.084131, "ok"),
            p("kp-newton", 41, 0.98, 2.084129, "ok"),
            p("slim", 394, 0.5, 2.08417, "not_converged"),
            failed,
        ];
        let t = per_mesh_table(&rows).unwrap();
        assert_eq!(
            t.columns[..8],
            ["dataset", "energy", "# vert", "# elem", "analysis [s]", "cm iter", "cm time [s]", "cm energy"]
        );
        assert_eq!(
            t.rows[0],
            [
                "cow", "sd", "4540", "8626", "0.031", "33", "0.60", "2.08413", "41", "0.98", "2.08413", "394*", "0.50",
                "2.08417", "failed", "", ""
            ]
        );
        // fewest iterations (cm), shortest time (slim), lowest energy at 5 decimals (cm and kp tie)
        let mut b = t.bold.clone();
        b.sort();
        assert_eq!(b, [(0, 5), (0, 7), (0, 10), (0, 12)]);
    }
}
