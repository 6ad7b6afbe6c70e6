//! `index.html` of a run folder: one self-contained page (inline CSS, no script, no network,
//! relative links only) with how the batch was timed (repeats, machine calibration and a
//! warning when the machine changed speed), the run status matrix, the tables with the corpus
//! aggregates and performance profiles, the plots, links to every file and the provenance
//! from `meta.json`. Readable on a phone: images scale down and
//! wide tables scroll sideways in their own box.

use crate::calibration::SPREAD_WARNING;
use crate::judge::verdict::Verdict;
use crate::report::batch::Batch;
use crate::report::plots::{Plot, PlotKind};
use crate::report::tables::ranking::Timed;
use crate::report::tables::{Table, AGGREGATES};
use crate::report::{clamped_label, reached_target, tau_text, tightest_target, to_target, unique, verdict_text};
use crate::run_folder::summary::RefSource;
use crate::run_folder::{run_stem, write_atomic, Status, SummaryRow};
use anyhow::{Context, Result};
use serde_json::Value;
use std::fmt::Write as _;
use std::path::Path;

pub(crate) const STYLE: &str = "\
body{font-family:system-ui,sans-serif;margin:0 auto;padding:0 12px 40px;max-width:1200px;line-height:1.4;color:#222}\
h1{font-size:1.5em;margin:.6em 0 .2em}h2{border-bottom:1px solid #ccc;margin-top:1.6em}h3{margin:1.2em 0 .4em}\
nav a{margin-right:1em}\
.scroll{overflow-x:auto;-webkit-overflow-scrolling:touch;margin:.4em 0}\
table{border-collapse:collapse;font-size:.9em}td,th{border:1px solid #bbb;padding:3px 7px;text-align:right;vertical-align:top}td{white-space:nowrap}\
th{background:#eee}td.k,th.k{text-align:left;white-space:nowrap}\
table.status td,table.status th{text-align:center;white-space:nowrap}table.status td.k{text-align:left;background:#fff}\
.ds{position:sticky;left:0;z-index:1}table.status th.ds{background:#eee}\
.ok{background:#d8f0d8}.nc{background:#fff0c2}.failed{background:#f6d0d3}.skipped{background:#e4e4e4;color:#666}\
table.status td.failed{text-align:left;white-space:normal;min-width:12em;max-width:22em;word-break:break-word}\
td.none{background:#f4f4f4;color:#999}td a{color:inherit;text-decoration:none}td small{color:#555}\
img{max-width:100%;height:auto}\
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(min(100%,400px),1fr));gap:14px}\
.maps{display:grid;grid-template-columns:repeat(auto-fill,minmax(min(45%,200px),1fr));gap:10px}\
figure{margin:0}figcaption{font-size:.85em;color:#444}\
dl{display:grid;grid-template-columns:max-content 1fr;gap:2px 14px}dt{font-weight:600}dd{margin:0;word-break:break-all}\
ul.files{columns:2 22em;font-size:.9em}code,pre{font-size:.85em}pre{overflow-x:auto;background:#f6f6f6;padding:6px}\
.caption{color:#444;font-size:.9em}\
.warn{background:#fde2c8;border:1px solid #d9822b;padding:6px 10px}";

/// Write `run_dir/index.html` from the summary rows, the tables (file stem, table), the
/// plots `render_all` wrote and the batch's calibration; the rest (meta.json, file lists) is
/// read from `run_dir`.
pub fn write_index(
    run_dir: &Path,
    summaries: &[SummaryRow],
    tables: &[(String, Table)],
    plots: &[Plot],
    batch: &Batch,
) -> Result<()> {
    let meta = read_meta(run_dir)?;
    let cfg = meta.as_ref().and_then(|m| m.get("config"));
    let name = cfg.and_then(|c| c.get("name")).and_then(Value::as_str).unwrap_or("run");
    let task = cfg
        .and_then(|c| c.get("task"))
        .and_then(Value::as_str)
        .map(str::to_string)
        .or_else(|| summaries.first().map(|s| s.task.as_str().to_string()))
        .unwrap_or_default();
    let mut h = String::new();
    let _ = write!(
        h,
        "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>mapbench: {n}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n\
         <h1>mapbench report: {n}</h1>\n<p>task <b>{t}</b>; {c}</p>\n\
         <nav><a href=\"#status\">status</a><a href=\"#tables\">tables</a><a href=\"#plots\">plots</a>\
         <a href=\"#files\">files</a><a href=\"#provenance\">provenance</a></nav>\n",
        n = esc(name),
        t = esc(&task),
        c = esc(&counts(summaries)),
    );
    history_link(&mut h, run_dir, meta.as_ref(), name);
    timing_section(&mut h, summaries, batch);
    status_matrix(&mut h, run_dir, summaries);
    tables_section(&mut h, run_dir, tables, plots, summaries);
    plots_section(&mut h, run_dir, plots);
    files_section(&mut h, run_dir, summaries, tables)?;
    provenance_section(&mut h, meta.as_ref());
    h += "</body>\n</html>\n";
    write_atomic(&run_dir.join("index.html"), h.as_bytes())
}

