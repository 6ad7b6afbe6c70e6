//! A paper's claims as the committed `claims/<paper>.toml` files write them: what a claim
//! says, where it is measured and the check over the judged results that decides it (the
//! vocabulary: [`Quantity`] and [`Check`], documented in the book's Claims page).

use serde::Deserialize;
use std::collections::BTreeMap;

/// One paper's file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Paper {
    /// Short key (`golla2018`), the prefix of its claims' ids.
    pub paper: String,
    /// Authors, year and short title as the report shows them.
    pub title: String,
    #[serde(rename = "claim")]
    pub claims: Vec<Claim>,
}

/// One claim.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Claim {
    /// Unique within its paper; `<paper>/<id>` is unique everywhere.
    pub id: String,
    /// The table, figure or section it comes from.
    pub source: String,
    /// The claim in a sentence.
    pub says: String,
    /// How our measurement differs from the paper's, where it does (shown with the claim).
    #[serde(default)]
    pub note: String,
    /// The names of the configs whose run folders answer it (`name` in the config).
    pub configs: Vec<String>,
    pub energy: String,
    pub metric: Quantity,
    pub check: Check,
    /// The solver the claim is about.
    pub solver: String,
    /// The solvers it is compared with (empty for a bound on `solver` alone).
    #[serde(default)]
    pub others: Vec<String>,
    /// The paper's numbers per solver, shown beside ours (in the metric's unit).
    #[serde(default)]
    pub published: BTreeMap<String, f64>,
    /// `within`: the largest relative difference; `value`: the relative tolerance.
    pub tolerance: Option<f64>,
    /// `each_less`: the share of meshes it must hold on (default 1: every mesh).
    pub at_least: Option<f64>,
    /// `each_at_most`: the bound.
    pub value: Option<f64>,
    /// `value`: the mesh the published number is of (the same mesh in our corpus).
    pub dataset: Option<String>,
    /// Only meshes of at least this many vertices count.
    pub min_vertices: Option<usize>,
}

/// The per-run number a claim aggregates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// Iterations: to the run's own stop (the paper's rule, unconverged runs at their cap as the
    /// paper's tables count them), or to the tightest target (the verdict's).
    Iterations,
    /// Run time in ms per vertex (Table 4's `t_v`), to the stop or to the target.
    MsPerVertex,
    /// Run time in seconds, to the stop or to the target.
    TimeS,
    /// The final energy.
    FinalEnergy,
    /// The median time of an iteration's Hessian projection (ms).
    ProjectMs,
    /// The median projection time over the median linear-solve time (Table 5's ratio).
    ProjectSolveRatio,
    /// The authalic energy of the final map.
    AuthalicEnergy,
    /// The standard deviation of the final map's area ratios.
    AreaRatioSd,
    /// Folded triangles of the final map.
    Folded,
}

impl Quantity {
    pub fn as_str(self) -> &'static str {
        match self {
            Quantity::Iterations => "iterations",
            Quantity::MsPerVertex => "ms per vertex",
            Quantity::TimeS => "time [s]",
            Quantity::FinalEnergy => "final energy",
            Quantity::ProjectMs => "projection [ms]",
            Quantity::ProjectSolveRatio => "projection / solve",
            Quantity::AuthalicEnergy => "authalic energy",
            Quantity::AreaRatioSd => "SD of area ratios",
            Quantity::Folded => "folded triangles",
        }
    }

    /// Whether the verdict's rule changes it: a cost counted to the target instead of to the
    /// run's own stop. A property of the final map or of one iteration is the same under both.
    pub fn has_target_variant(self) -> bool {
        matches!(self, Quantity::Iterations | Quantity::MsPerVertex | Quantity::TimeS)
    }
}

/// How a claim's numbers decide it. `agg` is a solver's mean over the meshes every solver of
/// the claim has a number on (the papers' tables average so).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Check {
    /// `agg(solver) < agg(o)` for every other.
    Fewest,
    /// `agg(solver) > agg(o)` for every other.
    Most,
    /// `agg(solver) < agg(o)` for each of `others` (one or more).
    Less,
    /// `|agg(solver) / agg(o) - 1| <= tolerance` for every other.
    Within,
    /// `agg` ascending in the order `solver, others...`.
    Order,
    /// Per mesh, `solver`'s number below every other's, on at least `at_least` of the meshes.
    EachLess,
    /// Per mesh, `solver`'s number equal to every other's.
    EachEqual,
    /// Per mesh, `solver`'s number at most `value`.
    EachAtMost,
    /// On `dataset`, `solver`'s number within `tolerance` (relative) of its published one.
    Value,
    /// `solver`'s number falls as the meshes grow: more pairs of meshes of different sizes
    /// fall than rise, and the largest mesh's is below the smallest's (3 sizes or more).
    FallsWithSize,
}

