//! The regression rules shared by `check` (a run folder against a baseline) and `compare`
//! (two run folders): what counts as a regression of one run, and when a time moved.
//!
//! - Iteration counts are deterministic: more iterations than before plus the tolerance is a
//!   regression, fewer an improvement. Three counts: to the run's end, to its own rule's first
//!   event (`rule_iters`: where the papers' protocol stops it) and to the tightest target
//!   (`target_iters`: the verdict's; not compared when `E*` moved).
//! - Status orders `skipped < failed < not_converged < budget < ok` ([`Status`]'s `Ord`): a worse status
//!   is a regression, and so is any run that becomes `failed`.
//! - The final energy may move by `energy_rtol` (relative); higher beyond it is a regression.
//!   A final energy that becomes NaN or infinite is a regression, one that stops being so an
//!   improvement ([`energy_change`]); a baseline keeps such a value as `"NaN"` / `"inf"`.
//! - Flips where there were none are a regression.
//! - A final gap to the reference minimum (`final_gap`, the harness's convergence test) that
//!   rises above the run's tightest target (default [`GAP_TARGET`]) is a regression, one that
//!   falls to it an improvement.
//! - When `E*` moved between the two (a batch lowered the reference), both are judged again
//!   against the lower one before anything is compared, and the move is reported, never as a
//!   regression of the solver; a side that cannot be judged again (a record without the
//!   yardstick's inputs) has its status and gap changes reported as "E* moved", not gated.
//! - Times are never a regression here: [`time_change`] only labels a time as slower or faster,
//!   when the spreads over the repeats are disjoint (the overlap rule of the report's rankings,
//!   [`Timed::overlaps`]) or, with a single sample, when the ratio exceeds [`SINGLE_SAMPLE_FACTOR`].

use crate::plan::Task;
use crate::run_folder::timed::Timed;
use crate::run_folder::{Status, SummaryRow};
use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};

/// The gap the gate holds a run to: the default tightest target of the convergence test.
pub const GAP_TARGET: f64 = 1e-6;

/// Default relative tolerance on the final energy.
pub const DEFAULT_ENERGY_RTOL: f64 = 1e-6;

/// With a single sample on either side there is no spread to compare: a time is flagged when
/// after / before exceeds this factor (or falls below its inverse). `asv compare`'s default
/// `--factor`.
pub const SINGLE_SAMPLE_FACTOR: f64 = 1.1;

/// What the rules compare of one run: the `summary.csv` columns that are gated (and, in a
/// baseline, its JSON record).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GatedRun {
    pub dataset: String,
    pub task: Task,
    pub energy: String,
    pub solver: String,
    pub iterations: Option<usize>,
    /// NaN and infinities are written as the strings `"NaN"`, `"inf"`, `"-inf"` (JSON has no
    /// such numbers, and `null` would read as "no energy").
    #[serde(default, with = "non_finite")]
    pub final_energy: Option<f64>,
    pub status: Status,
    pub flips: Option<usize>,
    /// Allowed increase of `iterations` before it counts as a regression (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iterations_tolerance: Option<usize>,
    /// Wall time of the run when the baseline was written; shown, never gated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_s: Option<f64>,
    /// The final gap to the reference minimum (`param`, `deform`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub final_gap: Option<f64>,
    /// The yardstick it was judged by: `E*`, the common start's energy, the energy's
    /// isometry value and the tightest target (what judging it again against another `E*`
    /// takes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ref_energy: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_energy: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ideal_energy: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<f64>,
    /// Iterations to the first of its own rules' events (`SummaryRow::rule_stop`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rule_iters: Option<usize>,
    /// Iterations to the tightest target, when it reached it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_iters: Option<usize>,
}

impl GatedRun {
    pub(crate) fn key(&self) -> (&str, Task, &str, &str) {
        (&self.dataset, self.task, &self.energy, &self.solver)
    }

    /// `dataset task energy solver`, how reports name a run.
    pub fn label(&self) -> String {
        format!("{} {} {} {}", self.dataset, self.task.as_str(), self.energy, self.solver)
    }
}

