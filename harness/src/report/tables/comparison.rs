//! Solver comparisons over a task's runs: the mean iterations and time per solver and energy
//! (`param`, `deform`) and the per-mesh iterations, time and final energy.

use super::ranking::{self, comparable, equal, fastest, lowest};
use super::table::{Layout, Table};
use crate::plan::Task;
use crate::report::select::{broke_down, converged, failed, finished, is_param_or_deform, skipped, unique};
use crate::report::target::target_rule;
use crate::run_folder::timed::Timed;
use crate::run_folder::SummaryRow;

/// How a solver x energy table averages its runs.
struct MeanSpec {
    task: Task,
    title: &'static str,
    /// The time of one run in the table's unit (proportional to `time_s`).
    time: fn(&SummaryRow) -> Option<f64>,
    time_label: &'static str,
}

/// Marks a cell whose runs solved some Newton systems with more than the base Tikhonov shift.
const SHIFTED: &str = "§";

/// The complex-view paper's Table 4 (`param`: iterations / ms per vertex) and Table 6
/// (`deform`: iterations / seconds) shape: per solver (rows) and energy (columns), the mean
/// number of iterations and the mean time over the datasets, `it/t`, including runs that did
/// not converge (marked `*`, their iterations count as run); failed runs, runs whose method
/// broke down ([`broke_down`]: their few iterations are no cost) and skipped pairs are left out
/// and counted in the caption (a solver skipped for an energy says `skipped`, one whose every run
/// broke down names the stop).
///
/// Bold ([`ranking`]): per energy, the fastest solver among those that converged on every
/// dataset of the energy (any failed, unconverged or missing run there takes a solver out:
/// its mean would be over other runs), with time ties on overlapping min–max intervals (the
/// means of the runs' min and max). `None` when no run of the task finished.
fn mean_table(rows: &[SummaryRow], spec: &MeanSpec) -> Option<Table> {
    let all: Vec<&SummaryRow> = rows.iter().filter(|r| r.task == spec.task).collect();
    if !all.iter().any(|r| finished(r)) {
        return None;
    }
    let done: Vec<&SummaryRow> = all.iter().copied().filter(|r| finished(r) && !broke_down(r)).collect();
    let energies = unique(all.iter().map(|r| r.energy.as_str()));
    let solvers = unique(all.iter().map(|r| r.solver.as_str()));
    // The datasets each energy was run on (some solver's run there was not skipped).
    let datasets_of = |e: &str| {
        let mut d: Vec<&str> =
            all.iter().filter(|r| r.energy == e && !skipped(r)).map(|r| r.dataset.as_str()).collect();
        d.sort_unstable();
        d.dedup();
        d
    };
    let mut columns = vec!["it/t".to_string()];
    columns.extend(energies.iter().map(|e| e.to_string()));
    // Per solver and energy: the cell's text without marks of the ranking, and its time when
    // the solver competes.
    let mut texts: Vec<Vec<String>> = Vec::new();
    let mut times: Vec<Vec<Option<Timed>>> = Vec::new();
    for s in &solvers {
        let (mut trow, mut crow) = (Vec::new(), Vec::new());
        for e in &energies {
            let of = |r: &&&SummaryRow| r.solver == *s && r.energy == *e;
            let cell: Vec<&SummaryRow> = done.iter().filter(of).copied().collect();
            if cell.is_empty() {
                let runs: Vec<&SummaryRow> = all.iter().filter(of).copied().collect();
                let all_skipped = !runs.is_empty() && runs.iter().all(|r| skipped(r));
                let stop = runs.iter().find(|r| broke_down(r)).map(|r| r.stop_column());
                trow.push(if all_skipped { "skipped".to_string() } else { stop.unwrap_or_default().to_string() });
                crow.push(None);
                continue;
            }
            let (text, time) = mean_cell(&cell, spec, &datasets_of(e));
            trow.push(text);
            crow.push(time);
        }
        texts.push(trow);
        times.push(crow);
    }
    let mut bold = Vec::new();
    let mut single = false;
    for j in 0..energies.len() {
        let marks = fastest(&times.iter().map(|t| t[j]).collect::<Vec<_>>());
        single |= marks.single_sample && !marks.best.is_empty();
        for &i in &marks.best {
            bold.push((i, j + 1));
            texts[i][j] = marks.label(i, std::mem::take(&mut texts[i][j]));
        }
    }
    bold.sort_unstable();
    let out = solvers.iter().zip(texts).map(|(s, t)| std::iter::once(s.to_string()).chain(t).collect()).collect();
    let sets: std::collections::BTreeSet<&str> = done.iter().map(|r| r.dataset.as_str()).collect();
    let count = |f: fn(&SummaryRow) -> bool| all.iter().filter(|r| f(r)).count();
    let (failed, broken, skipped) = (count(failed), count(broke_down), count(skipped));
    Some(Table {
        title: spec.title.into(),
        columns,
        rows: out,
        caption: format!(
            "Mean iterations / mean {} over {} datasets ({}), including runs that did not converge (* = at \
             least one, its iterations count as run); {failed} failed runs, {broken} whose method broke down (a \
             failed factorization or a direction that does not descend; a cell of only those names the stop) \
             and {skipped} skipped runs (solver not defined for the energy) left out; \
             {SHIFTED} = some run solved Newton systems with a Tikhonov shift above the base (shifted_iters > 0). \
             {} Bold: the fastest solver per energy among those that converged on every dataset of the energy \
             (a solver with a failed, unconverged or missing run there is never bold). {}{}",
            spec.time_label,
            sets.len(),
            sets.into_iter().collect::<Vec<_>>().join(", "),
            ranking::CONVERGED_RULE,
            ranking::time_rule(single),
            with_space(target_rule(all.iter().copied())),
        ),
        bold,
        layout: Layout::default(),
    })
}

