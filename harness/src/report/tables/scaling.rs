//! Iterations and time against the mesh size.

use super::comparison::with_space;
use super::table::{Layout, Table};
use crate::report::select::{converged, finished, is_param_or_deform, unique};
use crate::report::target::target_rule;
use crate::run_folder::timed::Timed;
use crate::run_folder::SummaryRow;

/// The composite-majorization paper's Figure 6 as a table: per energy, the datasets sorted by
/// size, and for each solver its iterations, median time per iteration and run time (with
/// its min–max over the repeats) and the growth of the resident memory during the run. It
/// ranks nothing (no bold). `None` unless some energy has
/// runs on at least three mesh sizes (`param` or `deform`); failed and skipped runs are left out.
pub fn scaling_table(rows: &[SummaryRow]) -> Option<Table> {
    let runs: Vec<&SummaryRow> =
        rows.iter().filter(|r| is_param_or_deform(r) && finished(r) && r.vertices.is_some()).collect();
    let mut energies = unique(runs.iter().map(|r| r.energy.as_str()));
    let solvers = unique(runs.iter().map(|r| r.solver.as_str()));
    energies.retain(|e| {
        let mut sizes: Vec<usize> = runs.iter().filter(|r| r.energy == *e).filter_map(|r| r.vertices).collect();
        sizes.sort_unstable();
        sizes.dedup();
        sizes.len() >= crate::report::plots::SCALING_MIN_SIZES
    });
    if energies.is_empty() {
        return None;
    }
    let mut columns = ["energy", "dataset", "vertices"].map(String::from).to_vec();
    for s in &solvers {
        columns.extend([format!("{s} iter"), format!("{s} ms/iter"), format!("{s} time [s]"), format!("{s} peak MB")]);
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
                        let mark = if converged(r) { "" } else { "*" };
                        row.push(r.iterations.map(|i| format!("{i}{mark}")).unwrap_or_default());
                        row.push(r.iter_ms_median.map(|t| format!("{t:.1}")).unwrap_or_default());
                        row.push(Timed::time_s(r).map(|t| t.text()).unwrap_or_default());
                        // The growth during the run; the process's peak (marked ~) when runs shared it.
                        let memory = match (r.peak_growth_mb, r.peak_rss_mb) {
                            (Some(own), _) => format!("{own:.0}"),
                            (None, Some(all)) => format!("~{all:.0}"),
                            _ => String::new(),
                        };
                        row.push(memory);
                    }
                    None => row.extend(std::iter::repeat_n(String::new(), 4)),
                }
            }
            out.push(row);
        }
    }
    Some(Table {
        title: "Iterations and time vs mesh size (composite-majorization paper, Figure 6)".into(),
        columns,
        rows: out,
        caption: format!(
            "Datasets sorted by vertices; ms/iter = median wall time of one iteration; time = whole run \
                  (the median over repeats, min–max in parentheses); peak MB = how far the process's resident memory \
                  rose above its level at the run's start (MiB, measured when no other run was in flight beside it, as \
                  with --jobs 1: the run's own peak less memory it reused from earlier runs); ~N = the process's peak, \
                  the runs beside it included, when they shared it; an external solver's own process group's \
                  peak; * = did not converge; failed runs and \
                  skipped pairs are left out (empty cells). Plotted in plots/scaling__<energy>__*.png.{}",
            with_space(target_rule(runs.iter().copied()))
        ),
        bold: Vec::new(),
        layout: Layout { keys: 3, group: 4 },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Task;
    use crate::run_folder::Status;

    #[test]
    fn scaling_table_sorts_by_size_and_needs_three_sizes() {
        let p = |d: &str, v: usize, s: &str, it: usize, ms: f64| SummaryRow {
            dataset: d.into(),
            task: Task::Param,
            energy: "sd".into(),
            solver: s.into(),
            vertices: Some(v),
            iterations: Some(it),
            iter_ms_median: Some(ms),
            time_s: Some(ms * it as f64 / 1e3),
            status: Status::Ok,
            peak_rss_mb: Some(ms * 2.0),
            peak_growth_mb: (s == "kp-newton").then_some(ms),
            ..Default::default()
        };
        let mut rows = vec![p("big", 50_000, "kp-newton", 30, 400.0), p("small", 1_000, "kp-newton", 10, 5.0)];
        assert!(scaling_table(&rows).is_none(), "two sizes are not a trend");
        rows.push(p("mid", 10_000, "kp-newton", 20, 50.0));
        rows.push(p("mid", 10_000, "slim", 200, 20.0));
        let t = scaling_table(&rows).unwrap();
        let order: Vec<&str> = t.rows.iter().map(|r| r[1].as_str()).collect();
        assert_eq!(order, ["small", "mid", "big"]);
        assert_eq!(t.rows[1], ["sd", "mid", "10000", "20", "50.0", "1.00", "50", "200", "20.0", "4.00", "~40"]);
        assert_eq!(t.rows[0][7..], ["", "", "", ""]);
    }
}
