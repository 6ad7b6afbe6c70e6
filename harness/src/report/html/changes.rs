//! The first screen of `index.html` (`id="changes"`): the batch's verdict in one line, what
//! changed since the previous batch of the config in the history database, and the problems
//! (failed and unsolved runs) as a short list; the status matrix and the rest follow.

use super::timing::significant;
use crate::escape::{esc, href};
use crate::gate::check::DEFAULT_ENERGY_RTOL;
use crate::gate::rules::Change;
use crate::history::{HistoryDb, HistoryOutcome};
use crate::judge::verdict::Verdict;
use crate::report::batch::Batch;
use crate::report::changes::{since_previous, Changes, Since};
use crate::report::count::{is_problem, Count};
use crate::report::plots::Plot;
use crate::report::select::{counted, unique};
use crate::report::target::{tau_text, tightest_target, verdict_text};
use crate::run_folder::meta::Meta;
use crate::run_folder::{run_stem, Status, SummaryRow};
use crate::utc::utc;
use std::fmt::Write as _;
use std::path::Path;

/// The problems listed on the first screen; the status matrix has them all.
const PROBLEMS_SHOWN: usize = 12;
/// Errors are cut to this many characters in the list (the status notes have them whole).
const ERROR_CHARS: usize = 140;

pub(super) fn changes_section(
    h: &mut String,
    run_dir: &Path,
    meta: Option<&Meta>,
    summaries: &[SummaryRow],
    plots: &[Plot],
    batch: &Batch,
    claims: &[crate::claims::Evaluated],
) {
    *h += "<section id=\"changes\">\n";
    let count = Count::of(summaries, batch);
    let _ = writeln!(h, "<p class=\"verdict\"><b>{}</b></p>", esc(&verdict_line(&count, summaries)));
    count_list(h, &count);
    super::provenance::glance(h, meta);
    if batch.calibration.as_ref().is_some_and(|c| c.unsteady()) {
        *h += "<p class=\"warn\">The machine changed speed during this batch: time rankings are less certain \
               (<a href=\"#timing\">calibration</a>).</p>\n";
    }
    super::external::sandbox_warning(h, summaries);
    since_section(h, run_dir, meta);
    super::rollup::rollup_section(h, summaries, batch);
    super::claims::glance(h, claims);
    problems(h, run_dir, summaries, plots, batch);
    *h += "</section>\n";
}

/// `850 runs: 420 solved at the tightest target (1e-6, sarap 1e-3), 150 not solved, 30 failed,
/// 100 skipped; apart, 28 on problems solved at their start and 122 of solvers expected to
/// fail`: the classes of the batch's one count, which add up to its runs.
fn verdict_line(c: &Count, summaries: &[SummaryRow]) -> String {
    let (ok, word) = match targets_text(summaries) {
        Some(t) => (format!("solved at the tightest target ({t})"), "solved"),
        None => ("converged".to_string(), "converged"),
    };
    let mut apart: Vec<String> = Vec::new();
    if c.trivial > 0 {
        apart.push(format!("{} on problems solved at their start", c.trivial));
    }
    if c.expected > 0 {
        apart.push(format!("{} of solvers expected to fail", c.expected));
    }
    let apart = match apart.is_empty() {
        true => String::new(),
        false => format!("; apart, {}", apart.join(" and ")),
    };
    format!(
        "{} runs: {} {ok}, {} not {word}, {} failed, {} skipped{apart}",
        c.runs,
        c.solved,
        c.not_solved_runs(),
        c.failed,
        c.skipped()
    )
}

