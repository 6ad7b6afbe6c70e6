//! `compare RUN_A RUN_B`: what changed from one run folder (A, before) to another (B, after),
//! the question of `asv compare`. Per run in both: iterations, status, final energy and time
//! before / after / ratio, gated by the rules `check` uses ([`super::rules`]); times are
//! labelled when they moved beyond their noise and are never gated unless asked
//! ([`Options::time_regressions`]). Runs in one folder only are listed, and the settings in
//! which the two batches' `meta.json` differ head the output.

use super::rules::{self, Change, Record, TimeChange};
use crate::report::html::esc;
use crate::report::tables::ranking::Timed;
use crate::report::tables::Table;
use crate::run_folder::{self, SummaryRow};
use anyhow::{bail, Context, Result};
use serde_json::Value;
use std::collections::{BTreeMap, HashSet};
use std::path::Path;

/// How strict the comparison is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Relative tolerance on the final energy (as a baseline's `energy_rtol`).
    pub energy_rtol: f64,
    /// Allowed increase of iterations (as a baseline record's `iterations_tolerance`).
    pub iterations_tolerance: usize,
    /// A time flagged slower is a regression (exit 1). Off by default: times are noisy and
    /// the gate keeps to the deterministic counts.
    pub time_regressions: bool,
}

impl Default for Options {
    fn default() -> Options {
        Options { energy_rtol: rules::DEFAULT_ENERGY_RTOL, iterations_tolerance: 0, time_regressions: false }
    }
}

/// One side of the comparison: a run folder's `summary.csv` rows and its `meta.json`.
#[derive(Clone, Debug, PartialEq)]
pub struct Side {
    /// The folder as given, for the output.
    pub name: String,
    pub rows: Vec<SummaryRow>,
    /// `None` when the folder has no `meta.json`.
    pub meta: Option<Value>,
}

impl Side {
    /// Read a run folder; errors name the file (and line) at fault.
    pub fn load(dir: &Path) -> Result<Side> {
        let rows = run_folder::read_summary(dir)?;
        let summary = run_folder::summary_csv(dir);
        let mut seen = HashSet::new();
        for r in &rows {
            if !seen.insert((r.dataset.as_str(), r.task, r.energy.as_str(), r.solver.as_str())) {
                bail!("{}: run {} appears twice", summary.display(), Record::from(r).label());
            }
        }
        let path = run_folder::meta_json(dir);
        let meta = if path.exists() {
            let text = std::fs::read_to_string(&path).with_context(|| format!("{}: cannot read", path.display()))?;
            Some(serde_json::from_str(&text).with_context(|| format!("{}: invalid JSON", path.display()))?)
        } else {
            None
        };
        Ok(Side { name: dir.display().to_string(), rows, meta })
    }
}

/// Which time the comparison uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeUnit {
    /// `time_norm`, in units of each batch's calibration workload: comparable across nights.
    Norm,
    /// `time_s`, wall seconds: only comparable when the machine was the same and as fast.
    Seconds,
}

impl TimeUnit {
    /// `time_norm` when every timed run of both folders has it, else `time_s`.
    fn of(a: &[SummaryRow], b: &[SummaryRow]) -> TimeUnit {
        let has_norm = |rows: &[SummaryRow]| {
            let timed: Vec<&SummaryRow> = rows.iter().filter(|r| r.time_s.is_some()).collect();
            !timed.is_empty() && timed.iter().all(|r| r.time_norm.is_some())
        };
        if has_norm(a) && has_norm(b) {
            TimeUnit::Norm
        } else {
            TimeUnit::Seconds
        }
    }

    fn timed(self, r: &SummaryRow) -> Option<Timed> {
        match self {
            TimeUnit::Norm => r.time_norm.map(|v| Timed::of(r, v)),
            TimeUnit::Seconds => Timed::time_s(r),
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            TimeUnit::Norm => "time_norm (time_s over each batch's calibration median)",
            TimeUnit::Seconds => "time_s (wall seconds; a folder has no time_norm)",
        }
    }
}

/// A run's time in both folders.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimePair {
    pub before: Timed,
    pub after: Timed,
    /// Beyond the noise, by [`rules::time_change`].
    pub change: Option<TimeChange>,
}

impl TimePair {
    /// after / before, when both are positive measurements.
    pub fn ratio(&self) -> Option<f64> {
        let (b, a) = (self.before.value, self.after.value);
        (b > 0.0 && a > 0.0 && (a / b).is_finite()).then(|| a / b)
    }
}

