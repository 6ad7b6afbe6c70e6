//! The papers' claims a batch answered, as the history keeps them (table `claims`, schema 8):
//! one row per claim and rule with its outcome, so that the next batch's first screen can say
//! which claim that held stopped holding.

use super::db::{sql_error, HistoryDb};
use super::error::HistoryError;
use crate::claims::{Evaluated, Outcome, Rule};
use rusqlite::{params, Transaction};

/// One claim's outcome by one rule in a batch.
#[derive(Clone, Debug, PartialEq)]
pub struct ClaimRow {
    /// `<paper>/<id>`.
    pub claim: String,
    pub rule: Rule,
    pub outcome: Outcome,
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

pub(super) fn insert(tx: &Transaction, batch_id: i64, rows: &[ClaimRow]) -> rusqlite::Result<()> {
    let mut stmt =
        tx.prepare("INSERT INTO claims (batch_id, claim, rule, outcome, why) VALUES (?1, ?2, ?3, ?4, ?5)")?;
    for r in rows {
        stmt.execute(params![batch_id, r.claim, r.rule.key(), r.outcome.key(), r.why])?;
    }
    Ok(())
}

impl HistoryDb {
    /// The claims batch `batch_id` answered (none for a batch recorded before schema 8).
    pub fn claims(&self, batch_id: i64) -> Result<Vec<ClaimRow>, HistoryError> {
        let sql = sql_error(&self.path);
        let mut stmt = self
            .conn
            .prepare("SELECT claim, rule, outcome, why FROM claims WHERE batch_id = ?1 ORDER BY rowid")
            .map_err(&sql)?;
        let rows = stmt
            .query_map([batch_id], |r| {
                let text = |i: usize| r.get::<_, String>(i);
                let bad = |i: usize, what: String| {
                    rusqlite::Error::FromSqlConversionFailure(i, rusqlite::types::Type::Text, what.into())
                };
                let (rule, outcome) = (text(1)?, text(2)?);
                Ok(ClaimRow {
                    claim: text(0)?,
                    rule: Rule::from_key(&rule).ok_or_else(|| bad(1, format!("unknown rule '{rule}'")))?,
                    outcome: Outcome::from_key(&outcome)
                        .ok_or_else(|| bad(2, format!("unknown outcome '{outcome}'")))?,
                    why: text(3)?,
                })
            })
            .map_err(&sql)?;
        rows.collect::<Result<Vec<_>, _>>().map_err(&sql)
    }
}

/// The claims that held in `before` and do not now (by the same rule): not held, or no
/// longer measurable.
pub fn stopped_holding<'a>(before: &[ClaimRow], after: &'a [ClaimRow]) -> Vec<&'a ClaimRow> {
    after
        .iter()
        .filter(|a| a.outcome != Outcome::Held)
        .filter(|a| before.iter().any(|b| b.claim == a.claim && b.rule == a.rule && b.outcome == Outcome::Held))
        .collect()
}

/// The claims that did not hold in `before` and hold now.
pub fn started_holding<'a>(before: &[ClaimRow], after: &'a [ClaimRow]) -> Vec<&'a ClaimRow> {
    after
        .iter()
        .filter(|a| a.outcome == Outcome::Held)
        .filter(|a| before.iter().any(|b| b.claim == a.claim && b.rule == a.rule && b.outcome != Outcome::Held))
        .collect()
}
