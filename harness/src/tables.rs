//! Paper-style tables computed from `summary.csv` rows, written as `.csv`, `.md` and `.html`.

use crate::run_folder::{write_atomic, SummaryRow};
use anyhow::Result;
use std::path::Path;

/// A rectangular table of already formatted cells.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    pub title: String,
    pub columns: Vec<String>,
    pub rows: Vec<Vec<String>>,
    /// A sentence under the table saying what the numbers are.
    pub caption: String,
    /// Cells `(row, column)` shown in bold: the best value among the solvers compared.
    pub bold: Vec<(usize, usize)>,
}

impl Table {
    pub fn to_csv(&self) -> Result<Vec<u8>> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(&self.columns)?;
        for r in &self.rows {
            w.write_record(r)?;
        }
        Ok(w.into_inner()?)
    }

    pub fn to_markdown(&self) -> String {
        let mut s =
            format!("### {}\n\n| {} |\n|{}\n", self.title, self.columns.join(" | "), "---|".repeat(self.columns.len()));
        for (i, r) in self.rows.iter().enumerate() {
            let cells: Vec<String> = r
                .iter()
                .enumerate()
                .map(|(j, c)| if self.bold.contains(&(i, j)) && !c.is_empty() { format!("**{c}**") } else { c.clone() })
                .collect();
            s += &format!("| {} |\n", cells.join(" | "));
        }
        s += &format!("\n{}\n", self.caption);
        s
    }

    /// A standalone page: the title and [`Table::to_html_fragment`].
    pub fn to_html(&self) -> String {
        let esc = |t: &str| t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;");
        format!(
            "<!doctype html>\n<meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width\">\n\
             <title>{t}</title>\n<style>body{{font-family:sans-serif}}table{{border-collapse:collapse}}\
             td,th{{border:1px solid #bbb;padding:2px 6px;text-align:right}}th{{background:#eee}}</style>\n\
             <h3>{t}</h3>\n{body}",
            t = esc(&self.title),
            body = self.to_html_fragment()
        )
    }

    /// Just the `<table>` and the caption paragraph, for embedding in a larger page.
    pub fn to_html_fragment(&self) -> String {
        let esc = |t: &str| t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;");
        let mut s = "<table>\n<tr>".to_string();
        for c in &self.columns {
            s += &format!("<th>{}</th>", esc(c));
        }
        s += "</tr>\n";
        for (i, r) in self.rows.iter().enumerate() {
            s += "<tr>";
            for (j, c) in r.iter().enumerate() {
                if self.bold.contains(&(i, j)) {
                    s += &format!("<td><b>{}</b></td>", esc(c));
                } else {
                    s += &format!("<td>{}</td>", esc(c));
                }
            }
            s += "</tr>\n";
        }
        s += &format!("</table>\n<p>{}</p>\n", esc(&self.caption));
        s
    }

    /// Write `dir/<stem>.csv|.md|.html`.
    pub fn write(&self, dir: &Path, stem: &str) -> Result<()> {
        write_atomic(&dir.join(format!("{stem}.csv")), &self.to_csv()?)?;
        write_atomic(&dir.join(format!("{stem}.md")), self.to_markdown().as_bytes())?;
        write_atomic(&dir.join(format!("{stem}.html")), self.to_html().as_bytes())
    }
}

/// The solvers whose per-element projection the projection table compares, with short labels.
const PROJECTIONS: [(&str, &str); 3] = [("kp-newton", "KP"), ("fp-newton-4x4", "FP4"), ("fp-newton-6x6", "FP6")];

