//! `meta.json` of a run folder: the plan and provenance of the batch.

use crate::calibration::Calibration;
use crate::plan::select::Shard;
use crate::plan::{Plan, RunSettings};
use crate::run_folder::write_atomic;
use anyhow::Result;
use solvers::solver::StopSettings;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::{SystemTime, UNIX_EPOCH};

/// `meta.json`: the config as read and the resolved settings of each energy, provenance
/// (code version, git revision, machine, toolchain), the batch's runs and how it ran.
pub struct Meta<'a> {
    pub plan: &'a Plan,
    pub shard: Option<Shard>,
    pub resume: bool,
    pub jobs: usize,
    pub threads: usize,
    pub started: SystemTime,
    /// What became of the folder's batch in the history, until this one's is known: a
    /// resumed folder's earlier outcome (its batch may be in the history), else nothing.
    pub history: Option<crate::history::Outcome>,
    /// The reference minimum of each (dataset, energy) group of the batch (`merge` judges
    /// the merged batch by them).
    pub references: Vec<crate::judge::reference::GroupReference>,
}

impl Meta<'_> {
    pub fn write(
        &self,
        out_dir: &Path,
        ended: Option<SystemTime>,
        interrupted: bool,
        calibration: &Calibration,
    ) -> Result<()> {
        let plan = self.plan;
        let secs = |t: SystemTime| t.duration_since(UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0);
        let (rev, dirty) = git_revision(&plan.config.dir);
        // Every energy of the config, whatever `--only` kept.
        let per_energy = crate::plan::energy_settings(&plan.config)?;
        let stop: BTreeMap<&str, StopSettings> = per_energy.iter().map(|(e, s)| (e.as_str(), s.stop())).collect();
        let ordering = per_energy
            .iter()
            .find_map(|(_, s)| match s {
                RunSettings::Param { settings, .. } => Some(settings.solver.linear.ordering),
                RunSettings::Deform { settings, .. } => Some(settings.solver.linear.ordering),
                RunSettings::Authalic(_) => None,
            })
            .unwrap_or_default();
        let meta = serde_json::json!({
            "config_path": plan.config.path.display().to_string(),
            // The config as read, and what each energy's runs resolve it to.
            "config": plan.config.raw,
            "settings_per_energy": per_energy.iter().map(|(e, s)| (e.clone(), serde_json::to_value(s).unwrap_or_default()))
                .collect::<serde_json::Map<_, _>>(),
            "only": plan.only,
            "resume": self.resume,
            "shard": self.shard.map(|s| s.to_string()),
            "plan": plan.runs.iter().map(|p| p.stem.as_str()).collect::<Vec<_>>(),
            "jobs": self.jobs,
            "threads_per_run": self.threads,
            // Newton systems of fewer than METIS_MIN_NODES vertices use AMD whatever this says.
            "linear_ordering": ordering.as_str(),
            "stop_per_energy": stop.iter().map(|(e, s)| (e.to_string(), serde_json::json!({
                "grad_tol": s.grad_tol, "energy_decrease_tol": s.energy_decrease_tol, "max_iters": s.max_iters
            }))).collect::<serde_json::Map<_, _>>(),
            "meshes_dir": std::env::var(crate::plan::registry::MESHES_ENV).ok(),
            "mapbench_version": env!("CARGO_PKG_VERSION"),
            "rustc": env!("MAPBENCH_RUSTC"),
            "crates": env!("MAPBENCH_CRATES"),
            "git_revision": rev,
            "git_dirty": dirty,
            "host": std::env::var("HOSTNAME").ok().or_else(|| std::fs::read_to_string("/etc/hostname").ok().map(|s| s.trim().to_string())),
            "cores": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
            "started_unix": secs(self.started),
            "ended_unix": ended.map(secs),
            "interrupted": interrupted,
            "repeat": self.plan.repeat,
            // The convergence test's targets, loosest first, and each group's reference.
            "targets": self.plan.targets,
            "references": self.references,
            // The history database the batch is in (null: not, or not yet) and what became of
            // it, set once the batch is over (`history::Outcome::conclude`).
            "history": self.history.as_ref().map_or(serde_json::Value::Null, |o| o.meta_history()),
            "history_outcome": self.history,
            // Which final maps the folder keeps (`maps`); merge prunes by it.
            "maps": self.plan.maps.as_str(),
            // The reference workload's samples; `time_norm` divides by their median.
            "calibration": calibration,
            "calibration_median_s": calibration.median_s(),
            "calibration_spread": calibration.spread(),
        });
        write_atomic(&super::meta_json(out_dir), serde_json::to_string_pretty(&meta)?.as_bytes())
    }
}

/// What identifies the code of a batch in its runs' `--resume` keys: version and git revision.
pub fn code_id(dir: &Path) -> String {
    let (rev, dirty) = git_revision(dir);
    format!("mapbench {} {} dirty={dirty:?}", env!("CARGO_PKG_VERSION"), rev.unwrap_or_default())
}

/// The git revision of the folder holding the config, and whether the tree is dirty.
fn git_revision(dir: &Path) -> (Option<String>, Option<bool>) {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .current_dir(dir)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    let rev = git(&["rev-parse", "HEAD"]);
    let dirty =
        rev.as_ref().and_then(|_| git(&["status", "--porcelain", "--untracked-files=no"])).map(|s| !s.is_empty());
    (rev, dirty)
}

/// The calibration samples of a run folder's `meta.json` (`None`: no meta, or a batch from
/// before calibration).
pub fn read_calibration(run_dir: &Path) -> Option<Calibration> {
    let text = std::fs::read_to_string(super::meta_json(run_dir)).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    serde_json::from_value(v.get("calibration")?.clone()).ok()
}
