//! Reference minima `E*` of the convergence test, one per problem: a dataset's mesh (and
//! handles) with a task, an energy and its parameters, and the common start. `E*` comes from
//! a tight solve, KP-Newton from the common start to `|grad| <= 1e-10` or until its line
//! search can no longer decrease the energy (the floating-point floor), and is kept in a
//! reference store keyed by what determines it, so a nightly does not solve it again. The
//! committed `references.json` beside the registry is read first (a fresh clone and CI
//! start warm); what a batch computes goes to the writable store (`references` in the
//! config, default `references.json` beside the history database), never into the
//! repository's tracked files. Like the history it is state kept across batches, outside the
//! run folder; with `--no-history` a batch writes neither and keeps what it computed to
//! itself (in `meta.json`).

use crate::hash::Fnv;
use crate::plan::paths::Stores;
use crate::plan::{Plan, PlannedRun, RunSettings, Task};
use crate::run_folder::write_atomic;
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use solvers::deform::DeformSettings;
use solvers::energy::EnergyKind;
use solvers::solver::{Flow, IterationRecord, Observer, StopSettings};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// Bumped whenever what a reference is changes without its key seeing it: an energy's
/// definition, a generated mesh, the common start, the tight solve.
pub const REFERENCE_VERSION: u32 = 1;

/// The tight solve's rule.
pub const TIGHT_STOP: StopSettings = StopSettings { grad_tol: 1e-10, energy_decrease_tol: 0.0, max_iters: 500 };

/// One reference minimum.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Reference {
    /// 16 hex digits of what determines it ([`key`]).
    pub key: String,
    /// For the reader: the dataset, task and energy it was computed for.
    pub dataset: String,
    pub task: Task,
    pub energy: String,
    pub e_star: f64,
    /// The tight solve: iterations, final gradient norm, why it stopped.
    pub iterations: usize,
    pub grad_norm: f64,
    pub stop_reason: String,
    /// The start it was computed from (`summary.csv`'s `start`).
    pub start: String,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct StoreFile {
    version: u32,
    references: Vec<Reference>,
}

/// The references of a batch's stores.
pub struct Book {
    seed: BTreeMap<String, Reference>,
    own: BTreeMap<String, Reference>,
    /// Where [`Book::add`] writes; `None`: it only remembers.
    store: Option<PathBuf>,
}

fn read_store(path: &Path) -> Result<BTreeMap<String, Reference>> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(BTreeMap::new()),
        Err(e) => return Err(e).with_context(|| format!("{}: cannot read the reference store", path.display())),
    };
    let file: StoreFile =
        serde_json::from_str(&text).with_context(|| format!("{}: not a reference store", path.display()))?;
    if file.version != REFERENCE_VERSION {
        // Another version's minima are of other definitions: none of them applies.
        return Ok(BTreeMap::new());
    }
    let mut out = BTreeMap::new();
    for r in file.references {
        if !r.e_star.is_finite() {
            bail!("{}: reference {} ({} {}) has e_star = {}", path.display(), r.key, r.dataset, r.energy, r.e_star);
        }
        out.insert(r.key.clone(), r);
    }
    Ok(out)
}

impl Book {
    /// Read both stores (absent files are empty; a file of another [`REFERENCE_VERSION`] has
    /// no reference that applies).
    pub fn open(stores: &Stores) -> Result<Book> {
        let seed = match &stores.seed {
            Some(p) => read_store(p)?,
            None => BTreeMap::new(),
        };
        let store = stores.persist.then(|| stores.store.clone());
        Ok(Book { seed, own: read_store(&stores.store)?, store })
    }

    pub fn get(&self, key: &str) -> Option<&Reference> {
        self.own.get(key).or_else(|| self.seed.get(key))
    }

    /// Add a computed reference to the writable store (written at once, atomically; another
    /// batch's additions since this one opened it are kept), or only to this book when the
    /// stores do not persist.
    pub fn add(&mut self, r: Reference) -> Result<()> {
        let Some(store) = &self.store else {
            self.own.insert(r.key.clone(), r);
            return Ok(());
        };
        let mut on_disk = read_store(store).unwrap_or_default();
        on_disk.insert(r.key.clone(), r.clone());
        self.own.insert(r.key.clone(), r);
        self.own.extend(on_disk.clone());
        write_store(store, on_disk.into_values().collect())
    }
}

/// Write a store: its references sorted by dataset, task, energy and key (stable diffs).
pub fn write_store(path: &Path, mut references: Vec<Reference>) -> Result<()> {
    references.sort_by(|a, b| (&a.dataset, a.task, &a.energy, &a.key).cmp(&(&b.dataset, b.task, &b.energy, &b.key)));
    let text = serde_json::to_string_pretty(&StoreFile { version: REFERENCE_VERSION, references })? + "\n";
    write_atomic(path, text.as_bytes())
}