impl Check {
    pub fn as_str(self) -> &'static str {
        match self {
            Check::Fewest => "fewest",
            Check::Most => "most",
            Check::Less => "less",
            Check::Within => "within",
            Check::Order => "order",
            Check::EachLess => "each_less",
            Check::EachEqual => "each_equal",
            Check::EachAtMost => "each_at_most",
            Check::Value => "value",
            Check::FallsWithSize => "falls_with_size",
        }
    }
}

/// Why a claims file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ClaimsError {
    #[error("{file}: {source}")]
    Toml { file: String, source: toml::de::Error },
    #[error("{file}: claim '{id}': {why}")]
    Claim { file: String, id: String, why: String },
    #[error(transparent)]
    Meta(#[from] crate::run_folder::meta::MetaError),
    #[error(transparent)]
    Summary(#[from] crate::run_folder::FolderError),
    #[error("{}: its meta.json names no config: no claim names it", dir.display())]
    NoName { dir: std::path::PathBuf },
}

impl Paper {
    /// Read and check one file's text (`file` names it in errors).
    pub fn parse(file: &str, text: &str) -> Result<Paper, ClaimsError> {
        let paper: Paper = toml::from_str(text).map_err(|source| ClaimsError::Toml { file: file.into(), source })?;
        let mut ids: Vec<&str> = Vec::new();
        for c in &paper.claims {
            let bad = |why: String| ClaimsError::Claim { file: file.into(), id: c.id.clone(), why };
            if ids.contains(&c.id.as_str()) {
                return Err(bad("a second claim with this id".into()));
            }
            ids.push(&c.id);
            c.check_fields().map_err(bad)?;
        }
        Ok(paper)
    }
}

impl Claim {
    /// The solver first, then the others.
    pub fn solvers(&self) -> Vec<&str> {
        std::iter::once(self.solver.as_str()).chain(self.others.iter().map(String::as_str)).collect()
    }

    /// The fields its check needs are there and in range, and every solver is a catalogue one.
    fn check_fields(&self) -> Result<(), String> {
        if self.configs.is_empty() {
            return Err("`configs` names no config".into());
        }
        for s in self.solvers().into_iter().chain(self.published.keys().map(String::as_str)) {
            if solvers::tasks::catalogue::find(s).is_none() {
                return Err(format!("'{s}' is not a catalogue solver"));
            }
        }
        let needs_others =
            matches!(self.check, Check::Fewest | Check::Most | Check::Less | Check::Within | Check::Order)
                || matches!(self.check, Check::EachLess | Check::EachEqual);
        if needs_others && self.others.is_empty() {
            return Err(format!("check '{}' compares with `others`, and there are none", self.check.as_str()));
        }
        if !needs_others && !self.others.is_empty() {
            return Err(format!("check '{}' is about `solver` alone: `others` would be ignored", self.check.as_str()));
        }
        let positive = |v: Option<f64>, key: &str| match v {
            Some(v) if v.is_finite() && v > 0.0 => Ok(()),
            Some(v) => Err(format!("{key} = {v}: it must be a positive number")),
            None => Err(format!("check '{}' needs `{key}`", self.check.as_str())),
        };
        match self.check {
            Check::Within => positive(self.tolerance, "tolerance")?,
            Check::Value => {
                positive(self.tolerance, "tolerance")?;
                if self.dataset.is_none() {
                    return Err("check 'value' needs the `dataset` the published number is of".into());
                }
                if !self.published.contains_key(&self.solver) {
                    return Err(format!("check 'value' needs `published.{}`", self.solver));
                }
            }
            Check::EachAtMost => match self.value {
                Some(v) if v.is_finite() && v >= 0.0 => {}
                _ => return Err("check 'each_at_most' needs a `value` >= 0".into()),
            },
            _ => {}
        }
        if let Some(a) = self.at_least {
            if !(a > 0.0 && a <= 1.0) || self.check != Check::EachLess {
                return Err(format!("at_least = {a}: a share in (0, 1], for check 'each_less' only"));
            }
        }
        Ok(())
    }
}
