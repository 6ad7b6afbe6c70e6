//! The harness's verdicts per energy: per solver, how many datasets it solved at
//! each target, and why the rest were not solved.

use super::ranking::{self, lowest};
use super::table::{Layout, Table};
use crate::judge::verdict::Verdict;
use crate::report::select::{failed, skipped, unique};
use crate::report::target::{tau_text, verdict_text};
use crate::run_folder::SummaryRow;

/// The table's file stem.
pub const VERDICTS: &str = "verdicts";

/// The verdicts a run that ran can get without being solved, in the table's column order.
const UNSOLVED: [Verdict; 6] = [
    Verdict::Flipped,
    Verdict::StoppedAboveTarget,
    Verdict::OtherMinimum,
    Verdict::Stalled,
    Verdict::BrokeDown,
    Verdict::Unfinished,
];

/// The run solved its problem at `tau`: it passed the convergence test there and its final
/// map flips no triangle (at the tightest target: the verdict `solved`).
fn solved_at(r: &SummaryRow, tau: f64) -> bool {
    r.flips.unwrap_or(0) == 0 && r.to_targets.iter().any(|t| t.tau == tau && t.iters.is_some())
}

/// Per energy of the judged runs (`authalic`: its energy `E_A`) and per solver: runs (not
/// skipped), the datasets solved at each target (`solved at 1e-3`, `solved at 1e-6`, loosest
/// first), and the verdicts of the others, then the failed runs. Bold: the most solved at each
/// target. `None` when the harness judged no run (a folder from before verdicts).
pub fn verdict_table(rows: &[SummaryRow]) -> Option<Table> {
    let rows: Vec<&SummaryRow> = rows.iter().collect();
    let mut taus = unique(rows.iter().flat_map(|r| &r.to_targets).map(|t| t.tau));
    if taus.is_empty() {
        return None;
    }
    taus.sort_by(|a, b| b.total_cmp(a));
    let mut columns = vec!["energy".to_string(), "solver".into(), "runs".into()];
    columns.extend(taus.iter().map(|t| format!("solved at {}", tau_text(*t))));
    columns.extend(UNSOLVED.iter().map(|v| verdict_text(*v).to_string()));
    columns.push("failed".into());
    columns.push("E* not certified".into());
    let (mut out, mut bold) = (Vec::new(), Vec::new());
    let solvers = unique(rows.iter().map(|r| r.solver.as_str()));
    for energy in unique(rows.iter().map(|r| r.energy.as_str())) {
        let first = out.len();
        let mut solved: Vec<Vec<Option<f64>>> = vec![Vec::new(); taus.len()];
        for s in &solvers {
            let mine: Vec<&SummaryRow> =
                rows.iter().copied().filter(|r| r.energy == energy && r.solver == *s && !skipped(r)).collect();
            if mine.is_empty() {
                continue;
            }
            let mut row = vec![energy.to_string(), s.to_string(), mine.len().to_string()];
            for (k, tau) in taus.iter().enumerate() {
                // An energy with its own targets is not judged at the others: no count there.
                let judged_at = rows.iter().any(|r| r.energy == energy && r.to_targets.iter().any(|t| t.tau == *tau));
                if !judged_at {
                    row.push("–".into());
                    solved[k].push(None);
                    continue;
                }
                let n = mine.iter().filter(|r| solved_at(r, *tau)).count();
                row.push(n.to_string());
                // The most solved is best: rank the negated counts.
                solved[k].push(Some(-(n as f64)));
            }
            row.extend(UNSOLVED.iter().map(|v| mine.iter().filter(|r| r.verdict == Some(*v)).count().to_string()));
            row.push(mine.iter().filter(|r| failed(r)).count().to_string());
            row.push(mine.iter().filter(|r| r.ref_certified == Some(false)).count().to_string());
            out.push(row);
        }
        for (k, counts) in solved.iter().enumerate() {
            let most = lowest(counts, ranking::equal);
            bold.extend(most.into_iter().filter(|i| counts[*i].is_some_and(|c| c != 0.0)).map(|i| (first + i, 3 + k)));
        }
    }
    bold.sort_unstable();
    let tightest = taus.last().map_or(String::new(), |t| tau_text(*t));
    Some(Table {
        title: "The harness's verdicts: datasets solved at each target".into(),
        columns,
        rows: out,
        caption: format!(
            "Per energy and solver over its runs that were not skipped (runs). solved at τ = the final map flips \
             no triangle and its energy is within τ of the reference minimum E* of its dataset and energy on the \
             span min(E0 − E*, A) (E0 the common start's energy, A = max(E* − E_iso, 10⁻⁴ max(1, |E_iso|)) the \
             minimum's own distortion: the same accuracy on every problem); solved at {tightest} is status ok. \
             An energy with its own targets is solved at its own tightest (– at the targets it does not have). Each run went on to its target, its \
             solver's stop rules recorded on the way; the others, by the harness's verdict: flipped = the final \
             map flips triangles; stopped above target = a stop rule ended it above the target (an external \
             solver's own, or a run without a reference to go to); other minimum = it ended stationary above \
             the target, and a tight Newton polish from its final map stayed there; stalled = it ended \
             stationary otherwise (no decrease beyond round-off over the stall window or in a line search, or \
             the gradient floor); broke down = the method broke down (a line search that found no decrease its \
             model promised, a failed factorization); out of budget = the iteration cap or the time limit ended it; failed = the \
             run did not finish. E* not certified = \
             the runs judged against a reference minimum without a certificate (the status matrix's †). Bold: \
             the most datasets solved at each target."
        ),
        bold,
        layout: Layout { keys: 3, group: 1 },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Task;
    use crate::run_folder::summary::ToTarget;
    use crate::run_folder::Status;

    /// A judged run reaching 1e-3 at `loose` and 1e-6 at `tight` iterations.
    fn judged(d: &str, e: &str, s: &str, loose: Option<usize>, tight: Option<usize>, v: Verdict) -> SummaryRow {
        let to = |tau, iters: Option<usize>| ToTarget { tau, iters, time_s: iters.map(|i| i as f64) };
        SummaryRow {
            dataset: d.into(),
            task: Task::Param,
            energy: e.into(),
            solver: s.into(),
            flips: Some(if v == Verdict::Flipped { 2 } else { 0 }),
            status: if v == Verdict::Solved { Status::Ok } else { Status::NotConverged },
            verdict: Some(v),
            to_targets: vec![to(1e-3, loose), to(1e-6, tight)],
            ..Default::default()
        }
    }

    #[test]
    fn counts_solved_at_each_target_and_the_verdicts_of_the_rest() {
        let rows = vec![
            judged("a", "sd", "kp-newton", Some(5), Some(8), Verdict::Solved),
            judged("b", "sd", "kp-newton", Some(6), Some(9), Verdict::Solved),
            judged("a", "sd", "slim", Some(50), None, Verdict::StoppedAboveTarget),
            judged("b", "sd", "slim", None, None, Verdict::OtherMinimum),
            judged("a", "sd", "lbfgs", Some(20), Some(40), Verdict::Flipped),
            judged("b", "sd", "lbfgs", Some(30), None, Verdict::Unfinished),
            SummaryRow {
                status: Status::Skipped,
                verdict: None,
                ..judged("a", "sd", "akvf", None, None, Verdict::Unfinished)
            },
            SummaryRow {
                status: Status::Failed,
                verdict: None,
                to_targets: Vec::new(),
                ..judged("a", "bconf", "kp-newton", None, None, Verdict::Unfinished)
            },
        ];
        // Dataset b's sd reference is not certified: its runs are counted.
        let rows: Vec<SummaryRow> = rows
            .into_iter()
            .map(|r| {
                let uncertified = r.dataset == "b" && r.energy == "sd";
                SummaryRow { ref_certified: Some(!uncertified), ..r }
            })
            .collect();
        let t = verdict_table(&rows).unwrap();
        assert_eq!(
            t.columns,
            [
                "energy",
                "solver",
                "runs",
                "solved at 1e-3",
                "solved at 1e-6",
                "flipped",
                "stopped above target",
                "other minimum",
                "stalled",
                "broke down",
                "out of budget",
                "failed",
                "E* not certified"
            ]
        );
        assert_eq!(t.rows[0], ["sd", "kp-newton", "2", "2", "2", "0", "0", "0", "0", "0", "0", "0", "1"]);
        assert_eq!(t.rows[1], ["sd", "slim", "2", "1", "0", "0", "1", "1", "0", "0", "0", "0", "1"]);
        // The flipped run reached both targets but is solved at neither.
        assert_eq!(t.rows[2], ["sd", "lbfgs", "2", "1", "0", "1", "0", "0", "0", "0", "1", "0", "1"]);
        // akvf was skipped everywhere: no row; bconf was judged at no target (its one run failed).
        assert_eq!(t.rows[3], ["bconf", "kp-newton", "1", "–", "–", "0", "0", "0", "0", "0", "0", "1", "0"]);
        assert_eq!(t.rows.len(), 4);
        // kp-newton solved the most at both targets; nobody solved bconf: nothing bold there.
        assert_eq!(t.bold, [(0, 3), (0, 4)]);
        assert!(t.caption.contains("solved at 1e-6 is status ok"), "{}", t.caption);
        // Nothing judged: no table.
        let unjudged: Vec<SummaryRow> =
            rows.iter().map(|r| SummaryRow { to_targets: Vec::new(), ..r.clone() }).collect();
        assert!(verdict_table(&unjudged).is_none());
    }
}