/// The reference key of a run's problem (16 hex digits); `None` for the authalic task.
pub fn key(plan: &Plan, run: &PlannedRun) -> Result<Option<String>> {
    let Some(problem) = run.settings.problem_key_text() else { return Ok(None) };
    let mut h = Fnv::new();
    h.bytes(format!("mapbench reference {REFERENCE_VERSION}").as_bytes()).bytes(problem.as_bytes());
    plan.dataset(run).hash_into(&mut h)?;
    Ok(Some(format!("{:016x}", h.0)))
}

/// Where a group's `E*` came from (`meta.json`'s `references`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Origin {
    /// The committed store.
    Seed,
    /// The writable store (an earlier batch computed it).
    Store,
    /// This batch computed it.
    Computed,
    /// None could be had (the mesh does not load, the solve failed): the batch's best final
    /// energy is the reference.
    Unavailable,
}

/// The reference of one (dataset, energy) group of a batch.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GroupReference {
    pub dataset: String,
    pub energy: String,
    pub key: Option<String>,
    pub e_star: Option<f64>,
    pub origin: Origin,
    /// Why it is unavailable.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// `deform`: the elastic energies at the rest pose and at the start, which bound the span
    /// the runs are judged on (`convergence::elastic_scale`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub elastic: Option<Elastic>,
}

/// A `deform` problem's elastic energy (the handles' penalty left out) at the rest pose and at
/// the start ([`solvers::deform::elastic_energies`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Elastic {
    pub rest: f64,
    pub start: f64,
}

impl GroupReference {
    /// The scale the group's runs are judged on besides `E0 - E*` (`deform` only), for the
    /// reference `e_star` the batch settled on.
    pub fn scale(&self, e_star: f64) -> Option<f64> {
        self.elastic.and_then(|e| crate::convergence::elastic_scale(e_star, e.rest, e.start))
    }
}

/// The references of the groups of `runs` (param, deform): looked up, or computed and added
/// to the writable store, with a `notice` each. Stops computing when `interrupt` is set.
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
        let mut group = GroupReference {
            dataset,
            energy: run.energy.clone(),
            key: None,
            e_star: None,
            origin: Origin::Unavailable,
            note: None,
            elastic: None,
        };
        if let RunSettings::Deform { energy, settings } = &run.settings {
            match elastic(plan, run, *energy, settings) {
                Ok(e) => group.elastic = Some(e),
                Err(e) => notice(&format!(
                    "{} {}: the elastic energies are not available ({e:#}); its runs are judged from E0",
                    group.dataset, group.energy
                )),
            }
        }
        let key = match key(plan, run) {
            Ok(Some(k)) => k,
            Ok(None) => continue,
            Err(e) => {
                group.note = Some(format!("{e:#}"));
                out.push(group);
                continue;
            }
        };
        group.key = Some(key.clone());
        if let Some(r) = book.get(&key) {
            group.origin = if book.own.contains_key(&key) { Origin::Store } else { Origin::Seed };
            group.e_star = Some(r.e_star);
        } else if !interrupt.load(Ordering::Relaxed) {
            notice(&format!(
                "reference minimum of {} {} {}: computing (kp-newton from the common start to |grad| <= {:e})",
                group.dataset,
                plan.task.as_str(),
                group.energy,
                TIGHT_STOP.grad_tol
            ));
            match compute(plan, run, &key, interrupt) {
                Ok(r) => {
                    notice(&format!(
                        "reference minimum of {} {}: E* = {:.12} ({} iterations, |grad| {:.1e}, {})",
                        group.dataset, group.energy, r.e_star, r.iterations, r.grad_norm, r.stop_reason
                    ));
                    group.e_star = Some(r.e_star);
                    group.origin = Origin::Computed;
                    book.add(r).with_context(|| "adding a computed reference")?;
                }
                Err(e) => {
                    notice(&format!(
                        "reference minimum of {} {}: not available ({e:#}); the batch's best final energy is used",
                        group.dataset, group.energy
                    ));
                    group.note = Some(format!("{e:#}"));
                }
            }
        }
        out.push(group);
    }
    Ok(out)
}