/// A run in both folders.
#[derive(Clone, Debug, PartialEq)]
pub struct RunPair {
    pub before: SummaryRow,
    pub after: SummaryRow,
    /// The metrics that moved, by the rules of `check`.
    pub changes: Vec<Change>,
    pub time: Option<TimePair>,
}

/// A setting in which the two batches differ.
#[derive(Clone, Debug, PartialEq)]
pub struct SettingDiff {
    pub setting: String,
    pub a: String,
    pub b: String,
}

/// The outcome of comparing two run folders.
#[derive(Clone, Debug, PartialEq)]
pub struct FolderComparison {
    pub a: String,
    pub b: String,
    /// `None` when a folder has no `meta.json` (the settings cannot be compared).
    pub settings: Option<Vec<SettingDiff>>,
    /// Where and how each batch ran: (what, A, B).
    pub provenance: Vec<(String, String, String)>,
    pub unit: TimeUnit,
    /// In A's order.
    pub pairs: Vec<RunPair>,
    pub only_a: Vec<SummaryRow>,
    pub only_b: Vec<SummaryRow>,
    pub options: Options,
}

impl FolderComparison {
    /// Regressed metrics, and slower times when they are gated.
    pub fn regressions(&self) -> usize {
        let metrics = self.pairs.iter().flat_map(|p| &p.changes).filter(|c| c.regression).count();
        metrics + if self.options.time_regressions { self.times(TimeChange::Slower) } else { 0 }
    }

    pub fn improvements(&self) -> usize {
        self.pairs.iter().flat_map(|p| &p.changes).filter(|c| !c.regression).count()
    }

    /// Runs whose time moved `way` beyond the noise.
    pub fn times(&self, way: TimeChange) -> usize {
        self.pairs.iter().filter(|p| p.time.and_then(|t| t.change) == Some(way)).count()
    }

    /// 2 when the folders share no run, 1 on a regression, else 0.
    pub fn exit_code(&self) -> u8 {
        if self.pairs.is_empty() {
            2
        } else if self.regressions() > 0 {
            1
        } else {
            0
        }
    }
}

/// Compare two run folders.
pub fn compare_folders(a: &Path, b: &Path, options: Options) -> Result<FolderComparison> {
    rules::check_energy_rtol(options.energy_rtol).context("--energy-rtol")?;
    Ok(compare(&Side::load(a)?, &Side::load(b)?, options))
}

/// Compare side `a` (before) with side `b` (after).
pub fn compare(a: &Side, b: &Side, options: Options) -> FolderComparison {
    let unit = TimeUnit::of(&a.rows, &b.rows);
    let key = |r: &SummaryRow| (r.dataset.clone(), r.task, r.energy.clone(), r.solver.clone());
    let in_b: BTreeMap<_, &SummaryRow> = b.rows.iter().map(|r| (key(r), r)).collect();
    let in_a: HashSet<_> = a.rows.iter().map(key).collect();
    let mut pairs = Vec::new();
    let mut only_a = Vec::new();
    for before in &a.rows {
        let Some(&after) = in_b.get(&key(before)) else {
            only_a.push(before.clone());
            continue;
        };
        let base = Record { iterations_tolerance: Some(options.iterations_tolerance), ..Record::from(before) };
        let changes = rules::changes(&base, &Record::from(after), options.energy_rtol);
        let time = match (unit.timed(before), unit.timed(after)) {
            (Some(tb), Some(ta)) => Some(TimePair { before: tb, after: ta, change: rules::time_change(&tb, &ta) }),
            _ => None,
        };
        pairs.push(RunPair { before: before.clone(), after: after.clone(), changes, time });
    }
    let only_b = b.rows.iter().filter(|r| !in_a.contains(&key(r))).cloned().collect();
    let settings = match (&a.meta, &b.meta) {
        (Some(ma), Some(mb)) => Some(settings_diff(ma, mb)),
        _ => None,
    };
    FolderComparison {
        a: a.name.clone(),
        b: b.name.clone(),
        settings,
        provenance: provenance(a.meta.as_ref(), b.meta.as_ref()),
        unit,
        pairs,
        only_a,
        only_b,
        options,
    }
}

/// The `meta.json` keys of how a batch ran that change results or times; the rest of
/// `meta.json` is provenance or derived (`plan` is the list of runs, `stop_per_energy`
/// repeats `settings_per_energy`).
const RUN_KEYS: [&str; 7] = ["repeat", "jobs", "threads_per_run", "linear_ordering", "only", "shard", "meshes_dir"];