/// A solver's runs of one energy (`cell`, none skipped or failed): the mean iterations and
/// time with their marks, and the time when the solver competes for the bold mark (converged
/// on every dataset of the energy, `datasets`).
fn mean_cell(cell: &[&SummaryRow], spec: &MeanSpec, datasets: &[&str]) -> (String, Option<Timed>) {
    let n = cell.len() as f64;
    let it = cell.iter().filter_map(|r| r.iterations).sum::<usize>() as f64 / n;
    let parts: Vec<Timed> = cell.iter().filter_map(|r| (spec.time)(r).map(|t| Timed::of(r, t))).collect();
    let t = if parts.len() == cell.len() { Timed::mean(&parts) } else { None };
    let mark = if cell.iter().any(|r| !converged(r)) { "*" } else { "" };
    let shifted = if cell.iter().any(|r| r.shifted_iters.unwrap_or(0) > 0) { SHIFTED } else { "" };
    let time = t.map(|t| t.text()).unwrap_or_default();
    let mut solved: Vec<&str> = cell.iter().filter(|r| comparable(r)).map(|r| r.dataset.as_str()).collect();
    solved.sort_unstable();
    solved.dedup();
    let all_converged = solved == datasets && cell.iter().all(|r| comparable(r));
    (format!("{it:.1}/{time}{mark}{shifted}"), t.filter(|_| all_converged))
}

/// ` sentence`, or nothing for an empty one.
pub(super) fn with_space(sentence: String) -> String {
    if sentence.is_empty() {
        sentence
    } else {
        format!(" {sentence}")
    }
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
        },
    )
}

