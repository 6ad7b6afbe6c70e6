//! The run status matrix: one short cell per run (linking to its problem in the explorer, or
//! its plots or CSV in a folder without one), the fastest solved run of each row framed, the full story in
//! the cell's tooltip, and the reasons of failed and skipped runs once each in numbered notes
//! under the table, so that 20 solvers fit one screen; its column heads stay in view.

use super::timing::{brief, seconds, significant};
use crate::escape::{esc, href};
use crate::external::probe::Probe;
use crate::judge::reference::{GroupReference, Origin};
use crate::judge::verdict::Verdict;
use crate::report::label::clamped_label;
use crate::report::plots::Plot;
use crate::report::select::unique;
use crate::report::tables::ranking::fastest;
use crate::report::target::{reached_target, tau_text, tightest_target, to_target, verdict_text};
use crate::run_folder::summary::RefSource;
use crate::run_folder::timed::Timed;
use crate::run_folder::{run_stem, Status, SummaryRow};
use std::fmt::Write as _;
use std::path::Path;

/// A verdict in at most 7 characters, the widest line of a cell (the legend spells them out).
fn verdict_short(v: Verdict) -> &'static str {
    match v {
        Verdict::Solved => "ok",
        Verdict::Flipped => "flipped",
        Verdict::StoppedAboveTarget => "above",
        Verdict::OtherMinimum => "other",
        Verdict::Stalled => "stalled",
        Verdict::BrokeDown => "broke",
        Verdict::Unfinished => "budget",
    }
}

/// The reasons of failed and skipped runs, each once, numbered in order of appearance.
#[derive(Default)]
struct Notes(Vec<(String, usize)>);

impl Notes {
    /// The note number of `reason` (1-based), counting one more cell for it.
    fn number(&mut self, reason: &str) -> usize {
        if let Some(i) = self.0.iter().position(|(r, _)| r == reason) {
            self.0[i].1 += 1;
            return i + 1;
        }
        self.0.push((reason.to_string(), 1));
        self.0.len()
    }

    /// The numbered list under the table (nothing when no cell needed a note).
    fn render(&self, h: &mut String) {
        if self.0.is_empty() {
            return;
        }
        *h += "<ol class=\"notes\" id=\"status-notes\">\n";
        for (reason, cells) in &self.0 {
            let _ = writeln!(
                h,
                "<li>{}<small> ({cells} cell{})</small></li>",
                esc(reason),
                if *cells == 1 { "" } else { "s" }
            );
        }
        *h += "</ol>\n";
    }
}

/// Whether a run is a problem of the morning: failed, finished without being solved, or
/// spent its fixed budget on a map that flips.
pub(crate) fn is_problem(s: &SummaryRow) -> bool {
    matches!(s.status, Status::Failed | Status::NotConverged)
        || (s.status == Status::Budget && s.verdict == Some(Verdict::Flipped))
}

/// A solver's name as a column head: it may wrap after each hyphen.
fn head(name: &str) -> String {
    esc(name).replace('-', "-<wbr>")
}

