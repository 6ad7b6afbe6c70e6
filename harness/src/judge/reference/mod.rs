//! Reference minima `E*` of the convergence test, one per problem: a dataset's mesh (and
//! handles) with a task, an energy and its parameters, and the common start. A reference is
//! the best known minimum, with the map that has it, how it was found and a certificate of the
//! stationarity reached (`entry`, `computation`); it is kept in a reference store keyed by what determines
//! it (`store`), so a nightly does not compute it again. The committed `references.json`
//! beside the registry is read with the writable store (`references` in the config, default
//! `references.json` beside the history database), each entry verified against its map, the
//! lower of the two used; what a batch computes or finds goes to the writable store only, and
//! only when lower. With `--no-history` a batch writes neither and keeps what it computed to
//! itself (in `meta.json`).

pub mod chained;
pub mod computation;
mod entry;
pub mod store;

pub use computation::{blank, compute};
pub use entry::{
    key, BatchSource, Certificate, CertificateRule, Polish, ProvenanceStep, Reference, StepKind, REFERENCE_VERSION,
};
pub use store::lookup;

use crate::judge::problem::Problem;
use crate::plan::{Plan, PlannedRun};
use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicBool, Ordering};
use store::Book;

/// Where a group's `E*` came from (`meta.json`'s `references`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Origin {
    /// The committed store.
    Seed,
    /// The writable store (an earlier batch computed or found it).
    Store,
    /// This batch computed it.
    Computed,
    /// A run of this batch ended below the stored one: its map, polished and certified, is
    /// the reference now (`note` names the run).
    Improved,
    /// None could be had (the mesh does not load, the solve failed): the batch's best final
    /// energy is the reference, uncertified.
    Unavailable,
}

/// The reference of one (dataset, energy) group of a batch: its yardstick.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GroupReference {
    pub dataset: String,
    pub energy: String,
    pub key: Option<String>,
    pub e_star: Option<f64>,
    pub origin: Origin,
    /// Why it is unavailable, what refused a stored one, or which run lowered it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// `E0`: the energy at the common start, whatever start a solver takes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_energy: Option<f64>,
    /// `E_iso`: the energy at an isometry.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ideal: Option<f64>,
    /// Whether `E*` carries a certificate ([`computation`]); an uncertified one is marked
    /// wherever its verdicts appear.
    #[serde(default)]
    pub certified: bool,
    /// The certificate's reason, or why there is none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub certificate: Option<String>,
}

impl GroupReference {
    fn unavailable(dataset: String, energy: String) -> GroupReference {
        GroupReference {
            dataset,
            energy,
            key: None,
            e_star: None,
            origin: Origin::Unavailable,
            note: None,
            start_energy: None,
            ideal: None,
            certified: false,
            certificate: None,
        }
    }

    /// Take the entry `r` as this group's reference.
    pub fn take(&mut self, r: &Reference, origin: Origin) {
        self.e_star = Some(r.e_star);
        self.origin = origin;
        self.certified = r.certificate.certified;
        self.certificate = Some(r.certificate.reason.clone());
    }
}