/// The link to the trend page of this config's history, when the batch was appended to one
/// and the page rendered (`meta.json`'s `history_outcome`, set by `run` and `merge` before the
/// report); relative, so the folders can move together.
fn history_link(h: &mut String, run_dir: &Path, meta: Option<&Value>, name: &str) {
    let outcome =
        meta.and_then(|m| serde_json::from_value::<crate::history::Outcome>(m.get("history_outcome")?.clone()).ok());
    let Some(outcome) = outcome else {
        return;
    };
    let Some((db, _, Some(page))) = outcome.in_history() else { return };
    let _ = writeln!(
        h,
        "<p>History: <a href=\"{}\">trend of {} over its batches</a> (database <code>{}</code>)</p>",
        href(&crate::paths::relative_link(run_dir, page)),
        esc(name),
        esc(&db.display().to_string())
    );
}

/// `meta.json`, or `None` when the folder has none (e.g. written by an older version).
fn read_meta(run_dir: &Path) -> Result<Option<Value>> {
    let path = run_dir.join("meta.json");
    if !path.exists() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&path).with_context(|| format!("{}: cannot read", path.display()))?;
    let v = serde_json::from_str(&text).with_context(|| format!("{}: invalid JSON", path.display()))?;
    Ok(Some(v))
}

/// HTML-escape text for element content and quoted attribute values.
pub fn esc(t: &str) -> String {
    let mut s = String::with_capacity(t.len());
    for c in t.chars() {
        match c {
            '&' => s += "&amp;",
            '<' => s += "&lt;",
            '>' => s += "&gt;",
            '"' => s += "&quot;",
            '\'' => s += "&#39;",
            _ => s.push(c),
        }
    }
    s
}

/// A relative link target: percent-encode all but unreserved characters and `/`, then escape.
pub(crate) fn href(path: &str) -> String {
    let mut s = String::new();
    for b in path.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~/".contains(&b) {
            s.push(b as char);
        } else {
            let _ = write!(s, "%{b:02X}");
        }
    }
    esc(&s)
}

fn counts(summaries: &[SummaryRow]) -> String {
    let n = |st: Status| summaries.iter().filter(|s| s.status == st).count();
    format!(
        "{} runs: {} ok, {} not converged, {} failed, {} skipped",
        summaries.len(),
        n(Status::Ok),
        n(Status::NotConverged),
        n(Status::Failed),
        n(Status::Skipped)
    )
}

/// How the times were taken: the repeats, the machine calibration of `meta.json` and, when
/// its spread exceeds [`SPREAD_WARNING`], a visible warning.
fn timing_section(h: &mut String, summaries: &[SummaryRow], batch: &Batch) {
    let repeats = summaries.iter().filter_map(|s| s.repeats).max().unwrap_or(1);
    let mut p = if repeats > 1 {
        format!(
            "Each run was repeated {repeats} times, round-robin over the plan; times are the median over \
             the repeats, with their min–max in parentheses, and ranked times tie when these intervals overlap."
        )
    } else {
        "Each run was timed once (repeat = 1): times are single samples, so rankings cannot tell \
         differences within the machine's noise (marked † in the tables)."
            .to_string()
    };
    let calibration = batch.calibration.as_ref().and_then(|c| Some((c, c.median_s()?, c.spread()?)));
    match calibration {
        Some((c, median, spread)) => {
            let _ = write!(
                p,
                " Machine calibration ({}): median {} over {} samples, spread {:.1}% ((max − min) / median); \
                 time_norm = time_s / {}.",
                c.workload,
                seconds(median),
                c.samples_s.len(),
                100.0 * spread,
                seconds(median)
            );
        }
        None => p += " No machine calibration in meta.json: times are not normalized (time_norm empty).",
    }
    let _ = writeln!(h, "<p class=\"caption\" id=\"timing\">{}</p>", esc(&p));
    if let Some((c, _, spread)) = calibration.filter(|(c, _, _)| c.unsteady()) {
        let _ = writeln!(
            h,
            "<p class=\"warn\"><b>Warning: the machine changed speed during this batch.</b> The calibration \
             samples ({}) spread by {:.1}%, more than {:.0}%: times of runs taken at different moments \
             differ by more than their repeats show, and time rankings are less certain.</p>",
            esc(&c.samples_s.iter().map(|t| seconds(*t)).collect::<Vec<_>>().join(", ")),
            100.0 * spread,
            100.0 * SPREAD_WARNING
        );
    }
}

/// Seconds with 3 significant digits (0.0431 s, 6.59 s, 123 s).
fn seconds(t: f64) -> String {
    format!("{} s", significant(t))
}

/// 3 significant digits (0.0431, 6.59, 123).
fn significant(t: f64) -> String {
    let digits = if t <= 0.0 { 3 } else { (2 - t.abs().log10().floor() as i64).clamp(0, 6) as usize };
    format!("{t:.digits$}")
}

/// `0.0538 s`, or with a spread over repeats `0.0538 s (0.0521–0.0560)`.
fn timed_seconds(t: &Timed) -> String {
    if t.single_sample() {
        seconds(t.value)
    } else {
        format!("{} ({}–{})", seconds(t.value), significant(t.lo), significant(t.hi))
    }
}

