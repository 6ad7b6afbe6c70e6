//! The trend page of the history (`mapbench history --out DIR`, and after every `run` and
//! `merge` that appends): per config, its batches in time order; per energy, each solver's
//! mean iterations and mean time per batch (PNG, each tick labelled with the batch's short
//! revision) with the totals in tables; and what changed in the latest batch since the
//! previous one of the same config, by the rules of `check`.

use super::batch::Batch;
use super::changes::Changes;
use super::corpus::{self, EnergyAggregate, SolverAggregate, TimeUnit, ITERATION_SHIFT};
use super::html::{changes_body, esc, href, utc, STYLE};
use super::label::labelled;
use super::plots::trend::{render_trend, TrendLine};
use super::select::unique;
use super::target::at_target;
use crate::history::{BatchRow, HistoryDb, HistoryError, RunRow};
use crate::paths::relative_link;
use crate::run_folder::{write_atomic, Status, SummaryRow};
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

/// A batch's runs as its report ranks them ([`at_target`], clamped SLIM runs labelled) and the
/// caps its unsolved runs enter the means at: the batch's `max_iters` and `timeout` from its
/// run folder's meta.json, or (`caps_known` false: the folder is gone) the most iterations and
/// the longest time of the batch, as a report without meta.json would.
struct Ranked {
    rows: Vec<SummaryRow>,
    batch: Batch,
    caps_known: bool,
}

impl Ranked {
    fn of(b: &BatchRow, runs: &[RunRow]) -> Ranked {
        let rows: Vec<SummaryRow> = runs.iter().map(RunRow::to_summary).collect();
        let folder = Path::new(&b.run_dir);
        let caps_known = !b.run_dir.is_empty() && crate::run_folder::meta_json(folder).exists();
        let batch = if caps_known { Batch::read(folder) } else { Batch::default() };
        Ranked { rows: labelled(&at_target(&rows)), batch, caps_known }
    }

    /// The report's aggregate of one energy of the batch ([`corpus::aggregate`], the function
    /// of its aggregates table), in `unit`.
    fn aggregate(&self, energy: &str, unit: TimeUnit) -> Option<EnergyAggregate> {
        let rows: Vec<SummaryRow> = self.rows.iter().filter(|r| r.energy == energy).cloned().collect();
        corpus::aggregate(&rows, &self.batch, unit).into_iter().next()
    }
}

/// One (batch, energy, solver) of the trend: the report's aggregate of the solver (`None`
/// when every run of it was skipped).
fn cell(agg: Option<&EnergyAggregate>, solver: &str) -> Option<SolverAggregate> {
    agg?.solvers.iter().find(|s| s.solver == solver && s.runs > 0).cloned()
}

/// The time of an energy's trend: calibrated (`time_norm`) when every finished run of every
/// batch shown has it, so that one axis compares nights and machines, else seconds; a batch's
/// numbers equal its report's when its report chose the same.
fn unit_of(ranked: &[Ranked], energy: &str) -> TimeUnit {
    TimeUnit::choose(ranked.iter().flat_map(|r| r.rows.iter()).filter(|r| r.energy == energy))
}

fn time_label(unit: TimeUnit) -> &'static str {
    match unit {
        TimeUnit::Calibrated => "time_norm (time_s / calibration median)",
        TimeUnit::Seconds => "time_s (seconds, not normalized)",
    }
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
    // Each batch turned back into summary rows and its caps read once, for charts and tables.
    let ranked: Vec<Vec<Ranked>> = configs.iter().map(ranked).collect();
    let charts: Vec<Chart> = configs.iter().zip(&ranked).flat_map(|(c, r)| charts_of(c, r)).collect();
    charts
        .par_iter()
        .map(|c| {
            let png = render_trend(&c.title, &c.y_desc, &c.labels, &c.lines(), &c.solvers())?;
            write_atomic(&out.join(&c.file), &png)
        })
        .collect::<anyhow::Result<Vec<()>>>()
        .map_err(render_err(&index))?;
    let html = page(&configs, &ranked, &charts, out);
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

/// The energies of a config's ranked batches, in first-appearance order, and its solvers as
/// the report names them.
fn names(ranked: &[Ranked]) -> (Vec<String>, Vec<String>) {
    let runs = || ranked.iter().flat_map(|r| r.rows.iter());
    let energies = unique(runs().map(|r| r.energy.as_str())).into_iter().map(String::from).collect();
    let solvers = unique(runs().map(|r| r.solver.as_str())).into_iter().map(String::from).collect();
    (energies, solvers)
}