/// The tightest targets the runs were judged at: `1e-6`, or `1e-6, sarap 1e-3` where an
/// energy has its own; `None` when no run was judged.
fn targets_text(summaries: &[SummaryRow]) -> Option<String> {
    let tightest = tightest_target(summaries)?;
    let mut own: Vec<(String, f64)> = Vec::new();
    for r in summaries {
        if let Some(t) = r.to_targets.last().filter(|t| t.tau != tightest) {
            if !own.iter().any(|(e, _)| *e == r.energy) {
                own.push((r.energy.clone(), t.tau));
            }
        }
    }
    let mut text = tau_text(tightest);
    for (energy, tau) in own {
        let _ = write!(text, ", {energy} {}", tau_text(tau));
    }
    Some(text)
}

/// The count's classes in words, each reason with its value.
fn count_list(h: &mut String, c: &Count) {
    *h += "<ul class=\"count\">\n";
    if !c.reached.is_empty() {
        let reached: Vec<String> = c.reached.iter().map(|(tau, n)| format!("{n} at {}", tau_text(*tau))).collect();
        let _ = writeln!(h, "<li>reached a target: {}</li>", esc(&reached.join(", ")));
    }
    if !c.not_solved.is_empty() {
        let why: Vec<String> = c.not_solved.iter().map(|(w, n)| format!("{n} {w}")).collect();
        let _ = writeln!(h, "<li>not solved ({}): {}</li>", c.not_solved_runs(), esc(&why.join("; ")));
    }
    for (solver, n, why) in &c.environment {
        let _ = writeln!(
            h,
            "<li class=\"warn\">{n} run{} of <b>{}</b> skipped: this machine cannot run it ({}). Install what it needs \
             and run the batch again (<code>--resume</code> runs only those).</li>",
            plural(*n),
            esc(solver),
            esc(why)
        );
    }
    if c.not_defined > 0 {
        let _ = writeln!(
            h,
            "<li>skipped: {} outside their solver's definition (the status matrix's notes)</li>",
            c.not_defined
        );
    }
    if c.trivial > 0 {
        let _ = writeln!(
            h,
            "<li>apart: {} run{} on {} problem{} solved at the start (its energy within round-off of E*: {}), left \
             out of the aggregates and profiles</li>",
            c.trivial,
            plural(c.trivial),
            c.trivial_problems.len(),
            plural(c.trivial_problems.len()),
            esc(&c.trivial_problems.join(", "))
        );
    }
    if c.expected > 0 {
        let _ = writeln!(
            h,
            "<li>apart: {} run{} of the solvers the config expects to fail (<code>expected_to_fail</code>), {} of \
             them solved</li>",
            c.expected,
            plural(c.expected),
            c.expected_solved
        );
    }
    *h += "</ul>\n";
}

/// "Since the previous batch of this config", from the history database `meta.json` names.
fn since_section(h: &mut String, run_dir: &Path, meta: Option<&Meta>) {
    *h += "<h3>Since the previous batch</h3>\n";
    let outcome =
        meta.and_then(|m| m.history_outcome.clone()).and_then(|o| serde_json::from_value::<HistoryOutcome>(o).ok());
    let config = meta.and_then(Meta::config_name).unwrap_or("run");
    let in_history = outcome.as_ref().and_then(HistoryOutcome::in_history);
    let Some((db, batch_id, _)) = in_history else {
        let why = match &outcome {
            Some(HistoryOutcome::NotAppended { reason, .. }) => format!("not appended to the history ({reason})"),
            Some(HistoryOutcome::Failed { error, .. }) => format!("appending to the history failed ({error})"),
            _ => "not in a history database (--no-history, or a shard)".to_string(),
        };
        let _ = writeln!(
            h,
            "<p>This batch is {}: nothing to compare with here. <code>mapbench compare A B</code> compares two run \
             folders.</p>",
            esc(&why)
        );
        return;
    };
    let since = HistoryDb::open_existing(db).and_then(|d| since_previous(&d, config, batch_id));
    match since {
        Ok(Some(Since::First { config })) => {
            let _ = writeln!(
                h,
                "<p>First batch of config <b>{}</b> in the history (<code>{}</code>): nothing to compare with yet.</p>",
                esc(&config),
                esc(&db.display().to_string())
            );
        }
        Ok(Some(Since::Previous(changes))) => previous(h, run_dir, &changes),
        Ok(None) => {
            let _ = writeln!(
                h,
                "<p>Batch {batch_id} is no longer in the history <code>{}</code>.</p>",
                esc(&db.display().to_string())
            );
        }
        Err(e) => {
            let _ = writeln!(h, "<p class=\"warn\">The history could not be read: {}</p>", esc(&e.to_string()));
        }
    }
}