/// Rows: dataset (and energy, when the run has several), columns: solver. Each cell links to
/// the run's per-iteration CSV when it exists.
fn status_matrix(h: &mut String, run_dir: &Path, summaries: &[SummaryRow]) {
    let solvers = unique(summaries.iter().map(|s| s.solver.as_str()));
    let datasets = unique(summaries.iter().map(|s| s.dataset.as_str()));
    let several_energies = unique(summaries.iter().map(|s| s.energy.as_str())).len() > 1;
    *h += "<h2 id=\"status\">Run status</h2>\n<p class=\"caption\">Each cell: status, iterations and \
           time (the median, with the min–max over the repeats in parentheses); click it for the run's \
           per-iteration CSV. <span class=\"ok\">ok</span> converged; \
           <span class=\"nc\">yellow</span> stopped by another rule (shown); \
           <span class=\"failed\">failed</span> with its error; <span class=\"skipped\">skipped</span>: not \
           run, the solver is not defined for the energy (the reason shown; left out of every aggregate and \
           ranking). “k shifted”: k iterations solved their Newton system with a Tikhonov shift above the \
           base (regularized Newton); “k CG-capped”: k steps of a truncated solver stopped CG at its \
           iteration cap short of the forcing term; “k clamped”: k iterations clamped SLIM weights (the solver run \
           outside the energies it is defined for; tables and profiles name it “slim (clamped)”).";
    if let Some(tau) = tightest_target(summaries) {
        let t = tau_text(tau);
        let _ = write!(
            h,
            " The harness judges param and deform runs against the reference minimum E* of their dataset and \
             energy, whatever the solver's own stop rule said: <span class=\"ok\">ok</span> = solved, the run \
             reached the {t} target (E0 − E ≥ (1 − {t})(E0 − E*)) with no flipped triangle, and its cell shows \
             the iterations and time <i>to the target</i> (“to {t}”; the tooltip gives its own stop). A yellow \
             cell names the harness's verdict and the final gap (E_final − E*)/(E0 − E*), with the iterations \
             and time to the target when the run reached it, else to its own stop: <b>stopped above target</b> = its own rule called it converged above the \
             target; <b>other minimum</b> = it stopped with a small gradient farther than the loosest target \
             from E* (another local minimum or a saddle, not short of this one); <b>unfinished</b> = it stopped \
             for another reason above the target (iteration cap, time limit, failed line search or linear \
             solve; the tooltip names it); <b>flipped</b> = it reached the target but its final map flips \
             triangles. Authalic runs keep their solvers' own rules."
        );
    }
    *h += "</p>\n";
    reference_note(h, summaries);
    *h += "<div class=\"scroll\"><table class=\"status\">\n<tr><th class=\"k ds\">dataset</th>";
    if several_energies {
        *h += "<th class=\"k\">energy</th>";
    }
    for s in &solvers {
        let _ = write!(h, "<th>{}</th>", esc(s));
    }
    *h += "</tr>\n";
    for d in datasets {
        let energies = unique(summaries.iter().filter(|s| s.dataset == d).map(|s| s.energy.as_str()));
        for (i, e) in energies.iter().enumerate() {
            *h += "<tr>";
            if i == 0 {
                let span = if several_energies { energies.len() } else { 1 };
                let _ = write!(h, "<td class=\"k ds\" rowspan=\"{span}\">{}</td>", esc(d));
            }
            if several_energies {
                let _ = write!(h, "<td class=\"k\">{}</td>", esc(e));
            }
            for solver in &solvers {
                let run = summaries.iter().find(|s| s.dataset == d && s.energy == *e && s.solver == *solver);
                status_cell(h, run_dir, run);
            }
            *h += "</tr>\n";
        }
    }
    *h += "</table></div>\n";
}

/// The line naming the (dataset, energy) groups whose reference minimum E* a run of this batch
/// set (`ref_source = batch`): every run of such a group is judged against it.
fn reference_note(h: &mut String, summaries: &[SummaryRow]) {
    let mut groups: Vec<String> = Vec::new();
    for s in summaries.iter().filter(|s| s.ref_source == Some(RefSource::Batch)) {
        let g = format!("{} / {}", s.dataset, s.energy);
        if !groups.contains(&g) {
            groups.push(g);
        }
    }
    if groups.is_empty() {
        return;
    }
    let _ = writeln!(
        h,
        "<p class=\"caption\" id=\"references\">E* from this batch (ref_source = batch) for {} group{}: {}. A run \
         of the batch ended below the stored reference minimum (or none was stored), so its final energy without \
         flips is E* for every run of the group.</p>",
        groups.len(),
        if groups.len() == 1 { "" } else { "s" },
        esc(&groups.join(", "))
    );
}