/// The composite-majorization paper's Table 1 shape: one row per mesh and energy, for each
/// solver its iterations, run time and final energy. Runs that hit `max_iters` (or stopped
/// without converging) are marked `*`, failed runs say `failed`, skipped pairs `skipped`;
/// iterations that needed a Tikhonov shift above the base are counted (`(k shifted)`).
/// Bold ([`ranking`], converged runs only): per row, the fewest iterations, the shortest time
/// (ties on overlapping min–max intervals) and the lowest energy (ties at the 5 printed
/// decimals). `None` without `param` or `deform` runs.
pub fn per_mesh_table(rows: &[SummaryRow]) -> Option<Table> {
    let runs: Vec<&SummaryRow> = rows.iter().filter(|r| is_param_or_deform(r)).collect();
    if runs.is_empty() {
        return None;
    }
    let solvers = unique(runs.iter().map(|r| r.solver.as_str()));
    let groups = unique(runs.iter().map(|r| (r.dataset.as_str(), r.energy.as_str())));
    let mut columns = ["dataset", "energy", "# vert", "# elem", "analysis [s]", "E*"].map(String::from).to_vec();
    for s in &solvers {
        columns.extend([format!("{s} iter"), format!("{s} time [s]"), format!("{s} energy")]);
    }
    let (mut out, mut bold) = (Vec::new(), Vec::new());
    let mut single = false;
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
                .map(|t| Timed::exact(t).text())
                .unwrap_or_default(),
            reference_cell(runs.iter().copied().filter(|r| r.dataset == *d && r.energy == *e)),
        ];
        // The converged runs' iterations, times and energies compete for the bold marks.
        let (mut iters, mut times, mut energies) = (Vec::new(), Vec::new(), Vec::new());
        for s in &solvers {
            let r = of(s).copied();
            row.extend(solver_cells(r));
            let ranked = r.filter(|r| comparable(r));
            iters.push(ranked.and_then(|r| r.iterations).map(|i| i as f64));
            times.push(ranked.and_then(Timed::time_s));
            energies.push(ranked.and_then(|r| r.final_energy));
        }
        let column = |j: usize, k: usize| KEYS + 3 * j + k;
        bold.extend(lowest(&iters, equal).into_iter().map(|j| (i, column(j, 0))));
        let marks = fastest(&times);
        single |= marks.single_sample && !marks.best.is_empty();
        for &j in &marks.best {
            bold.push((i, column(j, 1)));
            row[column(j, 1)] = marks.label(j, std::mem::take(&mut row[column(j, 1)]));
        }
        // Energies tie at the printed precision.
        let printed = |a: f64, b: f64| format!("{a:.5}") == format!("{b:.5}");
        bold.extend(lowest(&energies, printed).into_iter().map(|j| (i, column(j, 2))));
        out.push(row);
    }
    bold.sort_unstable();
    Some(Table {
        title: "Per mesh: iterations, time and final energy per solver (composite-majorization paper, Table 1)".into(),
        columns,
        rows: out,
        caption: format!(
            "analysis = the symbolic analysis of the Newton system (ordering + symbolic Cholesky), done \
             once per mesh and shared by its runs; time = whole run including the initial map, without \
             the analysis (the median over repeats); energy = final energy (normalized by area); \
             * = did not converge (hit max_iters or another stop rule); (k shifted) = k iterations solved \
             their Newton system with a Tikhonov shift above the base (regularized Newton); skipped = the \
             solver is not defined for the energy (not run); a stop in the iterations column (linear_solve_failed, \
             not_descent, ...) = the method broke down, its numbers are left out. E* = the reference minimum the \
             harness judges the group's runs against († = not certified: no certificate vouches for it). {} \
             Bold = best of the row: fewest iterations, shortest time, lowest energy to 5 decimals. {}{}",
            ranking::CONVERGED_RULE,
            ranking::time_rule(single),
            with_space(target_rule(runs.iter().copied())),
        ),
        bold,
        layout: Layout { keys: KEYS, group: 3 },
    })
}

/// The per-mesh table's columns before the solvers' (dataset to E*), repeated in each block.
const KEYS: usize = 6;

/// The group's reference minimum E* to 8 significant digits, `†` when it is not certified;
/// empty when the harness judged the group against none.
fn reference_cell<'a>(mut group: impl Iterator<Item = &'a SummaryRow>) -> String {
    let Some(r) = group.find(|r| r.ref_energy.is_some()) else { return String::new() };
    let e = r.ref_energy.map(|e| crate::run_folder::timed::significant(e, 8)).unwrap_or_default();
    if r.ref_certified == Some(false) {
        format!("{e}†")
    } else {
        e
    }
}

