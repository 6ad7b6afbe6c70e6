//! References only get better: a run of a batch whose final map (or the polish of it) ends
//! below its group's `E*` by more than round-off lowers the reference. Before the batch is
//! judged, the lowest such map of each group is verified (its energy recomputed), polished
//! and certified like a computed reference, and added to the writable store with the run as
//! its provenance; the whole group is then judged against it, and the next batch reads it.

use super::problem::Problem;
use super::reference::{self, computation, store::Book, BatchSource, GroupReference, Origin, ProvenanceStep, StepKind};
use crate::plan::{Plan, PlannedRun};
use crate::run_folder::{map, read_summary};
use anyhow::{Context, Result};
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// How far below `E*` (relative to `max(1, |E*|)`) a run must end to lower it: above the
/// energies' round-off, far below any target.
pub const IMPROVE_RTOL: f64 = 1e-11;

/// Whether `energy` is below `e_star` beyond round-off.
pub fn below(e_star: f64, energy: f64) -> bool {
    energy < e_star - IMPROVE_RTOL * e_star.abs().max(1.0)
}

/// A map of a run that ended below its group's reference.
pub struct Candidate {
    /// The run (`<dataset>__<energy>__<solver>`).
    pub stem: String,
    pub dataset: String,
    pub energy_name: String,
    /// The map, normalized frame, and its energy as the run reported it.
    pub x: Vec<f64>,
    pub energy: f64,
    /// How it was found: the run, and the polish when it was the polish that went lower.
    pub steps: Vec<ProvenanceStep>,
}

/// Lower the references of `groups` with `candidates` (maps of the runs of `runs` of
/// `plan`, each with the batch and run it came from): each group's lowest, verified, polished
/// and certified, added to the writable store (`plan`'s stores) and taken as the group's `E*`.
pub fn improve(
    plan: &Plan,
    runs: &[&PlannedRun],
    groups: &mut [GroupReference],
    mut candidates: Vec<(Candidate, BatchSource)>,
    notice: &dyn Fn(&str),
    interrupt: &AtomicBool,
) -> Result<()> {
    let Some(stores) = &plan.references else { return Ok(()) };
    candidates.sort_by(|a, b| a.0.energy.total_cmp(&b.0.energy));
    let mut book: Option<Book> = None;
    for group in groups.iter_mut() {
        let Some((c, source)) =
            candidates.iter().find(|(c, _)| c.dataset == group.dataset && c.energy_name == group.energy)
        else {
            continue;
        };
        let (Some(key), Some(run)) = (group.key.clone(), runs.iter().find(|r| r.stem == c.stem)) else { continue };
        let old = group.e_star.unwrap_or(f64::INFINITY);
        if !below(old, c.energy) {
            continue;
        }
        let name = format!("{} {} {}", group.dataset, plan.task.as_str(), group.energy);
        let problem = match Problem::of(plan, run) {
            Ok(p) => p,
            Err(e) => {
                notice(&format!("reference minimum of {name}: {} ended lower, but: {e:#}", source.run));
                continue;
            }
        };
        // Our code's energy of the map, not the solver's word for it.
        let m = problem.measure(&c.x);
        if m.flips > 0 || !(m.energy - c.energy).abs().le(&(1e-12 * c.energy.abs().max(1.0))) {
            notice(&format!(
                "reference minimum of {name}: {} reported {:.12} but its map's energy is {:.12} with {} flips: not taken",
                source.run, c.energy, m.energy, m.flips
            ));
            continue;
        }
        notice(&format!(
            "reference minimum of {name}: {} ended at {:.12}, below E* = {old:.12}: polishing and certifying it",
            source.run, m.energy
        ));
        let step = |line: &str| notice(&format!("reference minimum of {name}: {line}"));
        let mut steps = c.steps.clone();
        for s in steps.iter_mut() {
            s.batch = Some(source.clone());
        }
        let found = computation::Found { x: c.x.clone(), energy: m.energy, steps };
        let certified = computation::polish(&problem, found, &step, interrupt).and_then(|found| {
            let base = reference::blank(&key, &group.dataset, problem.task(), &group.energy);
            computation::certify(&problem, found, base, &step, interrupt)
        });
        let (r, x) = match certified {
            Ok(done) => done,
            Err(e) => {
                notice(&format!("reference minimum of {name}: not lowered ({e:#})"));
                continue;
            }
        };
        if book.is_none() {
            book = Some(Book::open(stores)?);
        }
        if let Some(b) = book.as_mut() {
            b.add(r.clone(), &x, &problem.mesh)?;
        }
        notice(&format!(
            "reference minimum of {name}: E* = {:.12} (was {old:.12}), {}",
            r.e_star,
            if r.certificate.certified { "certified" } else { "NOT certified" }
        ));
        group.take(&r, Origin::Improved);
        group.note = Some(format!("lowered from {old} by {}", source.run));
    }
    Ok(())
}