fn status_cell(h: &mut String, run_dir: &Path, run: Option<&SummaryRow>) {
    let Some(s) = run else {
        *h += "<td class=\"none\">–</td>";
        return;
    };
    // A judged run that reached its tightest target shows the iterations and time to it.
    let target = reached_target(s);
    let shown = to_target(s);
    let time = Timed::time_s(&shown);
    let to = target.map(|t| format!(" to {}", tau_text(t.tau))).unwrap_or_default();
    let mut detail = match (shown.iterations, &time) {
        (Some(i), Some(t)) => format!("{i} it, {}{to}", timed_seconds(t)),
        (Some(i), None) => format!("{i} it{to}"),
        _ => String::new(),
    };
    // What the tooltip adds: the run's own stop when the cell shows the target, the repeats
    // behind the time and the regularization.
    let mut more = String::new();
    if let (Some(t), Some(i)) = (target, shown.iterations) {
        let own = match (s.iterations, s.time_s) {
            (Some(i), Some(t)) => format!("{i} it, {}", seconds(t)),
            (Some(i), None) => format!("{i} it"),
            _ => "unknown".to_string(),
        };
        let at = time.map(|t| format!(" ({})", seconds(t.value))).unwrap_or_default();
        let _ = write!(more, "; reached the {} target at iteration {i}{at}; its own stop: {own}", tau_text(t.tau));
    }
    if let Some(t) = time.filter(|t| !t.single_sample()) {
        let _ = write!(more, "; time = median of {} repeats, min–max {}–{}", t.samples, seconds(t.lo), seconds(t.hi));
    } else if time.is_some() {
        more += "; time = a single sample";
    }
    if let Some(mb) = s.peak_rss_mb {
        let _ = write!(more, "; peak resident memory of the process during the run {mb:.0} MB");
    }
    if let Some(k) = s.shifted_iters.filter(|k| *k > 0) {
        let _ = write!(detail, ", {k} shifted");
        let _ = write!(more, "; {k} iterations solved with a Tikhonov shift above the base (regularized)");
    }
    if let Some(k) = s.cg_capped_iters.filter(|k| *k > 0) {
        let _ = write!(detail, ", {k} CG-capped");
        let _ = write!(more, "; {k} steps stopped CG at max_cg_iters short of its forcing term (truncated Newton)");
    }
    if let Some(k) = s.clamped_iters.filter(|k| *k > 0) {
        let _ = write!(detail, ", {k} clamped");
        let _ =
            write!(more, "; {k} iterations clamped SLIM weights (tables name the run {})", clamped_label(&s.solver));
    }
    // The harness's verdict on a judged run it did not call solved.
    let verdict = s.verdict.filter(|v| !matches!(v, Verdict::Solved | Verdict::OwnRule));
    let (class, head, tip, small) = match (s.status, verdict) {
        (Status::Ok, _) if s.verdict == Some(Verdict::Solved) => {
            ("ok", "ok".to_string(), format!("solved (own stop: {}){more}", s.stop_column()), detail)
        }
        (Status::Ok, _) => ("ok", "ok".to_string(), format!("converged ({}){more}", s.stop_column()), detail),
        (Status::NotConverged, Some(v)) => {
            let gap = s.final_gap.map(|g| format!("gap {g:.1e}; ")).unwrap_or_default();
            let flips = match (v, s.flips) {
                (Verdict::Flipped, Some(f)) => format!("; {f} flipped triangles"),
                _ => String::new(),
            };
            let tip = format!(
                "not solved: {}{flips}; final gap {}; own stop: {}{more}",
                verdict_text(v),
                s.final_gap.map_or("unknown".to_string(), |g| format!("{g:.3e}")),
                s.stop_column()
            );
            ("nc", verdict_text(v).to_string(), tip, format!("{gap}{detail}"))
        }
        (Status::NotConverged, None) => {
            ("nc", s.stop_column().to_string(), format!("not converged: {}{more}", s.stop_column()), detail)
        }
        (Status::Failed, _) => ("failed", "failed".to_string(), "failed".to_string(), s.error.clone()),
        (Status::Skipped, _) => ("skipped", "skipped".to_string(), format!("skipped: {}", s.error), s.error.clone()),
    };
    let body = format!("<b>{}</b><br><small>{}</small>", esc(&head), esc(&small));
    let csv = format!("runs/{}.csv", run_stem(&s.dataset, &s.energy, &s.solver));
    if run_dir.join(&csv).exists() {
        let _ = write!(h, "<td class=\"{class}\" title=\"{}\"><a href=\"{}\">{body}</a></td>", esc(&tip), href(&csv));
    } else {
        let _ = write!(h, "<td class=\"{class}\" title=\"{}\">{body}</td>", esc(&tip));
    }
}

/// Every table, and the performance profiles right after the corpus aggregates.
fn tables_section(
    h: &mut String,
    run_dir: &Path,
    tables: &[(String, Table)],
    plots: &[Plot],
    summaries: &[SummaryRow],
) {
    *h += "<h2 id=\"tables\">Tables</h2>\n";
    if tables.is_empty() {
        *h += "<p>No paper-style table applies to this run.</p>\n";
    }
    let profiles: Vec<&Plot> = plots.iter().filter(|p| p.kind.is_profile() && run_dir.join(&p.file).exists()).collect();
    for (stem, t) in tables {
        let _ = write!(
            h,
            "<h3 id=\"table-{}\">{}</h3>\n<div class=\"scroll\">\n{}</div>\n<p class=\"caption\">also as \
             <a href=\"{}\">CSV</a>, <a href=\"{}\">Markdown</a></p>\n",
            esc(stem),
            esc(&t.title),
            t.to_html_fragment(),
            href(&format!("tables/{stem}.csv")),
            href(&format!("tables/{stem}.md")),
        );
        if stem == AGGREGATES {
            profiles_section(h, &profiles, summaries);
        }
    }
    if !tables.iter().any(|(stem, _)| stem == AGGREGATES) {
        profiles_section(h, &profiles, summaries);
    }
}