/// The references of the groups of `runs` (every task; a chained start first): looked up and verified, or
/// computed and added to the writable store, with a `notice` each (not computed when the
/// config sets `compute_references = false`). Stops computing when `interrupt` is set.
pub fn prepare(
    plan: &Plan,
    runs: &[&PlannedRun],
    notice: &dyn Fn(&str),
    interrupt: &AtomicBool,
) -> Result<Vec<GroupReference>> {
    let Some(stores) = &plan.references else { return Ok(Vec::new()) };
    let mut book = Book::open(stores)?;
    let mut out: Vec<GroupReference> = Vec::new();
    for run in runs {
        let dataset = plan.dataset(run).name.clone();
        if out.iter().any(|g| g.dataset == dataset && g.energy == run.energy) {
            continue;
        }
        let mut group = GroupReference::unavailable(dataset, run.energy.clone());
        let key = match key(plan, run) {
            Ok(k) => k,
            Err(e) => {
                group.note = Some(format!("{e:#}"));
                out.push(group);
                continue;
            }
        };
        group.key = Some(key.clone());
        // A chained start (exp-SD's SD minimum) first: the problem starts there.
        if let Err(e) = chained::resolve(plan, run, Some(&mut book), notice, interrupt) {
            notice(&format!("{e:#}"));
            group.note = Some(format!("{e:#}"));
            out.push(group);
            continue;
        }
        let problem = match Problem::of(plan, run) {
            Ok(p) => p,
            Err(e) => {
                // The runs will fail on the same cause, each naming it.
                group.note = Some(format!("{e:#}"));
                out.push(group);
                continue;
            }
        };
        group.start_energy = Some(problem.e0);
        group.ideal = Some(problem.ideal);
        let name = format!("{} {} {}", group.dataset, plan.task.as_str(), group.energy);
        if let Some((r, _, own)) = lookup(&book, &key, &problem, notice) {
            group.take(&r, if own { Origin::Store } else { Origin::Seed });
        } else if !stores.compute {
            let why = "not computed: the config sets `compute_references = false`";
            notice(&format!(
                "reference minimum of {name}: {why}; the batch's best final energy is used, uncertified \
                 (`mapbench references` computes it)"
            ));
            group.note = Some(why.to_string());
        } else if !interrupt.load(Ordering::Relaxed) {
            notice(&format!("reference minimum of {name}: computing (the book's numerics page, \"Reference minima\")"));
            let step = |line: &str| notice(&format!("reference minimum of {name}: {line}"));
            match compute(&problem, &key, &group.dataset, &group.energy, &step, interrupt) {
                Ok((r, x)) => {
                    notice(&format!(
                        "reference minimum of {name}: E* = {:.12} (|grad| {:.1e}), {}",
                        r.e_star,
                        r.grad_norm,
                        if r.certificate.certified { "certified" } else { "NOT certified" },
                    ));
                    group.take(&r, Origin::Computed);
                    book.add(r, &x, &problem.mesh).with_context(|| "adding a computed reference")?;
                }
                Err(e) => {
                    notice(&format!(
                        "reference minimum of {name}: not available ({e:#}); the batch's best final energy is used, \
                         uncertified"
                    ));
                    group.note = Some(format!("{e:#}"));
                }
            }
        }
        out.push(group);
    }
    Ok(out)
}

/// Certify again the uncertified references of `groups` (the groups of `runs` of `plan`):
/// each stored map polished and certified by the rules of today, the entry replaced in the
/// writable store when it is lower or now certified. What `mapbench references --recertify`
/// runs after a change of the rules, or to give a slow minimum more polish.
pub fn recertify(
    plan: &Plan,
    runs: &[&PlannedRun],
    groups: &mut [GroupReference],
    notice: &dyn Fn(&str),
    interrupt: &AtomicBool,
) -> Result<()> {
    let Some(stores) = &plan.references else { return Ok(()) };
    let mut book = Book::open(stores)?;
    for group in groups.iter_mut().filter(|g| g.e_star.is_some() && !g.certified) {
        let Some(key) = group.key.clone() else { continue };
        let Some(run) = runs.iter().find(|r| plan.dataset(r).name == group.dataset && r.energy == group.energy) else {
            continue;
        };
        let problem = Problem::of(plan, run)?;
        let Some((r, x, _)) = lookup(&book, &key, &problem, notice) else { continue };
        let name = format!("{} {} {}", group.dataset, plan.task.as_str(), group.energy);
        let step = |line: &str| notice(&format!("reference minimum of {name}: {line}"));
        let found = computation::Found { x, energy: r.e_star, steps: r.provenance.clone() };
        let (again, x) = computation::certify(
            &problem,
            found,
            blank(&key, &group.dataset, problem.task(), &group.energy),
            &step,
            interrupt,
        )?;
        notice(&format!(
            "reference minimum of {name}: E* = {:.12}, {} ({})",
            again.e_star,
            if again.certificate.certified { "certified" } else { "NOT certified" },
            again.certificate.reason
        ));
        if book.add(again.clone(), &x, &problem.mesh)? {
            group.take(&again, group.origin);
        }
    }
    Ok(())
}

/// The (dataset, energy) groups of `plan` whose reference no store holds (verified) yet: what
/// a `references` run would compute (with the SD minimum a chained start needs). A group
/// whose problem cannot be made (its mesh unreadable) is not counted: its runs will fail on
/// their own. None with `compute_references = false`: the batch would not compute them.
pub fn missing(plan: &Plan) -> Result<Vec<(String, String)>> {
    let Some(stores) = plan.references.as_ref().filter(|s| s.compute) else { return Ok(Vec::new()) };
    let mut book = Book::open(stores)?;
    let mut out: Vec<(String, String)> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for run in &plan.runs {
        let group = (plan.dataset(run).name.clone(), run.energy.clone());
        if !seen.insert(group.clone()) {
            continue;
        }
        // A chained start missing from the stores: computing it is part of the group's work.
        if !chained::stored(plan, run, &mut book) {
            out.push(group);
            continue;
        }
        let (Ok(k), Ok(problem)) = (key(plan, run), Problem::of(plan, run)) else { continue };
        if lookup(&book, &k, &problem, &|_| {}).is_none() {
            out.push(group);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
