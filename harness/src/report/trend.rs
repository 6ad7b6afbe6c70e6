//! The trend page of the history (`mapbench history --out DIR`, and after every `run` and
//! `merge` that appends): per config, its batches in time order; per energy, each solver's
//! mean iterations and mean time per batch (PNG, each tick labelled with the batch's short
//! revision) with the totals in tables; and what changed in the latest batch since the
//! previous one of the same config, by the rules of `check`.

use super::changes::Changes;
use super::corpus::{ITERATION_SHIFT, TIME_NORM_SHIFT, TIME_SHIFT_S};
use super::html::{changes_body, esc, href, utc, STYLE};
use super::plots::trend::{render_trend, TrendLine};
use super::select::unique;
use crate::history::{BatchRow, HistoryDb, HistoryError, RunRow};
use crate::paths::relative_link;
use crate::run_folder::{write_atomic, Status};
use crate::stats::shifted_geometric_mean;
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What [`render`] wrote.
#[derive(Debug)]
pub struct TrendPage {
    pub index: PathBuf,
    /// The PNGs, relative to the page's folder.
    pub plots: Vec<String>,
    pub batches: usize,
}

/// One config's batches with their runs, oldest first.
struct ConfigHistory {
    name: String,
    batches: Vec<(BatchRow, Vec<RunRow>)>,
}

/// The runs a trend counts: those that ran to a stop (converged or not), as the report's means.
fn counted(r: &RunRow) -> bool {
    r.status.ran() && r.iterations.is_some()
}

/// Which time a trend shows: `time_norm` when every counted run of the plot has one (it
/// compares nights and machines), else the raw `time_s`.
#[derive(Clone, Copy, Debug, PartialEq)]
enum TimeColumn {
    Norm,
    Raw,
}

impl TimeColumn {
    fn pick(runs: &[&RunRow]) -> TimeColumn {
        if !runs.is_empty() && runs.iter().all(|r| r.time_norm.is_some()) {
            TimeColumn::Norm
        } else {
            TimeColumn::Raw
        }
    }

    fn of(self, r: &RunRow) -> Option<f64> {
        match self {
            TimeColumn::Norm => r.time_norm,
            TimeColumn::Raw => r.time_s,
        }
    }

    fn label(self) -> &'static str {
        match self {
            TimeColumn::Norm => "time_norm (time_s / calibration median)",
            TimeColumn::Raw => "time_s (seconds, not normalized)",
        }
    }

    /// The shift of its geometric mean (the report's aggregates use the same).
    fn shift(self) -> f64 {
        match self {
            TimeColumn::Norm => TIME_NORM_SHIFT,
            TimeColumn::Raw => TIME_SHIFT_S,
        }
    }
}

/// The cost of a run to the target as the trend counts it: a solved run's iterations and
/// time to its tightest target (to its own stop when it was not judged), `None` for an
/// unsolved one (it enters at the cap).
fn cost(r: &RunRow, time: TimeColumn) -> Option<(f64, Option<f64>)> {
    if r.status != Status::Ok {
        return None;
    }
    // A judged run recorded before the history kept the target (schema 6) counts to its own
    // stop: the page says so.
    let iterations = r.iters_to_target.or(r.iterations)? as f64;
    // The time to the target scales the run's time by time_to / time_s (as the report's tables).
    let k = match (r.time_s_to_target, r.time_s) {
        (Some(to), Some(t)) if t > 0.0 => to / t,
        (Some(_), Some(_)) => 0.0,
        _ => 1.0,
    };
    Some((iterations, time.of(r).map(|t| t * k)))
}

/// The caps an unsolved run enters the means at, per energy over the whole history shown: the
/// most iterations and the longest time any run of the energy took to its own stop (the
/// history does not keep `max_iters` or the timeout).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Caps {
    iterations: f64,
    time: Option<f64>,
}