/// The (dataset, energy) groups of `plan` whose reference no store holds yet (what a
/// `references` run would compute). Looks only; a group whose key cannot be made (its mesh
/// unreadable) is not counted: its runs will fail on their own.
pub fn missing(plan: &Plan) -> Result<Vec<(String, String)>> {
    let Some(stores) = &plan.references else { return Ok(Vec::new()) };
    let book = Book::open(stores)?;
    let mut out: Vec<(String, String)> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for run in &plan.runs {
        let group = (plan.dataset(run).name.clone(), run.energy.clone());
        if !seen.insert(group.clone()) {
            continue;
        }
        if let Ok(Some(k)) = key(plan, run) {
            if book.get(&k).is_none() {
                out.push(group);
            }
        }
    }
    Ok(out)
}

/// The elastic energies of `run`'s `deform` problem.
fn elastic(plan: &Plan, run: &PlannedRun, energy: EnergyKind, settings: &DeformSettings) -> Result<Elastic> {
    let ds = plan.dataset(run);
    let mesh = ds.load()?;
    let init = ds.initial_map();
    let e = solvers::deform::elastic_energies(&mesh, init.as_deref(), energy, settings)?;
    Ok(Elastic { rest: e.rest, start: e.start })
}

/// Keeps the lowest energy of the tight solve's rows without flips; stops on an interrupt.
struct Lowest<'a> {
    e_star: f64,
    last: Option<IterationRecord>,
    interrupt: &'a AtomicBool,
}

impl Observer for Lowest<'_> {
    fn observe(&mut self, r: &IterationRecord) -> Flow {
        if r.flips == 0 && r.energy.is_finite() {
            self.e_star = self.e_star.min(r.energy);
        }
        self.last = Some(r.clone());
        if self.interrupt.load(Ordering::Relaxed) {
            Flow::Stop
        } else {
            Flow::Continue
        }
    }
}

