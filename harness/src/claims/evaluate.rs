//! A claim decided over one run folder's rows, by the paper's rule and by the verdict's.

use super::spec::{Check, Claim, Quantity};
use crate::names::run_stem;
use crate::run_folder::SummaryRow;
use serde::Serialize;
use std::collections::BTreeMap;

/// How a run's cost is counted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Rule {
    /// The paper's: each run to its own stop (the config's `[stop]`, the papers' gradient or
    /// energy-decrease rule and iteration cap), an unconverged run at its cap: a run that went
    /// on to its target read at its rule's event.
    Paper,
    /// The harness's: iterations and time to the tightest target of the convergence test
    /// against the certified `E*`; a run that never reached it costs infinitely much.
    Verdict,
}

impl Rule {
    pub fn as_str(self) -> &'static str {
        match self {
            Rule::Paper => "paper's rule",
            Rule::Verdict => "verdict",
        }
    }

    /// As JSON and the history write it.
    pub fn key(self) -> &'static str {
        match self {
            Rule::Paper => "paper",
            Rule::Verdict => "verdict",
        }
    }

    pub fn from_key(key: &str) -> Option<Rule> {
        [Rule::Paper, Rule::Verdict].into_iter().find(|r| r.key() == key)
    }
}

/// What a claim came to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ClaimOutcome {
    Held,
    NotHeld,
    /// The folder cannot answer it (`why` says what is missing).
    NotMeasurable,
}

impl ClaimOutcome {
    pub fn as_str(self) -> &'static str {
        match self {
            ClaimOutcome::Held => "held",
            ClaimOutcome::NotHeld => "not held",
            ClaimOutcome::NotMeasurable => "not measurable",
        }
    }

    /// As JSON and the history write it.
    pub fn key(self) -> &'static str {
        match self {
            ClaimOutcome::Held => "held",
            ClaimOutcome::NotHeld => "not_held",
            ClaimOutcome::NotMeasurable => "not_measurable",
        }
    }

    pub fn from_key(key: &str) -> Option<ClaimOutcome> {
        [ClaimOutcome::Held, ClaimOutcome::NotHeld, ClaimOutcome::NotMeasurable].into_iter().find(|o| o.key() == key)
    }
}

/// A claim under one rule.
#[derive(Clone, Debug, Serialize)]
pub struct Judged {
    pub rule: Rule,
    pub outcome: ClaimOutcome,
    /// The comparison in words, or what is missing.
    pub why: String,
    /// Our number per solver: the mean over `datasets` (the one mesh's for `value`), by the
    /// verdict over the meshes where it reached the target (infinite when it reached it on none).
    pub ours: BTreeMap<String, f64>,
    /// By the verdict, per solver, the meshes where it never reached the target.
    pub unreached: BTreeMap<String, usize>,
    /// The meshes it was decided on.
    pub datasets: Vec<String>,
    /// The runs it read (`runs/<stem>.csv`).
    pub runs: Vec<String>,
}

/// `solver`'s number on one mesh under `rule`; `None` when the run has none (failed, skipped,
/// not judged, or a metric it does not measure). Infinite when, by the verdict, it never
/// reached the target.
pub fn run_value(metric: Quantity, rule: Rule, r: &SummaryRow) -> Option<f64> {
    if !r.status.ran() {
        return None;
    }
    if rule == Rule::Verdict && metric.has_target_variant() {
        let t = r.to_targets.last()?;
        let (Some(iters), Some(to)) = (t.iters, t.time_s) else { return Some(f64::INFINITY) };
        return match metric {
            Quantity::Iterations => Some(iters as f64),
            Quantity::TimeS => Some(to),
            _ => {
                let k = r.time_s.filter(|t| *t > 0.0).map_or(0.0, |t| to / t);
                r.ms_per_vertex.map(|v| v * k)
            }
        };
    }
    // By the paper's rule, a run that went on past its rule reads at the rule's event: the
    // rows there are those of the run the rule ends (a run no rule held in ended as it would).
    let stop = r.rule_stop();
    let k = match (stop.and_then(|e| e.time_s), r.time_s.filter(|t| *t > 0.0)) {
        (Some(at), Some(t)) => at / t,
        _ => 1.0,
    };
    match metric {
        Quantity::Iterations => stop.map_or(r.iterations, |e| Some(e.iters)).map(|i| i as f64),
        Quantity::MsPerVertex => r.ms_per_vertex.map(|v| v * k),
        Quantity::TimeS => stop.map_or(r.time_s, |e| e.time_s),
        Quantity::FinalEnergy => stop.map_or(r.final_energy, |e| e.energy),
        Quantity::ProjectMs => r.project_ms_median,
        Quantity::ProjectSolveRatio => {
            r.project_ms_median.zip(r.solve_ms_median.filter(|s| *s > 0.0)).map(|(p, s)| p / s)
        }
        Quantity::AuthalicEnergy => r.authalic_energy,
        Quantity::AreaRatioSd => r.area_ratio_sd,
        Quantity::Folded => r.folded.map(|f| f as f64),
    }
    .filter(|v| !v.is_nan())
}