/// The complex-view paper's Table 5 shape: per mesh and energy, the median per-iteration time
/// of each projection next to the linear solve, and their ratio. `None` when no run of a
/// projection solver finished.
pub fn projection_table(rows: &[SummaryRow]) -> Option<Table> {
    let present: Vec<(&str, &str)> = PROJECTIONS
        .iter()
        .copied()
        .filter(|(s, _)| rows.iter().any(|r| r.solver == *s && r.status != "failed"))
        .collect();
    if present.is_empty() {
        return None;
    }
    let mut columns = vec!["dataset".to_string(), "energy".into(), "vertices".into(), "solve_ms".into()];
    for (_, l) in &present {
        columns.push(format!("{l}_project_ms"));
        columns.push(format!("{l}_project/solve"));
    }
    let mut groups: Vec<(&str, &str)> = Vec::new();
    for r in rows {
        if !groups.contains(&(r.dataset.as_str(), r.energy.as_str())) {
            groups.push((&r.dataset, &r.energy));
        }
    }
    let ms = |v: f64| format!("{v:.3}");
    let mut out = Vec::new();
    for (d, e) in groups {
        let runs: Vec<&SummaryRow> = rows
            .iter()
            .filter(|r| r.dataset == d && r.energy == e && r.status != "failed" && r.iterations.unwrap_or(0) > 0)
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
    })
}

/// The complex-view paper's Table 7 shape: per mesh and energy with a smoothness term, the
/// median per-iteration linear solve next to the Hessian projection with the analytic 8x8
/// edge projection (`kp-newton`) and the numeric one (`kp-newton-eig8`). `None` unless a
/// `kp-newton-eig8` run finished.
pub fn smoothness_table(rows: &[SummaryRow]) -> Option<Table> {
    let ok = |r: &&SummaryRow| r.status != "failed" && r.iterations.unwrap_or(0) > 0;
    if !rows.iter().filter(ok).any(|r| r.solver == "kp-newton-eig8") {
        return None;
    }
    let mut groups: Vec<(&str, &str)> = Vec::new();
    for r in rows.iter().filter(ok) {
        if !groups.contains(&(r.dataset.as_str(), r.energy.as_str())) {
            groups.push((&r.dataset, &r.energy));
        }
    }
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
    })
}