impl Caps {
    fn of(c: &ConfigHistory, energy: &str, time: TimeColumn) -> Caps {
        let runs = || c.batches.iter().flat_map(|(_, r)| r.iter()).filter(|r| r.energy == energy && counted(r));
        let iterations = runs().filter_map(|r| r.iterations).max().unwrap_or(0) as f64;
        let time = runs().filter_map(|r| time.of(r)).filter(|t| t.is_finite()).reduce(f64::max);
        Caps { iterations, time }
    }
}

/// One (batch, energy, solver) of the trend: solved at the target out of the runs that were
/// not skipped, and the shifted geometric means to the target with unsolved runs at the caps
/// (the report's aggregates rule).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Cell {
    runs: usize,
    solved: usize,
    sgm_iterations: Option<f64>,
    sgm_time: Option<f64>,
}

fn cell(runs: &[RunRow], energy: &str, solver: &str, time: TimeColumn, caps: Caps) -> Option<Cell> {
    let mine: Vec<&RunRow> =
        runs.iter().filter(|r| r.energy == energy && r.solver == solver && r.status != Status::Skipped).collect();
    if mine.is_empty() {
        return None;
    }
    let costs: Vec<Option<(f64, Option<f64>)>> = mine.iter().map(|r| cost(r, time)).collect();
    // An unsolved run at the cap, which is at least its own iterations (the most any run
    // took); a failed run has none of its own.
    let iterations: Vec<f64> = costs.iter().map(|c| c.map_or(caps.iterations, |c| c.0)).collect();
    let times: Option<Vec<f64>> = costs.iter().map(|c| c.map_or(caps.time, |c| c.1)).collect();
    Some(Cell {
        runs: mine.len(),
        solved: costs.iter().filter(|c| c.is_some()).count(),
        sgm_iterations: shifted_geometric_mean(&iterations, ITERATION_SHIFT),
        sgm_time: times.and_then(|t| shifted_geometric_mean(&t, time.shift())),
    })
}

/// Render the trend page of `config` (every config when `None`) from the last `last`
/// batches of each (all when `None`) into `out/index.html` and `out/plots/*.png`.
pub fn render(
    db: &HistoryDb,
    config: Option<&str>,
    last: Option<usize>,
    out: &Path,
) -> Result<TrendPage, HistoryError> {
    let batches = db.batches(config, last)?;
    if batches.is_empty() {
        return Err(HistoryError::Meta {
            path: db.path().to_path_buf(),
            what: match config {
                Some(c) => format!("no batch of config {c:?}"),
                None => "no batch yet".into(),
            },
        });
    }
    let mut configs: Vec<ConfigHistory> = Vec::new();
    for b in batches {
        // The names become file names below: a database edited by hand must not write elsewhere.
        crate::names::check_name("config", &b.config_name).map_err(|e| bad(db, e))?;
        let runs = db.runs(b.id)?;
        for r in &runs {
            crate::names::check_name("energy", &r.energy).map_err(|e| bad(db, e))?;
        }
        match configs.last_mut() {
            Some(c) if c.name == b.config_name => c.batches.push((b, runs)),
            _ => configs.push(ConfigHistory { name: b.config_name.clone(), batches: vec![(b, runs)] }),
        }
    }
    let render_err = |path: &Path| {
        let path = path.to_path_buf();
        move |err: anyhow::Error| HistoryError::Render { path: path.clone(), err }
    };
    let index = out.join("index.html");
    let charts: Vec<Chart> = configs.iter().flat_map(charts_of).collect();
    charts
        .par_iter()
        .map(|c| {
            let png = render_trend(&c.title, &c.y_desc, &c.labels, &c.lines(), &c.solvers())?;
            write_atomic(&out.join(&c.file), &png)
        })
        .collect::<anyhow::Result<Vec<()>>>()
        .map_err(render_err(&index))?;
    let html = page(&configs, &charts, out);
    write_atomic(&index, html.as_bytes()).map_err(render_err(&index))?;
    let batches = configs.iter().map(|c| c.batches.len()).sum();
    Ok(TrendPage { index, plots: charts.into_iter().map(|c| c.file).collect(), batches })
}