impl From<&SummaryRow> for GatedRun {
    fn from(row: &SummaryRow) -> GatedRun {
        GatedRun {
            dataset: row.dataset.clone(),
            task: row.task,
            energy: row.energy.clone(),
            solver: row.solver.clone(),
            iterations: row.iterations,
            final_energy: row.final_energy,
            status: row.status,
            flips: row.flips,
            iterations_tolerance: None,
            time_s: row.time_s,
            final_gap: row.final_gap,
            ref_energy: row.ref_energy,
            start_energy: row.start_energy,
            ideal_energy: row.ideal_energy,
            target: row.to_targets.last().map(|t| t.tau),
            rule_iters: row.rule_stop().map(|e| e.iters),
            target_iters: row.to_targets.last().and_then(|t| t.iters),
        }
    }
}

/// Whether two reference minima differ beyond round-off.
fn moved(a: f64, b: f64) -> bool {
    (a - b).abs() > 1e-11 * a.abs().max(b.abs()).max(1.0)
}

impl GatedRun {
    /// This run judged against `e_star` instead of its own reference: its final gap and, for
    /// a run the harness judged (it has a gap and ran), its status; `None` without what that
    /// takes (the yardstick's inputs).
    pub fn judged_against(&self, e_star: f64) -> Option<GatedRun> {
        // Only a judged run (it has a gap) is judged again.
        self.final_gap?;
        let e = self.final_energy?;
        let span = crate::convergence::span(self.start_energy?, e_star, self.ideal_energy?);
        let tau = self.target.unwrap_or(GAP_TARGET);
        let mut r = self.clone();
        r.final_gap = Some(crate::convergence::gap_on(e, e_star, span));
        r.ref_energy = Some(e_star);
        if self.status.ran() {
            let solved = self.flips == Some(0) && crate::convergence::passes(e, e_star, span, tau);
            // a fixed budget spent stays what it is unless the run is solved, as the judge says
            r.status = match self.status {
                _ if solved => Status::Ok,
                Status::Budget => Status::Budget,
                _ => Status::NotConverged,
            };
        }
        Some(r)
    }
}

/// One metric that moved.
#[derive(Clone, Debug, PartialEq)]
pub struct Change {
    pub run: String,
    pub metric: &'static str,
    pub before: String,
    pub after: String,
    pub delta: String,
    pub regression: bool,
}

/// A tolerance on the final energy the gate can use: non-negative and finite.
pub fn check_energy_rtol(energy_rtol: f64) -> Result<()> {
    if !(energy_rtol >= 0.0 && energy_rtol.is_finite()) {
        bail!("energy_rtol = {energy_rtol} must be non-negative and finite");
    }
    Ok(())
}

