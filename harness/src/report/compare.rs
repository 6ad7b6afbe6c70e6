//! `compare`'s output: the comparison `gate::compare` computed, as Markdown or as an HTML
//! page (legend, verdict and tables).

use super::html::esc;
use super::tables::{Layout, Table};
use crate::gate::compare::{FolderComparison, TimePair};
use crate::gate::rules::{self, GatedRun, TimeChange};
use crate::run_folder::timed::Timed;

/// A part of the output: a table, or a titled sentence.
enum Section {
    Table(Table),
    Text { title: String, text: String },
}

/// What the flags and the exit code mean; every output ends with it.
fn legend(cmp: &FolderComparison) -> String {
    let o = &cmp.options;
    format!(
        "A is before, B after. Regressions (exit 1) follow the rules of `check`: more iterations than A's plus \
         {tol} (--iterations-tolerance), a worse status (skipped < failed < not_converged < budget < ok; any run that \
         becomes failed), a final energy higher by more than {rtol:e} relative (--energy-rtol), flips where A had \
         none. Times compare {unit}. A time is flagged slower or faster only beyond its noise: when the \
         [min, max] intervals over the repeats do not overlap (the report's ranking rule), or, with a single \
         sample on either side (repeat = 1), when the ratio B/A exceeds {f} either way (asv compare's default \
         factor). {gated} Runs in one folder only are listed and not gated; exit 2 when the folders share no run.",
        tol = o.iterations_tolerance,
        rtol = o.energy_rtol,
        unit = cmp.unit.describe(),
        f = rules::SINGLE_SAMPLE_FACTOR,
        gated = if o.time_regressions {
            "With --time-regressions a slower time is a regression."
        } else {
            "Times are never gated: a flagged time is information, not a regression (--time-regressions gates slower times)."
        },
    )
}

/// The one-line verdict.
fn verdict(cmp: &FolderComparison) -> String {
    format!(
        "{} runs in both folders: {} regressions, {} improvements, {} slower and {} faster times{}, {} only in A, \
         {} only in B (exit {})",
        cmp.pairs.len(),
        cmp.regressions(),
        cmp.improvements(),
        cmp.times(TimeChange::Slower),
        cmp.times(TimeChange::Faster),
        if cmp.options.time_regressions { " (gated)" } else { " (not gated)" },
        cmp.only_a.len(),
        cmp.only_b.len(),
        cmp.exit_code()
    )
}

fn table(title: &str, columns: &[&str], rows: Vec<Vec<String>>, caption: &str) -> Table {
    Table {
        title: title.to_string(),
        columns: columns.iter().map(|c| c.to_string()).collect(),
        rows,
        caption: caption.to_string(),
        bold: Vec::new(),
        layout: Layout::default(),
    }
}

fn sections(cmp: &FolderComparison) -> Vec<Section> {
    let mut out = Vec::new();
    match &cmp.settings {
        None => out
            .push(Section::Text { title: "Settings".into(), text: "Not compared: a folder has no meta.json.".into() }),
        Some(d) if d.is_empty() => {
            out.push(Section::Text { title: "Settings".into(), text: "The same in both meta.json.".into() })
        }
        Some(d) => out.push(Section::Table(table(
            "Settings that differ",
            &["setting", "A", "B"],
            d.iter().map(|s| vec![s.setting.clone(), s.a.clone(), s.b.clone()]).collect(),
            "From meta.json: how the batch ran, the config as written ((unset): its default) and the settings \
             each energy resolved to. The runs are compared all the same.",
        ))),
    }
    if !cmp.provenance.is_empty() {
        out.push(Section::Table(table(
            "Provenance",
            &["", "A", "B"],
            cmp.provenance.iter().map(|(w, a, b)| vec![w.clone(), a.clone(), b.clone()]).collect(),
            "",
        )));
    }
    let change_rows = |regression: bool| -> Vec<Vec<String>> {
        let moved = cmp.pairs.iter().flat_map(|p| &p.changes).filter(|c| c.regression == regression);
        moved
            .map(|c| vec![c.run.clone(), c.metric.into(), c.before.clone(), c.after.clone(), c.delta.clone()])
            .collect()
    };
    let change_columns = ["run", "metric", "A", "B", "delta"];
    let regressions = change_rows(true);
    if !regressions.is_empty() {
        out.push(Section::Table(table("Regressions", &change_columns, regressions, "")));
    }
    let improvements = change_rows(false);
    if !improvements.is_empty() {
        out.push(Section::Table(table("Improvements", &change_columns, improvements, "")));
    }
    out.extend(time_changes(cmp));
    out.push(runs_in_both(cmp));
    for (title, rows) in [("Only in A", &cmp.only_a), ("Only in B", &cmp.only_b)] {
        if !rows.is_empty() {
            out.push(Section::Table(table(
                title,
                &["dataset", "task", "energy", "solver", "iterations", "status"],
                rows.iter()
                    .map(|r| {
                        vec![
                            r.dataset.clone(),
                            r.task.as_str().into(),
                            r.energy.clone(),
                            r.solver.clone(),
                            r.iterations.map_or("-".to_string(), |x| x.to_string()),
                            r.status.to_string(),
                        ]
                    })
                    .collect(),
                "",
            )));
        }
    }
    out
}

