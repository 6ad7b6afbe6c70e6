//! The corpus aggregates table: per energy and solver, the solved count and the shifted
//! geometric means of iterations and time (computed in [`crate::report::corpus`]), next to
//! the paper-shaped mean tables that one hard mesh can dominate.

use super::comparison::with_space;
use super::ranking::{self, fastest, lowest};
use super::table::{Layout, Table};
use crate::report::batch::Batch;
use crate::report::corpus::{self, Cap, CapSource, TimeUnit, ITERATION_SHIFT};
use crate::report::select::{finished, is_param_or_deform};
use crate::report::target::target_rule;
use crate::run_folder::timed::Timed;
use crate::run_folder::SummaryRow;

/// The table's file stem (and the anchor the profiles sit under in `index.html`).
pub const AGGREGATES: &str = "aggregates";

/// Per energy of the `param`/`deform` runs and per solver: runs (not skipped), solved, not
/// converged, failed, skipped, runs with shifted Newton systems, and the shifted geometric
/// means with unsolved runs at the caps, which the last columns show with their source.
///
/// Bold ([`ranking`]): the lowest means among the solvers that solved every dataset of the
/// energy (a mean over capped runs is a bound, not a cost); times tie on overlapping
/// intervals. `None` without a `param`/`deform` run that finished.
pub fn aggregates_table(rows: &[SummaryRow], batch: &Batch) -> Option<Table> {
    let rows: Vec<SummaryRow> = rows.iter().filter(|r| is_param_or_deform(r)).cloned().collect();
    if !rows.iter().any(finished) {
        return None;
    }
    let unit = TimeUnit::choose(&rows);
    let energies = corpus::aggregate(&rows, batch, unit);
    let columns = [
        "energy".to_string(),
        "solver".into(),
        "runs".into(),
        "solved".into(),
        "not converged".into(),
        "failed".into(),
        "skipped".into(),
        "shifted".into(),
        format!("sgm iterations (shift {ITERATION_SHIFT})"),
        format!("sgm time [{}] (shift {})", unit.symbol(), unit.shift()),
        "iteration cap".into(),
        format!("time cap [{}]", unit.symbol()),
    ]
    .to_vec();
    let (mut out, mut bold) = (Vec::new(), Vec::new());
    let mut single = false;
    for e in &energies {
        let first = out.len();
        // Only a solver that solved all of the energy's datasets has a mean of costs.
        let competes = |s: &corpus::SolverAggregate| s.runs == e.datasets && s.solved == s.runs && s.runs > 0;
        let iters: Vec<Option<f64>> = e.solvers.iter().map(|s| s.sgm_iterations.filter(|_| competes(s))).collect();
        let times: Vec<Option<Timed>> = e.solvers.iter().map(|s| s.sgm_time.filter(|_| competes(s))).collect();
        let printed = |a: f64, b: f64| format!("{a:.1}") == format!("{b:.1}");
        let best_iters = lowest(&iters, printed);
        let marks = fastest(&times);
        single |= marks.single_sample && !marks.best.is_empty();
        for (i, s) in e.solvers.iter().enumerate() {
            let time = s.sgm_time.map(|t| marks.label(i, t.text())).unwrap_or_default();
            out.push(aggregate_row(e, s, time, unit));
            if best_iters.contains(&i) {
                bold.push((first + i, 8));
            }
            if marks.contains(i) {
                bold.push((first + i, 9));
            }
        }
    }
    bold.sort_unstable();
    Some(Table {
        title: "Across the corpus: solved counts and shifted geometric means".into(),
        columns,
        rows: out,
        caption: format!(
            "Per energy over its datasets; runs = runs that were not skipped (skipped pairs are left out of \
             every aggregate), solved = status ok (the harness's verdict where the runs were judged); shifted = runs with Newton systems solved with \
             a Tikhonov shift above the base (regularized). sgm = (Π (v_i + s))^(1/n) − s over the runs, with \
             shift s = {ITERATION_SHIFT} iterations and, for {}. Unsolved runs (not converged or failed) count \
             at the cap, the Mittelmann convention: iterations at the energy's max_iters (meta.json \
             stop_per_energy), else at the most iterations any run of the energy made; time at the config's \
             timeout, else at the longest time any run of the energy took; never below the run's own value. \
             The caps used are in the last columns (limit = the batch's max_iters or timeout, most seen = \
             observed). Time bounds in parentheses: the same mean over the repeats' min and max times. Bold: \
             the lowest means among the solvers that solved every dataset of the energy (iterations tie at \
             the printed digit). {} {}{}",
            unit.describe(),
            ranking::CONVERGED_RULE,
            ranking::time_rule(single),
            with_space(target_rule(&rows)),
        ),
        bold,
        layout: Layout { keys: 2, group: 1 },
    })
}

