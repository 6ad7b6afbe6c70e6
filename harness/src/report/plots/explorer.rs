//! The report's explorer, `explorer.html`: one page that draws a problem's convergence curves
//! (the judge's gap against iterations or time, log axes, the targets drawn) or one solver's
//! curves over the problems of an energy, chosen from menus, with uPlot (vendored in
//! `harness/assets/uplot/`), each solver in the colour and marker of the PNGs: a solver is
//! hidden by a click on its legend entry, the values under the cursor show in the legend, and
//! a table under the chart gives each run's iterations and time to the target with its
//! repeats' spread (drawn against time as a whisker from the fastest to the slowest repeat).
//! It works offline from the folder alone: the page, `explorer/uPlot.*` and
//! `explorer/data.js` (the curves, thinned to [`MAX_POINTS`]).

use super::chart::{style, Curve};
use crate::escape::esc;
use crate::report::select::{converged, finished, unique};
use crate::report::target::{reached_target, to_target, verdict_text};
use crate::run_folder::timed::Timed;
use crate::run_folder::{write_atomic, SummaryRow};
use anyhow::Result;
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;

/// The explorer's page, at the top of the run folder.
pub const EXPLORER: &str = "explorer.html";
/// The uPlot release vendored, and the digests of its two files (checked by a test).
pub const UPLOT_VERSION: &str = "1.6.32";
const UPLOT_JS: &[u8] = include_bytes!("../../../assets/uplot/uPlot.iife.min.js");
const UPLOT_CSS: &[u8] = include_bytes!("../../../assets/uplot/uPlot.min.css");
const UPLOT_LICENSE: &[u8] = include_bytes!("../../../assets/uplot/LICENSE");
#[cfg(test)]
const UPLOT_JS_SHA256: &str = "19c8d4c6ad88929a79f4ae49d6f7161566dfd0ba3d15cc495e974f787eb78f1f";
#[cfg(test)]
const UPLOT_CSS_SHA256: &str = "df630c6a8d6f8eeaff264b50f73ce5b114f646ffd9a0bb74f049b0a00135fa04";

/// The most points a curve keeps: every one of its first `DENSE` iterations, then
/// geometrically spaced ones and its last, so a 5000-iteration run stays a few KB.
pub const MAX_POINTS: usize = 400;
const DENSE: usize = 50;

/// One (dataset, energy) problem: its yardstick and the curves of its finished runs.
#[derive(Serialize)]
struct Problem {
    dataset: String,
    energy: String,
    /// The gap is the verdict's `(E - E*) / span` (else `E - best`).
    judged: bool,
    certified: Option<bool>,
    targets: Vec<f64>,
    /// Where a gap at or below 0 (at or below E*) is drawn on the log axis.
    floor: f64,
    runs: Vec<Run>,
}

/// A run's curve and what the table under the chart says of it.
#[derive(Serialize)]
struct Run {
    solver: String,
    color: String,
    /// The solver's marker, the PNGs' (`chart::draw_marker`'s shapes, in the same order).
    marker: usize,
    /// The harness's verdict (or the status when not judged).
    verdict: String,
    /// Drawn solid: it converged (solved when judged).
    solved: bool,
    iter: Vec<f64>,
    time: Vec<f64>,
    gap: Vec<f64>,
    iters_to_target: Option<usize>,
    /// The median over the repeats with its min–max, to the target when it reached it.
    time_s: Option<[f64; 3]>,
    repeats: usize,
    final_gap: Option<f64>,
}

#[derive(Serialize)]
struct Data<'a> {
    name: &'a str,
    solvers: Vec<(&'a str, String)>,
    problems: Vec<Problem>,
}