fn previous(h: &mut String, run_dir: &Path, ch: &Changes) {
    let b = &ch.before;
    let folder = Path::new(&b.run_dir).join("index.html");
    let _ = writeln!(
        h,
        "<p>Batch {} (<code>{}</code>) since batch {} (<code>{}</code>, {}, <a href=\"{}\">its report</a>): \
         <b>{} regression{}</b>, {} improvement{}, {} new run{}, {} missing.</p>",
        ch.after.id,
        esc(&ch.after.short_revision()),
        b.id,
        esc(&b.short_revision()),
        b.started_unix.map_or("start unknown".to_string(), |s| utc(s.max(0) as u64)),
        href(&crate::paths::relative_link(run_dir, &folder)),
        ch.regressions(),
        plural(ch.regressions()),
        ch.improvements(),
        plural(ch.improvements()),
        ch.added.len(),
        plural(ch.added.len()),
        ch.comparison.missing.len()
    );
    let moved: Vec<String> = ch
        .solved
        .iter()
        .filter(|s| s.changed())
        .map(|s| format!("{} {} → {}", s.solver, count(s.before), count(s.after)))
        .collect();
    let unchanged = ch.solved.len() - moved.len();
    let _ = writeln!(
        h,
        "<p>Solved runs per solver (solved / run, then → now): {}{}.</p>",
        if moved.is_empty() { "no solver's count changed".to_string() } else { esc(&moved.join(", ")) },
        if moved.is_empty() || unchanged == 0 { String::new() } else { format!("; {unchanged} solvers unchanged") }
    );
    *h += "<details><summary>every solver's solved count</summary><div class=\"scroll\"><table>\n\
           <tr><th class=\"k\">solver</th><th>before</th><th>now</th></tr>\n";
    for s in &ch.solved {
        let _ = writeln!(
            h,
            "<tr><td class=\"k\">{}</td><td>{}</td><td>{}</td></tr>",
            esc(&s.solver),
            count(s.before),
            count(s.after)
        );
    }
    *h += "</table></div></details>\n";
    claims_since(h, ch);
    changes_body(h, ch);
}

/// The papers' claims that stopped holding since the previous batch (a warning), and those
/// that started to.
fn claims_since(h: &mut String, ch: &Changes) {
    let list = |rows: &[crate::history::ClaimRow]| {
        rows.iter()
            .map(|c| {
                format!(
                    "<a href=\"#claim-{}\">{}</a> ({}: {})",
                    super::claims::anchor(&c.claim),
                    esc(&c.claim),
                    c.rule.as_str(),
                    esc(&c.why)
                )
            })
            .collect::<Vec<_>>()
            .join("; ")
    };
    if !ch.claims_lost.is_empty() {
        let _ = writeln!(
            h,
            "<p class=\"warn\"><b>{} of the papers' claims stopped holding</b> since batch {}: {}</p>",
            ch.claims_lost.len(),
            ch.before.id,
            list(&ch.claims_lost)
        );
    }
    if !ch.claims_won.is_empty() {
        let _ =
            writeln!(h, "<p>Claims that hold now and did not in batch {}: {}</p>", ch.before.id, list(&ch.claims_won));
    }
}

