//! The run status matrix: one cell per run, linking to its CSV.

use super::timing::{seconds, timed_seconds};
use super::{esc, href};
use crate::external::probe::Probe;
use crate::judge::verdict::Verdict;
use crate::report::{clamped_label, reached_target, tau_text, tightest_target, to_target, unique, verdict_text};
use crate::run_folder::summary::RefSource;
use crate::run_folder::timed::Timed;
use crate::run_folder::{run_stem, Status, SummaryRow};
use std::fmt::Write as _;
use std::path::Path;

/// Rows: dataset (and energy, when the run has several), columns: solver. Each cell links to
/// the run's per-iteration CSV when it exists.
pub(super) fn status_matrix(h: &mut String, run_dir: &Path, summaries: &[SummaryRow], external: &[Probe]) {
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
        match external.iter().find(|p| p.name == *s) {
            Some(p) => {
                let version = p.version.as_deref().unwrap_or("version not recorded");
                let _ = write!(
                    h,
                    "<th title=\"external solver: {}\">{}<br><a href=\"#external\" class=\"caption\">external</a></th>",
                    esc(version),
                    esc(s)
                );
            }
            None => {
                let _ = write!(h, "<th>{}</th>", esc(s));
            }
        }
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
pub(super) fn reference_note(h: &mut String, summaries: &[SummaryRow]) {
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

pub(super) fn status_cell(h: &mut String, run_dir: &Path, run: Option<&SummaryRow>) {
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