/// Rows: dataset (and energy, when the run has several), those with a problem first;
/// columns: solver. Each cell links to its problem in the explorer; in a folder without one
/// (an older report), to its problem's section of plots, or to the run's per-iteration CSV.
pub(super) fn status_matrix(
    h: &mut String,
    run_dir: &Path,
    summaries: &[SummaryRow],
    plots: &[Plot],
    external: &[Probe],
    references: &[GroupReference],
) {
    let solvers = unique(summaries.iter().map(|s| s.solver.as_str()));
    let mut datasets = unique(summaries.iter().map(|s| s.dataset.as_str()));
    let troubled = |d: &str| summaries.iter().any(|s| s.dataset == d && is_problem(s));
    // A stable sort: problem rows first, each part in the summary's order.
    datasets.sort_by_key(|d| !troubled(d));
    let several_energies = unique(summaries.iter().map(|s| s.energy.as_str())).len() > 1;
    let explorer = run_dir.join(crate::report::plots::explorer::EXPLORER).exists();
    status_caption(h, summaries, explorer);
    *h += "</p>\n";
    reference_note(h, summaries, references);
    *h += "<div class=\"scroll status\"><table class=\"status\">\n<tr><th class=\"k ds\">dataset</th>";
    if several_energies {
        *h += "<th class=\"k\">energy</th>";
    }
    for s in &solvers {
        solver_head(h, s, external);
    }
    *h += "</tr>\n";
    let mut notes = Notes::default();
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
            let runs: Vec<Option<&SummaryRow>> = solvers
                .iter()
                .map(|solver| summaries.iter().find(|s| s.dataset == d && s.energy == *e && s.solver == *solver))
                .collect();
            let fast = fastest_solved(&runs);
            let section = if explorer {
                Some(crate::report::plots::explorer::problem_link(d, e))
            } else {
                super::figures::has_section(run_dir, plots, d, e)
                    .then(|| format!("#{}", super::figures::problem_anchor(d, e)))
            };
            for (j, run) in runs.iter().enumerate() {
                let link = section.clone().or_else(|| {
                    let csv = run.map(|s| format!("runs/{}.csv", run_stem(&s.dataset, &s.energy, &s.solver)))?;
                    run_dir.join(&csv).exists().then(|| href(&csv))
                });
                status_cell(h, *run, &mut notes, fast.contains(&j), link.as_deref());
            }
            *h += "</tr>\n";
        }
    }
    *h += "</table></div>\n";
    notes.render(h);
}

/// The table's legend: what a cell says, and how the harness judges.
fn status_caption(h: &mut String, summaries: &[SummaryRow], explorer: bool) {
    *h += "<h2 id=\"status\">Run status</h2>\n<p class=\"caption\">Rows with a failed or unsolved run come first. \
           Each cell: iterations over the time in seconds (the median over the repeats); hover it for the \
           whole story (“it” = iteration; the min–max of the repeats; how the run ended; peak RSS = the \
           process's peak resident memory, with other runs in flight unless its growth is given) and click it \
           for ";
    *h += if explorer {
        "its problem in the <a href=\"explorer.html\">explorer</a> (its curves, interactive)."
    } else {
        "its problem's plots (or the run's per-iteration CSV)."
    };
    *h += " A framed cell is the fastest solved run of its row by time to the target (those whose repeat \
           spreads overlap it framed too). <span class=\"ok\">green</span> solved; \
           <span class=\"nc\">yellow</span> not solved (the verdict in the cell, how it ended in its tooltip); \
           <span class=\"failed\">failed</span> and <span class=\"skipped\">skip</span> (not run: the solver is \
           not defined for the energy, or this machine cannot run an external solver; left out of every \
           aggregate and ranking) give the number of their reason in the notes under the table. A “+” after the \
           iterations: some iterations solved their Newton system with a Tikhonov shift above the base \
           (regularized Newton), stopped CG at its iteration cap short of the forcing term (truncated solvers; \
           “CG capped”) or clamped SLIM weights (the solver outside the energies it is defined for; tables and \
           profiles name it “slim (clamped)”); the tooltip counts them.";
    if let Some(tau) = tightest_target(summaries) {
        let t = tau_text(tau);
        let own: Vec<String> = crate::report::select::unique(
            summaries
                .iter()
                .filter_map(|r| r.to_targets.last().filter(|x| x.tau != tau).map(|x| (r.energy.as_str(), x.tau))),
        )
        .into_iter()
        .map(|(e, x)| format!("{e} at {}", tau_text(x)))
        .collect();
        let own = if own.is_empty() { String::new() } else { format!(" ({}: its config's own)", own.join(", ")) };
        let _ = write!(
            h,
            " Every run went on to its target, its solver's stop rules recorded on the way (the tooltip names \
             the iteration where the first held, where the papers' protocol stops), and the harness judges it \
             against the reference minimum E* of its dataset and energy from the common start's energy E0 for \
             every solver: <span class=\"ok\">green</span> = solved, its final map has no flipped triangle and \
             E − E* ≤ {t} × span{own}, the span being min(E0 − E*, A) with A = max(E* − E_iso, 10⁻⁴ max(1, \
             |E_iso|)) the minimum's own distortion (E_iso: the energy at an isometry, SD's 2), so that “solved” \
             is the same accuracy on every problem; its cell counts the iterations and time <i>to the target</i>. \
             A yellow cell names the harness's verdict over the final gap (E_final − E*)/span: <b>budget</b> = \
             out of budget, the iteration cap or the time limit ended it; <b>stalled</b> = it ended stationary \
             (no decrease beyond round-off over the stall window or in a line search, or the gradient floor); \
             <b>broke</b> = the method broke down (a line search that found no decrease its model promised, a \
             failed factorization); <b>other</b> = other minimum, it ended stationary above the target and a \
             tight Newton polish from its final map stayed there; <b>above</b> = a stop rule ended it above the target (an external \
             solver's own, or a run without a reference to go to); <b>flipped</b> = its final map flips \
             triangles. A <b>†</b> marks the runs of a group whose E* is not certified (its reason in the notes \
             below), a <b>≠</b> a run whose repeats did not reproduce its first (its first repeat's result is \
             shown)."
        );
    }
}