/// The tight solve of `run`'s problem: KP-Newton from the common start, [`TIGHT_STOP`].
fn compute(plan: &Plan, run: &PlannedRun, key: &str, interrupt: &AtomicBool) -> Result<Reference> {
    let ds = plan.dataset(run);
    let mesh = ds.load()?;
    let mut obs = Lowest { e_star: f64::INFINITY, last: None, interrupt };
    let outcome = match &run.settings {
        RunSettings::Param { energy, settings } => {
            let mut settings = settings.clone();
            settings.solver.stop = TIGHT_STOP;
            settings.solver.options = Default::default();
            solvers::param::solve_param(&mesh, *energy, "kp-newton", &settings, &mut obs)?
        }
        RunSettings::Deform { energy, settings } => {
            let handles = ds.handles.load(&mesh)?;
            let mut settings = settings.clone();
            settings.solver.stop = TIGHT_STOP;
            settings.solver.options = Default::default();
            let init = ds.initial_map();
            solvers::deform::solve_deform(&mesh, &handles, init.as_deref(), *energy, "kp-newton", &settings, &mut obs)?
        }
        RunSettings::Authalic(_) => bail!("the authalic task has no reference minima"),
    };
    if interrupt.load(Ordering::Relaxed) {
        bail!("interrupted");
    }
    if !obs.e_star.is_finite() {
        bail!("the tight solve has no energy without flips ({})", outcome.stop_reason.as_str());
    }
    Ok(Reference {
        key: key.to_string(),
        dataset: ds.name.clone(),
        task: plan.task,
        energy: run.energy.clone(),
        e_star: obs.e_star,
        iterations: outcome.iterations,
        grad_norm: outcome.grad_norm,
        stop_reason: outcome.stop_reason.as_str().to_string(),
        start: outcome.start.map_or("?", |s| s.as_str()).to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::config::LoadedConfig;

    fn reference(key: &str, e: f64) -> Reference {
        Reference {
            key: key.into(),
            dataset: "d".into(),
            task: Task::Param,
            energy: "sd".into(),
            e_star: e,
            iterations: 3,
            grad_norm: 1e-11,
            stop_reason: "grad_tol".into(),
            start: "tutte-scaled".into(),
        }
    }

    /// A config in `dir` on the inline dataset `name` (`m.obj`), storing references in
    /// `refs.json`, and what `prepare` made of its groups with the notices it gave.
    fn prepared(dir: &Path, name: &str, energies: &str, extra: &str) -> (Vec<GroupReference>, Vec<String>) {
        let text = format!(
            "name = \"t\"\nreferences = \"refs.json\"\nenergies = [{energies}]\nsolvers = [\"kp-newton\", \"slim\"]\n\
             [[dataset]]\nname = {name:?}\npath = \"m.obj\"\n{extra}"
        );
        let cfg = LoadedConfig::parse(&text, &dir.join("c.toml")).unwrap();
        let plan = Plan::resolve(cfg, &[]).unwrap();
        let runs: Vec<&PlannedRun> = plan.runs.iter().collect();
        let notices = std::cell::RefCell::new(Vec::new());
        let groups =
            prepare(&plan, &runs, &|line| notices.borrow_mut().push(line.to_string()), &AtomicBool::new(false))
                .unwrap();
        (groups, notices.into_inner())
    }

    /// A reference is computed once and found again by what determines it: the mesh's content
    /// (not the dataset's name), the task and the energy with its parameters; a changed mesh
    /// or parameter computes another.
    #[test]
    fn the_store_is_reused_and_a_changed_mesh_or_energy_parameter_computes_anew() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        let obj =
            |z: f64| format!("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 {z}\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n");
        std::fs::write(dir.join("m.obj"), obj(0.3)).unwrap();
        let (first, notices) = prepared(dir, "m", "\"sd\"", "");
        // one group for both solvers, computed with a notice before and after
        assert_eq!(first.len(), 1, "{first:?}");
        assert_eq!(first[0].origin, Origin::Computed);
        assert!(notices.len() == 2 && notices[0].contains("computing"), "{notices:?}");
        let e_star = first[0].e_star.unwrap();
        let stored = read_store(&dir.join("refs.json")).unwrap();
        assert_eq!(stored.keys().collect::<Vec<_>>(), [first[0].key.as_ref().unwrap()]);
        // the next batch reads it, under another dataset name too
        for name in ["m", "renamed"] {
            let (again, notices) = prepared(dir, name, "\"sd\"", "");
            assert_eq!((again[0].origin, again[0].e_star, &again[0].key), (Origin::Store, Some(e_star), &first[0].key));
            assert!(notices.is_empty(), "{notices:?}");
        }
        // another energy, another parameter: other problems
        let (other, _) = prepared(dir, "m", "\"sd\", \"sarap\"", "[energy.sd]\nsmoothness = 0.25\n");
        assert_eq!(other.iter().map(|g| g.origin).collect::<Vec<_>>(), [Origin::Computed, Origin::Computed]);
        assert!(other.iter().all(|g| g.key != first[0].key) && other[0].key != other[1].key, "{other:?}");
        // the mesh changed: the old reference does not apply
        std::fs::write(dir.join("m.obj"), obj(0.31)).unwrap();
        let (moved, _) = prepared(dir, "m", "\"sd\"", "");
        assert_eq!(moved[0].origin, Origin::Computed);
        assert!(moved[0].key != first[0].key && moved[0].e_star != Some(e_star), "{moved:?}");
        assert_eq!(read_store(&dir.join("refs.json")).unwrap().len(), 4);
    }

    #[test]
    fn the_writable_store_is_read_before_the_seed_and_only_it_is_written() {
        let tmp = tempfile::tempdir().unwrap();
        let (seed, store) = (tmp.path().join("seed.json"), tmp.path().join("out/refs.json"));
        write_store(&seed, vec![reference("a", 2.5), reference("b", 3.0)]).unwrap();
        let stores = Stores { seed: Some(seed.clone()), store: store.clone(), persist: true };
        let mut book = Book::open(&stores).unwrap();
        assert_eq!(book.get("a").map(|r| r.e_star), Some(2.5));
        assert!(book.get("c").is_none());
        book.add(reference("c", 4.0)).unwrap();
        // another batch added "d" meanwhile: kept
        let mut other = Book::open(&stores).unwrap();
        other.add(reference("d", 5.0)).unwrap();
        book.add(reference("a", 2.25)).unwrap();
        let written = read_store(&store).unwrap();
        assert_eq!(written.keys().collect::<Vec<_>>(), ["a", "c", "d"]);
        assert_eq!(Book::open(&stores).unwrap().get("a").map(|r| r.e_star), Some(2.25));
        // the seed is never written
        assert_eq!(read_store(&seed).unwrap().len(), 2);
        // a book that does not persist remembers what it adds and writes nothing
        let mut quiet = Book::open(&Stores { persist: false, ..stores.clone() }).unwrap();
        quiet.add(reference("e", 6.0)).unwrap();
        assert_eq!(quiet.get("e").map(|r| r.e_star), Some(6.0));
        assert!(!read_store(&store).unwrap().contains_key("e"));
        // a store of another version has no reference that applies; a corrupt one is an error
        std::fs::write(&store, r#"{"version": 999, "references": []}"#).unwrap();
        assert!(Book::open(&stores).unwrap().get("c").is_none());
        std::fs::write(&store, "{").unwrap();
        let e = format!("{:#}", Book::open(&stores).err().unwrap());
        assert!(e.contains("refs.json: not a reference store"), "{e}");
    }
}
