//! The tables, performance profiles and plots of the page.

use crate::escape::{esc, href};
use crate::report::plots::{Plot, PlotKind};
use crate::report::select::unique;
use crate::report::tables::{Table, AGGREGATES};
use crate::report::target::{tau_text, tightest_target};
use crate::run_folder::SummaryRow;
use std::fmt::Write as _;
use std::path::Path;

/// The tables with a row per mesh: on their own pages (`tables/<stem>.html`), linked with
/// their caption, so the report stays light however many meshes a batch has.
const OWN_PAGE: [&str; 4] = ["per_mesh", "projection", "smoothness", "scaling"];

/// Every table (those of [`OWN_PAGE`] linked), and the performance profiles right after the
/// corpus aggregates.
pub(super) fn tables_section(
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
        let file = |ext: &str| href(&format!("tables/{stem}.{ext}"));
        let body = if OWN_PAGE.contains(&stem.as_str()) {
            format!(
                "<p>{} rows, on <a href=\"{}\">its own page</a>. {}</p>\n",
                t.rows.len(),
                file("html"),
                esc(&t.caption)
            )
        } else {
            format!("<div class=\"scroll\">\n{}</div>\n", t.to_html_fragment())
        };
        let _ = write!(
            h,
            "<h3 id=\"table-{}\">{}</h3>\n{body}<p class=\"caption\">also as <a href=\"{}\">CSV</a>, \
             <a href=\"{}\">Markdown</a>, <a href=\"{}\">LaTeX</a> (booktabs)</p>\n",
            esc(stem),
            esc(&t.title),
            file("csv"),
            file("md"),
            file("tex"),
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
pub(super) fn profiles_section(h: &mut String, profiles: &[&Plot], summaries: &[SummaryRow]) {
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
            "<figure><a href=\"{f}\"><img src=\"{f}\" alt=\"{t}\" width=\"800\" height=\"500\" loading=\"lazy\"></a>\
             <figcaption>{t}</figcaption></figure>",
            f = href(&p.file),
            t = esc(&p.title)
        );
    }
    *h += "</div>\n";
}

/// Curves in a responsive grid per (dataset, energy), then the map thumbnails linking to the
/// full image. Plots whose file is missing are left out. Each problem (dataset and energy)
/// has its anchor ([`problem_anchor`]).
pub(super) fn plots_section(h: &mut String, run_dir: &Path, plots: &[Plot]) {
    *h += "<h2 id=\"plots\">Plots</h2>\n";
    // Profiles are shown with the aggregates table.
    let present: Vec<&Plot> = plots.iter().filter(|p| shown(run_dir, p)).collect();
    if present.is_empty() {
        *h += "<p>No plots (no run finished).</p>\n";
        return;
    }
    *h += "<p class=\"caption\">Energy gap: E − E*, E* the lowest energy any solver reached on the \
           same dataset and energy; values ≤ 0 (the best run's last point) are drawn at the bottom \
           of the log axis; dashed lines did not converge. Click a plot or a map for the full image. Maps: each \
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
        let _ = writeln!(h, "<h3 id=\"{}\">{} / {}</h3>", problem_anchor(d, e), esc(d), esc(e));
        let of_group = || present.iter().filter(|p| p.dataset == d && p.energy == e);
        *h += "<div class=\"grid\">\n";
        for p in of_group().filter(|p| !matches!(p.kind, PlotKind::Map { .. })) {
            let _ = writeln!(
                h,
                "<figure><a href=\"{f}\"><img src=\"{f}\" alt=\"{t}\" width=\"800\" height=\"500\" \
                 loading=\"lazy\"></a><figcaption>{t}</figcaption></figure>",
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

/// Whether the plots section has a section for the problem (dataset and energy): a plot of it
/// that is not a profile and whose file is there.
pub(super) fn has_section(run_dir: &Path, plots: &[Plot], dataset: &str, energy: &str) -> bool {
    plots.iter().any(|p| shown(run_dir, p) && p.dataset == dataset && p.energy == energy)
}

/// A plot the plots section draws: not a profile (those are with the aggregates), its file there.
fn shown(run_dir: &Path, p: &Plot) -> bool {
    !p.kind.is_profile() && run_dir.join(&p.file).exists()
}

/// The id of a problem's plot section: `problem-<dataset>__<energy>`, as the run files name
/// them (dataset and energy names are `[a-z0-9_-]`), escaped all the same.
pub(super) fn problem_anchor(dataset: &str, energy: &str) -> String {
    crate::escape::esc(&format!("problem-{dataset}__{energy}"))
}