fn bad(db: &HistoryDb, e: crate::names::NameError) -> HistoryError {
    HistoryError::Meta { path: db.path().to_path_buf(), what: e.to_string() }
}

/// One PNG of the page.
struct Chart {
    config: String,
    energy: String,
    file: String,
    title: String,
    y_desc: String,
    labels: Vec<String>,
    solvers: Vec<String>,
    /// Per solver, `(batch index, value)`.
    values: Vec<(String, Vec<(usize, f64)>)>,
}

impl Chart {
    fn lines(&self) -> Vec<TrendLine<'_>> {
        self.values.iter().map(|(s, p)| TrendLine { solver: s, points: p.clone() }).collect()
    }
    fn solvers(&self) -> Vec<&str> {
        self.solvers.iter().map(String::as_str).collect()
    }
}

/// The energies of a config, in first-appearance order, and its solvers.
fn names(c: &ConfigHistory) -> (Vec<String>, Vec<String>) {
    let runs = || c.batches.iter().flat_map(|(_, r)| r.iter());
    let energies = unique(runs().map(|r| r.energy.as_str())).into_iter().map(String::from).collect();
    let solvers = unique(runs().map(|r| r.solver.as_str())).into_iter().map(String::from).collect();
    (energies, solvers)
}

fn time_column(c: &ConfigHistory, energy: &str) -> TimeColumn {
    let runs: Vec<&RunRow> =
        c.batches.iter().flat_map(|(_, r)| r.iter()).filter(|r| r.energy == energy && counted(r)).collect();
    TimeColumn::pick(&runs)
}

/// What a trend chart plots of a cell.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Measure {
    Solved,
    Iterations,
    Time,
}

impl Measure {
    fn of(self, c: &Cell) -> Option<f64> {
        match self {
            Measure::Solved => Some(c.solved as f64),
            Measure::Iterations => c.sgm_iterations,
            Measure::Time => c.sgm_time,
        }
    }
}

/// The fewest batches a trend chart is drawn for: with one or two, a chart is one or two
/// points and says nothing the table under it does not.
pub const MIN_TREND_BATCHES: usize = 3;

/// The three charts of each energy of a config, per batch: solved runs, and the shifted
/// geometric means of iterations and time to the target (unsolved at the caps); none before
/// [`MIN_TREND_BATCHES`].
fn charts_of(c: &ConfigHistory) -> Vec<Chart> {
    if c.batches.len() < MIN_TREND_BATCHES {
        return Vec::new();
    }
    let (energies, solvers) = names(c);
    let labels: Vec<String> = c.batches.iter().map(|(b, _)| b.short_revision()).collect();
    let mut out = Vec::new();
    for energy in &energies {
        let time = time_column(c, energy);
        let caps = Caps::of(c, energy, time);
        // Per solver, its cell in each batch: the three charts plot three measures of them.
        let cells: Vec<Vec<Option<Cell>>> = solvers
            .iter()
            .map(|s| c.batches.iter().map(|(_, runs)| cell(runs, energy, s, time, caps)).collect())
            .collect();
        for measure in [Measure::Solved, Measure::Iterations, Measure::Time] {
            let values: Vec<(String, Vec<(usize, f64)>)> = solvers
                .iter()
                .zip(&cells)
                .map(|(s, row)| {
                    let pts =
                        row.iter().enumerate().filter_map(|(i, x)| measure.of(x.as_ref()?).map(|v| (i, v))).collect();
                    (s.clone(), pts)
                })
                .filter(|(_, p): &(String, Vec<_>)| !p.is_empty())
                .collect();
            if values.is_empty() {
                continue;
            }
            let (suffix, what, y_desc) = match measure {
                Measure::Solved => ("solved", "runs solved per batch", "solved runs (at the target)".to_string()),
                Measure::Iterations => (
                    "iterations",
                    "shifted geometric mean of iterations to the target",
                    format!("iterations, sgm (shift {ITERATION_SHIFT}), unsolved at the cap"),
                ),
                Measure::Time => (
                    "time",
                    "shifted geometric mean of time to the target",
                    format!("{}, sgm (shift {})", time.label(), time.shift()),
                ),
            };
            out.push(Chart {
                config: c.name.clone(),
                energy: energy.clone(),
                file: format!("plots/{}__{energy}__{suffix}.png", c.name),
                title: format!("{}, {energy}: {what}", c.name),
                y_desc,
                labels: labels.clone(),
                solvers: solvers.clone(),
                values,
            });
        }
    }
    out
}