/// The profiles of each energy side by side: the Dolan–Moré performance profiles of
/// iterations and time, and the Moré–Wild data profile.
fn profiles_section(h: &mut String, profiles: &[&Plot], summaries: &[SummaryRow]) {
    if profiles.is_empty() {
        return;
    }
    let (costs, solved) = match tightest_target(summaries) {
        Some(tau) => {
            let t = tau_text(tau);
            (
                format!(
                    "Costs: iterations and time to the {t} target (the harness's convergence test), iterations at \
                     least 1; time in time_norm units when every finished run has it, else time_s (the median over \
                     repeats)."
                ),
                format!("solved = reached the {t} target with no flipped triangle (status ok)"),
            )
        }
        None => (
            "Costs: iterations (at least 1), and time_norm when every finished run has it, else time_s (the \
             median over repeats)."
                .to_string(),
            "solved = converged (status ok)".to_string(),
        ),
    };
    let _ = write!(
        h,
        "<h3 id=\"profiles\">Performance and data profiles</h3>\n<p class=\"caption\">Dolan–Moré performance \
         profiles per energy (iterations, time): for each solver, the fraction of datasets it solves within τ \
         times the cost of the best solver on that dataset (the best of the solvers that solved it), τ on a log2 \
         axis. At τ = 1: how often the solver is the best; at the right end: how often it solves at all. \
         Moré–Wild data profiles (Moré and Wild 2009, “data profile”): d_s(α) = the fraction of datasets solver s \
         solves within a budget α of time, α on a log10 axis in calibration units (time normalized by the batch's \
         calibration, like time_norm) when the batch is calibrated, else in seconds; unlike the performance \
         profile it does not compare with the best solver, so adding a solver does not move the others' \
         curves. {solved}; failed and unsolved runs never count. Problem set: the datasets on which every solver \
         of the plot has a run that was not skipped (a common set; a dataset where some solver was skipped is \
         left out for all, and a solver skipped everywhere is not drawn); datasets no solver solved stay in the \
         denominator. {costs}</p>\n<div class=\"grid\">\n",
        solved = esc(&solved),
        costs = esc(&costs),
    );
    for p in profiles {
        let _ = writeln!(
            h,
            "<figure><img src=\"{f}\" alt=\"{t}\" width=\"800\" height=\"500\" loading=\"lazy\">\
             <figcaption>{t}</figcaption></figure>",
            f = href(&p.file),
            t = esc(&p.title)
        );
    }
    *h += "</div>\n";
}

/// Curves in a responsive grid per (dataset, energy), then the map thumbnails linking to the
/// full image. Plots whose file is missing are left out.
fn plots_section(h: &mut String, run_dir: &Path, plots: &[Plot]) {
    *h += "<h2 id=\"plots\">Plots</h2>\n";
    // Profiles are shown with the aggregates table.
    let present: Vec<&Plot> = plots.iter().filter(|p| !p.kind.is_profile() && run_dir.join(&p.file).exists()).collect();
    if present.is_empty() {
        *h += "<p>No plots (no run finished).</p>\n";
        return;
    }
    *h += "<p class=\"caption\">Energy gap: E − E*, E* the lowest energy any solver reached on the \
           same dataset and energy; values ≤ 0 (the best run's last point) are drawn at the bottom \
           of the log axis; dashed lines did not converge. Maps (click for the full image): each \
           triangle colored by its distortion max(σ₁, 1/σ₂) with the global scale removed (param, \
           deform; 1 = similarity, flipped triangles blue) or by its area ratio (authalic; folded \
           triangles black); the maps of one dataset and energy share a log color scale covering \
           99% of their triangles.</p>\n";
    let groups = unique(present.iter().map(|p| p.dataset.as_str()))
        .into_iter()
        .flat_map(|d| {
            unique(present.iter().filter(|p| p.dataset == d).map(|p| p.energy.as_str()))
                .into_iter()
                .map(move |e| (d, e))
        })
        .collect::<Vec<_>>();
    for (d, e) in groups {
        let _ = writeln!(h, "<h3>{} / {}</h3>", esc(d), esc(e));
        let of_group = || present.iter().filter(|p| p.dataset == d && p.energy == e);
        *h += "<div class=\"grid\">\n";
        for p in of_group().filter(|p| !matches!(p.kind, PlotKind::Map { .. })) {
            let _ = writeln!(
                h,
                "<figure><img src=\"{f}\" alt=\"{t}\" width=\"800\" height=\"500\" loading=\"lazy\">\
                 <figcaption>{t}</figcaption></figure>",
                f = href(&p.file),
                t = esc(&p.title)
            );
        }
        *h += "</div>\n";
        let maps: Vec<&&Plot> = of_group().filter(|p| matches!(p.kind, PlotKind::Map { .. })).collect();
        if !maps.is_empty() {
            *h += "<div class=\"maps\">\n";
            for p in maps {
                let PlotKind::Map { solver } = &p.kind else { continue };
                let _ = writeln!(
                    h,
                    "<figure><a href=\"{f}\"><img src=\"{f}\" alt=\"{t}\" width=\"250\" height=\"270\" \
                     loading=\"lazy\"></a><figcaption>{s}</figcaption></figure>",
                    f = href(&p.file),
                    t = esc(&p.title),
                    s = esc(solver)
                );
            }
            *h += "</div>\n";
        }
    }
}

/// Sorted file names (relative to `run_dir`) in `sub` with extension `ext`; empty when absent.
fn list_files(run_dir: &Path, sub: &str, ext: &str) -> Result<Vec<String>> {
    let dir = run_dir.join(sub);
    if !dir.is_dir() {
        return Ok(Vec::new());
    }
    let mut out = Vec::new();
    for entry in std::fs::read_dir(&dir).with_context(|| format!("{}: cannot list", dir.display()))? {
        let entry = entry.with_context(|| format!("{}: cannot list", dir.display()))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        // Skip write_atomic's temporaries (`.name.tmpPID`).
        if name.ends_with(&format!(".{ext}")) && !name.starts_with('.') {
            out.push(format!("{sub}/{name}"));
        }
    }
    out.sort();
    Ok(out)
}