/// What differs between two `meta.json`: the keys of [`RUN_KEYS`], the config as written
/// (`config.*`, `(unset)` where a side leaves a key to its default) and the settings each
/// energy resolved to (`settings[energies].*`, one line for the energies that differ alike).
pub fn settings_diff(a: &Value, b: &Value) -> Vec<SettingDiff> {
    let mut out = Vec::new();
    let mut diff = |setting: String, va: Option<&String>, vb: Option<&String>| {
        if va != vb {
            let show = |v: Option<&String>| v.cloned().unwrap_or_else(|| "(unset)".into());
            out.push(SettingDiff { setting, a: show(va), b: show(vb) });
        }
    };
    for k in RUN_KEYS {
        let (fa, fb) = (flat(a.get(k), k), flat(b.get(k), k));
        for s in union(&fa, &fb) {
            diff(s.clone(), fa.get(&s), fb.get(&s));
        }
    }
    let (ca, cb) = (flat(a.get("config"), "config"), flat(b.get("config"), "config"));
    for s in union(&ca, &cb) {
        diff(s.clone(), ca.get(&s), cb.get(&s));
    }
    // Per energy, grouped: (setting, A, B) -> the energies where it differs so.
    let per_energy = |m: &Value| m.get("settings_per_energy").and_then(Value::as_object).cloned().unwrap_or_default();
    let (ea, eb) = (per_energy(a), per_energy(b));
    let mut grouped: BTreeMap<(String, Option<String>, Option<String>), Vec<String>> = BTreeMap::new();
    let energies: std::collections::BTreeSet<&String> = ea.keys().chain(eb.keys()).collect();
    for e in energies {
        match (ea.get(e), eb.get(e)) {
            (Some(sa), Some(sb)) => {
                let (fa, fb) = (flat(Some(sa), ""), flat(Some(sb), ""));
                for s in union(&fa, &fb) {
                    let (va, vb) = (fa.get(&s).cloned(), fb.get(&s).cloned());
                    if va != vb {
                        grouped.entry((s, va, vb)).or_default().push(e.clone());
                    }
                }
            }
            (sa, sb) => {
                let present = |v: Option<&Value>| v.map(|_| "(in the batch)".to_string());
                diff(format!("settings[{e}]"), present(sa).as_ref(), present(sb).as_ref());
            }
        }
    }
    for ((s, va, vb), es) in grouped {
        diff(format!("settings[{}].{s}", es.join(", ")), va.as_ref(), vb.as_ref());
    }
    out
}

/// A JSON value as `path -> leaf` (objects descended, arrays and scalars as their JSON, strings
/// bare); a missing value gives no entry.
fn flat(v: Option<&Value>, prefix: &str) -> BTreeMap<String, String> {
    fn walk(path: String, v: &Value, out: &mut BTreeMap<String, String>) {
        match v {
            Value::Object(m) if !m.is_empty() => {
                for (k, x) in m {
                    walk(if path.is_empty() { k.clone() } else { format!("{path}.{k}") }, x, out);
                }
            }
            Value::String(s) => {
                out.insert(path, s.clone());
            }
            other => {
                out.insert(path, other.to_string());
            }
        }
    }
    let mut out = BTreeMap::new();
    if let Some(v) = v {
        walk(prefix.to_string(), v, &mut out);
    }
    out
}

fn union(a: &BTreeMap<String, String>, b: &BTreeMap<String, String>) -> Vec<String> {
    let keys: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
    keys.into_iter().cloned().collect()
}