/// The numbers of a claim's solvers per mesh, on the meshes where each of them has one.
struct Table {
    /// (dataset, vertices, one number per solver in `Claim::solvers` order).
    meshes: Vec<(String, usize, Vec<f64>)>,
    left_out: Vec<String>,
    runs: Vec<String>,
}

fn table(claim: &Claim, rule: Rule, rows: &[SummaryRow]) -> Table {
    let solvers = claim.solvers();
    let rows: Vec<&SummaryRow> = rows.iter().filter(|r| r.energy == claim.energy).collect();
    let mut datasets: Vec<&str> = Vec::new();
    for r in &rows {
        if !datasets.contains(&r.dataset.as_str()) {
            datasets.push(&r.dataset);
        }
    }
    let mut out = Table { meshes: Vec::new(), left_out: Vec::new(), runs: Vec::new() };
    for d in datasets {
        if claim.dataset.as_deref().is_some_and(|want| want != d) {
            continue;
        }
        let find = |s: &str| rows.iter().find(|r| r.dataset == d && r.solver == s);
        let vertices = rows.iter().filter(|r| r.dataset == d).find_map(|r| r.vertices).unwrap_or(0);
        if claim.min_vertices.is_some_and(|m| vertices < m) {
            continue;
        }
        let values: Vec<Option<f64>> =
            solvers.iter().map(|s| find(s).and_then(|r| run_value(claim.metric, rule, r))).collect();
        if let Some(i) = values.iter().position(Option::is_none) {
            let why = find(solvers[i]).map_or("no run", |r| r.status.as_str());
            out.left_out.push(format!("{d} ({} {why})", solvers[i]));
            continue;
        }
        out.runs.extend(solvers.iter().map(|s| run_stem(d, &claim.energy, s)));
        out.meshes.push((d.to_string(), vertices, values.into_iter().flatten().collect()));
    }
    out
}

/// `claim` decided by `rule` over one folder's rows.
pub fn judge(claim: &Claim, rule: Rule, rows: &[SummaryRow]) -> Judged {
    let t = table(claim, rule, rows);
    let solvers = claim.solvers();
    let n = t.meshes.len();
    let ours: BTreeMap<String, f64> = if n == 0 {
        BTreeMap::new()
    } else {
        solvers.iter().enumerate().map(|(k, s)| (s.to_string(), t.mean(k))).collect()
    };
    let unreached = solvers.iter().enumerate().map(|(k, s)| (s.to_string(), t.unreached(k))).collect();
    let mut judged = Judged {
        rule,
        outcome: ClaimOutcome::NotMeasurable,
        why: String::new(),
        ours,
        unreached,
        datasets: t.meshes.iter().map(|m| m.0.clone()).collect(),
        runs: t.runs.clone(),
    };
    let left = if t.left_out.is_empty() { String::new() } else { format!("; left out: {}", t.left_out.join(", ")) };
    if n == 0 {
        let which = match (&claim.dataset, claim.min_vertices) {
            (Some(d), _) => format!(" ({d})"),
            (None, Some(v)) => format!(" of at least {v} vertices"),
            (None, None) => String::new(),
        };
        judged.why =
            format!("no mesh of {}{which} where {} each have a number{left}", claim.energy, solvers.join(", "));
        return judged;
    }
    let (outcome, why) = decide(claim, &t);
    judged.outcome = outcome;
    judged.why = format!("{why} (over {n} mesh{}{left})", if n == 1 { "" } else { "es" });
    judged
}

impl Table {
    /// Solver `k`'s mean over the meshes where it has a finite number (infinite: none).
    fn mean(&self, k: usize) -> f64 {
        let v: Vec<f64> = self.meshes.iter().map(|m| m.2[k]).filter(|v| v.is_finite()).collect();
        if v.is_empty() {
            f64::INFINITY
        } else {
            v.iter().sum::<f64>() / v.len() as f64
        }
    }

    /// The meshes where solver `k` never reached the target (by the verdict).
    fn unreached(&self, k: usize) -> usize {
        self.meshes.iter().filter(|m| m.2[k].is_infinite()).count()
    }

