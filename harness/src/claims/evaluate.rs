//! A claim decided over one run folder's rows, by the paper's rule and by the verdict's.

use super::spec::{Check, Claim, Metric};
use crate::names::run_stem;
use crate::run_folder::SummaryRow;
use serde::Serialize;
use std::collections::BTreeMap;

/// How a run's cost is counted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Rule {
    /// The paper's: each run to its own stop (the config's `[stop]`, the papers' gradient or
    /// energy-decrease rule and iteration cap), an unconverged run at its cap.
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
pub enum Outcome {
    Held,
    NotHeld,
    /// The folder cannot answer it (`why` says what is missing).
    NotMeasurable,
}

impl Outcome {
    pub fn as_str(self) -> &'static str {
        match self {
            Outcome::Held => "held",
            Outcome::NotHeld => "not held",
            Outcome::NotMeasurable => "not measurable",
        }
    }

    /// As JSON and the history write it.
    pub fn key(self) -> &'static str {
        match self {
            Outcome::Held => "held",
            Outcome::NotHeld => "not_held",
            Outcome::NotMeasurable => "not_measurable",
        }
    }

    pub fn from_key(key: &str) -> Option<Outcome> {
        [Outcome::Held, Outcome::NotHeld, Outcome::NotMeasurable].into_iter().find(|o| o.key() == key)
    }
}

/// A claim under one rule.
#[derive(Clone, Debug, Serialize)]
pub struct Judged {
    pub rule: Rule,
    pub outcome: Outcome,
    /// The comparison in words, or what is missing.
    pub why: String,
    /// Our number per solver: the mean over `datasets` (the one mesh's for `value`).
    pub ours: BTreeMap<String, f64>,
    /// The meshes it was decided on.
    pub datasets: Vec<String>,
    /// The runs it read (`runs/<stem>.csv`).
    pub runs: Vec<String>,
}

