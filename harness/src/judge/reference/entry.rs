//! One reference minimum as a store keeps it: what it is, how it was found, its certificate,
//! and the key of what determines it.

use crate::hash::Fnv;
use crate::plan::{Plan, PlannedRun, Task};
use anyhow::Result;
use serde::{Deserialize, Serialize};

/// Bumped whenever what a reference is changes without its key seeing it: an energy's
/// definition, a generated mesh, the common start, how a reference is computed or certified.
pub const REFERENCE_VERSION: u32 = 2;

/// One reference minimum, as a store keeps it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Reference {
    /// 16 hex digits of what determines it ([`key`]).
    pub key: String,
    /// For the reader: the dataset, task and energy it was computed for.
    pub dataset: String,
    pub task: Task,
    pub energy: String,
    /// The energy of its map.
    pub e_star: f64,
    /// The energy's value at an isometry (its lower bound, `E_iso` of the accuracy scale).
    pub ideal: f64,
    /// The energy at the common start, `E0` of every run of the problem.
    pub start_energy: f64,
    /// The common start (`summary.csv`'s `start`).
    pub start: String,
    /// `|grad|` at its map.
    pub grad_norm: f64,
    /// Its map, in the store's `references/` folder, and the checksum of its coordinates.
    pub map: String,
    pub map_checksum: String,
    /// How the map was found, in order.
    pub provenance: Vec<ProvenanceStep>,
    pub certificate: Certificate,
}

/// What a step of a reference's provenance was.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StepKind {
    /// A method of the portfolio from the common start.
    Portfolio,
    /// A polish from the kept map that went lower.
    Polish,
    /// A certifying polish that went lower (then the map's next polish).
    Certify,
    /// A run of a batch that ended below the reference.
    Run,
}

/// One solve of a reference's provenance.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProvenanceStep {
    pub what: StepKind,
    pub solver: String,
    /// Where it started: `common start`, `the kept map`, or the run.
    pub from: String,
    pub iterations: usize,
    pub stop_reason: String,
    /// The energy it ended at, and `|grad|` there.
    pub energy: f64,
    pub grad_norm: Option<f64>,
    /// The batch whose run it was (`what = run`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub batch: Option<BatchSource>,
}

/// The batch a run that improved a reference came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BatchSource {
    pub config: String,
    /// The build that ran it (`git describe`-like, with `-dirty` and the diff's hash).
    pub code: String,
    pub folder: String,
    pub run: String,
    pub unix_time: u64,
}

/// Which rule certifies a reference (the energy's smoothness decides).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CertificateRule {
    /// A smooth energy: Newton stops at its floor with a small gradient, and neither
    /// certifying polish goes lower.
    Stationary,
    /// SARAP: neither certifying polish goes lower over a long window.
    Stalled,
}

/// One certifying polish.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Polish {
    pub solver: String,
    pub iterations: usize,
    pub stop_reason: String,
    /// How much lower than `E*` it ended (0 or less: not at all).
    pub decrease: f64,
}

/// A reference's certificate ([`super::computation`]'s rules).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Certificate {
    pub rule: CertificateRule,
    pub certified: bool,
    /// Why (or why not), in words.
    pub reason: String,
    /// The largest decrease a certifying polish may find (`CERTIFY_TOL * A`).
    pub tolerance: f64,
    pub polishes: Vec<Polish>,
}

/// The reference key of a run's problem (16 hex digits).
pub fn key(plan: &Plan, run: &PlannedRun) -> Result<String> {
    let problem = run.settings.problem_key_text();
    let mut h = Fnv::new();
    h.bytes(format!("mapbench reference {REFERENCE_VERSION}").as_bytes()).bytes(problem.as_bytes());
    plan.dataset(run).hash_into(&mut h)?;
    Ok(format!("{:016x}", h.0))
}