    /// Whether solver `i` costs less than `j`: fewer meshes where it never reached the target,
    /// else the lower mean over the meshes both reached it on; `None` when they never reached
    /// it on the same meshes and share no mesh where both did. By the paper's rule (no
    /// infinite cost) this is the lower mean.
    fn below(&self, i: usize, j: usize) -> Option<bool> {
        let (ui, uj) = (self.unreached(i), self.unreached(j));
        if ui != uj {
            return Some(ui < uj);
        }
        let (a, b) = self.common_means(i, j)?;
        Some(a < b)
    }

    /// The means of solvers `i` and `j` over the meshes where both have finite numbers.
    fn common_means(&self, i: usize, j: usize) -> Option<(f64, f64)> {
        let both: Vec<(f64, f64)> =
            self.meshes.iter().map(|m| (m.2[i], m.2[j])).filter(|(a, b)| a.is_finite() && b.is_finite()).collect();
        if both.is_empty() {
            return None;
        }
        let n = both.len() as f64;
        Some((both.iter().map(|x| x.0).sum::<f64>() / n, both.iter().map(|x| x.1).sum::<f64>() / n))
    }
}

/// Whether `a < b` can be said of one mesh: not when both are infinite (neither reached the target).
fn below(a: f64, b: f64) -> Option<bool> {
    if a.is_infinite() && b.is_infinite() {
        None
    } else {
        Some(a < b)
    }
}

/// A number as the claims show it: 6 significant digits without trailing zeros (final
/// energies differ in the fifth decimal), integers as integers.
pub fn fmt(v: f64) -> String {
    if v.is_infinite() {
        return "never at the target".into();
    }
    if v.fract() == 0.0 && v.abs() < 1e9 {
        return format!("{v:.0}");
    }
    let s = crate::run_folder::timed::significant(v, 6);
    match s.split_once('e') {
        Some((m, e)) if m.contains('.') => format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.')),
        None if s.contains('.') => s.trim_end_matches('0').trim_end_matches('.').to_string(),
        _ => s,
    }
}

type Decided = (ClaimOutcome, String);

fn decided(held: bool, text: String) -> Decided {
    (if held { ClaimOutcome::Held } else { ClaimOutcome::NotHeld }, text)
}

fn unreached(x: &str, y: &str) -> Decided {
    (
        ClaimOutcome::NotMeasurable,
        format!("{x} and {y} both never reached the target on some mesh: they cannot be ordered"),
    )
}

fn decide(claim: &Claim, t: &Table) -> Decided {
    match claim.check {
        Check::Fewest | Check::Less | Check::Most => compared(claim, t),
        Check::Within => within(claim, t),
        Check::Order => order(claim, t),
        Check::EachLess | Check::EachEqual => each(claim, t),
        Check::EachAtMost => each_at_most(claim, t),
        Check::Value => value(claim, t),
        Check::FallsWithSize => falls_with_size(claim, t),
    }
}

/// `mean iterations: kp-newton 7.5, cm 8 (never at the target on 2 meshes)`.
fn means(claim: &Claim, t: &Table) -> String {
    let listing: Vec<String> = claim
        .solvers()
        .iter()
        .enumerate()
        .map(|(k, o)| match t.unreached(k) {
            0 => format!("{o} {}", fmt(t.mean(k))),
            u if u == t.meshes.len() => format!("{o} never at the target"),
            u => format!("{o} {} (never at the target on {u})", fmt(t.mean(k))),
        })
        .collect();
    format!("mean {}: {}", claim.metric.as_str(), listing.join(", "))
}

/// `fewest`, `less` (below each other) and `most` (above each other).
fn compared(claim: &Claim, t: &Table) -> Decided {
    let mut held = true;
    for (i, o) in claim.others.iter().enumerate() {
        let pair = if claim.check == Check::Most { t.below(i + 1, 0) } else { t.below(0, i + 1) };
        match pair {
            Some(h) => held &= h,
            None => return unreached(&claim.solver, o),
        }
    }
    decided(held, means(claim, t))
}

fn within(claim: &Claim, t: &Table) -> Decided {
    let s = claim.solver.as_str();
    let tol = claim.tolerance.unwrap_or(0.0);
    let mut worst: f64 = 0.0;
    for (i, o) in claim.others.iter().enumerate() {
        if t.unreached(0) != t.unreached(i + 1) {
            return decided(
                false,
                format!("{s} and {o} never reached the target on different meshes: {}", means(claim, t)),
            );
        }
        match t.common_means(0, i + 1) {
            Some((a, b)) => worst = worst.max((a / b - 1.0).abs()),
            None => return unreached(s, o),
        }
    }
    let text = format!("{}; largest difference {:.1}% (at most {:.0}%)", means(claim, t), 100.0 * worst, 100.0 * tol);
    decided(worst <= tol, text)
}