/// What moved from `before` to `after` (the same run), in the order status, iterations,
/// final energy, flips; `before.iterations_tolerance` (default 0) is the allowed increase of
/// iterations. Unchanged metrics give no entry.
pub fn changes(before: &GatedRun, after: &GatedRun, energy_rtol: f64) -> Vec<Change> {
    // E* moved: both judged against the lower one, or (without what that takes) the status
    // and gap changes reported but not gated.
    let (mut gated, mut rejudged) = (true, None);
    if let (Some(eb), Some(ea)) = (before.ref_energy, after.ref_energy) {
        if moved(eb, ea) {
            let low = eb.min(ea);
            match (before.judged_against(low), after.judged_against(low)) {
                (Some(b), Some(a)) => rejudged = Some((b, a)),
                _ => gated = false,
            }
        }
    }
    let (b, a) = match &rejudged {
        Some((b, a)) => (b, a),
        None => (before, after),
    };
    let mut out = Vec::new();
    let fmt_opt = |v: Option<usize>| v.map_or("-".to_string(), |x| x.to_string());
    let mut push = |metric, before: String, after: String, delta: String, regression| {
        out.push(Change { run: b.label(), metric, before, after, delta, regression })
    };
    if let Some((eb, ea)) = before.ref_energy.zip(after.ref_energy).filter(|_| rejudged.is_some() || !gated) {
        let how = if gated { "E* moved: both judged against the lower" } else { "E* moved: not judged again" };
        push("ref_energy", format!("{eb:.10}"), format!("{ea:.10}"), how.into(), false);
    }
    if a.status != b.status {
        // Status orders skipped < failed < not_converged < budget < ok: a pair that stops
        // being run is a regression, one that starts an improvement (unless it fails).
        let regression = a.status < b.status || a.status == Status::Failed;
        let judged_only = matches!(
            (b.status, a.status),
            (Status::Ok, Status::NotConverged | Status::Budget) | (Status::NotConverged | Status::Budget, Status::Ok)
        );
        let metric = if judged_only && !gated { "status (E* moved)" } else { "status" };
        push(metric, b.status.to_string(), a.status.to_string(), String::new(), regression && (gated || !judged_only));
    }
    let tol = b.iterations_tolerance.unwrap_or(0);
    let mut counts = vec![("iterations", b.iterations, a.iterations), ("rule_iters", b.rule_iters, a.rule_iters)];
    if rejudged.is_none() && gated {
        counts.push(("target_iters", b.target_iters, a.target_iters));
    }
    for (metric, bi, ai) in counts {
        if let Some((before, after, delta, regression)) = count_change(bi, ai, tol) {
            push(metric, before, after, delta, regression);
        }
    }
    if let (Some(be), Some(ae)) = (b.final_energy, a.final_energy) {
        if let Some((delta, regression)) = energy_change(be, ae, energy_rtol) {
            push("final_energy", format!("{be:.10}"), format!("{ae:.10}"), delta, regression);
        }
    }
    if let (Some(bg), Some(ag)) = (b.final_gap, a.final_gap) {
        let tau = a.target.or(b.target).unwrap_or(GAP_TARGET);
        let (was, is) = (bg <= tau, ag <= tau);
        if was != is {
            let metric = if gated { "final_gap" } else { "final_gap (E* moved)" };
            push(metric, format!("{bg:.2e}"), format!("{ag:.2e}"), format!("target {tau:e}"), was && gated);
        }
    }
    if b.flips == Some(0) && a.flips.unwrap_or(0) > 0 {
        push("flips", "0".into(), fmt_opt(a.flips), String::new(), true);
    }
    out
}

/// Whether an iteration count moved from `before` to `after`: more than `tol` up is a
/// regression, down an improvement; a count that disappears is a regression, one that
/// appears an improvement (a run that reaches its target, or whose rule now holds).
fn count_change(before: Option<usize>, after: Option<usize>, tol: usize) -> Option<(String, String, String, bool)> {
    let text = |v: Option<usize>| v.map_or("-".to_string(), |x| x.to_string());
    match (before, after) {
        (Some(bi), Some(ai)) if ai != bi => {
            // Counts and tolerances come from the files: no overflow on huge ones.
            let delta = format!("{:+}", ai as i128 - bi as i128);
            if ai > bi.saturating_add(tol) {
                Some((bi.to_string(), ai.to_string(), delta, true))
            } else if ai < bi {
                Some((bi.to_string(), ai.to_string(), delta, false))
            } else {
                None
            }
        }
        (bi, ai) if bi.is_some() != ai.is_some() => Some((text(bi), text(ai), String::new(), ai.is_none())),
        _ => None,
    }
}

/// Whether a final energy moved from `before` to `after`: `None` when not, else the delta's
/// text and whether it is a regression. Finite values move beyond `energy_rtol` (relative),
/// higher being a regression; a value that becomes NaN or infinite is a regression, one that
/// stops being so an improvement, and two non-finite values are no change. The one rule of
/// `check` and `compare`.
pub fn energy_change(before: f64, after: f64, energy_rtol: f64) -> Option<(String, bool)> {
    match (before.is_finite(), after.is_finite()) {
        (true, true) => {
            let rel = (after - before) / before.abs().max(1e-300);
            (rel.abs() > energy_rtol).then(|| (format!("{rel:+.2e} rel"), after > before))
        }
        (true, false) => Some(("not finite".into(), true)),
        (false, true) => Some(("finite again".into(), false)),
        (false, false) => None,
    }
}