/// A solver's three cells of a row of the per-mesh table: iterations (with marks), time and
/// final energy; a failed or skipped run says so, a run whose method broke down names its stop.
fn solver_cells(r: Option<&SummaryRow>) -> [String; 3] {
    match r {
        Some(r) if failed(r) || skipped(r) => [r.status.as_str().to_string(), String::new(), String::new()],
        Some(r) if broke_down(r) => [r.stop_column().to_string(), String::new(), String::new()],
        Some(r) => {
            let mark = if converged(r) { "" } else { "*" };
            let shifted = match r.shifted_iters {
                Some(k) if k > 0 => format!(" ({k} shifted)"),
                _ => String::new(),
            };
            [
                r.iterations.map(|i| format!("{i}{mark}{shifted}")).unwrap_or_default(),
                Timed::time_s(r).map(|t| t.text()).unwrap_or_default(),
                r.final_energy.map(|x| format!("{x:.5}")).unwrap_or_default(),
            ]
        }
        None => Default::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::tables::tests::row;
    use crate::run_folder::{RunStop, Status};

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
        // Single samples: the bold time says so.
        assert_eq!(t.rows[0], ["kp-newton", "25.0/0.600†", "10.0/0.100"]);
        assert_eq!(t.rows[1], ["akvf", "100.0/2.00*", ""]);
        assert!(t.caption.contains("2 datasets (a, b)") && t.caption.contains("1 failed"), "{}", t.caption);
        assert!(t.caption.contains("† single sample"), "{}", t.caption);
        // sd: kp-newton converged on both shapes. bconf: no solver converged on both (akvf
        // failed on b, kp-newton has no run there), so nothing is bold.
        assert_eq!(t.bold, [(0, 1)]);
        assert!(t.to_markdown().contains("| kp-newton | **25.0/0.600†** | 10.0/0.100 |"));
        assert!(t.to_html().contains("<td><b>25.0/0.600†</b></td>"));
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
        // slim is faster but did not converge: kp-newton is the best.
        assert_eq!(t.rows, [["kp-newton", "15.0/0.300†"], ["slim", "300.0/0.100*"]]);
        assert_eq!(t.bold, [(0, 1)]);
        assert!(t.title.contains("Table 4"));
    }

    /// A param run of `solver` on `d` (sd) with 5 repeats spread +-`spread` around `t`.
    fn timed(d: &str, s: &str, it: usize, t: f64, spread: f64, status: Status) -> SummaryRow {
        SummaryRow {
            dataset: d.into(),
            task: Task::Param,
            energy: "sd".into(),
            solver: s.into(),
            vertices: Some(1000),
            iterations: Some(it),
            time_s: Some(t),
            ms_per_vertex: Some(t),
            time_s_min: Some(t - spread),
            time_s_max: Some(t + spread),
            repeats: Some(5),
            final_energy: Some(2.0),
            status,
            ..Default::default()
        }
    }

    #[test]
    fn mean_tables_never_bold_failed_newton_and_tie_on_overlap() {
        // newton fails its factorization at once in every run (0
        // iterations, the shortest time), cm and kp converge with overlapping spreads.
        let mut rows = vec![
            timed("a", "newton", 0, 0.01, 0.001, Status::NotConverged),
            timed("b", "newton", 0, 0.01, 0.001, Status::NotConverged),
            timed("a", "cm", 10, 1.0, 0.1, Status::Ok),
            timed("b", "cm", 10, 1.0, 0.1, Status::Ok),
            timed("a", "kp-newton", 12, 1.15, 0.1, Status::Ok),
            timed("b", "kp-newton", 12, 1.15, 0.1, Status::Ok),
            timed("a", "slim", 300, 3.0, 0.1, Status::Ok),
            timed("b", "slim", 300, 3.0, 0.1, Status::Ok),
        ];
        rows.push(SummaryRow {
            status: Status::Skipped,
            error: "not defined".into(),
            ..timed("a", "akvf", 0, 0.0, 0.0, Status::Skipped)
        });
        rows[2].shifted_iters = Some(3);
        let t = param_table(&rows).unwrap();
        let solvers: Vec<&str> = t.rows.iter().map(|r| r[0].as_str()).collect();
        assert_eq!(solvers, ["newton", "cm", "kp-newton", "slim", "akvf"]);
        // cm [0.9, 1.1] and kp-newton [1.05, 1.25] overlap: both bold; slim does not.
        assert_eq!(t.bold, [(1, 1), (2, 1)]);
        assert_eq!(t.rows[1][1], "10.0/1.00 (0.900–1.10)§", "spread, shifted mark, no single-sample mark");
        assert_eq!(t.rows[0][1], "0.0/0.0100 (0.00900–0.0110)*");
        assert_eq!(t.rows[4][1], "skipped");
        assert!(
            t.caption.contains("0 failed runs, 0 whose")
                && t.caption.contains("and 1 skipped runs")
                && !t.caption.contains('†'),
            "{}",
            t.caption
        );
        // Disjoint spreads: only the fastest.
        for r in rows.iter_mut().filter(|r| r.solver == "kp-newton") {
            (r.time_s_min, r.time_s_max) = (Some(1.11), Some(1.2));
        }
        assert_eq!(param_table(&rows).unwrap().bold, [(1, 1)]);
        // A solver that converged on one dataset only does not compete with its mean of one.
        rows[3].status = Status::NotConverged;
        assert_eq!(param_table(&rows).unwrap().bold, [(2, 1)]);
        // newton's factorization failed in both runs: no mean of its few iterations, the stop.
        for r in rows.iter_mut().filter(|r| r.solver == "newton") {
            r.stop_reason =
                Some(RunStop::Solver(solvers::solver::StopReason::LinearSolveFailed("not positive definite".into())));
        }
        let t = param_table(&rows).unwrap();
        assert_eq!(t.rows[0][1], "linear_solve_failed");
        assert!(t.caption.contains("0 failed runs, 2 whose method broke down"), "{}", t.caption);
    }

    #[test]
    fn per_mesh_table_ranks_converged_runs_only() {
        let mut rows = vec![
            timed("cow", "newton", 0, 0.01, 0.0, Status::NotConverged),
            timed("cow", "cm", 30, 1.0, 0.1, Status::Ok),
            timed("cow", "kp-newton", 30, 1.05, 0.1, Status::Ok),
            SummaryRow {
                error: "slim is not defined for nh".into(),
                ..timed("cow", "slim", 0, 0.0, 0.0, Status::Skipped)
            },
        ];
        rows[0].final_energy = Some(1.0);
        rows[1].shifted_iters = Some(2);
        rows[2].final_energy = Some(2.000001);
        let t = per_mesh_table(&rows).unwrap();
        assert_eq!(t.rows[0][6..9], ["0*", "0.0100 (0.0100–0.0100)", "1.00000"]);
        assert_eq!(t.rows[0][9..12], ["30 (2 shifted)", "1.00 (0.900–1.10)", "2.00000"]);
        assert_eq!(t.rows[0][15..], ["skipped", "", ""]);
        // newton: fewest iterations, shortest time and lowest energy, and never bold; cm and
        // kp tie on iterations, on time (overlap) and on energy (5 decimals).
        assert_eq!(t.bold, [(0, 9), (0, 10), (0, 11), (0, 12), (0, 13), (0, 14)]);
        // A failed factorization: the stop instead of numbers that would look best.
        rows[0].stop_reason =
            Some(RunStop::Solver(solvers::solver::StopReason::LinearSolveFailed("not positive definite".into())));
        let t = per_mesh_table(&rows).unwrap();
        assert_eq!(t.rows[0][6..9], ["linear_solve_failed", "", ""]);
        assert!(t.caption.contains("the method broke down"), "{}", t.caption);
        assert!(t.caption.contains("never best") && t.caption.contains("(k shifted)"), "{}", t.caption);
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
            ref_energy: Some(2.08412876),
            ref_certified: Some(false),
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
            t.columns[..9],
            ["dataset", "energy", "# vert", "# elem", "analysis [s]", "E*", "cm iter", "cm time [s]", "cm energy"]
        );
        assert_eq!(
            t.rows[0],
            [
                "cow",
                "sd",
                "4540",
                "8626",
                "0.0312",
                "2.0841288†",
                "33",
                "0.600†",
                "2.08413",
                "41",
                "0.980",
                "2.08413",
                "394*",
                "0.500",
                "2.08417",
                "failed",
                "",
                ""
            ]
        );
        // fewest iterations and shortest time of the converged runs (cm: slim is faster but did
        // not converge), lowest energy at 5 decimals (cm and kp tie)
        assert_eq!(t.bold, [(0, 6), (0, 7), (0, 8), (0, 11)]);
        assert_eq!(t.layout, Layout { keys: 6, group: 3 });
        // A certified reference has no mark.
        let certified: Vec<SummaryRow> =
            rows.iter().cloned().map(|r| SummaryRow { ref_certified: Some(true), ..r }).collect();
        assert_eq!(per_mesh_table(&certified).unwrap().rows[0][5], "2.0841288");
    }
}