fn ranked(c: &ConfigHistory) -> Vec<Ranked> {
    c.batches.iter().map(|(b, runs)| Ranked::of(b, runs)).collect()
}

/// What a trend chart plots of a cell.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Measure {
    Solved,
    Iterations,
    Time,
}

impl Measure {
    fn of(self, c: &SolverAggregate) -> Option<f64> {
        match self {
            Measure::Solved => Some(c.solved as f64),
            Measure::Iterations => c.sgm_iterations,
            Measure::Time => c.sgm_time.map(|t| t.value),
        }
    }
}

/// The fewest batches a trend chart is drawn for: with one or two, a chart is one or two
/// points and says nothing the table under it does not.
pub const MIN_TREND_BATCHES: usize = 3;

/// The three charts of each energy of a config, per batch: solved runs, and the shifted
/// geometric means of iterations and time to the target (unsolved at the caps); none before
/// [`MIN_TREND_BATCHES`].
fn charts_of(c: &ConfigHistory, ranked: &[Ranked]) -> Vec<Chart> {
    if c.batches.len() < MIN_TREND_BATCHES {
        return Vec::new();
    }
    let (energies, solvers) = names(ranked);
    let labels: Vec<String> = c.batches.iter().map(|(b, _)| b.short_revision()).collect();
    let mut out = Vec::new();
    for energy in &energies {
        let time = unit_of(ranked, energy);
        let aggregates: Vec<Option<EnergyAggregate>> = ranked.iter().map(|r| r.aggregate(energy, time)).collect();
        // Per solver, its cell in each batch: the three charts plot three measures of them.
        let cells: Vec<Vec<Option<SolverAggregate>>> =
            solvers.iter().map(|s| aggregates.iter().map(|a| cell(a.as_ref(), s)).collect()).collect();
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
                    format!("{}, sgm (shift {})", time_label(time), time.shift()),
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

fn page(configs: &[ConfigHistory], ranked: &[Vec<Ranked>], charts: &[Chart], out: &Path) -> String {
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
          that were not skipped, an unsolved run (not converged or failed) entering at the cap: each batch's \
          numbers are its report's aggregates, computed by the same function from the same runs, at that \
          batch's caps (its max_iters and timeout, read from its run folder; where the folder is gone, marked \
          *, the most iterations and the longest time of the batch). A solver that starts failing earlier \
          therefore moves up, not down. Batches recorded before the history kept the target \
          (schema 6) count their solved runs to their own stop. Changes use the rules of \
          <code>mapbench check</code>.</p>\n";
    if configs.len() > 1 {
        h += "<nav>";
        for c in configs {
            let _ = write!(h, "<a href=\"#{}\">{}</a>", href(&c.name), esc(&c.name));
        }
        h += "</nav>\n";
    }
    for (c, ranked) in configs.iter().zip(ranked) {
        let _ = writeln!(h, "<h2 id=\"{}\">{}: {} batches</h2>", esc(&c.name), esc(&c.name), c.batches.len());
        batches_table(&mut h, c, out);
        changes_section(&mut h, c);
        let (energies, solvers) = names(ranked);
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
            totals_table(&mut h, c, ranked, energy, &solvers);
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

/// Per batch and solver: solved / runs and the two means to the target, printed as the
/// report's aggregates table prints them.
fn totals_table(h: &mut String, c: &ConfigHistory, ranked: &[Ranked], energy: &str, solvers: &[String]) {
    let time = unit_of(ranked, energy);
    let _ = write!(
        h,
        "<details><summary>{} per batch: solved / runs, and the shifted geometric means of iterations and of {} \
         to the target (unsolved runs at the batch's caps; * = caps seen in the batch, its run folder gone)\
         </summary><div class=\"scroll\"><table>\n<tr><th class=\"k\">batch</th>",
        esc(energy),
        time_label(time),
    );
    for s in solvers {
        let _ = write!(h, "<th>{}</th>", esc(s));
    }
    *h += "</tr>\n";
    for ((b, _), r) in c.batches.iter().zip(ranked).rev() {
        let mark = if r.caps_known { "" } else { "*" };
        let _ = write!(h, "<tr><td class=\"k\">{} <code>{}</code>{mark}</td>", b.id, esc(&b.short_revision()));
        let agg = r.aggregate(energy, time);
        for s in solvers {
            match cell(agg.as_ref(), s) {
                Some(x) => {
                    let _ = write!(
                        h,
                        "<td>{}/{}<br><small>{} it, {}</small></td>",
                        x.solved,
                        x.runs,
                        x.sgm_iterations.map_or("-".to_string(), |v| format!("{v:.1}")),
                        x.sgm_time.map_or("-".to_string(), |t| t.text())
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

    /// Each batch of the trend is its report's aggregates: the same numbers from the same runs
    /// at the batch's caps. A solver that starts failing earlier: its solved count drops and
    /// its means rise (the failed run enters at the cap); solved runs count to the target, not
    /// to their own stop; skipped runs are left out.
    #[test]
    fn a_batch_of_the_trend_is_its_reports_aggregates() {
        let dir = tempfile::tempdir().unwrap();
        let meta = serde_json::json!({ "config": { "name": "n" }, "stop_per_energy": { "sd": { "max_iters": 100 } } });
        std::fs::write(dir.path().join("meta.json"), meta.to_string()).unwrap();
        let folder = BatchRow { run_dir: dir.path().display().to_string(), ..Default::default() };
        let c = ConfigHistory {
            name: "n".into(),
            batches: vec![
                (
                    BatchRow::default(),
                    vec![
                        judged("cm", "a", Status::Ok, 30, Some((20, 2.0))),
                        judged("cm", "b", Status::Ok, 30, Some((20, 2.0))),
                        judged("slim", "a", Status::NotConverged, 100, None),
                    ],
                ),
                (
                    folder,
                    vec![
                        judged("cm", "a", Status::Ok, 30, Some((20, 2.0))),
                        judged("cm", "b", Status::NotConverged, 3, None),
                        judged("slim", "a", Status::Skipped, 0, None),
                    ],
                ),
            ],
        };
        let ranked = ranked(&c);
        assert_eq!((ranked[0].caps_known, ranked[1].caps_known), (false, true));
        let unit = unit_of(&ranked, "sd");
        assert_eq!(unit, TimeUnit::Calibrated);
        for ((_, runs), r) in c.batches.iter().zip(&ranked) {
            // The batch's report: its tables rank the summary rows to the target, labelled.
            let rows: Vec<SummaryRow> = runs.iter().map(RunRow::to_summary).collect();
            let table = crate::report::tables::aggregates_table(&labelled(&at_target(&rows)), &r.batch).unwrap();
            let agg = r.aggregate("sd", unit);
            for row in &table.rows {
                // A solver skipped on every run has a row there and no cell here.
                if row[2] == "0" {
                    assert!(cell(agg.as_ref(), &row[1]).is_none(), "{row:?}");
                    continue;
                }
                let s = cell(agg.as_ref(), &row[1]).unwrap();
                assert_eq!(row[8], format!("{:.1}", s.sgm_iterations.unwrap()), "{row:?}");
                assert!(row[9].starts_with(&s.sgm_time.unwrap().text()), "{row:?}");
            }
        }
        let first = cell(ranked[0].aggregate("sd", unit).as_ref(), "cm").unwrap();
        let second = cell(ranked[1].aggregate("sd", unit).as_ref(), "cm").unwrap();
        assert_eq!((first.runs, first.solved, second.runs, second.solved), (2, 2, 2, 1));
        // 20 iterations to the target (not the 30 of its own stop); time_norm 6.0 x 2.0 / 3.0.
        let close = |a: Option<f64>, b: f64| a.is_some_and(|a| (a - b).abs() < 1e-9);
        assert!(close(first.sgm_iterations, 20.0), "{first:?}");
        assert!(close(first.sgm_time.map(|t| t.value), 4.0), "{first:?}");
        // The unsolved run at the batch's max_iters: sqrt((20 + 10)(100 + 10)) - 10.
        assert!(close(second.sgm_iterations, (30.0f64 * 110.0).sqrt() - 10.0), "{second:?}");
        assert!(second.sgm_iterations > first.sgm_iterations);
        // Skipped: no cell; unsolved only: at the cap (the batch's most, its folder unknown).
        assert!(cell(ranked[1].aggregate("sd", unit).as_ref(), "slim").is_none());
        let slim = cell(ranked[0].aggregate("sd", unit).as_ref(), "slim").unwrap();
        assert_eq!((slim.solved, slim.sgm_iterations.map(f64::round)), (0, Some(100.0)));
    }
}