/// `solver`'s number on one mesh under `rule`; `None` when the run has none (failed, skipped,
/// not judged, or a metric it does not measure). Infinite when, by the verdict, it never
/// reached the target.
pub fn run_value(metric: Metric, rule: Rule, r: &SummaryRow) -> Option<f64> {
    if !r.status.ran() {
        return None;
    }
    if rule == Rule::Verdict && metric.has_target_variant() {
        let t = r.to_targets.last()?;
        let (Some(iters), Some(to)) = (t.iters, t.time_s) else { return Some(f64::INFINITY) };
        return match metric {
            Metric::Iterations => Some(iters as f64),
            Metric::TimeS => Some(to),
            _ => {
                let k = r.time_s.filter(|t| *t > 0.0).map_or(0.0, |t| to / t);
                r.ms_per_vertex.map(|v| v * k)
            }
        };
    }
    match metric {
        Metric::Iterations => r.iterations.map(|i| i as f64),
        Metric::MsPerVertex => r.ms_per_vertex,
        Metric::TimeS => r.time_s,
        Metric::FinalEnergy => r.final_energy,
        Metric::ProjectMs => r.project_ms_median,
        Metric::ProjectSolveRatio => {
            r.project_ms_median.zip(r.solve_ms_median.filter(|s| *s > 0.0)).map(|(p, s)| p / s)
        }
        Metric::AuthalicEnergy => r.authalic_energy,
        Metric::AreaRatioSd => r.area_ratio_sd,
        Metric::Folded => r.folded.map(|f| f as f64),
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
    let mean = |k: usize| t.meshes.iter().map(|m| m.2[k]).sum::<f64>() / n.max(1) as f64;
    let ours: BTreeMap<String, f64> = if n == 0 {
        BTreeMap::new()
    } else {
        solvers.iter().enumerate().map(|(k, s)| (s.to_string(), mean(k))).collect()
    };
    let mut judged = Judged {
        rule,
        outcome: Outcome::NotMeasurable,
        why: String::new(),
        ours,
        datasets: t.meshes.iter().map(|m| m.0.clone()).collect(),
        runs: t.runs.clone(),
    };
    let left = if t.left_out.is_empty() { String::new() } else { format!("; left out: {}", t.left_out.join(", ")) };
    if n == 0 {
        judged.why = format!("no mesh of {} where {} each have a number{left}", claim.energy, solvers.join(", "));
        return judged;
    }
    let (outcome, why) = decide(claim, &t, &judged.ours);
    judged.outcome = outcome;
    judged.why = format!("{why} (over {n} mesh{}{left})", if n == 1 { "" } else { "es" });
    judged
}

/// Whether `a < b` can be said: not when both are infinite (neither reached the target).
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

fn decide(claim: &Claim, t: &Table, agg: &BTreeMap<String, f64>) -> (Outcome, String) {
    let solvers = claim.solvers();
    let a = |s: &str| agg[s];
    let s = claim.solver.as_str();
    let unreached = |x: &str, y: &str| {
        (
            Outcome::NotMeasurable,
            format!("{x} and {y} both never reached the target on some mesh: they cannot be ordered"),
        )
    };
    let verdict = |held: bool, text: String| (if held { Outcome::Held } else { Outcome::NotHeld }, text);
    let listing = || solvers.iter().map(|o| format!("{o} {}", fmt(a(o)))).collect::<Vec<_>>().join(", ");
    match claim.check {
        Check::Fewest | Check::Less | Check::Most => {
            let mut held = true;
            for o in &claim.others {
                let pair = if claim.check == Check::Most { below(a(o), a(s)) } else { below(a(s), a(o)) };
                match pair {
                    Some(h) => held &= h,
                    None => return unreached(s, o),
                }
            }
            verdict(held, format!("mean {}: {}", claim.metric.as_str(), listing()))
        }
        Check::Within => {
            let tol = claim.tolerance.unwrap_or(0.0);
            let mut worst: f64 = 0.0;
            for o in &claim.others {
                if a(s).is_infinite() || a(o).is_infinite() {
                    return if a(s).is_infinite() && a(o).is_infinite() {
                        unreached(s, o)
                    } else {
                        verdict(false, format!("one of {s} and {o} never reached the target: {}", listing()))
                    };
                }
                worst = worst.max((a(s) / a(o) - 1.0).abs());
            }
            let text = format!(
                "mean {}: {}; largest difference {:.1}% (at most {:.0}%)",
                claim.metric.as_str(),
                listing(),
                100.0 * worst,
                100.0 * tol
            );
            verdict(worst <= tol, text)
        }
        Check::Order => {
            let mut held = true;
            for w in solvers.windows(2) {
                match below(a(w[0]), a(w[1])) {
                    Some(h) => held &= h,
                    None => return unreached(w[0], w[1]),
                }
            }
            verdict(held, format!("mean {} in the order claimed? {}", claim.metric.as_str(), listing()))
        }
        Check::EachLess | Check::EachEqual => {
            let equal = claim.check == Check::EachEqual;
            let mut ok = 0;
            let mut misses = Vec::new();
            for (d, _, v) in &t.meshes {
                let here = v[1..].iter().all(|o| if equal { v[0] == *o } else { below(v[0], *o).unwrap_or(false) });
                if here {
                    ok += 1;
                } else {
                    misses.push(d.as_str());
                }
            }
            let n = t.meshes.len();
            let need = if equal { 1.0 } else { claim.at_least.unwrap_or(1.0) };
            let op = if equal { "equal to" } else { "below" };
            let text = format!(
                "{s}'s {} {op} {}'s on {ok} of {n} meshes (needed: {:.0}%){}",
                claim.metric.as_str(),
                claim.others.join(" and "),
                100.0 * need,
                if misses.is_empty() { String::new() } else { format!("; not on {}", misses.join(", ")) }
            );
            verdict(ok as f64 >= need * n as f64 - 1e-9, text)
        }
        Check::EachAtMost => {
            let bound = claim.value.unwrap_or(0.0);
            let over: Vec<String> =
                t.meshes.iter().filter(|m| m.2[0] > bound).map(|m| format!("{} {}", m.0, fmt(m.2[0]))).collect();
            let text = format!(
                "{s}'s {} at most {} on {} of {} meshes{}",
                claim.metric.as_str(),
                fmt(bound),
                t.meshes.len() - over.len(),
                t.meshes.len(),
                if over.is_empty() { String::new() } else { format!("; above on {}", over.join(", ")) }
            );
            verdict(over.is_empty(), text)
        }
        Check::Value => {
            let want = claim.published[s];
            let got = a(s);
            let rel = ((got - want) / want).abs();
            let tol = claim.tolerance.unwrap_or(0.0);
            verdict(
                rel <= tol,
                format!(
                    "{s}: ours {} vs published {} (relative difference {rel:.1e}, at most {tol:.0e})",
                    fmt(got),
                    fmt(want)
                ),
            )
        }
        Check::FallsWithSize => {
            let mut m: Vec<(usize, f64)> = t.meshes.iter().map(|m| (m.1, m.2[0])).collect();
            m.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)));
            let sizes = {
                let mut v: Vec<usize> = m.iter().map(|x| x.0).collect();
                v.dedup();
                v.len()
            };
            if sizes < 3 {
                return (Outcome::NotMeasurable, format!("{sizes} mesh size(s): 3 or more are needed"));
            }
            let (mut fall, mut rise) = (0, 0);
            for i in 0..m.len() {
                for j in i + 1..m.len() {
                    if m[i].0 < m[j].0 {
                        if m[j].1 < m[i].1 {
                            fall += 1;
                        } else if m[j].1 > m[i].1 {
                            rise += 1;
                        }
                    }
                }
            }
            let (first, last) = (m[0], m[m.len() - 1]);
            let text = format!(
                "{s}'s {}: {} at {} vertices, {} at {}; {fall} pairs of meshes fall with size, {rise} rise",
                claim.metric.as_str(),
                fmt(first.1),
                first.0,
                fmt(last.1),
                last.0
            );
            verdict(fall > rise && last.1 < first.1, text)
        }
    }
}
