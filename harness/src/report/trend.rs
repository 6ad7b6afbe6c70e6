//! The trend page of the history (`mapbench history --out DIR`, and after every `run` and
//! `merge` that appends): per config, its batches in time order; per energy, each solver's
//! mean iterations and mean time per batch (PNG, each tick labelled with the batch's short
//! revision) with the totals in tables; and what changed in the latest batch since the
//! previous one of the same config, by the rules of `check`.

use super::changes::Changes;
use super::html::{esc, href, utc, STYLE};
use super::plots::trend::{render_trend, TrendLine};
use super::unique;
use crate::gate::check::DEFAULT_ENERGY_RTOL;
use crate::gate::rules::Change;
use crate::history::{BatchRow, HistoryDb, HistoryError, RunRow};
use crate::paths::relative_link;
use crate::run_folder::{write_atomic, Status};
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
    matches!(r.status, Status::Ok | Status::NotConverged) && r.iterations.is_some()
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
}

/// Totals of one (batch, energy, solver) cell over its counted runs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Cell {
    runs: usize,
    iterations: i64,
    time: f64,
    /// Runs of the cell without the chosen time column (left out of `time`).
    untimed: usize,
}

impl Cell {
    fn mean_iterations(&self) -> f64 {
        self.iterations as f64 / self.runs as f64
    }
    fn mean_time(&self) -> Option<f64> {
        let timed = self.runs - self.untimed;
        (timed > 0).then(|| self.time / timed as f64)
    }
}

