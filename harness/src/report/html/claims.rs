//! The report's Claims section: each claim of the papers this batch's config answers, the
//! paper's numbers, ours and the outcome by the paper's rule and by the verdict, with links
//! to the runs it read; and its one-line count on the first screen.

use crate::claims::render::published;
use crate::claims::{counts, ClaimOutcome, Evaluated, Judged, Rule};
use crate::escape::{esc, href};
use std::fmt::Write as _;

/// `Papers' claims (12 answered by this config): 15 held, 3 not held, 2 not measurable`, with
/// the claims that do not hold named; nothing when the config answers no claim.
pub(super) fn glance(h: &mut String, claims: &[Evaluated]) {
    if claims.is_empty() {
        return;
    }
    let [held, not, unknown] = counts(claims);
    let broken: Vec<String> = claims
        .iter()
        .flat_map(|c| c.rules.iter().filter(|j| j.outcome == ClaimOutcome::NotHeld).map(move |j| (c, j)))
        .map(|(c, j)| format!("<a href=\"#claim-{}\">{}</a> ({})", anchor(&c.id), esc(&c.id), j.rule.as_str()))
        .collect();
    let _ = writeln!(
        h,
        "<p><a href=\"#claims\">Papers' claims</a> ({} claims name this config; each rule counted): {held} held, \
         {not} not held, {unknown} not measurable{}</p>",
        claims.len(),
        if broken.is_empty() { ".".to_string() } else { format!(": not held {}.", broken.join(", ")) }
    );
}

/// The section, after the tables; nothing when the config answers no claim.
pub(super) fn claims_section(h: &mut String, claims: &[Evaluated]) {
    if claims.is_empty() {
        return;
    }
    *h += "<h2 id=\"claims\">Papers' claims</h2>\n<p class=\"caption\">Each claim of <code>claims/*.toml</code> \
           this config answers, decided over this batch: by the paper's rule (each run to its own stop, as the \
           paper's tables count) and, for a cost, by the verdict (iterations and time to the tightest target \
           against the certified E*; a run that never reached it costs infinitely much). Means are over the \
           meshes where every solver of the claim has a number. <code>mapbench claims</code> prints them; the \
           book's Claims page has the vocabulary.</p>\n<div class=\"scroll\"><table class=\"claims\">\n<tr><th \
           class=\"k\">claim</th><th class=\"k\">the paper</th><th class=\"k\">by the paper's rule</th><th \
           class=\"k\">by the verdict</th></tr>\n";
    for c in claims {
        let note =
            if c.note.is_empty() { String::new() } else { format!("<br><small><i>{}</i></small>", esc(&c.note)) };
        let numbers = if c.published.is_empty() {
            String::new()
        } else {
            format!("<br><small>published {}: {}</small>", esc(c.metric), esc(&published(c)))
        };
        let _ = writeln!(
            h,
            "<tr id=\"claim-{}\"><td class=\"k\"><code>{}</code><br><small>{}, {}</small></td><td class=\"k\">{}{note}{numbers}</td>\
             <td class=\"k\">{}</td><td class=\"k\">{}</td></tr>",
            anchor(&c.id),
            esc(&c.id),
            esc(&c.paper),
            esc(&c.source),
            esc(&c.says),
            cell(c.by(Rule::Paper)),
            c.by(Rule::Verdict).map_or_else(|| "<small>one rule: a value of the final map or of an iteration</small>".to_string(), |j| cell(Some(j))),
        );
    }
    *h += "</table></div>\n";
}

/// The anchor of a claim: its id with `/` as `-`.
pub(super) fn anchor(id: &str) -> String {
    id.replace('/', "-")
}

fn cell(j: Option<&Judged>) -> String {
    let Some(j) = j else { return String::new() };
    let class = match j.outcome {
        ClaimOutcome::Held => "ok",
        ClaimOutcome::NotHeld => "failed",
        ClaimOutcome::NotMeasurable => "skipped",
    };
    let runs: Vec<String> =
        j.runs.iter().map(|stem| format!("<a href=\"runs/{}.csv\">{}</a>", href(stem), esc(stem))).collect();
    let runs = if runs.is_empty() {
        String::new()
    } else {
        format!("<details><summary>{} runs</summary><small>{}</small></details>", runs.len(), runs.join(" "))
    };
    format!("<span class=\"{class}\"><b>{}</b></span>: {}{runs}", j.outcome.as_str(), esc(&j.why))
}