/// How a solver x energy table averages its runs.
struct MeanSpec {
    task: &'static str,
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
    let done: Vec<&SummaryRow> = all.iter().copied().filter(|r| r.status != "failed").collect();
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
            let mark = if cell.iter().any(|r| r.status != "ok") { "*" } else { "" };
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
            task: "param",
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
            task: "deform",
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
    let runs: Vec<&SummaryRow> = rows.iter().filter(|r| r.task == "param" || r.task == "deform").collect();
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
                Some(r) if r.status == "failed" => {
                    row.extend(["failed".to_string(), String::new(), String::new()]);
                    values.push(None);
                }
                Some(r) => {
                    let mark = if r.status == "ok" { "" } else { "*" };
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

/// The composite-majorization paper's Figure 6 as a table: per energy, the datasets sorted by
/// size, and for each solver its iterations, median time per iteration and run time. `None`
/// unless some energy has runs on at least three mesh sizes (`param` or `deform`).
pub fn scaling_table(rows: &[SummaryRow]) -> Option<Table> {
    let runs: Vec<&SummaryRow> = rows
        .iter()
        .filter(|r| (r.task == "param" || r.task == "deform") && r.status != "failed" && r.vertices.is_some())
        .collect();
    let mut energies: Vec<&str> = Vec::new();
    let mut solvers: Vec<&str> = Vec::new();
    for r in &runs {
        if !energies.contains(&r.energy.as_str()) {
            energies.push(&r.energy);
        }
        if !solvers.contains(&r.solver.as_str()) {
            solvers.push(&r.solver);
        }
    }
    energies.retain(|e| {
        let mut sizes: Vec<usize> = runs.iter().filter(|r| r.energy == *e).filter_map(|r| r.vertices).collect();
        sizes.sort_unstable();
        sizes.dedup();
        sizes.len() >= crate::plots::SCALING_MIN_SIZES
    });
    if energies.is_empty() {
        return None;
    }
    let mut columns = ["energy", "dataset", "vertices"].map(String::from).to_vec();
    for s in &solvers {
        columns.extend([format!("{s} iter"), format!("{s} ms/iter"), format!("{s} time [s]")]);
    }
    let mut out = Vec::new();
    for e in &energies {
        let mut sets: Vec<(&str, usize)> = Vec::new();
        for r in runs.iter().filter(|r| r.energy == *e) {
            if !sets.iter().any(|(d, _)| *d == r.dataset) {
                sets.push((&r.dataset, r.vertices.unwrap_or(0)));
            }
        }
        sets.sort_by_key(|&(d, v)| (v, d));
        for (d, v) in sets {
            let mut row = vec![e.to_string(), d.to_string(), v.to_string()];
            for s in &solvers {
                match runs.iter().find(|r| r.energy == *e && r.dataset == d && r.solver == *s) {
                    Some(r) => {
                        let mark = if r.status == "ok" { "" } else { "*" };
                        row.push(r.iterations.map(|i| format!("{i}{mark}")).unwrap_or_default());
                        row.push(r.iter_ms_median.map(|t| format!("{t:.1}")).unwrap_or_default());
                        row.push(r.time_s.map(|t| format!("{t:.2}")).unwrap_or_default());
                    }
                    None => row.extend(std::iter::repeat_n(String::new(), 3)),
                }
            }
            out.push(row);
        }
    }
    Some(Table {
        title: "Iterations and time vs mesh size (composite-majorization paper, Figure 6)".into(),
        columns,
        rows: out,
        caption: "Datasets sorted by vertices; ms/iter = median wall time of one iteration; time = whole run; \
                  * = did not converge. Plotted in plots/scaling__<energy>__*.png."
            .into(),
        bold: Vec::new(),
    })
}

/// Short labels of the authalic solvers, in the column order of the AEM paper's Table 1.
const AUTHALIC: [(&str, &str); 3] = [("sem", "SEM"), ("aem-cg", "AEM-CG"), ("aem-cg-safe", "AEM-CG-safe")];

/// The AEM paper's Table 1 shape: per mesh, for each solver the SD of the area ratios, the
/// normalized authalic energy, the time and the number of folded triangles. `None` when no
/// authalic run finished.
pub fn authalic_table(rows: &[SummaryRow]) -> Option<Table> {
    let done: Vec<&SummaryRow> =
        rows.iter().filter(|r| r.task == "authalic" && r.status != "failed" && r.authalic_energy.is_some()).collect();
    let present: Vec<(&str, &str)> =
        AUTHALIC.iter().copied().filter(|(s, _)| done.iter().any(|r| r.solver == *s)).collect();
    if present.is_empty() {
        return None;
    }
    let mut columns = vec!["dataset".to_string(), "vertices".into(), "faces".into()];
    for (_, l) in &present {
        columns.extend([format!("{l} area ratio SD"), format!("{l} E_A"), format!("{l} time_s"), format!("{l} folds")]);
    }
    let mut datasets: Vec<&str> = Vec::new();
    for r in &done {
        if !datasets.contains(&r.dataset.as_str()) {
            datasets.push(&r.dataset);
        }
    }
    let sci = |v: Option<f64>| v.map(|x| format!("{x:.2e}")).unwrap_or_default();
    let (mut out, mut bold) = (Vec::new(), Vec::new());
    for (i, d) in datasets.into_iter().enumerate() {
        let runs: Vec<&&SummaryRow> = done.iter().filter(|r| r.dataset == d).collect();
        // Bold the lowest area ratio SD and E_A of the row.
        for (k, f) in [|r: &SummaryRow| r.area_ratio_sd, |r: &SummaryRow| r.authalic_energy].iter().enumerate() {
            let vals: Vec<Option<f64>> =
                present.iter().map(|(s, _)| runs.iter().find(|r| r.solver == *s).and_then(|r| f(r))).collect();
            let best = vals.iter().flatten().copied().fold(f64::INFINITY, f64::min);
            bold.extend((0..vals.len()).filter(|&j| vals[j] == Some(best)).map(|j| (i, 3 + 4 * j + k)));
        }
        let count = |f: fn(&SummaryRow) -> Option<usize>| runs.first().and_then(|r| f(r)).map(|v| v.to_string());
        let mut row =
            vec![d.to_string(), count(|r| r.vertices).unwrap_or_default(), count(|r| r.faces).unwrap_or_default()];
        for (s, _) in &present {
            match runs.iter().find(|r| r.solver == *s) {
                Some(r) => row.extend([
                    sci(r.area_ratio_sd),
                    sci(r.authalic_energy),
                    r.time_s.map(|t| format!("{t:.2}")).unwrap_or_default(),
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
             over faces; E_A = normalized authalic energy (Eq. 4); time = whole run including the initial map; \
             folds = faces with non-positive image area; bold = lowest of the row."
        ),
        bold,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(d: &str, s: &str, p: f64, sv: f64) -> SummaryRow {
        SummaryRow {
            dataset: d.into(),
            energy: "sd".into(),
            solver: s.into(),
            vertices: Some(100),
            iterations: Some(5),
            project_ms_median: Some(p),
            solve_ms_median: Some(sv),
            status: "ok".into(),
            ..Default::default()
        }
    }

    #[test]
    fn deform_table_averages_over_shapes() {
        let d = |shape: &str, e: &str, s: &str, it: usize, t: f64, status: &str| SummaryRow {
            dataset: shape.into(),
            task: "deform".into(),
            energy: e.into(),
            solver: s.into(),
            iterations: Some(it),
            time_s: Some(t),
            status: status.into(),
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
    fn scaling_table_sorts_by_size_and_needs_three_sizes() {
        let p = |d: &str, v: usize, s: &str, it: usize, ms: f64| SummaryRow {
            dataset: d.into(),
            task: "param".into(),
            energy: "sd".into(),
            solver: s.into(),
            vertices: Some(v),
            iterations: Some(it),
            iter_ms_median: Some(ms),
            time_s: Some(ms * it as f64 / 1e3),
            status: "ok".into(),
            ..Default::default()
        };
        let mut rows = vec![p("big", 50_000, "kp-newton", 30, 400.0), p("small", 1_000, "kp-newton", 10, 5.0)];
        assert!(scaling_table(&rows).is_none(), "two sizes are not a trend");
        rows.push(p("mid", 10_000, "kp-newton", 20, 50.0));
        rows.push(p("mid", 10_000, "slim", 200, 20.0));
        let t = scaling_table(&rows).unwrap();
        let order: Vec<&str> = t.rows.iter().map(|r| r[1].as_str()).collect();
        assert_eq!(order, ["small", "mid", "big"]);
        assert_eq!(t.rows[1], ["sd", "mid", "10000", "20", "50.0", "1.00", "200", "20.0", "4.00"]);
        assert_eq!(t.rows[0][6..], ["", "", ""]);
    }

    #[test]
    fn param_table_is_table_4_in_ms_per_vertex() {
        let p = |d: &str, s: &str, it: usize, ms: f64, status: &str| SummaryRow {
            dataset: d.into(),
            task: "param".into(),
            energy: "sd".into(),
            solver: s.into(),
            iterations: Some(it),
            ms_per_vertex: Some(ms),
            time_s: Some(100.0),
            status: status.into(),
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
            task: "param".into(),
            energy: "sd".into(),
            solver: s.into(),
            vertices: Some(4540),
            faces: Some(8626),
            iterations: Some(it),
            time_s: Some(t),
            final_energy: Some(e),
            status: status.into(),
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

    #[test]
    fn authalic_table_has_the_shape_of_table_1() {
        let auth = |d: &str, s: &str, sd: f64, e: f64| SummaryRow {
            dataset: d.into(),
            task: "authalic".into(),
            energy: "authalic".into(),
            solver: s.into(),
            vertices: Some(10),
            faces: Some(12),
            iterations: Some(100),
            time_s: Some(1.234),
            status: "not_converged".into(),
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
    }

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