/// The maps of run folders `dirs` that end below their group's reference in `groups` (the
/// groups of `plan`): what `mapbench references --from` lowers a store with. Each run's map
/// is read against the plan's mesh of its dataset (a map of another mesh is refused).
pub fn from_folders(plan: &Plan, groups: &[GroupReference], dirs: &[&Path]) -> Result<Vec<(Candidate, BatchSource)>> {
    let mut out = Vec::new();
    for dir in dirs {
        let rows = read_summary(dir).with_context(|| format!("{}: not a run folder", dir.display()))?;
        let meta = crate::run_folder::meta::Meta::read(dir).ok();
        for r in rows.iter().filter(|r| r.status.ran() && r.flips == Some(0)) {
            let Some(group) = groups.iter().find(|g| g.dataset == r.dataset && g.energy == r.energy) else { continue };
            let Some(last) = r.final_energy.filter(|e| e.is_finite()) else { continue };
            if !below(group.e_star.unwrap_or(f64::INFINITY), last) {
                continue;
            }
            let Some(run) = plan.runs.iter().find(|p| plan.dataset(p).name == r.dataset && p.energy == r.energy) else {
                continue;
            };
            let mesh = plan.dataset(run).load()?;
            let stored = map::StoredMesh {
                positions: mesh.positions.clone(),
                faces: mesh.faces.clone(),
                checksum: map::checksum(&mesh.positions, &mesh.faces),
            };
            let stem = crate::names::run_stem(&r.dataset, &r.energy, &r.solver);
            let path = map::uv_path(dir, &stem);
            if !path.is_file() {
                continue;
            }
            let uv = map::read_uv(&path, &stored)?;
            let step = ProvenanceStep {
                what: StepKind::Run,
                solver: r.solver.clone(),
                from: "common start".into(),
                iterations: r.iterations.unwrap_or(0),
                stop_reason: r.stop_column().into(),
                energy: last,
                grad_norm: r.grad_norm,
                batch: None,
            };
            let source = BatchSource {
                config: meta.as_ref().and_then(|m| m.config_path.clone()).unwrap_or_default(),
                code: meta
                    .as_ref()
                    .and_then(|m| m.git_revision.clone())
                    .map(|rev| if meta.as_ref().and_then(|m| m.git_dirty) == Some(true) { rev + "-dirty" } else { rev })
                    .unwrap_or_else(|| "unknown".into()),
                folder: crate::paths::absolute(dir).display().to_string(),
                run: stem.clone(),
                unix_time: meta.as_ref().and_then(|m| m.ended_unix).unwrap_or(0),
            };
            let candidate = Candidate {
                stem: run.stem.clone(),
                dataset: r.dataset.clone(),
                energy_name: r.energy.clone(),
                x: uv.iter().flat_map(|p| [p[0], p[1]]).collect(),
                energy: last,
                steps: vec![step],
            };
            out.push((candidate, source));
        }
    }
    Ok(out)
}