/// Where and how each batch ran, from `meta.json`: the lines either side has.
fn provenance(a: Option<&Value>, b: Option<&Value>) -> Vec<(String, String, String)> {
    let revision = |m: Option<&Value>| {
        let m = m?;
        let rev = m.get("git_revision")?.as_str()?;
        let dirty = m.get("git_dirty").and_then(Value::as_bool) == Some(true);
        // By characters: a hand-edited meta.json need not be ASCII.
        let short: String = rev.chars().take(12).collect();
        Some(format!("{short}{}", if dirty { " (dirty)" } else { "" }))
    };
    let field = |m: Option<&Value>, k: &str| match m?.get(k)? {
        Value::Null => None,
        Value::String(s) => Some(s.clone()),
        v => Some(v.to_string()),
    };
    let mut out = Vec::new();
    let mut line = |what: &str, va: Option<String>, vb: Option<String>| {
        if va.is_some() || vb.is_some() {
            let show = |v: Option<String>| v.unwrap_or_else(|| "-".into());
            out.push((what.to_string(), show(va), show(vb)));
        }
    };
    line("git revision", revision(a), revision(b));
    for k in [
        "host",
        "cores",
        "mapbench_version",
        "rustc",
        "started_unix",
        "calibration_median_s",
        "calibration_spread",
        "interrupted",
        "resume",
    ] {
        line(k, field(a, k), field(b, k));
    }
    out
}

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
         {tol} (--iterations-tolerance), a worse status (skipped < failed < not_converged < ok; any run that \
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
                Record::from(&p.before).label(),
                t.before.format(3),
                t.after.format(3),
                ratio(&t),
                change.as_str().into(),
                rule,
            ])
        })
        .collect();
    if !timed.is_empty() {
        let title =
            if cmp.options.time_regressions { "Time changes (slower gated)" } else { "Time changes (not gated)" };
        out.push(Section::Table(table(
            title,
            &["run", "A", "B", "ratio", "change", "rule"],
            timed,
            cmp.unit.describe(),
        )));
    }
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
        let time = |t: Option<Timed>| t.map_or("-".to_string(), |t| t.format(3));
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
        out.push(Section::Text { title: "Runs in both folders".into(), text: "None: nothing to compare.".into() });
    } else {
        out.push(Section::Table(runs));
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Task;
    use crate::run_folder::Status;
    use serde_json::json;

    /// A converged run: `time_s` with `repeats` and its spread, `time_norm` = time_s / 2.
    fn row(dataset: &str, solver: &str, iterations: usize, t: (f64, f64, f64), repeats: usize) -> SummaryRow {
        SummaryRow {
            dataset: dataset.into(),
            task: Task::Param,
            energy: "sd".into(),
            solver: solver.into(),
            iterations: Some(iterations),
            final_energy: Some(2.0),
            status: Status::Ok,
            flips: Some(0),
            time_s: Some(t.0),
            time_s_min: Some(t.1),
            time_s_max: Some(t.2),
            repeats: Some(repeats),
            time_norm: Some(t.0 / 2.0),
            ..Default::default()
        }
    }

    fn meta(max_iters: usize, repeat: usize) -> Value {
        let energy = |e: &str| json!({"param": {"energy": {"name": e}, "settings": {"solver": {"stop": {"max_iters": max_iters, "grad_tol": 1e-3}}}}});
        // The config as written: `[stop]` only when the batch set it.
        let mut config = json!({"name": "n", "datasets": ["d"]});
        if max_iters != 1000 {
            config["stop"] = json!({"max_iters": max_iters});
        }
        json!({
            "config": config,
            "settings_per_energy": {"sd": energy("sd"), "bconf": energy("bconf")},
            "repeat": repeat, "jobs": 1, "git_revision": "0123456789abcdef0123", "git_dirty": true, "host": "h",
        })
    }

    fn side(name: &str, rows: Vec<SummaryRow>) -> Side {
        Side { name: name.into(), rows, meta: Some(meta(1000, 3)) }
    }

    const SPREAD: (f64, f64, f64) = (1.0, 0.9, 1.1);

    #[test]
    fn exit_codes_no_change_regression_and_nothing_shared() {
        let a = side("A", vec![row("d", "kp", 10, SPREAD, 3), row("d", "cm", 8, SPREAD, 3)]);
        let same = compare(&a, &a, Options::default());
        assert_eq!((same.exit_code(), same.pairs.len(), same.regressions()), (0, 2, 0));
        let b = side("B", vec![row("d", "kp", 11, SPREAD, 3), row("d", "cm", 7, SPREAD, 3)]);
        let c = compare(&a, &b, Options::default());
        assert_eq!((c.exit_code(), c.regressions(), c.improvements()), (1, 1, 1));
        // The iteration tolerance is check's per-record one, given for every run.
        let tolerant = Options { iterations_tolerance: 1, ..Options::default() };
        assert_eq!(compare(&a, &b, tolerant).exit_code(), 0);
        // Worse status and higher energy, by the same rules.
        let worse = Record { status: Status::NotConverged, ..Record::from(&a.rows[0]) };
        let mut nc = a.rows[0].clone();
        nc.status = worse.status;
        let c = compare(&a, &side("B", vec![nc]), Options::default());
        assert_eq!((c.exit_code(), c.pairs[0].changes[0].metric), (1, "status"));
        let mut higher = a.rows[0].clone();
        higher.final_energy = Some(2.0 * (1.0 + 1e-5));
        assert_eq!(compare(&a, &side("B", vec![higher.clone()]), Options::default()).exit_code(), 1);
        let loose = Options { energy_rtol: 1e-4, ..Options::default() };
        assert_eq!(compare(&a, &side("B", vec![higher]), loose).exit_code(), 0);
        // No run in both: exit 2, whatever else.
        let other = side("C", vec![row("e", "kp", 10, SPREAD, 3)]);
        let c = compare(&a, &other, Options::default());
        assert_eq!((c.exit_code(), c.only_a.len(), c.only_b.len()), (2, 2, 1));
        assert!(to_markdown(&c).contains("(exit 2)"));
    }

    #[test]
    fn times_are_flagged_only_outside_the_spread_and_never_gated_by_default() {
        let a = side("A", vec![row("d", "kp", 10, SPREAD, 3), row("d", "cm", 8, SPREAD, 3)]);
        // kp: 1.4x slower but the intervals overlap; cm: 1.2x, disjoint.
        let b = side("B", vec![row("d", "kp", 10, (1.4, 1.05, 1.6), 3), row("d", "cm", 8, (1.2, 1.15, 1.3), 3)]);
        let c = compare(&a, &b, Options::default());
        assert_eq!(c.unit, TimeUnit::Norm);
        let flags: Vec<_> = c.pairs.iter().map(|p| p.time.unwrap().change).collect();
        assert_eq!(flags, [None, Some(TimeChange::Slower)]);
        assert!((c.pairs[1].time.unwrap().ratio().unwrap() - 1.2).abs() < 1e-12);
        assert_eq!((c.exit_code(), c.times(TimeChange::Slower)), (0, 1), "times are not gated");
        let md = to_markdown(&c);
        assert!(md.contains("spreads disjoint") && md.contains("Times are never gated"), "{md}");
        // In time_norm units (time_s / 2 here), spread scaled alike.
        assert!(md.contains("| 0.500 (0.450–0.550) | 0.600 (0.575–0.650) | 1.20 | slower"), "{md}");
        // --time-regressions: a slower time is a regression.
        let gated = Options { time_regressions: true, ..Options::default() };
        assert_eq!(compare(&a, &b, gated).exit_code(), 1);
        // Faster beyond the spread: labelled, never a regression.
        let fast = side("B", vec![row("d", "kp", 10, (0.5, 0.45, 0.55), 3)]);
        let c = compare(&a, &fast, gated);
        assert_eq!((c.pairs[0].time.unwrap().change, c.exit_code()), (Some(TimeChange::Faster), 0));
    }

    #[test]
    fn single_samples_use_asvs_factor_and_seconds_without_time_norm() {
        let one = |t: f64| row("d", "kp", 10, (t, t, t), 1);
        let a = side("A", vec![one(1.0)]);
        for (t, flag) in [(1.09, None), (1.11, Some(TimeChange::Slower)), (0.9, Some(TimeChange::Faster))] {
            let c = compare(&a, &side("B", vec![one(t)]), Options::default());
            assert_eq!(c.pairs[0].time.unwrap().change, flag, "{t}");
        }
        let c = compare(&a, &side("B", vec![one(1.2)]), Options::default());
        assert!(to_markdown(&c).contains("single sample, ratio beyond 1.1"));
        // A folder without time_norm: both compare time_s.
        let mut old = one(1.2);
        old.time_norm = None;
        let c = compare(&a, &side("B", vec![old]), Options::default());
        assert_eq!(c.unit, TimeUnit::Seconds);
        assert!(to_markdown(&c).contains("| 1.000 | 1.200 | 1.20 | slower"));
        // A run without a time (failed) has none to compare.
        let failed = SummaryRow { status: Status::Failed, time_s: None, time_norm: None, ..one(1.0) };
        let c = compare(&a, &side("B", vec![failed]), Options::default());
        assert_eq!((c.pairs[0].time, c.exit_code()), (None, 1));
    }

    #[test]
    fn runs_on_one_side_only_are_listed() {
        let a = side("A", vec![row("d", "kp", 10, SPREAD, 3), row("gone", "kp", 5, SPREAD, 3)]);
        let b = side("B", vec![row("d", "kp", 10, SPREAD, 3), row("new", "cm", 7, SPREAD, 3)]);
        let c = compare(&a, &b, Options::default());
        assert_eq!(c.exit_code(), 0, "a run on one side only is not a regression");
        let md = to_markdown(&c);
        let only_a = md.find("### Only in A").unwrap();
        let only_b = md.find("### Only in B").unwrap();
        assert!(md[only_a..only_b].contains("| gone | param | sd | kp | 5 | ok |"), "{md}");
        assert!(md[only_b..].contains("| new | param | sd | cm | 7 | ok |"), "{md}");
        assert!(md.contains("1 only in A, 1 only in B"));
    }

    #[test]
    fn differing_settings_head_the_output() {
        let a = side("A", vec![row("d", "kp", 10, SPREAD, 3)]);
        let mut b = side("B", vec![row("d", "kp", 5, SPREAD, 3)]);
        b.meta = Some(meta(5, 1));
        let c = compare(&a, &b, Options::default());
        let d = c.settings.as_ref().unwrap();
        let line = |s: &str| d.iter().find(|x| x.setting == s).map(|x| (x.a.as_str(), x.b.as_str()));
        assert_eq!(line("repeat"), Some(("3", "1")));
        assert_eq!(line("config.stop.max_iters"), Some(("(unset)", "5")));
        // Both energies moved alike: one line.
        assert_eq!(line("settings[bconf, sd].param.settings.solver.stop.max_iters"), Some(("1000", "5")));
        assert_eq!(d.len(), 3, "{d:?}");
        let md = to_markdown(&c);
        let first = md.find("### ").unwrap();
        assert!(md[first..].starts_with("### Settings that differ"), "{md}");
        assert!(md.contains("| repeat | 3 | 1 |") && md.contains("| git revision | 0123456789ab (dirty) |"), "{md}");
        // Identical settings, and a folder without meta.json, say so.
        assert!(to_markdown(&compare(&a, &a, Options::default())).contains("### Settings\n\nThe same in both"));
        b.meta = None;
        let c = compare(&a, &b, Options::default());
        assert_eq!(c.settings, None);
        assert!(to_markdown(&c).contains("Not compared: a folder has no meta.json."));
        // An energy in one batch only is one line, not one per key.
        let mut m = meta(1000, 3);
        m["settings_per_energy"].as_object_mut().unwrap().remove("bconf");
        let d = settings_diff(&meta(1000, 3), &m);
        assert_eq!(
            d,
            [SettingDiff { setting: "settings[bconf]".into(), a: "(in the batch)".into(), b: "(unset)".into() }]
        );
    }

    #[test]
    fn html_is_one_escaped_page_and_markdown_cells_keep_their_pipes() {
        let mut a = side("A<&>|", vec![row("d", "kp", 10, SPREAD, 3)]);
        a.meta.as_mut().unwrap()["config"]["name"] = json!("x|<y>");
        let b = side("B", vec![row("d", "kp", 12, SPREAD, 3)]);
        let c = compare(&a, &b, Options::default());
        let html = to_html(&c);
        assert!(html.starts_with("<!doctype html>\n<html lang=\"en\">") && html.ends_with("</body>\n</html>\n"));
        for (open, close) in [("<table>", "</table>"), ("<tr>", "</tr>"), ("<h3>", "</h3>"), ("<p>", "</p>")] {
            assert_eq!(html.matches(open).count(), html.matches(close).count(), "{open}");
        }
        assert!(html.contains("A&lt;&amp;&gt;|") && html.contains("x|&lt;y&gt;") && !html.contains("<y>"));
        assert!(html.contains("<td><b>regression: iterations</b></td>"), "{html}");
        let md = to_markdown(&c);
        assert!(md.contains("| config.name | x\\|<y> | n |"), "{md}");
    }

    #[test]
    fn a_folder_listing_a_run_twice_is_refused_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let r = row("d", "kp", 10, SPREAD, 3);
        run_folder::write_summary(&run_folder::summary_csv(dir.path()), &[r.clone(), r]).unwrap();
        let e = format!("{:#}", Side::load(dir.path()).unwrap_err());
        assert!(e.contains("summary.csv: run d param sd kp appears twice"), "{e}");
        let bad = Options { energy_rtol: -1.0, ..Options::default() };
        let e = format!("{:#}", compare_folders(dir.path(), dir.path(), bad).unwrap_err());
        assert!(e.contains("--energy-rtol") && e.contains("non-negative"), "{e}");
    }

    /// Found by review: the revision was cut at byte 12, a panic inside a multi-byte character.
    #[test]
    fn a_non_ascii_revision_is_shortened_by_characters() {
        let m = json!({"git_revision": "ééééééééééééééé"});
        let p = provenance(Some(&m), None);
        assert_eq!(p[0], ("git revision".to_string(), "éééééééééééé".to_string(), "-".to_string()));
    }
}