fn order(claim: &Claim, t: &Table) -> Decided {
    let solvers = claim.solvers();
    let mut held = true;
    for k in 1..solvers.len() {
        match t.below(k - 1, k) {
            Some(h) => held &= h,
            None => return unreached(solvers[k - 1], solvers[k]),
        }
    }
    decided(held, format!("{}, claimed ascending", means(claim, t)))
}

/// `each_less` and `each_equal`: per mesh, on enough of the meshes where they can be ordered
/// (not where both never reached the target).
fn each(claim: &Claim, t: &Table) -> Decided {
    let equal = claim.check == Check::EachEqual;
    let mut misses: Vec<&str> = Vec::new();
    let mut unordered = 0;
    for (d, _, v) in &t.meshes {
        let here: Option<bool> = v[1..]
            .iter()
            .map(|o| if equal { (v[0].is_finite() || o.is_finite()).then_some(v[0] == *o) } else { below(v[0], *o) })
            .try_fold(true, |all, h| h.map(|h| all && h));
        match here {
            Some(true) => {}
            Some(false) => misses.push(d),
            None => unordered += 1,
        }
    }
    let n = t.meshes.len() - unordered;
    if n == 0 {
        return (
            ClaimOutcome::NotMeasurable,
            format!("on no mesh did {} reach the target", claim.solvers().join(" or ")),
        );
    }
    let ok = n - misses.len();
    let need = if equal { 1.0 } else { claim.at_least.unwrap_or(1.0) };
    let text = format!(
        "{}'s {} {} {}'s on {ok} of {n} meshes (needed: {:.0}%){}{}",
        claim.solver,
        claim.metric.as_str(),
        if equal { "equal to" } else { "below" },
        claim.others.join(" and "),
        100.0 * need,
        if misses.is_empty() { String::new() } else { format!("; not on {}", misses.join(", ")) },
        if unordered == 0 {
            String::new()
        } else {
            format!("; {unordered} mesh(es) where none reached the target left out")
        }
    );
    decided(ok as f64 >= need * n as f64 - 1e-9, text)
}

fn each_at_most(claim: &Claim, t: &Table) -> Decided {
    let bound = claim.value.unwrap_or(0.0);
    let over: Vec<String> =
        t.meshes.iter().filter(|m| m.2[0] > bound).map(|m| format!("{} {}", m.0, fmt(m.2[0]))).collect();
    let text = format!(
        "{}'s {} at most {} on {} of {} meshes{}",
        claim.solver,
        claim.metric.as_str(),
        fmt(bound),
        t.meshes.len() - over.len(),
        t.meshes.len(),
        if over.is_empty() { String::new() } else { format!("; above on {}", over.join(", ")) }
    );
    decided(over.is_empty(), text)
}

fn value(claim: &Claim, t: &Table) -> Decided {
    let s = claim.solver.as_str();
    let (want, got) = (claim.published[s], t.mean(0));
    let rel = ((got - want) / want).abs();
    let tol = claim.tolerance.unwrap_or(0.0);
    let text =
        format!("{s}: ours {} vs published {} (relative difference {rel:.1e}, at most {tol:.0e})", fmt(got), fmt(want));
    decided(rel <= tol, text)
}
fn falls_with_size(claim: &Claim, t: &Table) -> Decided {
    let mut m: Vec<(usize, f64)> = t.meshes.iter().map(|m| (m.1, m.2[0])).collect();
    m.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)));
    let mut sizes: Vec<usize> = m.iter().map(|x| x.0).collect();
    sizes.dedup();
    if sizes.len() < 3 {
        return (ClaimOutcome::NotMeasurable, format!("{} mesh size(s): 3 or more are needed", sizes.len()));
    }
    let (mut fall, mut rise) = (0, 0);
    for (i, x) in m.iter().enumerate() {
        for y in m[i + 1..].iter().filter(|y| y.0 > x.0) {
            if y.1 < x.1 {
                fall += 1;
            } else if y.1 > x.1 {
                rise += 1;
            }
        }
    }
    let (first, last) = (m[0], m[m.len() - 1]);
    let text = format!(
        "{}'s {}: {} at {} vertices, {} at {}; {fall} pairs of meshes fall with size, {rise} rise",
        claim.solver,
        claim.metric.as_str(),
        fmt(first.1),
        first.0,
        fmt(last.1),
        last.0
    );
    decided(fall > rise && last.1 < first.1, text)
}
