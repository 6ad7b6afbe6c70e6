//! The targets the runs were judged at, as the report reads them: the rows as ranked to the
//! tightest target ([`to_target`]), and the target and the verdicts in words.

use crate::judge::verdict::Verdict;
use crate::run_folder::summary::ToTarget;
use crate::run_folder::SummaryRow;

/// The tightest target of a judged run (`param`, `deform`) when it reached it: its iterations
/// and time there. `None` for a run that did not, and for runs the harness does not judge
/// (`authalic`, folders from before the verdicts).
pub fn reached_target(r: &SummaryRow) -> Option<ToTarget> {
    r.to_targets.last().filter(|t| t.iters.is_some() && t.time_s.is_some()).copied()
}

/// The row as every table, aggregate and profile ranks it: a judged run that
/// reached its tightest target counts the iterations and time to it, not to its own stop; the
/// time's min–max over the repeats, `time_norm` and `ms_per_vertex` scale by the same ratio
/// `time_to / time_s`. Any other run counts as it ran (an unsolved run enters the means at the
/// cap anyway). Names and statuses are unchanged, so files are found as before.
pub fn to_target(r: &SummaryRow) -> SummaryRow {
    let Some(ToTarget { iters: Some(iters), time_s: Some(to), .. }) = reached_target(r) else { return r.clone() };
    // time_to <= time_s; a run of no measurable time reached it in no time.
    let k = r.time_s.filter(|t| *t > 0.0).map_or(0.0, |t| to / t);
    let scale = |v: Option<f64>| v.map(|v| v * k);
    SummaryRow {
        iterations: Some(iters),
        time_s: Some(to),
        time_s_min: scale(r.time_s_min),
        time_s_max: scale(r.time_s_max),
        time_norm: scale(r.time_norm),
        ms_per_vertex: scale(r.ms_per_vertex),
        ..r.clone()
    }
}

/// [`to_target`] of every row.
pub fn at_target(summary: &[SummaryRow]) -> Vec<SummaryRow> {
    summary.iter().map(to_target).collect()
}

/// The tightest target the runs were judged at (`1e-6` by default), `None` when no run was
/// judged.
pub fn tightest_target<'a>(rows: impl IntoIterator<Item = &'a SummaryRow>) -> Option<f64> {
    rows.into_iter().filter_map(|r| r.to_targets.last()).map(|t| t.tau).reduce(f64::min)
}

/// A target as the columns name it: `1e-6`.
pub fn tau_text(tau: f64) -> String {
    format!("{tau:e}")
}

/// The caption sentence of a table that counts iterations and time of judged runs: what they
/// are counted to. Empty when no run was judged (the solvers' own stops then).
pub fn target_rule<'a>(rows: impl IntoIterator<Item = &'a SummaryRow>) -> String {
    let Some(tau) = tightest_target(rows) else { return String::new() };
    let t = tau_text(tau);
    format!(
        "Iterations and times are to the {t} target (the harness's convergence test: the first iteration \
         with E − E* ≤ {t} × span, E* the reference minimum, the span min(E0 − E*, A) with A = max(E* − E_iso, \
         10⁻⁴ max(1, |E_iso|))), not to where the solver's stop rules held; ok = solved (reached {t} with no \
         flipped triangle, the harness's verdict); a run that did not reach it counts as it ran, to its end."
    )
}

/// A verdict in the report's words (`stopped above target`).
pub fn verdict_text(v: Verdict) -> &'static str {
    match v {
        Verdict::Solved => "solved",
        Verdict::Flipped => "flipped",
        Verdict::StoppedAboveTarget => "stopped above target",
        Verdict::OtherMinimum => "other minimum",
        Verdict::Stalled => "stalled",
        Verdict::BrokeDown => "broke down",
        Verdict::Unfinished => "out of budget",
    }
}