/// `final_energy` in a baseline: a number, `null`, or `"NaN"`, `"inf"`, `"-inf"`.
mod non_finite {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(x) if x.is_nan() => s.serialize_str("NaN"),
            Some(x) if x.is_infinite() => s.serialize_str(if *x > 0.0 { "inf" } else { "-inf" }),
            Some(x) => s.serialize_f64(*x),
            None => s.serialize_none(),
        }
    }

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Value {
        Number(f64),
        Text(String),
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
        match Option::<Value>::deserialize(d)? {
            None => Ok(None),
            Some(Value::Number(x)) => Ok(Some(x)),
            Some(Value::Text(t)) => match t.as_str() {
                "NaN" => Ok(Some(f64::NAN)),
                "inf" => Ok(Some(f64::INFINITY)),
                "-inf" => Ok(Some(f64::NEG_INFINITY)),
                other => Err(serde::de::Error::custom(format!(
                    "final_energy \"{other}\" is not a number (text is only \"NaN\", \"inf\" or \"-inf\")"
                ))),
            },
        }
    }
}

/// A time that moved beyond the noise.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeChange {
    Slower,
    Faster,
}

impl TimeChange {
    pub fn as_str(&self) -> &'static str {
        match self {
            TimeChange::Slower => "slower",
            TimeChange::Faster => "faster",
        }
    }
}

