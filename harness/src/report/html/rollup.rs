//! The first screen's roll-up of what broke: per solver and energy, how many of its runs were
//! left unsolved or failed and why (the stops that say so most often), the solvers the config
//! expects to fail (`expected_to_fail`) apart from the news; the runs are those of the
//! batch's count ([`crate::report::count`]), so the heading and the verdict line agree.

use crate::escape::esc;
use crate::judge::verdict::Verdict;
use crate::report::batch::Batch;
use crate::report::count::{class, is_problem, Class};
use crate::report::select::{counted, unique};
use crate::run_folder::{Status, SummaryRow, FAILED_STOP};
use std::fmt::Write as _;

/// The stops named per solver and energy; the rest are counted as "other".
const REASONS_SHOWN: usize = 3;

/// The pairs listed on the first screen, the most unsolved first; the rest fold away (a
/// nightly with 61 unsolved pairs filled the screen with them).
const PAIRS_SHOWN: usize = 8;

/// Why a run is a problem, in a word: its `stop_reason` column (`error` for a failed run).
fn why(s: &SummaryRow) -> &'static str {
    match s.status {
        Status::Failed => FAILED_STOP,
        _ => s.stop_column(),
    }
}

/// One solver and energy's unsolved runs.
struct Line<'a> {
    solver: &'a str,
    energy: &'a str,
    unsolved: usize,
    ran: usize,
    /// Each stop with its count, the most frequent first.
    reasons: Vec<(&'static str, usize)>,
}

impl Line<'_> {
    fn text(&self) -> String {
        let mut reasons: Vec<String> =
            self.reasons.iter().take(REASONS_SHOWN).map(|(r, n)| format!("{r} {n}")).collect();
        let other: usize = self.reasons.iter().skip(REASONS_SHOWN).map(|(_, n)| n).sum();
        if other > 0 {
            reasons.push(format!("other {other}"));
        }
        format!(
            "{} / {}: {} of {} unsolved ({})",
            self.solver,
            self.energy,
            self.unsolved,
            self.ran,
            reasons.join(", ")
        )
    }
}

/// The unsolved runs (`unsolved`) rolled up per (solver, energy), the most unsolved first
/// (ties in the batch's order); "of N" counts the runs of the pair that ran or failed, but
/// those on problems solved at their start.
fn lines<'a>(summaries: &'a [SummaryRow], batch: &Batch, unsolved: impl Fn(&SummaryRow) -> bool) -> Vec<Line<'a>> {
    let counted_in =
        |s: &SummaryRow| !matches!(class(s, batch), Class::NotDefined | Class::Environment | Class::Trivial);
    let ran: Vec<&SummaryRow> = summaries.iter().filter(|s| counted_in(s)).collect();
    let mut out: Vec<Line> = unique(ran.iter().map(|s| (s.solver.as_str(), s.energy.as_str())))
        .into_iter()
        .map(|(solver, energy)| {
            let of = || ran.iter().filter(move |s| s.solver == solver && s.energy == energy);
            let mut reasons = counted(of().filter(|s| unsolved(s)).map(|s| why(s)));
            reasons.sort_by_key(|r| std::cmp::Reverse(r.1));
            Line { solver, energy, unsolved: reasons.iter().map(|r| r.1).sum(), ran: of().count(), reasons }
        })
        .filter(|l| l.unsolved > 0)
        .collect();
    out.sort_by_key(|l| std::cmp::Reverse(l.unsolved));
    out
}