/// The folder's files of this batch: its tables, and the runs' and meshes' files of the runs
/// in the summary (an interrupted run's partial repeats, or any other file, are not listed).
fn files_section(h: &mut String, run_dir: &Path, summaries: &[SummaryRow], tables: &[(String, Table)]) -> Result<()> {
    let stems: std::collections::HashSet<String> =
        summaries.iter().map(|s| crate::run_folder::run_stem(&s.dataset, &s.energy, &s.solver)).collect();
    let datasets: std::collections::HashSet<&str> = summaries.iter().map(|s| s.dataset.as_str()).collect();
    // `runs/<stem>.csv`, `uv/<stem>.uv.gz`, `meshes/<dataset>.obj.gz`: the name up to its extension.
    let of_batch = |f: &String, ext: &str| {
        let name = f.rsplit('/').next().unwrap_or(f);
        let base = name.strip_suffix(&format!(".{ext}")).unwrap_or(name);
        stems.contains(base) || datasets.contains(base)
    };
    *h += "<h2 id=\"files\">Files</h2>\n";
    let link = |f: &str| format!("<li><a href=\"{}\">{}</a></li>\n", href(f), esc(f));
    *h += "<ul class=\"files\">\n";
    for f in ["summary.csv", "meta.json"] {
        if run_dir.join(f).exists() {
            *h += &link(f);
        }
    }
    for (stem, _) in tables {
        for ext in ["csv", "md", "html"] {
            *h += &link(&format!("tables/{stem}.{ext}"));
        }
    }
    *h += "</ul>\n";
    for (title, sub, ext) in [
        ("Per-iteration CSVs", "runs", "csv"),
        (
            "Final maps (UVs only: mapbench map RUN_DIR RUN --obj FILE joins one with its mesh into an OBJ)",
            "uv",
            "uv.gz",
        ),
        ("Meshes of the maps (gzip OBJ)", "meshes", "obj.gz"),
        ("Final maps of an older folder (OBJ: source mesh as v, map as vt)", "uv", "obj"),
    ] {
        let files: Vec<String> = list_files(run_dir, sub, ext)?.into_iter().filter(|f| of_batch(f, ext)).collect();
        if files.is_empty() && sub != "runs" {
            continue;
        }
        // Collapsed: hundreds of links; the status matrix already links each run's CSV.
        let _ = writeln!(h, "<details><summary>{} ({})</summary>", esc(title), files.len());
        *h += "<ul class=\"files\">\n";
        for f in &files {
            *h += &link(f);
        }
        *h += "</ul></details>\n";
    }
    Ok(())
}

/// Unix seconds as `YYYY-MM-DD hh:mm:ss UTC` (civil-from-days, no date crate needed).
pub(crate) fn utc(secs: u64) -> String {
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02} UTC", rem / 3600, rem % 3600 / 60, rem % 60)
}