fn count(c: Option<(usize, usize)>) -> String {
    c.map_or("–".to_string(), |(solved, runs)| format!("{solved}/{runs}"))
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

/// An unsolved run the harness did not judge (no reference minimum).
const NOT_CONVERGED: &str = "not converged";

/// What kind of problem a failed or unsolved run is: `failed`, the harness's verdict, or
/// [`NOT_CONVERGED`].
fn problem_kind(s: &SummaryRow) -> &'static str {
    match (s.status, s.verdict) {
        (Status::Failed, _) => "failed",
        (_, Some(v)) => verdict_text(v),
        _ => NOT_CONVERGED,
    }
}

/// The failed and unsolved runs, at most [`PROBLEMS_SHOWN`], each linking to its CSV when it
/// has one.
fn problems(h: &mut String, run_dir: &Path, summaries: &[SummaryRow], plots: &[Plot], batch: &Batch) {
    let mut list: Vec<&SummaryRow> = summaries.iter().filter(|s| is_problem(s, batch)).collect();
    // The worst first: failures, then flipped maps (at the target, but unusable), then the runs
    // that stopped short of it for another reason, last those their own rule stopped above it.
    list.sort_by_key(|s| match (s.status, s.verdict) {
        (Status::Failed, _) => 0,
        (_, Some(Verdict::Flipped)) => 1,
        (_, Some(Verdict::StoppedAboveTarget)) => 3,
        _ => 2,
    });
    if list.is_empty() {
        *h += "<h3>Problems</h3>\n<p>None: every run that ran was solved.</p>\n";
        return;
    }
    let kinds: Vec<String> =
        counted(list.iter().map(|s| problem_kind(s))).iter().map(|(k, n)| format!("{n} {k}")).collect();
    let _ = writeln!(h, "<h3>Problems ({}: {})</h3>\n<ul class=\"problems\">", list.len(), esc(&kinds.join(", ")));
    for s in list.iter().take(PROBLEMS_SHOWN) {
        let kind = problem_kind(s);
        let what = match s.status {
            Status::Failed => {
                let mut e: String = s.error.chars().take(ERROR_CHARS).collect();
                if e.len() < s.error.len() {
                    e.push('…');
                }
                format!("{kind}: {e}")
            }
            _ if kind != NOT_CONVERGED => {
                let gap = s.final_gap.map(|g| format!(", final gap {g:.1e}")).unwrap_or_default();
                let iters = s.iterations.map(|i| format!(" after {i} iterations")).unwrap_or_default();
                format!("{kind}{gap}{iters} (own stop: {})", s.stop_column())
            }
            _ => format!(
                "{kind}: {}{}",
                s.stop_column(),
                s.time_s.map(|t| format!(" after {} s", significant(t))).unwrap_or_default()
            ),
        };
        let name = problem_name(run_dir, s, plots);
        let _ = writeln!(
            h,
            "<li class=\"{}\">{name}: {}</li>",
            if s.status == Status::Failed { "failed" } else { "nc" },
            esc(&what)
        );
    }
    *h += "</ul>\n";
    if list.len() > PROBLEMS_SHOWN {
        let _ = writeln!(
            h,
            "<p>… and {} more: the <a href=\"#status\">status matrix</a> lists them first.</p>",
            list.len() - PROBLEMS_SHOWN
        );
    }
}

/// `dataset / energy / solver`, the problem linking its plots (when it has any) and the solver
/// its CSV (when it has one).
fn problem_name(run_dir: &Path, s: &SummaryRow, plots: &[Plot]) -> String {
    let problem = format!("{} / {}", esc(&s.dataset), esc(&s.energy));
    let problem = match super::figures::has_section(run_dir, plots, &s.dataset, &s.energy) {
        true => format!("<a href=\"#{}\">{problem}</a>", super::figures::problem_anchor(&s.dataset, &s.energy)),
        false => problem,
    };
    let csv = format!("runs/{}.csv", run_stem(&s.dataset, &s.energy, &s.solver));
    let solver = esc(&s.solver);
    let solver = if run_dir.join(&csv).exists() { format!("<a href=\"{}\">{solver}</a>", href(&csv)) } else { solver };
    format!("{problem} / {solver}")
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
