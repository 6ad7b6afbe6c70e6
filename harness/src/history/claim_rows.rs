//! The papers' claims a batch answered, as the history keeps them (table `claims`, schema 8):
//! one row per claim and rule with its outcome, so that the next batch's first screen can say
//! which claim that held stopped holding.

use crate::claims::{ClaimOutcome, Evaluated, Rule};

/// One claim's outcome by one rule in a batch.
#[derive(Clone, Debug, PartialEq)]
pub struct ClaimRow {
    /// `<paper>/<id>`.
    pub claim: String,
    pub rule: Rule,
    pub outcome: ClaimOutcome,
    pub why: String,
}

impl ClaimRow {
    /// Every rule's outcome of `claims`.
    pub fn of(claims: &[Evaluated]) -> Vec<ClaimRow> {
        claims
            .iter()
            .flat_map(|c| {
                c.rules.iter().map(|j| ClaimRow {
                    claim: c.id.clone(),
                    rule: j.rule,
                    outcome: j.outcome,
                    why: j.why.clone(),
                })
            })
            .collect()
    }
}

/// The claims that held in `before` and do not now (by the same rule): not held, or no
/// longer measurable.
pub fn stopped_holding<'a>(before: &[ClaimRow], after: &'a [ClaimRow]) -> Vec<&'a ClaimRow> {
    moved(before, after, true)
}

/// The claims that did not hold in `before` and hold now.
pub fn started_holding<'a>(before: &[ClaimRow], after: &'a [ClaimRow]) -> Vec<&'a ClaimRow> {
    moved(before, after, false)
}

/// The claims of `after` whose holding went from `held_before` to its opposite.
fn moved<'a>(before: &[ClaimRow], after: &'a [ClaimRow], held_before: bool) -> Vec<&'a ClaimRow> {
    let held = |r: &ClaimRow| r.outcome == ClaimOutcome::Held;
    after
        .iter()
        .filter(|a| held(a) != held_before)
        .filter(|a| before.iter().any(|b| b.claim == a.claim && b.rule == a.rule && held(b) == held_before))
        .collect()
}