fn provenance_section(h: &mut String, meta: Option<&Value>) {
    *h += "<h2 id=\"provenance\">Provenance</h2>\n";
    let Some(m) = meta else {
        *h += "<p>No meta.json in this folder.</p>\n";
        return;
    };
    let text = |k: &str| match m.get(k) {
        None | Some(Value::Null) => None,
        Some(Value::String(s)) => Some(s.clone()),
        Some(v) => Some(v.to_string()),
    };
    let mut rows: Vec<(&str, String)> = Vec::new();
    if let Some(rev) = text("git_revision") {
        let dirty = match m.get("git_dirty").and_then(Value::as_bool) {
            Some(true) => " (dirty: uncommitted changes)",
            Some(false) => " (clean)",
            None => "",
        };
        rows.push(("git revision", format!("{rev}{dirty}")));
    } else {
        rows.push(("git revision", "unknown (not a git checkout)".into()));
    }
    for (label, key) in [
        ("mapbench version", "mapbench_version"),
        ("rustc", "rustc"),
        ("crates", "crates"),
        ("config file", "config_path"),
        ("host", "host"),
        ("cores", "cores"),
        ("--jobs", "jobs"),
        ("threads per run", "threads_per_run"),
        ("linear ordering", "linear_ordering"),
        ("shard", "shard"),
        ("meshes folder", "meshes_dir"),
        ("--only", "only"),
        ("--resume", "resume"),
        ("interrupted", "interrupted"),
    ] {
        if let Some(v) = text(key) {
            rows.push((label, v));
        }
    }
    let secs = |k: &str| m.get(k).and_then(Value::as_u64);
    if let Some(s) = secs("started_unix") {
        rows.push(("started", utc(s)));
    }
    match (secs("started_unix"), secs("ended_unix")) {
        (Some(s), Some(e)) => rows.push(("ended", format!("{} ({} s)", utc(e), e.saturating_sub(s)))),
        (_, None) => rows.push(("ended", "not recorded (interrupted or still running)".into())),
        _ => {}
    }
    *h += "<dl>\n";
    for (k, v) in rows {
        let _ = writeln!(h, "<dt>{}</dt><dd>{}</dd>", esc(k), esc(&v));
    }
    *h += "</dl>\n";
    if let Ok(pretty) = serde_json::to_string_pretty(m) {
        let _ = writeln!(h, "<details><summary>meta.json</summary><pre>{}</pre></details>", esc(&pretty));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::plots::tests::{png_size, tiny_run};

    fn table(title: &str) -> Table {
        Table {
            title: title.into(),
            columns: vec!["a".into(), "b".into()],
            rows: vec![vec!["1".into(), "x<y".into()]],
            caption: "what the numbers are".into(),
            bold: Vec::new(),
        }
    }

    #[test]
    fn index_links_every_run_plot_and_table_and_escapes_errors() {
        let (dir, rows) = tiny_run();
        let p = dir.path();
        let tables = vec![("deform".to_string(), table("Deform & friends")), ("authalic".to_string(), table("AEM"))];
        let plots = crate::report::plots::render_all(p, &rows).unwrap();
        write_index(p, &rows, &tables, &plots, &Batch::read(p)).unwrap();
        let html = std::fs::read_to_string(p.join("index.html")).unwrap();
        assert!(html.contains("<title>mapbench: tiny-config</title>"));
        for t in ["Deform &amp; friends", "AEM"] {
            assert!(html.contains(&format!(">{t}</h3>")), "table title {t}");
        }
        assert!(html.contains("<td>x&lt;y</td>"));
        // Every PNG written is shown, and is a PNG.
        let mut shown = 0;
        for entry in std::fs::read_dir(p.join("plots")).unwrap() {
            let name = entry.unwrap().file_name().to_string_lossy().into_owned();
            assert!(html.contains(&format!("<img src=\"plots/{name}\"")), "{name} not shown");
            assert!(png_size(&p.join("plots").join(&name)).0 > 0);
            shown += 1;
        }
        assert_eq!(shown, 12);
        // Every run CSV is linked (the failed run's too), and every map OBJ.
        for stem in ["tiny__sd__kp-newton", "tiny__sd__slim", "tiny__sd__cm", "disk__authalic__aem-cg"] {
            assert!(html.contains(&format!("href=\"runs/{stem}.csv\"")), "{stem}");
        }
        for file in ["uv/tiny__sd__kp-newton.uv.gz", "uv/tiny__sd__slim.uv.gz", "meshes/tiny.obj.gz"] {
            assert!(html.contains(&format!("href=\"{file}\"")), "{file}");
        }
        // tiny_run leaves disk's map in the format of older folders.
        assert!(html.contains("href=\"uv/disk__authalic__aem-cg.obj\""));
        assert!(html.contains("factorization failed: pivot &lt; 0 &amp; NaN in &lt;K&gt;"));
        assert!(!html.contains("<K>"));
        assert!(html.contains("0123456789abcdef0123456789abcdef01234567 (dirty"));
        assert!(html.contains("2023-11-14 22:13:20 UTC"));
        assert!(html.contains("not converged: max_iters"));
        // Self-contained: no script, no absolute or network links.
        assert!(!html.contains("<script") && !html.contains("http://") && !html.contains("https://"));
        assert!(!html.contains("href=\"/") && !html.contains("src=\"/"));
    }

    #[test]
    fn index_states_repeats_calibration_spreads_shifts_and_skipped_pairs() {
        let (dir, mut rows) = tiny_run();
        let p = dir.path();
        for r in rows.iter_mut().filter(|r| r.status != Status::Failed) {
            (r.repeats, r.time_s_min, r.time_s_max) = (Some(5), Some(0.24), Some(0.31));
        }
        rows[0].shifted_iters = Some(2);
        rows[0].cg_capped_iters = Some(4);
        rows.push(SummaryRow {
            dataset: "tiny".into(),
            task: crate::plan::Task::Param,
            energy: "sd".into(),
            solver: "akvf".into(),
            status: Status::Skipped,
            error: "akvf is not defined for sd here".into(),
            ..Default::default()
        });
        let calibration = |samples: Vec<f64>| Batch {
            calibration: Some(crate::calibration::Calibration { workload: "kp-newton sd".into(), samples_s: samples }),
            ..Default::default()
        };
        let page = |rows: &[SummaryRow], batch: &Batch| {
            write_index(p, rows, &crate::report::tables(rows, batch), &[], batch).unwrap();
            std::fs::read_to_string(p.join("index.html")).unwrap()
        };
        let html = page(&rows, &calibration(vec![0.50, 0.51, 0.52]));
        assert!(html.contains("Each run was repeated 5 times"), "repeats stated");
        assert!(html.contains("median 0.510 s over 3 samples, spread 3.9%"), "calibration stated");
        assert!(!html.contains("class=\"warn\""), "steady machine: no warning");
        // The time spread in the cell, the repeats in its tooltip, the shifted iterations in both.
        assert!(html.contains("0.250 s (0.240–0.310), 2 shifted, 4 CG-capped"), "spread, shifts, caps in the cell");
        assert!(html.contains("4 steps stopped CG at max_cg_iters"), "caps in the tooltip");
        assert!(html.contains("time = median of 5 repeats, min–max 0.240 s–0.310 s"));
        assert!(html.contains("2 iterations solved with a Tikhonov shift above the base"));
        // The skipped pair: grey, with its reason, counted, and in the tables as skipped.
        assert!(html.contains("<td class=\"skipped\" title=\"skipped: akvf is not defined for sd here\">"));
        assert!(html.contains("5 runs: 2 ok, 1 not converged, 1 failed, 1 skipped"));
        assert!(html.contains("<td>skipped</td>"), "the per-mesh table marks the skipped pair");
        assert!(html.contains("id=\"table-aggregates\""), "the aggregates table is on the page");
        // An unsteady machine: a visible warning with the samples.
        let html = page(&rows, &calibration(vec![0.50, 0.40, 0.60]));
        assert!(html.contains("<p class=\"warn\"><b>Warning: the machine changed speed during this batch.</b>"));
        assert!(html.contains("spread by 40.0%, more than 10%"));
        // No calibration, single samples: said so.
        for r in &mut rows {
            (r.repeats, r.time_s_min, r.time_s_max) = (Some(1), r.time_s, r.time_s);
        }
        let html = page(&rows, &Batch::default());
        assert!(html.contains("Each run was timed once (repeat = 1)"));
        assert!(html.contains("No machine calibration in meta.json"));
        assert!(html.contains("time = a single sample"));
    }

    #[test]
    fn status_cells_show_the_target_the_verdict_and_the_gap() {
        use crate::run_folder::summary::ToTarget;
        let (dir, mut rows) = tiny_run();
        let p = dir.path();
        let to = |iters: Option<usize>, time_s: Option<f64>| {
            vec![ToTarget { tau: 1e-3, iters: Some(1), time_s: Some(0.1) }, ToTarget { tau: 1e-6, iters, time_s }]
        };
        // kp-newton solved 1e-6 at iteration 2 (0.2 s) and stopped at 3 (0.25 s); slim's own
        // rule stopped it above the target, whose E* it lowered.
        (rows[0].verdict, rows[0].to_targets, rows[0].final_gap) =
            (Some(Verdict::Solved), to(Some(2), Some(0.2)), Some(0.0));
        (rows[1].verdict, rows[1].to_targets, rows[1].final_gap) =
            (Some(Verdict::StoppedAboveTarget), to(None, None), Some(3.2e-4));
        for r in &mut rows[..2] {
            (r.ref_energy, r.ref_source) = (Some(4.0), Some(RefSource::Batch));
        }
        let plots = crate::report::plots::render_all(p, &rows).unwrap();
        let tables = crate::report::tables(&crate::report::at_target(&rows), &Batch::default());
        write_index(p, &rows, &tables, &plots, &Batch::default()).unwrap();
        let html = std::fs::read_to_string(p.join("index.html")).unwrap();
        assert!(html.contains("<b>ok</b><br><small>2 it, 0.200 s to 1e-6</small>"), "the solved cell");
        assert!(html.contains("solved (own stop: grad_tol); reached the 1e-6 target at iteration 2 (0.200 s); its own stop: 3 it, 0.250 s"));
        assert!(
            html.contains("<b>stopped above target</b><br><small>gap 3.2e-4; 3 it, 0.250 s</small>"),
            "the verdict cell"
        );
        assert!(html.contains("not solved: stopped above target; final gap 3.200e-4; own stop: max_iters"));
        // The legend explains the verdicts; the batch's references are named.
        for words in
            ["<b>other minimum</b> = ", "<b>unfinished</b> = ", "<b>flipped</b> = ", "to the target</i> (“to 1e-6”"]
        {
            assert!(html.contains(words), "{words}");
        }
        assert!(html.contains("E* from this batch (ref_source = batch) for 1 group: tiny / sd."));
        // The data profile sits with the performance profiles, explained.
        assert!(html.contains("<img src=\"plots/profile__sd__data.png\""));
        assert!(html.contains("Moré–Wild data profiles (Moré and Wild 2009, “data profile”): d_s(α)"));
        assert!(html.contains("Costs: iterations and time to the 1e-6 target"));
        assert!(html.contains("id=\"table-verdicts\""), "the verdicts table");
        // Another verdict and a flipped run that reached the target.
        rows[1].verdict = Some(Verdict::OtherMinimum);
        (rows[0].verdict, rows[0].status, rows[0].flips) = (Some(Verdict::Flipped), Status::NotConverged, Some(4));
        for r in &mut rows[..2] {
            r.ref_source = Some(RefSource::Reference);
        }
        write_index(p, &rows, &[], &[], &Batch::default()).unwrap();
        let html = std::fs::read_to_string(p.join("index.html")).unwrap();
        assert!(html.contains("<b>other minimum</b><br><small>gap 3.2e-4; 3 it, 0.250 s</small>"));
        assert!(html.contains("<b>flipped</b><br><small>gap 0.0e0; 2 it, 0.200 s to 1e-6</small>"));
        assert!(html.contains("not solved: flipped; 4 flipped triangles"));
        assert!(!html.contains("E* from this batch"), "stored references: no line");
    }

    #[test]
    fn a_plot_without_its_file_is_left_out() {
        let (dir, rows) = tiny_run();
        let mut plots = crate::report::plots::render_all(dir.path(), &rows).unwrap();
        std::fs::remove_file(dir.path().join(&plots[0].file)).unwrap();
        plots.push(Plot {
            file: "plots/never_written.png".into(),
            title: "x".into(),
            dataset: "tiny".into(),
            energy: "sd".into(),
            kind: PlotKind::EnergyIter,
        });
        write_index(dir.path(), &rows, &[], &plots, &Batch::default()).unwrap();
        let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
        assert!(!html.contains(&plots[0].file) && !html.contains("never_written"));
        assert!(html.contains(&format!("<img src=\"{}\"", plots[1].file)));
    }

    #[test]
    fn escapes_and_formats() {
        assert_eq!(esc("a<b & \"c\" 'd'>"), "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;");
        assert_eq!(href("runs/a b#c.csv"), "runs/a%20b%23c.csv");
        assert_eq!(utc(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(utc(951_782_400), "2000-02-29 00:00:00 UTC");
        assert_eq!(seconds(0.04312), "0.0431 s");
        assert_eq!(seconds(6.594), "6.59 s");
        assert_eq!(seconds(123.4), "123 s");
    }
}