/// Whether a run's time moved beyond its noise from `before` to `after` (each a median with
/// its min–max over the repeats). With spreads on both sides: only when the intervals do not
/// overlap (touching intervals share a point and do not count). With a single sample on
/// either side: when the ratio exceeds [`SINGLE_SAMPLE_FACTOR`] either way. Non-finite or
/// non-positive times never count.
pub fn time_change(before: &Timed, after: &Timed) -> Option<TimeChange> {
    let (b, a) = (before.value, after.value);
    if !(b.is_finite() && a.is_finite() && b > 0.0 && a > 0.0) {
        return None;
    }
    let moved = if before.single_sample() || after.single_sample() {
        let ratio = a / b;
        !(1.0 / SINGLE_SAMPLE_FACTOR..=SINGLE_SAMPLE_FACTOR).contains(&ratio)
    } else {
        !before.overlaps(after)
    };
    match moved {
        false => None,
        true if a > b => Some(TimeChange::Slower),
        true => Some(TimeChange::Faster),
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    fn rec(it: usize, e: f64) -> GatedRun {
        record("kp-newton", it, e)
    }

    /// A converged `param` SD run of `solver` on dataset `d` (the gate's tests' fixture).
    pub(crate) fn record(solver: &str, it: usize, e: f64) -> GatedRun {
        GatedRun {
            dataset: "d".into(),
            task: Task::Param,
            energy: "sd".into(),
            solver: solver.into(),
            iterations: Some(it),
            final_energy: Some(e),
            status: Status::Ok,
            flips: Some(0),
            iterations_tolerance: None,
            time_s: Some(1.0),
            final_gap: None,
            ref_energy: None,
            start_energy: None,
            ideal_energy: None,
            target: None,
            rule_iters: None,
            target_iters: None,
        }
    }

    fn metrics(c: &[Change]) -> Vec<(&str, bool)> {
        c.iter().map(|c| (c.metric, c.regression)).collect()
    }

    #[test]
    fn each_rule_in_its_order() {
        assert!(changes(&rec(10, 2.0), &rec(10, 2.0), 1e-6).is_empty());
        // All four at once, in the order status, iterations, energy, flips.
        let worse = GatedRun { status: Status::NotConverged, flips: Some(2), ..rec(12, 2.1) };
        let c = changes(&rec(10, 2.0), &worse, 1e-6);
        assert_eq!(metrics(&c), [("status", true), ("iterations", true), ("final_energy", true), ("flips", true)]);
        assert_eq!((c[1].before.as_str(), c[1].after.as_str(), c[1].delta.as_str()), ("10", "12", "+2"));
        assert_eq!(c[0].run, "d param sd kp-newton");
        // Improvements are changes, not regressions.
        let c = changes(&rec(10, 2.0), &rec(8, 1.9), 1e-6);
        assert_eq!(metrics(&c), [("iterations", false), ("final_energy", false)]);
    }

    /// The iterations to the run's own rule's event and to the target are gated like those to
    /// its end: a run whose rule now holds later, or that needs more to reach the target, is a
    /// regression even when it ends where it did; one that no longer reaches it too.
    #[test]
    fn the_rule_s_event_and_the_target_are_gated_as_iterations() {
        let at = |rule: Option<usize>, target: Option<usize>| GatedRun {
            rule_iters: rule,
            target_iters: target,
            ..rec(40, 2.0)
        };
        assert!(changes(&at(Some(8), Some(30)), &at(Some(8), Some(30)), 1e-6).is_empty());
        let c = changes(&at(Some(8), Some(30)), &at(Some(12), Some(25)), 1e-6);
        assert_eq!(metrics(&c), [("rule_iters", true), ("target_iters", false)]);
        assert_eq!((c[0].before.as_str(), c[0].after.as_str(), c[0].delta.as_str()), ("8", "12", "+4"));
        let c = changes(&at(Some(8), Some(30)), &at(Some(8), None), 1e-6);
        assert_eq!(metrics(&c), [("target_iters", true)]);
        let c = changes(&at(None, None), &at(Some(8), Some(30)), 1e-6);
        assert_eq!(metrics(&c), [("rule_iters", false), ("target_iters", false)]);
        // within the tolerance
        let tolerant = GatedRun { iterations_tolerance: Some(5), ..at(Some(8), Some(30)) };
        assert!(changes(&tolerant, &at(Some(12), Some(34)), 1e-6).is_empty());
    }

    #[test]
    fn tolerances_bound_what_counts() {
        let tolerant = GatedRun { iterations_tolerance: Some(2), ..rec(10, 2.0) };
        assert!(changes(&tolerant, &rec(12, 2.0), 1e-6).is_empty());
        assert_eq!(metrics(&changes(&tolerant, &rec(13, 2.0), 1e-6)), [("iterations", true)]);
        // energy: relative, both ways
        assert!(changes(&rec(10, 2.0), &rec(10, 2.0 * (1.0 + 0.9e-3)), 1e-3).is_empty());
        assert_eq!(metrics(&changes(&rec(10, 2.0), &rec(10, 2.0 * (1.0 + 1.1e-3)), 1e-3)), [("final_energy", true)]);
        assert_eq!(metrics(&changes(&rec(10, 2.0), &rec(10, f64::NAN), 1.0)), [("final_energy", true)]);
    }

    #[test]
    fn a_final_gap_that_rises_above_the_target_is_a_regression() {
        let gap = |g| GatedRun { final_gap: Some(g), ..rec(10, 2.0) };
        assert_eq!(metrics(&changes(&gap(1e-9), &gap(1e-4), 1e-6)), [("final_gap", true)]);
        assert_eq!(metrics(&changes(&gap(1e-4), &gap(1e-9), 1e-6)), [("final_gap", false)]);
        // within the target, or above it, both times: no change
        assert!(changes(&gap(1e-9), &gap(1e-7), 1e-6).is_empty());
        assert!(changes(&gap(1e-3), &gap(1e-2), 1e-6).is_empty());
        // an old baseline without gaps: not compared
        assert!(changes(&rec(10, 2.0), &gap(1.0), 1e-6).is_empty());
        let c = changes(&gap(1e-9), &gap(f64::INFINITY), 1e-6);
        assert_eq!(metrics(&c), [("final_gap", true)]);
    }

    /// `E*` moved between two batches (the second lowered it): both are judged against the
    /// lower one before anything is compared, and the move is listed, never a regression. The
    /// same final energy is then the same verdict; a record without the yardstick's inputs has
    /// its status change listed as "E* moved", not gated.
    #[test]
    fn when_e_star_moved_both_sides_are_judged_against_the_lower() {
        // E0 = 10, E_iso = 2: E* = 3 gives the span 1, E* = 2.9 the span 0.9
        let judged = |e: f64, e_star: f64, status: Status| GatedRun {
            status,
            final_energy: Some(e),
            ref_energy: Some(e_star),
            start_energy: Some(10.0),
            ideal_energy: Some(2.0),
            target: Some(1e-6),
            final_gap: Some((e - e_star) / (e_star - 2.0)),
            ..rec(10, e)
        };
        // the same run, judged solved against 3.0 then not against 2.9: not the solver's doing
        let c = changes(&judged(3.0, 3.0, Status::Ok), &judged(3.0, 2.9, Status::NotConverged), 1e-6);
        assert_eq!(metrics(&c), [("ref_energy", false)]);
        assert!(c[0].delta.contains("judged against the lower"), "{c:?}");
        // a run that really got worse is still a regression against the lower E*
        let c = changes(&judged(2.9, 3.0, Status::Ok), &judged(3.0, 2.9, Status::NotConverged), 1e-6);
        assert_eq!(metrics(&c), [("ref_energy", false), ("status", true), ("final_energy", true), ("final_gap", true)]);
        // the baseline without the yardstick: listed, not gated
        let bare = GatedRun { start_energy: None, ..judged(3.0, 3.0, Status::Ok) };
        let c = changes(&bare, &judged(3.0, 2.9, Status::NotConverged), 1e-6);
        assert_eq!(metrics(&c), [("ref_energy", false), ("status (E* moved)", false), ("final_gap (E* moved)", false)]);
        // E* the same to round-off: compared as before
        let c = changes(&judged(3.0, 3.0, Status::Ok), &judged(3.0, 3.0 + 1e-13, Status::Ok), 1e-6);
        assert!(c.is_empty(), "{c:?}");
        // judged again: the gap on the lower E*'s span
        let r = judged(3.0, 3.0, Status::Ok).judged_against(2.9).unwrap();
        assert!((r.final_gap.unwrap() - 0.1 / 0.9).abs() < 1e-12 && r.status == Status::NotConverged);
        // a fixed budget spent stays so when judged again unsolved, and a budget run that E*
        // moved from solved is the yardstick's doing, not a regression
        let r = judged(3.1, 3.0, Status::Budget).judged_against(2.9).unwrap();
        assert_eq!(r.status, Status::Budget);
        let bare = GatedRun { start_energy: None, ..judged(3.0, 3.0, Status::Ok) };
        let c = changes(&bare, &judged(3.0, 2.9, Status::Budget), 1e-6);
        assert!(metrics(&c).contains(&("status (E* moved)", false)), "{c:?}");
    }

    #[test]
    fn non_finite_energies_one_rule_both_ways() {
        let nan = f64::NAN;
        assert_eq!(energy_change(2.0, nan, 1e-6), Some(("not finite".into(), true)));
        assert_eq!(energy_change(2.0, f64::INFINITY, 1e-6), Some(("not finite".into(), true)));
        assert_eq!(energy_change(nan, 2.0, 1e-6), Some(("finite again".into(), false)));
        assert_eq!(energy_change(f64::NEG_INFINITY, 2.0, 1e-6), Some(("finite again".into(), false)));
        assert_eq!(energy_change(nan, nan, 1e-6), None);
        assert_eq!(energy_change(nan, f64::INFINITY, 1e-6), None);
        assert_eq!(energy_change(2.0, 2.0 * (1.0 + 1e-7), 1e-6), None);
        assert_eq!(energy_change(2.0, 2.1, 1e-6).map(|c| c.1), Some(true));
        assert_eq!(energy_change(2.0, 1.9, 1e-6).map(|c| c.1), Some(false));
    }

    #[test]
    fn a_baseline_keeps_non_finite_energies() {
        for e in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 2.5] {
            let r = GatedRun { final_energy: Some(e), ..rec(3, 0.0) };
            let json = serde_json::to_string(&r).unwrap();
            let back: GatedRun = serde_json::from_str(&json).unwrap();
            assert_eq!(back.final_energy.map(f64::to_bits), Some(e.to_bits()), "{json}");
        }
        let none = GatedRun { final_energy: None, ..rec(3, 0.0) };
        let back: GatedRun = serde_json::from_str(&serde_json::to_string(&none).unwrap()).unwrap();
        assert_eq!(back.final_energy, None);
        let bad = serde_json::to_string(&rec(3, 1.0)).unwrap().replace("1.0", "\"one\"");
        let e = serde_json::from_str::<GatedRun>(&bad).unwrap_err().to_string();
        assert!(e.contains("final_energy \"one\" is not a number"), "{e}");
    }

    #[test]
    fn status_order_and_new_failures() {
        let with = |s| GatedRun { status: s, ..rec(10, 2.0) };
        for (b, a, regression) in [
            (Status::Ok, Status::NotConverged, true),
            (Status::NotConverged, Status::Ok, false),
            (Status::NotConverged, Status::Failed, true),
            (Status::Skipped, Status::Failed, true),
            (Status::Skipped, Status::Ok, false),
            (Status::Ok, Status::Skipped, true),
        ] {
            assert_eq!(metrics(&changes(&with(b), &with(a), 1e-6)), [("status", regression)], "{b} -> {a}");
        }
    }

    #[test]
    fn energy_rtol_must_be_usable() {
        assert!(check_energy_rtol(0.0).is_ok() && check_energy_rtol(1e-6).is_ok());
        for bad in [-1.0, f64::NAN, f64::INFINITY] {
            let e = check_energy_rtol(bad).unwrap_err().to_string();
            assert!(e.contains("must be non-negative and finite"), "{e}");
        }
    }

    fn spread(value: f64, lo: f64, hi: f64) -> Timed {
        Timed { value, lo, hi, samples: 3 }
    }

    fn single(value: f64) -> Timed {
        Timed { value, lo: value, hi: value, samples: 1 }
    }

    #[test]
    fn times_move_only_outside_their_spreads() {
        let before = spread(1.0, 0.9, 1.1);
        // 1.5x slower but the spreads overlap: noise, not a change.
        assert_eq!(time_change(&before, &spread(1.5, 1.1, 2.0)), None);
        assert_eq!(time_change(&before, &spread(1.15, 1.11, 1.3)), Some(TimeChange::Slower));
        assert_eq!(time_change(&before, &spread(0.8, 0.7, 0.85)), Some(TimeChange::Faster));
        // Disjoint spreads count even when the ratio is under asv's factor.
        assert_eq!(time_change(&spread(1.0, 0.99, 1.01), &spread(1.05, 1.04, 1.06)), Some(TimeChange::Slower));
    }

    #[test]
    fn single_samples_move_beyond_asvs_factor() {
        assert_eq!(time_change(&single(1.0), &single(1.09)), None);
        assert_eq!(time_change(&single(1.0), &single(1.11)), Some(TimeChange::Slower));
        assert_eq!(time_change(&single(1.0), &single(1.0 / 1.09)), None);
        assert_eq!(time_change(&single(1.0), &single(1.0 / 1.11)), Some(TimeChange::Faster));
        // One side single: the factor rule, whatever the other's spread says.
        assert_eq!(time_change(&spread(1.0, 0.99, 1.01), &single(1.05)), None);
        assert_eq!(time_change(&single(1.0), &spread(1.2, 1.0, 1.3)), Some(TimeChange::Slower));
        // Not measurements: never flagged.
        assert_eq!(time_change(&single(0.0), &single(1.0)), None);
        assert_eq!(time_change(&single(1.0), &single(f64::NAN)), None);
    }
}