fn page(configs: &[ConfigHistory], charts: &[Chart], out: &Path) -> String {
    let mut h = String::new();
    let title = match configs {
        [one] => format!("mapbench history: {}", one.name),
        _ => "mapbench history".to_string(),
    };
    let _ = write!(
        h,
        "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>{}</title>\n\
         <style>{STYLE}</style>\n</head>\n<body>\n<h1>{}</h1>\n",
        esc(&title),
        esc(&title)
    );
    h += "<p class=\"caption\">Each point is one batch (night), labelled with its short git revision (+: the tree \
          was dirty). Per energy and solver: the runs solved at the target (the harness's verdict; ok for runs it \
          does not judge), and the shifted geometric means of iterations and time to the target over the runs \
          that were not skipped, an unsolved run (not converged or failed) entering at the cap: the most \
          iterations and the longest time any run of the energy took in the batches shown. A solver that starts \
          failing earlier therefore moves up, not down. Batches recorded before the history kept the target \
          (schema 6) count their solved runs to their own stop. Changes use the rules of \
          <code>mapbench check</code>.</p>\n";
    if configs.len() > 1 {
        h += "<nav>";
        for c in configs {
            let _ = write!(h, "<a href=\"#{}\">{}</a>", href(&c.name), esc(&c.name));
        }
        h += "</nav>\n";
    }
    for c in configs {
        let _ = writeln!(h, "<h2 id=\"{}\">{}: {} batches</h2>", esc(&c.name), esc(&c.name), c.batches.len());
        batches_table(&mut h, c, out);
        changes_section(&mut h, c);
        let (energies, solvers) = names(c);
        if c.batches.len() < MIN_TREND_BATCHES {
            let _ = writeln!(
                h,
                "<p>{} batch{} so far: a trend is drawn from {MIN_TREND_BATCHES} on; the numbers are in the \
                 tables below.</p>",
                c.batches.len(),
                if c.batches.len() == 1 { "" } else { "es" }
            );
        }
        for energy in &energies {
            let _ = writeln!(h, "<h3>{}</h3>\n<div class=\"grid\">", esc(energy));
            for chart in charts.iter().filter(|x| x.config == c.name && &x.energy == energy) {
                let _ = writeln!(
                    h,
                    "<figure><a href=\"{0}\"><img src=\"{0}\" alt=\"{1}\" loading=\"lazy\"></a><figcaption>{1}</figcaption></figure>",
                    href(&chart.file),
                    esc(&chart.title)
                );
            }
            h += "</div>\n";
            totals_table(&mut h, c, energy, &solvers);
        }
    }
    h += "</body>\n</html>\n";
    h
}