/// `<h3>Not solved or failed per solver</h3>` with the news first and the expected failures
/// apart.
pub(super) fn rollup_section(h: &mut String, summaries: &[SummaryRow], batch: &Batch) {
    let news = lines(summaries, batch, |s| is_problem(s, batch));
    let expected = |s: &SummaryRow| class(s, batch) == Class::Expected && s.verdict != Some(Verdict::Solved);
    let known = lines(summaries, batch, expected);
    if news.is_empty() && known.is_empty() {
        return;
    }
    let (news, known): (Vec<&Line>, Vec<&Line>) = (news.iter().collect(), known.iter().collect());
    let runs = |ls: &[&Line]| ls.iter().map(|l| l.unsolved).sum::<usize>();
    let _ = writeln!(
        h,
        "<h3 id=\"rollup\">Not solved or failed per solver ({} run{} of {} solver-energy pair{})</h3>",
        runs(&news),
        if runs(&news) == 1 { "" } else { "s" },
        news.len(),
        if news.len() == 1 { "" } else { "s" }
    );
    if news.is_empty() {
        *h += "<p>None but those the config expects.</p>\n";
    } else {
        let item = |l: &&Line| format!("<li class=\"nc\">{}</li>\n", esc(&l.text()));
        let (first, rest) = news.split_at(news.len().min(PAIRS_SHOWN));
        *h += "<ul class=\"problems\">\n";
        h.extend(first.iter().map(item));
        *h += "</ul>\n";
        if !rest.is_empty() {
            let _ = writeln!(
                h,
                "<details><summary>{} more pair{}, {} runs</summary><ul class=\"problems\">",
                rest.len(),
                if rest.len() == 1 { "" } else { "s" },
                runs(rest)
            );
            h.extend(rest.iter().map(item));
            *h += "</ul></details>\n";
        }
    }
    if !known.is_empty() {
        let texts: Vec<String> = known.iter().map(|l| l.text()).collect();
        let _ = writeln!(
            h,
            "<p class=\"caption\">Expected to fail (the config's <code>expected_to_fail</code>), {} run{}: {}.</p>",
            runs(&known),
            if runs(&known) == 1 { "" } else { "s" },
            esc(&texts.join("; "))
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Task;
    use solvers::solver::StopReason;

    use crate::run_folder::RunStop;

    fn row(solver: &str, status: Status, stop: Option<StopReason>) -> SummaryRow {
        SummaryRow {
            dataset: "m".into(),
            task: Task::Param,
            energy: "sd".into(),
            solver: solver.into(),
            status,
            stop_reason: stop.map(RunStop::Solver),
            ..SummaryRow::default()
        }
    }

    fn expecting(solvers: &[&str]) -> Batch {
        Batch { expected_to_fail: solvers.iter().map(|s| s.to_string()).collect(), ..Batch::default() }
    }

    fn batch() -> Vec<SummaryRow> {
        let failed = || Some(StopReason::LinearSolveFailed("the system at iterate 0".into()));
        let mut rows = vec![row("kp-newton", Status::Ok, Some(StopReason::GradientTolerance)); 3];
        rows.extend([
            row("newton", Status::NotConverged, failed()),
            row("newton", Status::NotConverged, failed()),
            row("newton", Status::NotConverged, Some(StopReason::MaxIterations)),
            row("lbfgs", Status::NotConverged, Some(StopReason::MaxIterations)),
            row("lbfgs", Status::Ok, Some(StopReason::GradientTolerance)),
            row("lbfgs", Status::Failed, None),
            row("slim", Status::Skipped, Some(StopReason::MaxIterations)),
        ]);
        rows
    }

    /// "newton / sd: 3 of 3 unsolved (linear_solve_failed 2, max_iters 1)", the most unsolved
    /// first; solved and skipped runs count only in "of N" (skipped not even there).
    #[test]
    fn unsolved_runs_roll_up_per_solver_and_energy_with_their_stops() {
        let rows = batch();
        let none = expecting(&[]);
        let texts: Vec<String> = lines(&rows, &none, |s| is_problem(s, &none)).iter().map(Line::text).collect();
        assert_eq!(
            texts,
            [
                "newton / sd: 3 of 3 unsolved (linear_solve_failed 2, max_iters 1)",
                "lbfgs / sd: 2 of 3 unsolved (max_iters 1, error 1)"
            ]
        );
        assert_eq!(
            rows.iter().filter(|s| crate::report::select::broke_down(s)).count(),
            2,
            "the failed factorizations"
        );
    }

    /// A solver the config expects to fail is listed apart, and the heading counts the news.
    #[test]
    fn expected_failures_are_shown_apart_from_the_news() {
        let mut h = String::new();
        rollup_section(&mut h, &batch(), &expecting(&["newton"]));
        assert!(h.contains("Not solved or failed per solver (2 runs of 1 solver-energy pair)"), "{h}");
        let (news, known) = h.split_once("Expected to fail").unwrap();
        assert!(news.contains("lbfgs / sd") && !news.contains("newton"), "{h}");
        assert!(known.contains("3 runs: newton / sd: 3 of 3 unsolved"), "{h}");
        let mut none = String::new();
        rollup_section(&mut none, &batch()[..3], &expecting(&[]));
        assert!(none.is_empty(), "nothing unsolved, no section");
    }

    /// Past the first pairs the list folds away, counted.
    #[test]
    fn many_unsolved_pairs_fold_past_the_first_ones() {
        let rows: Vec<SummaryRow> = (0..PAIRS_SHOWN + 4)
            .map(|k| SummaryRow {
                solver: format!("s{k}"),
                ..row("x", Status::NotConverged, Some(StopReason::MaxIterations))
            })
            .collect();
        let mut h = String::new();
        rollup_section(&mut h, &rows, &expecting(&[]));
        let (shown, folded) = h.split_once("<details>").expect("the rest folded");
        assert_eq!(shown.matches("<li").count(), PAIRS_SHOWN);
        assert_eq!(folded.matches("<li").count(), 4);
        assert!(folded.starts_with("<summary>4 more pairs, 4 runs</summary>"), "{folded}");
    }
}