/// A solver's column head; an external solver's names its version and links to the section
/// on external solvers.
fn solver_head(h: &mut String, solver: &str, external: &[Probe]) {
    match external.iter().find(|p| p.name == solver) {
        Some(p) => {
            let version = p.version.as_deref().unwrap_or("version not recorded");
            let _ = write!(
                h,
                "<th title=\"external solver: {}\">{}<br><a href=\"#external\" class=\"caption\">ext.</a></th>",
                esc(version),
                head(solver)
            );
        }
        None => {
            let _ = write!(h, "<th>{}</th>", head(solver));
        }
    }
}

/// The notes on the batch's reference minima: the groups whose E* is not certified (their
/// verdicts carry a †), those whose E* a run of this batch lowered (every run of the group is
/// judged against it, and the store keeps it), those without a reference (the batch's best,
/// `ref_source = batch`), and the stored entries refused.
pub(super) fn reference_note(h: &mut String, summaries: &[SummaryRow], references: &[GroupReference]) {
    let judged = |g: &GroupReference| summaries.iter().any(|s| s.dataset == g.dataset && s.energy == g.energy);
    let mut lines: Vec<String> = Vec::new();
    let uncertified: Vec<String> = references
        .iter()
        .filter(|g| judged(g) && g.e_star.is_some() && !g.certified)
        .map(|g| {
            let why = g.certificate.as_deref().unwrap_or("no certificate recorded");
            format!("{} / {} ({})", g.dataset, g.energy, why)
        })
        .collect();
    if !uncertified.is_empty() {
        lines.push(format!(
            "† E* not certified for {} group{} (its verdicts are against the best minimum known, which no \
             certificate vouches for): {}.",
            uncertified.len(),
            if uncertified.len() == 1 { "" } else { "s" },
            uncertified.join("; ")
        ));
    }
    let lowered: Vec<String> = references
        .iter()
        .filter(|g| judged(g) && g.origin == Origin::Improved)
        .map(|g| format!("{} / {} ({})", g.dataset, g.energy, g.note.as_deref().unwrap_or("lowered")))
        .collect();
    if !lowered.is_empty() {
        lines.push(format!(
            "E* lowered by this batch for {} group{}: {}. A run ended below the stored reference minimum; its map, \
             polished and certified, is E* for every run of the group, and the reference store keeps it.",
            lowered.len(),
            if lowered.len() == 1 { "" } else { "s" },
            lowered.join("; ")
        ));
    }
    let groups: Vec<String> = summaries
        .iter()
        .filter(|s| s.ref_source == Some(RefSource::Batch))
        .map(|s| format!("{} / {}", s.dataset, s.energy))
        .collect();
    let batch = unique(groups.iter().map(String::as_str));
    if !batch.is_empty() {
        lines.push(format!(
            "No reference minimum for {} group{}: {}. E* is the batch's best final energy without flips \
             (ref_source = batch), uncertified: these verdicts depend on which solvers ran.",
            batch.len(),
            if batch.len() == 1 { "" } else { "s" },
            batch.join(", ")
        ));
    }
    if lines.is_empty() {
        return;
    }
    let _ = writeln!(h, "<p class=\"caption\" id=\"references\">{}</p>", esc(&lines.join(" ")));
}