fn batches_table(h: &mut String, c: &ConfigHistory, out: &Path) {
    *h += "<div class=\"scroll\"><table>\n<tr><th>batch</th><th class=\"k\">started</th><th class=\"k\">revision</th>\
           <th class=\"k\">config hash</th><th class=\"k\">source</th><th class=\"k\">host</th><th>cores</th>\
           <th>jobs</th><th>repeats</th><th>calibration (s)</th><th>spread</th><th>ok / runs</th>\
           <th class=\"k\">run folder</th></tr>\n";
    let opt = |v: Option<i64>| v.map_or(String::new(), |x| x.to_string());
    for (b, runs) in c.batches.iter().rev() {
        let ok = runs.iter().filter(|r| r.status == Status::Ok).count();
        let folder = Path::new(&b.run_dir);
        let link = relative_link(out, &folder.join("index.html"));
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td class=\"k\">{}</td><td class=\"k\"><code title=\"{}\">{}</code></td>\
             <td class=\"k\"><code>{}</code></td><td class=\"k\">{}</td><td class=\"k\">{}</td><td>{}</td><td>{}</td>\
             <td>{}</td><td>{}</td><td>{}</td><td>{ok} / {}</td><td class=\"k\"><a href=\"{}\">{}</a></td></tr>",
            b.id,
            b.started_unix.map_or(String::new(), |s| utc(s.max(0) as u64)),
            esc(b.git_revision.as_deref().unwrap_or("unknown")),
            esc(&b.short_revision()),
            esc(&b.config_hash),
            b.source.as_str(),
            esc(b.host.as_deref().unwrap_or("")),
            opt(b.cores),
            opt(b.jobs),
            opt(b.repeats),
            b.calibration_median_s.map_or(String::new(), |x| format!("{x:.3}")),
            b.calibration_spread.map_or(String::new(), |x| format!("{:.0}%", 100.0 * x)),
            runs.len(),
            href(&link),
            esc(&b.run_dir),
        );
    }
    *h += "</table></div>\n";
}

/// What changed in the latest batch since the one before it (iterations, status, final
/// energy beyond `DEFAULT_ENERGY_RTOL`, new flips), and the runs only one of them has.
fn changes_section(h: &mut String, c: &ConfigHistory) {
    let [.., (prev, prev_runs), (last, last_runs)] = c.batches.as_slice() else {
        *h += "<p>One batch so far: nothing to compare with.</p>\n";
        return;
    };
    let _ = writeln!(
        h,
        "<h3>What changed: batch {} ({}) since batch {} ({})</h3>",
        last.id,
        esc(&last.short_revision()),
        prev.id,
        esc(&prev.short_revision())
    );
    changes_body(h, &Changes::between((prev, prev_runs), (last, last_runs)));
}