fn cell(runs: &[RunRow], energy: &str, solver: &str, time: TimeColumn) -> Option<Cell> {
    let mut c = Cell::default();
    for r in runs.iter().filter(|r| r.energy == energy && r.solver == solver && counted(r)) {
        c.runs += 1;
        c.iterations += r.iterations.unwrap_or(0);
        match time.of(r) {
            Some(t) => c.time += t,
            None => c.untimed += 1,
        }
    }
    (c.runs > 0).then_some(c)
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

/// The two charts of each energy of a config: mean iterations and mean time per batch.
fn charts_of(c: &ConfigHistory) -> Vec<Chart> {
    let (energies, solvers) = names(c);
    let labels: Vec<String> = c.batches.iter().map(|(b, _)| b.short_revision()).collect();
    let mut out = Vec::new();
    for energy in &energies {
        let time = time_column(c, energy);
        for iterations in [true, false] {
            let values: Vec<(String, Vec<(usize, f64)>)> = solvers
                .iter()
                .map(|s| {
                    let pts = c
                        .batches
                        .iter()
                        .enumerate()
                        .filter_map(|(i, (_, runs))| {
                            let cell = cell(runs, energy, s, time)?;
                            let v = if iterations { Some(cell.mean_iterations()) } else { cell.mean_time() };
                            v.map(|v| (i, v))
                        })
                        .collect();
                    (s.clone(), pts)
                })
                .filter(|(_, p): &(String, Vec<_>)| !p.is_empty())
                .collect();
            if values.is_empty() {
                continue;
            }
            let (suffix, what, y_desc) = if iterations {
                ("iterations", "mean iterations per batch", "mean iterations".to_string())
            } else {
                ("time", "mean time per batch", format!("mean {}", time.label()))
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
          was dirty). Means and totals count the runs that ran to a stop (ok or not converged); failed and skipped \
          runs are left out. Changes use the rules of <code>mapbench check</code>.</p>\n";
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

/// The changes of one batch since another: a warning when the settings differ, the changed
/// metrics (worse first) and the runs only one batch has. Shared with the report's first
/// screen.
pub(crate) fn changes_body(h: &mut String, ch: &Changes) {
    let cmp = &ch.comparison;
    if ch.settings_differ() {
        *h += "<p class=\"warn\">The two batches ran different configs or plans (config hash differs): changes may \
               come from the settings, not the code.</p>\n";
    }
    if ch.is_quiet() {
        let _ = writeln!(
            h,
            "<p>No change in iterations, status or final energy (rel. tol. {DEFAULT_ENERGY_RTOL:e}) over {} runs.</p>",
            cmp.compared
        );
        return;
    }
    let _ = writeln!(
        h,
        "<p>{} of {} runs in both changed: {} regressions, {} improvements.</p>",
        unique(cmp.changes.iter().map(|c| c.run.as_str())).len(),
        cmp.compared,
        ch.regressions(),
        ch.improvements()
    );
    let worse: Vec<&Change> = cmp.changes.iter().filter(|c| c.regression).collect();
    let better: Vec<&Change> = cmp.changes.iter().filter(|c| !c.regression).collect();
    // Every regression counts, but the first screen shows the first few.
    change_table(h, &worse[..worse.len().min(FOLD)]);
    if worse.len() > FOLD {
        let _ = write!(h, "<details><summary>{} more regressions</summary>", worse.len() - FOLD);
        change_table(h, &worse[FOLD..]);
        *h += "</details>\n";
    }
    // Improvements matter less in the morning: many of them fold away.
    if better.len() > FOLD {
        let _ = write!(h, "<details><summary>{} improvements</summary>", better.len());
        change_table(h, &better);
        *h += "</details>\n";
    } else {
        change_table(h, &better);
    }
    for (what, list) in [("Only in the previous batch", &cmp.missing), ("New in the latest batch", &ch.added)] {
        if !list.is_empty() {
            let _ = writeln!(h, "<p>{what} ({}): {}</p>", list.len(), esc(&list.join(", ")));
        }
    }
}

/// Regressions past this many, and improvements when more, are folded.
const FOLD: usize = 8;

fn change_table(h: &mut String, changes: &[&Change]) {
    if changes.is_empty() {
        return;
    }
    *h += "<div class=\"scroll\"><table>\n<tr><th class=\"k\">run</th><th class=\"k\">metric</th><th>before</th>\
           <th>after</th><th>delta</th><th class=\"k\"></th></tr>\n";
    for change in changes {
        let _ = writeln!(
            h,
            "<tr class=\"{}\"><td class=\"k\">{}</td><td class=\"k\">{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"k\">{}</td></tr>",
            if change.regression { "failed" } else { "ok" },
            esc(&change.run),
            change.metric,
            esc(&change.before),
            esc(&change.after),
            esc(&change.delta),
            if change.regression { "worse" } else { "better" }
        );
    }
    *h += "</table></div>\n";
}

/// Per batch and solver: total iterations (mean) and total time (mean) of an energy.
fn totals_table(h: &mut String, c: &ConfigHistory, energy: &str, solvers: &[String]) {
    let time = time_column(c, energy);
    let _ = write!(
        h,
        "<details><summary>{} per batch: total iterations (mean) and total {} (mean), runs counted</summary>\
         <div class=\"scroll\"><table>\n<tr><th class=\"k\">batch</th>",
        esc(energy),
        time.label()
    );
    for s in solvers {
        let _ = write!(h, "<th>{}</th>", esc(s));
    }
    *h += "</tr>\n";
    for (b, runs) in c.batches.iter().rev() {
        let _ = write!(h, "<tr><td class=\"k\">{} <code>{}</code></td>", b.id, esc(&b.short_revision()));
        for s in solvers {
            match cell(runs, energy, s, time) {
                Some(x) => {
                    let t = x.mean_time().map_or("-".to_string(), |m| format!("{:.3} ({m:.3})", x.time));
                    let _ = write!(
                        h,
                        "<td>{} ({:.1})<br><small>{t}, n = {}</small></td>",
                        x.iterations,
                        x.mean_iterations(),
                        x.runs
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
    fn recording_two_folders_makes_two_nights_on_the_trend_page() {
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
                stop_reason: Some(StopReason::GradientTolerance),
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
            "time_norm (time_s / calibration median)",
            "\"../../../night2/index.html\"",
            "plots/nightly__sd__iterations.png",
            "plots/nightly__sd__time.png",
        ] {
            assert!(html.contains(needle), "{needle} not in the page:\n{html}");
        }
        // cm did not change: only kp-newton's iterations are listed
        assert!(!html.contains("a param sd cm"), "{html}");
        let trend = page.index.parent().unwrap();
        assert_eq!(page.plots, ["plots/nightly__sd__iterations.png", "plots/nightly__sd__time.png"]);
        for png in &page.plots {
            assert_eq!(png_size(&trend.join(png)), (800, 500));
        }
        let h = HistoryDb::open_existing(&db).unwrap();
        assert_eq!(h.last_batch_of(&absolute(&dir.path().join("night2")).display().to_string()).unwrap(), Some(2));
    }
}