/// One solver's row of an energy: its counts, its means (`time` already marked) and the
/// energy's caps.
fn aggregate_row(
    e: &corpus::EnergyAggregate,
    s: &corpus::SolverAggregate,
    time: String,
    unit: TimeUnit,
) -> Vec<String> {
    vec![
        e.energy.clone(),
        s.solver.clone(),
        s.runs.to_string(),
        s.solved.to_string(),
        s.not_converged.to_string(),
        s.failed.to_string(),
        s.skipped.to_string(),
        s.shifted.to_string(),
        s.sgm_iterations.map(|v| format!("{v:.1}")).unwrap_or_default(),
        time,
        cap_text(e.iteration_cap, |v| format!("{v:.0}")),
        cap_text(e.time_cap, |v| {
            let t = Timed::exact(v).text();
            if unit == TimeUnit::Seconds {
                format!("{t} s")
            } else {
                t
            }
        }),
    ]
}

/// `1000 (limit)` or `412 (most seen)`, the value as `text` writes it.
fn cap_text(cap: Option<Cap>, text: impl Fn(f64) -> String) -> String {
    let Some(c) = cap else { return String::new() };
    let source = match c.source {
        CapSource::Limit => "limit",
        CapSource::Observed => "most seen",
    };
    format!("{} ({source})", text(c.value))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Task;
    use crate::run_folder::Status;

    fn run(d: &str, e: &str, s: &str, status: Status, it: usize, t: f64) -> SummaryRow {
        SummaryRow {
            dataset: d.into(),
            task: Task::Param,
            energy: e.into(),
            solver: s.into(),
            iterations: Some(it),
            time_s: Some(t),
            status,
            ..Default::default()
        }
    }

    #[test]
    fn aggregates_count_solved_and_skipped_and_bold_only_solvers_that_solved_all() {
        let rows = vec![
            run("a", "sd", "cm", Status::Ok, 10, 1.0),
            run("b", "sd", "cm", Status::Ok, 30, 3.0),
            run("a", "sd", "kp-newton", Status::Ok, 12, 1.2),
            run("b", "sd", "kp-newton", Status::Ok, 30, 3.0),
            // newton: fails at once on both, never bold however fast.
            run("a", "sd", "newton", Status::NotConverged, 0, 0.001),
            run("b", "sd", "newton", Status::NotConverged, 0, 0.001),
            run("a", "sd", "slim", Status::Skipped, 0, 0.0),
            run("b", "sd", "slim", Status::Skipped, 0, 0.0),
            run("a", "bconf", "cm", Status::Ok, 5, 0.5),
        ];
        let batch = Batch { max_iters: [("sd".to_string(), 1000)].into(), ..Default::default() };
        let t = aggregates_table(&rows, &batch).unwrap();
        assert_eq!(t.columns[8], "sgm iterations (shift 10)");
        assert_eq!(t.columns[9], "sgm time [s] (shift 0.1)");
        let solvers: Vec<(&str, &str)> = t.rows.iter().map(|r| (r[0].as_str(), r[1].as_str())).collect();
        assert_eq!(solvers, [("sd", "cm"), ("sd", "kp-newton"), ("sd", "newton"), ("sd", "slim"), ("bconf", "cm")]);
        // cm: sqrt(20 * 40) - 10 = 18.28 iterations, sqrt(1.1 * 3.1) - 0.1 = 1.75 s.
        assert_eq!(t.rows[0][2..10], ["2", "2", "0", "0", "0", "0", "18.3", "1.75†"]);
        // newton at the caps: 1000 iterations, 3 s (the longest run; no timeout).
        assert_eq!(
            t.rows[2][2..],
            ["2", "0", "2", "0", "0", "0", "1000.0", "3.00", "1000 (limit)", "3.00 s (most seen)"]
        );
        assert_eq!(t.rows[3][2..10], ["0", "0", "0", "0", "2", "0", "", ""]);
        // bconf without max_iters in meta.json: the most iterations seen.
        assert_eq!(t.rows[4][10], "5 (most seen)");
        assert_eq!(t.bold, [(0, 8), (0, 9), (4, 8), (4, 9)]);
        assert!(t.caption.contains("Mittelmann") && t.caption.contains("time_s in seconds"), "{}", t.caption);
        assert!(t.caption.contains("† single sample"));
        // Nothing of param/deform finished: no table.
        assert!(aggregates_table(&rows[6..8], &batch).is_none());
    }

    #[test]
    fn normalized_times_and_overlapping_spreads() {
        let mut rows = vec![
            run("a", "sd", "cm", Status::Ok, 10, 1.0),
            run("a", "sd", "kp-newton", Status::Ok, 10, 1.1),
            run("a", "sd", "slim", Status::Ok, 100, 2.0),
        ];
        for r in &mut rows {
            let t = r.time_s.unwrap();
            (r.repeats, r.time_s_min, r.time_s_max, r.time_norm) =
                (Some(5), Some(t - 0.1), Some(t + 0.1), Some(2.0 * t));
        }
        let t = aggregates_table(&rows, &Batch::default()).unwrap();
        assert_eq!(t.columns[9], "sgm time [cal] (shift 0.25)");
        assert_eq!(t.rows[0][9], "2.00 (1.80–2.20)");
        // cm and kp tie on iterations (equal) and on time (overlap); slim does neither.
        assert_eq!(t.bold, [(0, 8), (0, 9), (1, 8), (1, 9)]);
        assert!(t.caption.contains("time_norm in calibration units") && !t.caption.contains('†'), "{}", t.caption);
    }
}