/// The cell's tooltip after its first words: the iterations and time (to the target, and the
/// run's own), the repeats' spread, memory, the safety nets that fired and the marks; and
/// whether a safety net fired (a “+” after the iterations).
fn cell_story(s: &SummaryRow, shown: &SummaryRow, time: Option<Timed>) -> (String, bool) {
    let mut more = String::new();
    if let (Some(t), Some(i)) = (reached_target(s), shown.iterations) {
        let own = match (s.iterations, s.time_s) {
            (Some(i), Some(t)) => format!("{i} it, {}", seconds(t)),
            (Some(i), None) => format!("{i} it"),
            _ => "unknown".to_string(),
        };
        let at = time.map(|t| format!(", {}", seconds(t.value))).unwrap_or_default();
        let _ = write!(more, "; {} target at it {i}{at}; ended at {own}", tau_text(t.tau));
    } else if let Some(i) = shown.iterations {
        let at = time.map(|t| format!(", {}", seconds(t.value))).unwrap_or_default();
        let _ = write!(more, "; {i} it{at}");
    }
    if let Some(t) = time.filter(|t| !t.single_sample()) {
        let _ = write!(more, "; {} repeats {}–{}", t.samples, significant(t.lo), seconds(t.hi));
    } else if time.is_some() {
        more += "; 1 sample";
    }
    match (s.peak_growth_mb, s.peak_rss_mb) {
        (Some(own), Some(all)) => {
            let _ = write!(more, "; peak RSS {all:.0} MB, +{own:.0} MB its own");
        }
        (None, Some(all)) => {
            let _ = write!(more, "; peak RSS {all:.0} MB");
        }
        _ => {}
    }
    let mut marked = false;
    if let Some(k) = s.shifted_iters.filter(|k| *k > 0) {
        marked = true;
        let _ = write!(more, "; {k} it shifted");
    }
    if let Some(k) = s.cg_capped_iters.filter(|k| *k > 0) {
        marked = true;
        let _ = write!(more, "; {k} it CG capped");
    }
    if let Some(k) = s.clamped_iters.filter(|k| *k > 0) {
        marked = true;
        let _ = write!(more, "; {k} it clamped ({})", clamped_label(&s.solver));
    }
    if s.ref_certified == Some(false) {
        more += "; † E* uncertified";
    }
    if let Some(d) = &s.repeats_differ {
        let _ = write!(more, "; ≠ {d} (repeat 1 shown)");
    }
    (more, marked)
}

/// ` at 1e-6`: the tightest target a judged run was held to (its energy's own where it has one).
fn at_target(s: &SummaryRow) -> String {
    s.to_targets.last().map(|t| format!(" at {}", tau_text(t.tau))).unwrap_or_default()
}

/// `; grad_tol held at iteration 8`: where the run's own rule would have ended it.
fn rule_held(s: &SummaryRow) -> String {
    s.rule_stop().map(|e| format!("; {} held at iteration {}", e.rule.as_str(), e.iters)).unwrap_or_default()
}