/// Write `explorer.html`, `explorer/data.js` and uPlot into `run_dir`; `false` (and nothing
/// written) when no run finished.
pub fn write(run_dir: &Path, name: &str, summaries: &[SummaryRow]) -> Result<bool> {
    let solvers = unique(summaries.iter().map(|s| s.solver.as_str()));
    let groups = unique(summaries.iter().filter(|s| finished(s)).map(|s| (s.dataset.as_str(), s.energy.as_str())));
    if groups.is_empty() {
        return Ok(false);
    }
    let problems = groups
        .par_iter()
        .map(|&(d, e)| {
            let runs: Vec<&SummaryRow> =
                summaries.iter().filter(|s| s.dataset == d && s.energy == e && finished(s)).collect();
            problem(run_dir, (d, e), &runs, &solvers)
        })
        .collect::<Result<Vec<_>>>()?;
    let colors = solvers.iter().map(|s| (*s, hex(style(&solvers, s).color))).collect();
    let data = Data { name, solvers: colors, problems };
    let dir = run_dir.join("explorer");
    write_atomic(&dir.join("uPlot.iife.min.js"), UPLOT_JS)?;
    write_atomic(&dir.join("uPlot.min.css"), UPLOT_CSS)?;
    write_atomic(&dir.join("LICENSE.uPlot"), UPLOT_LICENSE)?;
    let js = format!("window.MAPBENCH_EXPLORER = {};\n", serde_json::to_string(&data)?);
    write_atomic(&dir.join("data.js"), js.as_bytes())?;
    let page = PAGE.replace("{name}", &esc(name)).replace("{uplot}", UPLOT_VERSION);
    write_atomic(&run_dir.join(EXPLORER), page.as_bytes())?;
    Ok(true)
}

/// A link to a problem in the explorer, escaped for an `href`:
/// `explorer.html#p=<dataset>__<energy>` (the page decodes the fragment).
pub fn problem_link(dataset: &str, energy: &str) -> String {
    format!("{EXPLORER}#p={}", crate::escape::href(&format!("{dataset}__{energy}")))
}

fn problem(run_dir: &Path, (dataset, energy): (&str, &str), runs: &[&SummaryRow], solvers: &[&str]) -> Result<Problem> {
    // The group's yardstick when every run has the same (as the PNG curves).
    let yardstick = runs.first().and_then(|r| r.ref_energy.zip(r.gap_scale));
    let yardstick = yardstick.filter(|y| runs.iter().all(|r| r.ref_energy.zip(r.gap_scale) == Some(*y)));
    let targets: Vec<f64> = match yardstick {
        Some(_) => runs.first().map(|r| r.to_targets.iter().map(|t| t.tau).collect()).unwrap_or_default(),
        None => Vec::new(),
    };
    let mut out = Vec::new();
    let mut roundoff = Vec::new();
    for r in runs {
        let curve = Curve::new(crate::run_folder::read_run(run_dir, r)?, yardstick);
        roundoff.push(curve.roundoff);
        let keep = thin(curve.iter.len());
        let pick = |v: &[f64]| keep.iter().map(|&i| short(v[i])).collect::<Vec<_>>();
        let shown = to_target(r);
        let reached = reached_target(r).is_some();
        let look = style(solvers, &r.solver);
        out.push(Run {
            solver: r.solver.clone(),
            color: hex(look.color),
            marker: look.marker,
            verdict: r.verdict.map_or_else(|| r.status.as_str().to_string(), |v| verdict_text(v).to_string()),
            solved: converged(r),
            iter: pick(&curve.iter),
            time: pick(&curve.time),
            gap: pick(&curve.gap),
            iters_to_target: if reached { shown.iterations } else { None },
            time_s: Timed::time_s(&shown).map(|t| [short(t.value), short(t.lo), short(t.hi)]),
            repeats: r.repeats.unwrap_or(1),
            final_gap: r.final_gap.map(short),
        });
    }
    let gaps = out.iter().flat_map(|r| r.gap.iter().copied()).chain(targets.iter().copied());
    let floor = short(super::chart::gap_floor(gaps, roundoff));
    Ok(Problem {
        dataset: dataset.into(),
        energy: energy.into(),
        judged: yardstick.is_some(),
        certified: runs.first().and_then(|r| r.ref_certified),
        targets,
        floor,
        runs: out,
    })
}

/// The indices a curve of `n` points keeps: all when `n <= MAX_POINTS`, else the first
/// `DENSE`, geometrically spaced ones after them and the last.
fn thin(n: usize) -> Vec<usize> {
    if n <= MAX_POINTS {
        return (0..n).collect();
    }
    let mut keep: Vec<usize> = (0..DENSE).collect();
    let steps = MAX_POINTS - DENSE - 1;
    let ratio = ((n - 1) as f64 / DENSE as f64).powf(1.0 / steps as f64);
    let mut x = DENSE as f64;
    for _ in 0..steps {
        let i = (x.round() as usize).min(n - 1);
        if keep.last() != Some(&i) {
            keep.push(i);
        }
        x *= ratio;
    }
    if keep.last() != Some(&(n - 1)) {
        keep.push(n - 1);
    }
    keep
}