/// The runs whose time moved beyond the noise rule, if any.
fn time_changes(cmp: &FolderComparison) -> Option<Section> {
    let timed: Vec<Vec<String>> = cmp
        .pairs
        .iter()
        .filter_map(|p| {
            let t = p.time?;
            let change = t.change?;
            let rule = if t.before.single_sample() || t.after.single_sample() {
                format!("single sample, ratio beyond {}", rules::SINGLE_SAMPLE_FACTOR)
            } else {
                "spreads disjoint".to_string()
            };
            Some(vec![
                GatedRun::from(&p.before).label(),
                t.before.text(),
                t.after.text(),
                ratio(&t),
                change.as_str().into(),
                rule,
            ])
        })
        .collect();
    if timed.is_empty() {
        return None;
    }
    let title = if cmp.options.time_regressions { "Time changes (slower gated)" } else { "Time changes (not gated)" };
    Some(Section::Table(table(title, &["run", "A", "B", "ratio", "change", "rule"], timed, cmp.unit.describe())))
}

/// Every run in both folders, side by side, its regressions in bold.
fn runs_in_both(cmp: &FolderComparison) -> Section {
    let mut runs = table(
        "Runs in both folders",
        &[
            "dataset",
            "task",
            "energy",
            "solver",
            "iterations A",
            "iterations B",
            "status A",
            "status B",
            "final energy A",
            "final energy B",
            "time A",
            "time B",
            "ratio",
            "change",
        ],
        Vec::new(),
        &format!("Times: {}; in parentheses the min–max over the repeats.", cmp.unit.describe()),
    );
    for (i, p) in cmp.pairs.iter().enumerate() {
        let (b, a) = (&p.before, &p.after);
        let count = |v: Option<usize>| v.map_or("-".to_string(), |x| x.to_string());
        let energy = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.8}"));
        let time = |t: Option<Timed>| t.map_or("-".to_string(), |t| t.text());
        let mut change = Vec::new();
        let metrics = |regression: bool| {
            p.changes.iter().filter(|c| c.regression == regression).map(|c| c.metric).collect::<Vec<_>>().join(", ")
        };
        let (worse, better) = (metrics(true), metrics(false));
        if !worse.is_empty() {
            change.push(format!("regression: {worse}"));
        }
        if !better.is_empty() {
            change.push(format!("improvement: {better}"));
        }
        if let Some(c) = p.time.and_then(|t| t.change) {
            change.push(c.as_str().to_string());
        }
        let slower_gated = cmp.options.time_regressions && p.time.and_then(|t| t.change) == Some(TimeChange::Slower);
        if !worse.is_empty() || slower_gated {
            runs.bold.push((i, 13));
        }
        runs.rows.push(vec![
            b.dataset.clone(),
            b.task.as_str().into(),
            b.energy.clone(),
            b.solver.clone(),
            count(b.iterations),
            count(a.iterations),
            b.status.to_string(),
            a.status.to_string(),
            energy(b.final_energy),
            energy(a.final_energy),
            time(p.time.map(|t| t.before)),
            time(p.time.map(|t| t.after)),
            p.time.as_ref().map_or("-".to_string(), ratio),
            change.join("; "),
        ]);
    }
    if runs.rows.is_empty() {
        Section::Text { title: "Runs in both folders".into(), text: "None: nothing to compare.".into() }
    } else {
        Section::Table(runs)
    }
}

fn ratio(t: &TimePair) -> String {
    t.ratio().map_or("-".to_string(), |r| format!("{r:.2}"))
}

/// The comparison as Markdown (what `compare` prints).
pub fn to_markdown(cmp: &FolderComparison) -> String {
    // A `|` in a cell (a path, a setting's value) would end the cell.
    let cell = |c: &str| c.replace('|', "\\|");
    let mut s =
        format!("# mapbench compare\n\nA = `{}` (before), B = `{}` (after)\n\n**{}**\n\n", cmp.a, cmp.b, verdict(cmp));
    for sec in sections(cmp) {
        match sec {
            Section::Table(mut t) => {
                t.rows.iter_mut().flatten().for_each(|c| *c = cell(c));
                t.columns.iter_mut().for_each(|c| *c = cell(c));
                s += t.to_markdown().trim_end();
                s += "\n\n";
            }
            Section::Text { title, text } => s += &format!("### {title}\n\n{text}\n\n"),
        }
    }
    s += &format!("{}\n", legend(cmp));
    s
}

/// The comparison as one self-contained HTML page (`--html FILE`).
pub fn to_html(cmp: &FolderComparison) -> String {
    let mut s = format!(
        "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width\">\n<title>mapbench compare {a} → {b}</title>\n\
         <style>body{{font-family:sans-serif}}table{{border-collapse:collapse}}\
         td,th{{border:1px solid #bbb;padding:2px 6px;text-align:right}}th{{background:#eee}}\
         td:first-child{{text-align:left}}</style>\n</head>\n<body>\n<h1>mapbench compare</h1>\n\
         <p>A = <code>{a}</code> (before), B = <code>{b}</code> (after)</p>\n<p><b>{v}</b></p>\n",
        a = esc(&cmp.a),
        b = esc(&cmp.b),
        v = esc(&verdict(cmp)),
    );
    for sec in sections(cmp) {
        match sec {
            Section::Table(t) => s += &format!("<h3>{}</h3>\n{}", esc(&t.title), t.to_html_fragment()),
            Section::Text { title, text } => s += &format!("<h3>{}</h3>\n<p>{}</p>\n", esc(&title), esc(&text)),
        }
    }
    s += &format!("<p>{}</p>\n</body>\n</html>\n", esc(&legend(cmp)));
    s
}