/// The row's fastest solved runs by their time to the target: the one rule of the tables
/// ([`fastest`]), ties on overlapping spreads included.
fn fastest_solved(runs: &[Option<&SummaryRow>]) -> Vec<usize> {
    let times: Vec<Option<Timed>> =
        runs.iter().map(|r| r.filter(|s| s.status == Status::Ok).and_then(|s| Timed::time_s(&to_target(s)))).collect();
    fastest(&times).best
}

/// One run's cell: `fast` frames it, `link` is where a click goes.
fn status_cell(h: &mut String, run: Option<&SummaryRow>, notes: &mut Notes, fast: bool, link: Option<&str>) {
    let Some(s) = run else {
        *h += "<td class=\"none\">–</td>";
        return;
    };
    // A judged run that reached its tightest target shows the iterations and time to it.
    let shown = to_target(s);
    let time = Timed::time_s(&shown);
    let (more, marked) = cell_story(s, &shown, time);
    let iterations = shown.iterations.map(|i| format!("{i}{}", if marked { "+" } else { "" })).unwrap_or_default();
    let secs = time.map(|t| brief(t.value)).unwrap_or_default();
    // The harness's verdict on a judged run it did not call solved.
    let verdict = s.verdict.filter(|v| !matches!(v, Verdict::Solved));
    let (class, top, bottom, tip) = match (s.status, verdict) {
        (Status::Ok, _) => {
            let what = if s.verdict == Some(Verdict::Solved) { "solved" } else { "converged" };
            (
                "ok",
                iterations,
                secs,
                format!("{what}{}, ended: {}{}{more}", at_target(s), s.stop_column(), rule_held(s)),
            )
        }
        (Status::NotConverged, Some(v)) => {
            let flips = match (v, s.flips) {
                (Verdict::Flipped, Some(f)) => format!("; {f} flipped triangles"),
                _ => String::new(),
            };
            let tip = format!(
                "not solved{}: {}{flips}; gap {}; ended: {}{}{more}",
                at_target(s),
                verdict_text(v),
                s.final_gap.map_or("unknown".to_string(), |g| format!("{g:.3e}")),
                s.stop_column(),
                rule_held(s)
            );
            let gap = s.final_gap.map(|g| format!("{g:.0e}")).unwrap_or_default();
            ("nc", verdict_short(v).to_string(), gap, tip)
        }
        (Status::NotConverged, None) => {
            ("nc", "nc".to_string(), iterations, format!("not converged: {}{more}", s.stop_column()))
        }
        (Status::Budget, v) => {
            let judged = v.map(|v| format!("; not solved: {}", verdict_text(v))).unwrap_or_default();
            let tip = format!("its budget of {iterations} iterations spent (a fixed-budget protocol){judged}{more}");
            let top = if v == Some(Verdict::Flipped) { verdict_short(Verdict::Flipped) } else { "budget" };
            ("budget", top.to_string(), secs, tip)
        }
        (Status::Failed, _) => {
            let n = notes.number(&format!("failed: {}", s.error));
            ("failed", "failed".to_string(), format!("[{n}]"), format!("failed: {}", s.error))
        }
        (Status::Skipped, _) => {
            let n = notes.number(&format!("skipped: {}", s.error));
            ("skipped", "skip".to_string(), format!("[{n}]"), format!("skipped: {}", s.error))
        }
    };
    let marks = format!(
        "{}{}",
        if s.ref_certified == Some(false) { "†" } else { "" },
        if s.repeats_differ.is_some() { "≠" } else { "" }
    );
    let body = format!("<b>{}{marks}</b><br><small>{}</small>", esc(&top), esc(&bottom));
    let (class, tip) =
        if fast { (format!("{class} fast"), format!("fastest of the row; {tip}")) } else { (class.to_string(), tip) };
    match link {
        Some(l) => {
            let _ = write!(h, "<td class=\"{class}\" title=\"{}\"><a href=\"{l}\">{body}</a></td>", esc(&tip));
        }
        None => {
            let _ = write!(h, "<td class=\"{class}\" title=\"{}\">{body}</td>", esc(&tip));
        }
    }
}