/// 5 significant digits: what a chart can show, in a fifth of the bytes. Non-finite values
/// (a diverged energy) become `null` in JSON and a gap in the curve.
fn short(x: f64) -> f64 {
    if !x.is_finite() {
        return f64::NAN;
    }
    format!("{x:.4e}").parse().unwrap_or(x)
}

fn hex(c: plotters::style::RGBColor) -> String {
    format!("#{:02x}{:02x}{:02x}", c.0, c.1, c.2)
}

/// The page: menus, the chart, the table; `{name}` and `{uplot}` filled in.
const PAGE: &str = include_str!("explorer.html");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::corpus::sha256_hex;

    #[test]
    fn the_vendored_uplot_is_the_release_named() {
        assert_eq!(sha256_hex(UPLOT_JS), UPLOT_JS_SHA256);
        assert_eq!(sha256_hex(UPLOT_CSS), UPLOT_CSS_SHA256);
        let head = std::str::from_utf8(&UPLOT_JS[..80]).unwrap();
        assert!(head.contains(&format!("(v{UPLOT_VERSION})")), "{head}");
        assert!(std::str::from_utf8(UPLOT_LICENSE).unwrap().contains("MIT"));
    }

    #[test]
    fn long_curves_are_thinned_to_the_first_iterations_and_a_geometric_tail() {
        assert_eq!(thin(5), [0, 1, 2, 3, 4]);
        for n in [MAX_POINTS + 1, 1000, 5001, 100_000] {
            let k = thin(n);
            assert!(k.len() <= MAX_POINTS, "{n}: {}", k.len());
            assert_eq!(k[..DENSE], (0..DENSE).collect::<Vec<_>>()[..]);
            assert_eq!(*k.last().unwrap(), n - 1);
            assert!(k.windows(2).all(|w| w[0] < w[1]), "{n}: strictly increasing");
        }
        assert_eq!(short(0.123456789), 0.12346);
        assert!(short(f64::INFINITY).is_nan());
        assert_eq!(serde_json::to_string(&[short(f64::NAN)]).unwrap(), "[null]");
    }

    #[test]
    fn the_explorer_holds_every_finished_run_of_every_problem_and_nothing_else() {
        let (dir, rows) = super::super::tests::tiny_run();
        let p = dir.path();
        assert!(write(p, "tiny <config>", &rows).unwrap());
        let page = std::fs::read_to_string(p.join(EXPLORER)).unwrap();
        assert!(page.contains("tiny &lt;config&gt;") && !page.contains("{name}") && !page.contains("{uplot}"));
        assert_eq!(problem_link("a b", "sd"), "explorer.html#p=a%20b__sd");
        // Offline: only files of the folder.
        for src in ["explorer/uPlot.iife.min.js", "explorer/uPlot.min.css", "explorer/data.js"] {
            assert!(page.contains(src), "{src}");
            assert!(p.join(src).exists(), "{src}");
        }
        assert!(!page.contains("http://") && !page.contains("https://"));
        let js = std::fs::read_to_string(p.join("explorer/data.js")).unwrap();
        let json: serde_json::Value =
            serde_json::from_str(js.trim_start_matches("window.MAPBENCH_EXPLORER = ").trim_end().trim_end_matches(';'))
                .unwrap();
        let problems = json["problems"].as_array().unwrap();
        let finished: Vec<&SummaryRow> = rows.iter().filter(|r| finished(r)).collect();
        let runs: usize = problems.iter().map(|p| p["runs"].as_array().unwrap().len()).sum();
        assert_eq!(runs, finished.len());
        for p in problems {
            for r in p["runs"].as_array().unwrap() {
                let n = r["iter"].as_array().unwrap().len();
                assert!(n > 0 && r["time"].as_array().unwrap().len() == n && r["gap"].as_array().unwrap().len() == n);
                assert!(r["color"].as_str().unwrap().starts_with('#'));
            }
        }
        assert_eq!(problem_link("cow", "sd"), "explorer.html#p=cow__sd");
        // A folder with no finished run has no explorer.
        let empty = tempfile::tempdir().unwrap();
        assert!(!write(empty.path(), "none", &[]).unwrap());
        assert!(!empty.path().join(EXPLORER).exists());
    }
}
