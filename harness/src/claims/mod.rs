//! The papers' claims, re-checked on a batch: each claim of `claims/<paper>.toml` (built into
//! the binary) is decided over the run folders of the configs it names, by the paper's own
//! stop rule and by the harness's verdict, with our numbers beside the paper's. `mapbench
//! claims` prints them, the report has a Claims section, and the history keeps each batch's
//! outcomes so that the first screen says when a claim that held stops holding.

pub mod evaluate;
pub mod render;
pub mod spec;

pub use evaluate::{ClaimOutcome, Judged, Rule};
pub use spec::{Check, Claim, ClaimsError, Paper, Quantity};

use crate::run_folder::SummaryRow;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The committed claims files, in the order the report lists them.
const BUILT_IN: [(&str, &str); 3] = [
    ("claims/golla-seidel-chen-2018.toml", include_str!("../../../claims/golla-seidel-chen-2018.toml")),
    ("claims/shtengel-2017.toml", include_str!("../../../claims/shtengel-2017.toml")),
    ("claims/liu-yueh.toml", include_str!("../../../claims/liu-yueh.toml")),
];

/// Every committed paper's claims.
pub fn built_in() -> Result<Vec<Paper>, ClaimsError> {
    BUILT_IN.iter().map(|(file, text)| Paper::parse(file, text)).collect()
}

/// A run folder as the claims read it: the name of the config it ran and its rows.
pub struct Folder {
    pub config: String,
    pub dir: PathBuf,
    pub rows: Vec<SummaryRow>,
}

impl Folder {
    /// `dir`'s config name (from `meta.json`) and `summary.csv`.
    pub fn read(dir: &Path) -> Result<Folder, ClaimsError> {
        let meta = crate::run_folder::meta::Meta::read(dir)?;
        let config = meta.config_name().ok_or_else(|| ClaimsError::NoName { dir: dir.to_path_buf() })?.to_string();
        Ok(Folder { config, dir: dir.to_path_buf(), rows: crate::run_folder::read_summary(dir)? })
    }
}

/// The claims `folder`'s config answers, decided over it (none when it names no claim's config).
pub fn for_folder(folder: &Folder) -> Result<Vec<Evaluated>, ClaimsError> {
    let mut papers = built_in()?;
    for p in &mut papers {
        p.claims.retain(|c| c.configs.contains(&folder.config));
    }
    Ok(evaluate(&papers, std::slice::from_ref(folder)))
}

/// One claim decided: what it says, the paper's numbers, the folder that answered it and the
/// outcome by each rule (the verdict's only where the metric is a cost to a target).
#[derive(Clone, Debug, Serialize)]
pub struct Evaluated {
    /// `<paper>/<id>`.
    pub id: String,
    pub paper: String,
    pub source: String,
    pub says: String,
    /// How our measurement differs from the paper's (empty when it does not).
    pub note: String,
    pub energy: String,
    pub metric: &'static str,
    pub check: &'static str,
    pub published: BTreeMap<String, f64>,
    /// The config names that answer it.
    pub configs: Vec<String>,
    /// The folder that answered it, when one did.
    pub folder: Option<PathBuf>,
    pub rules: Vec<Judged>,
}

impl Evaluated {
    /// The outcome by `rule`, if it was decided by that rule.
    pub fn by(&self, rule: Rule) -> Option<&Judged> {
        self.rules.iter().find(|j| j.rule == rule)
    }
}

/// Every claim of `papers` over `folders`: the first folder whose config the claim names
/// answers it; a claim no folder answers is not measurable, saying which configs would.
pub fn evaluate(papers: &[Paper], folders: &[Folder]) -> Vec<Evaluated> {
    let mut out = Vec::new();
    for p in papers {
        for c in &p.claims {
            let folder = folders.iter().find(|f| c.configs.contains(&f.config));
            let rules: Vec<Rule> =
                if c.metric.has_target_variant() { vec![Rule::Paper, Rule::Verdict] } else { vec![Rule::Paper] };
            let rules = rules
                .into_iter()
                .map(|rule| match folder {
                    Some(f) => evaluate::judge(c, rule, &f.rows),
                    None => Judged {
                        rule,
                        outcome: ClaimOutcome::NotMeasurable,
                        why: format!("no run folder of config {}", c.configs.join(" or ")),
                        ours: BTreeMap::new(),
                        unreached: BTreeMap::new(),
                        datasets: Vec::new(),
                        runs: Vec::new(),
                    },
                })
                .collect();
            out.push(Evaluated {
                id: format!("{}/{}", p.paper, c.id),
                paper: p.title.clone(),
                source: c.source.clone(),
                says: c.says.clone(),
                note: c.note.clone(),
                energy: c.energy.clone(),
                metric: c.metric.as_str(),
                check: c.check.as_str(),
                published: c.published.clone(),
                configs: c.configs.clone(),
                folder: folder.map(|f| f.dir.clone()),
                rules,
            });
        }
    }
    out
}

/// Held, not held and not measurable counts over every rule's outcome.
pub fn counts(claims: &[Evaluated]) -> [usize; 3] {
    let mut n = [0; 3];
    for j in claims.iter().flat_map(|c| &c.rules) {
        n[match j.outcome {
            ClaimOutcome::Held => 0,
            ClaimOutcome::NotHeld => 1,
            ClaimOutcome::NotMeasurable => 2,
        }] += 1;
    }
    n
}

#[cfg(test)]
mod tests;
