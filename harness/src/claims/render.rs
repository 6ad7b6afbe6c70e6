//! Claims in words: the lines `mapbench claims` prints and the Markdown table of the book's
//! Results page (the report draws its own HTML section from the same [`Evaluated`]).

use super::evaluate::{fmt, ClaimOutcome, Judged, Rule};
use super::Evaluated;
use std::fmt::Write;

/// The paper's numbers: `kp-newton 67.3, cm 93.2` (empty when it gives none).
pub fn published(c: &Evaluated) -> String {
    c.published.iter().map(|(s, v)| format!("{s} {}", fmt(*v))).collect::<Vec<_>>().join(", ")
}

/// One block per claim: its id and sentence, the paper's numbers, then each rule's outcome.
pub fn text(claims: &[Evaluated]) -> String {
    let mut s = String::new();
    for c in claims {
        let _ = writeln!(s, "{} ({}, {}): {}", c.id, c.paper, c.source, c.says);
        if !c.note.is_empty() {
            let _ = writeln!(s, "  note: {}", c.note);
        }
        if !c.published.is_empty() {
            let _ = writeln!(s, "  published {}: {}", c.metric, published(c));
        }
        for j in &c.rules {
            let _ = writeln!(s, "  {:<14} {:<15} {}", j.rule.as_str(), j.outcome.as_str(), j.why);
        }
    }
    let [held, not, unknown] = super::counts(claims);
    let _ = writeln!(
        s,
        "{} claims: {held} held, {not} not held, {unknown} not measurable (each rule counted)",
        claims.len()
    );
    s
}

/// A Markdown table of every claim, with the paper's numbers and both rules' outcomes.
pub fn markdown(claims: &[Evaluated]) -> String {
    let mut s = String::from(
        "| claim | source | the paper says | published | by the paper's rule | by the verdict |\n|---|---|---|---|---|---|\n",
    );
    let cell = |j: Option<&Judged>| match j {
        None => "– (one rule: a final value)".to_string(),
        Some(j) => {
            let word = match j.outcome {
                ClaimOutcome::Held => "**held**",
                ClaimOutcome::NotHeld => "**not held**",
                ClaimOutcome::NotMeasurable => "not measurable",
            };
            format!("{word}: {}", j.why.replace('|', "\\|"))
        }
    };
    for c in claims {
        let _ = writeln!(
            s,
            "| `{}` | {} | {} | {} | {} | {} |",
            c.id,
            c.source,
            if c.note.is_empty() {
                c.says.replace('|', "\\|")
            } else {
                format!("{} (*{}*)", c.says, c.note).replace('|', "\\|")
            },
            if c.published.is_empty() { "–".to_string() } else { format!("{}: {}", c.metric, published(c)) },
            cell(c.by(Rule::Paper)),
            cell(c.by(Rule::Verdict)),
        );
    }
    s
}