/// Per batch and solver: solved / runs and the two means to the target.
fn totals_table(h: &mut String, c: &ConfigHistory, energy: &str, solvers: &[String]) {
    let time = time_column(c, energy);
    let caps = Caps::of(c, energy, time);
    let _ = write!(
        h,
        "<details><summary>{} per batch: solved / runs, and the shifted geometric means of iterations and of {} \
         to the target (unsolved runs at the caps: {} iterations, {})</summary><div class=\"scroll\"><table>\n\
         <tr><th class=\"k\">batch</th>",
        esc(energy),
        time.label(),
        caps.iterations,
        caps.time.map_or("no time".to_string(), |t| format!("{t:.3}"))
    );
    for s in solvers {
        let _ = write!(h, "<th>{}</th>", esc(s));
    }
    *h += "</tr>\n";
    for (b, runs) in c.batches.iter().rev() {
        let _ = write!(h, "<tr><td class=\"k\">{} <code>{}</code></td>", b.id, esc(&b.short_revision()));
        for s in solvers {
            match cell(runs, energy, s, time, caps) {
                Some(x) => {
                    let mean = |v: Option<f64>, digits: usize| v.map_or("-".to_string(), |v| format!("{v:.digits$}"));
                    let _ = write!(
                        h,
                        "<td>{}/{}<br><small>{} it, {}</small></td>",
                        x.solved,
                        x.runs,
                        mean(x.sgm_iterations, 1),
                        mean(x.sgm_time, 3)
                    );
                }
                None => *h += "<td class=\"none\"></td>",
            }
        }
        *h += "</tr>\n";
    }
    *h += "</table></div></details>\n";
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::history::{record, trend_dir};
    use crate::paths::absolute;
    use crate::plan::Task;
    use crate::report::plots::tests::png_size;
    use crate::run_folder::{write_summary, SummaryRow};
    use solvers::solver::StopReason;

    /// `record` reads a run folder (meta.json, summary.csv) and appends it, and the trend page
    /// renders from the database it leaves open; the second batch's page names both revisions
    /// and lists the run whose iterations changed, and the totals use `time_norm`.
    #[test]
    fn recording_folders_makes_nights_on_the_trend_page_drawn_from_the_third() {
        let dir = tempfile::tempdir().unwrap();
        let db = dir.path().join("reports/history.sqlite");
        let folder = |name: &str, rev: &str, started: u64, kp_iters: usize| {
            let d = dir.path().join(name);
            std::fs::create_dir_all(&d).unwrap();
            let meta = serde_json::json!({
                "config": {"name": "nightly"}, "plan": ["a__sd__kp-newton", "a__sd__cm"], "repeat": 1,
                "git_revision": rev, "git_dirty": false, "started_unix": started, "ended_unix": started + 9,
                "host": "node", "cores": 2, "jobs": 2, "threads_per_run": 1,
                "calibration_median_s": 0.5, "calibration_spread": 0.02,
            });
            std::fs::write(d.join("meta.json"), meta.to_string()).unwrap();
            let row = |solver: &str, it: usize| SummaryRow {
                dataset: "a".into(),
                task: Task::Param,
                energy: "sd".into(),
                solver: solver.into(),
                iterations: Some(it),
                converged: true,
                stop_reason: Some(StopReason::GradientTolerance.into()),
                final_energy: Some(2.0),
                time_s: Some(0.1 * it as f64),
                time_norm: Some(0.2 * it as f64),
                status: Status::Ok,
                ..Default::default()
            };
            write_summary(&d.join("summary.csv"), &[row("kp-newton", kp_iters), row("cm", 9)]).unwrap();
            d
        };
        let first = record(&db, &folder("night1", "1111111aaaa", 1000, 8)).unwrap();
        let second = record(&db, &folder("night2", "2222222bbbb", 90_000, 11)).unwrap();
        assert_eq!((first.runs, second.batch_id, second.config.as_str()), (2, first.batch_id + 1, "nightly"));
        let page = render(&second.history, Some(&second.config), None, &trend_dir(&db, &second.config)).unwrap();
        assert_eq!(page.index, dir.path().join("reports/history-trend/nightly/index.html"));
        let html = std::fs::read_to_string(&page.index).unwrap();
        for needle in [
            "1111111",
            "2222222",
            "What changed: batch 2 (2222222) since batch 1 (1111111)",
            "a param sd kp-newton",
            "\"../../../night2/index.html\"",
            "2 batches so far: a trend is drawn from 3 on",
        ] {
            assert!(html.contains(needle), "{needle} not in the page:\n{html}");
        }
        assert!(page.plots.is_empty() && !html.contains("<img"), "no chart of two points: {html}");
        // cm did not change: only kp-newton's iterations are listed
        assert!(!html.contains("a param sd cm"), "{html}");
        // A third night draws the trend.
        let third = record(&db, &folder("night3", "3333333cccc", 180_000, 11)).unwrap();
        let page = render(&third.history, Some(&third.config), None, &trend_dir(&db, &third.config)).unwrap();
        let html = std::fs::read_to_string(&page.index).unwrap();
        for needle in [
            "time_norm (time_s / calibration median)",
            "plots/nightly__sd__iterations.png",
            "plots/nightly__sd__time.png",
        ] {
            assert!(html.contains(needle), "{needle} not in the page:\n{html}");
        }
        assert!(!html.contains("so far: a trend"), "{html}");
        let trend = page.index.parent().unwrap();
        assert_eq!(
            page.plots,
            ["plots/nightly__sd__solved.png", "plots/nightly__sd__iterations.png", "plots/nightly__sd__time.png"]
        );
        for png in &page.plots {
            assert_eq!(png_size(&trend.join(png)), (800, 500));
        }
        let h = HistoryDb::open_existing(&db).unwrap();
        assert_eq!(h.last_batch_of(&absolute(&dir.path().join("night2")).display().to_string()).unwrap(), Some(2));
        assert_eq!(h.last_batch_of(&absolute(&dir.path().join("night3")).display().to_string()).unwrap(), Some(3));
    }

    fn judged(solver: &str, dataset: &str, status: Status, iterations: i64, to: Option<(i64, f64)>) -> RunRow {
        RunRow {
            dataset: dataset.into(),
            task: Task::Param,
            energy: "sd".into(),
            solver: solver.into(),
            iterations: Some(iterations),
            status,
            time_s: Some(0.1 * iterations as f64),
            time_norm: Some(0.2 * iterations as f64),
            target_tau: Some(1e-6),
            iters_to_target: to.map(|t| t.0),
            time_s_to_target: to.map(|t| t.1),
            ..Default::default()
        }
    }

    /// A solver that starts failing earlier: its solved count drops and its means rise (the
    /// failed run enters at the cap), where the old mean over the runs that stopped fell.
    /// Solved runs count to the target, not to their own stop; skipped runs are left out.
    #[test]
    fn trend_cells_count_solved_runs_and_means_to_the_target_with_unsolved_at_the_cap() {
        let night = |runs: Vec<RunRow>| (BatchRow::default(), runs);
        let c = ConfigHistory {
            name: "n".into(),
            batches: vec![
                night(vec![
                    judged("cm", "a", Status::Ok, 30, Some((20, 2.0))),
                    judged("cm", "b", Status::Ok, 30, Some((20, 2.0))),
                    judged("slim", "a", Status::NotConverged, 100, None),
                ]),
                night(vec![
                    judged("cm", "a", Status::Ok, 30, Some((20, 2.0))),
                    judged("cm", "b", Status::NotConverged, 3, None),
                    judged("slim", "a", Status::Skipped, 0, None),
                ]),
            ],
        };
        let time = time_column(&c, "sd");
        assert_eq!(time, TimeColumn::Norm);
        let caps = Caps::of(&c, "sd", time);
        assert_eq!(caps, Caps { iterations: 100.0, time: Some(20.0) });
        let first = cell(&c.batches[0].1, "sd", "cm", time, caps).unwrap();
        let second = cell(&c.batches[1].1, "sd", "cm", time, caps).unwrap();
        assert_eq!((first.runs, first.solved, second.runs, second.solved), (2, 2, 2, 1));
        // 20 iterations to the target (not the 30 of its own stop); time_norm 6.0 x 2.0 / 3.0.
        let close = |a: Option<f64>, b: f64| a.is_some_and(|a| (a - b).abs() < 1e-9);
        assert!(close(first.sgm_iterations, 20.0), "{first:?}");
        assert!(close(first.sgm_time, 4.0), "{first:?}");
        // The unsolved run at the cap: sqrt((20 + 10)(100 + 10)) - 10.
        assert!(close(second.sgm_iterations, (30.0f64 * 110.0).sqrt() - 10.0), "{second:?}");
        assert!(second.sgm_iterations > first.sgm_iterations);
        assert!(close(second.sgm_time, ((4.0 + TIME_NORM_SHIFT) * (20.0 + TIME_NORM_SHIFT)).sqrt() - TIME_NORM_SHIFT));
        // Skipped: no cell; unsolved only: at the cap, 0 solved.
        assert_eq!(cell(&c.batches[1].1, "sd", "slim", time, caps), None);
        let slim = cell(&c.batches[0].1, "sd", "slim", time, caps).unwrap();
        assert_eq!((slim.solved, slim.sgm_iterations.map(f64::round)), (0, Some(100.0)));
    }
}
