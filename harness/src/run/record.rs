//! What a batch writes into its folder's `meta.json`: the plan and provenance of the batch.

use super::options::RunOptions;
use crate::calibration::Calibration;
use crate::external::probe::Probe;
use crate::history::HistoryOutcome;
use crate::judge::reference::GroupReference;
use crate::plan::select::Shard;
use crate::plan::{Plan, RunSettings};
use crate::run_folder::meta::{Meta, MetaError, Stop, VERSION};
use std::collections::BTreeMap;
use std::path::Path;
use std::time::{SystemTime, UNIX_EPOCH};

/// What a batch knows about itself while it runs; [`BatchRecord::write`] turns it into the
/// folder's [`Meta`].
pub struct BatchRecord<'a> {
    pub plan: &'a Plan,
    pub shard: Option<Shard>,
    pub resume: bool,
    pub jobs: usize,
    pub threads: usize,
    pub started: SystemTime,
    /// What became of the folder's batch in the history, until this one's is known: a
    /// resumed folder's earlier outcome (its batch may be in the history), else nothing.
    pub history: Option<HistoryOutcome>,
    /// The reference minimum of each (dataset, energy) group of the batch (`merge` judges
    /// the merged batch by them).
    pub references: Vec<GroupReference>,
    /// What the batch found out about its external solvers.
    pub external: Vec<Probe>,
}

impl<'a> BatchRecord<'a> {
    /// The record of a batch starting now with `jobs` runs at once of `threads` threads each.
    pub fn starting(
        plan: &'a Plan,
        opts: &RunOptions,
        (jobs, threads): (usize, usize),
        history: Option<HistoryOutcome>,
        external: Vec<Probe>,
    ) -> Self {
        let (shard, resume, started) = (opts.shard, opts.resume, SystemTime::now());
        BatchRecord { plan, shard, resume, jobs, threads, started, history, references: Vec::new(), external }
    }

    pub fn write(
        &self,
        out_dir: &Path,
        ended: Option<SystemTime>,
        interrupted: bool,
        calibration: &Calibration,
    ) -> Result<(), MetaError> {
        self.meta(ended, interrupted, calibration)?.write(out_dir)
    }

    fn meta(&self, ended: Option<SystemTime>, interrupted: bool, calibration: &Calibration) -> Result<Meta, MetaError> {
        let plan = self.plan;
        let secs = |t: SystemTime| t.duration_since(UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0);
        let (config_rev, config_dirty) = git_revision(&plan.config.dir);
        let code = build();
        let settings_error =
            |e: &dyn std::fmt::Display| MetaError::Settings { path: plan.config.path.clone(), what: e.to_string() };
        // Every energy of the config, whatever `--only` kept.
        let per_energy = crate::plan::energy_settings(&plan.config).map_err(|e| settings_error(&e))?;
        let ordering = per_energy
            .iter()
            .find_map(|(_, s)| match s {
                RunSettings::Param { settings, .. } => Some(settings.solver.linear.ordering),
                RunSettings::Deform { settings, .. } => Some(settings.solver.linear.ordering),
                RunSettings::Authalic(_) => None,
            })
            .unwrap_or_default();
        let mut settings_per_energy = BTreeMap::new();
        for (e, s) in &per_energy {
            settings_per_energy.insert(e.clone(), serde_json::to_value(s).map_err(|e| settings_error(&e))?);
        }
        let stop_per_energy = per_energy.iter().map(|(e, s)| (e.clone(), Stop::from(s.stop()))).collect();
        Ok(Meta {
            version: Some(VERSION),
            calibration: Some(calibration.clone()),
            calibration_median_s: calibration.median_s(),
            calibration_spread: calibration.spread(),
            config: serde_json::to_value(&plan.config.raw).map_err(|e| settings_error(&e))?,
            config_git_dirty: config_dirty,
            config_git_revision: config_rev,
            config_path: Some(plan.config.path.display().to_string()),
            cores: Some(std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)),
            crates: Some(env!("MAPBENCH_CRATES").into()),
            ended_unix: ended.map(secs),
            external: (!self.external.is_empty()).then(|| serde_json::to_value(&self.external).ok()).flatten(),
            git_dirty: code.dirty,
            git_diff: code.diff,
            git_revision: code.revision,
            hardware: Some(crate::hardware::Hardware::detect()),
            history: self.history.as_ref().and_then(HistoryOutcome::meta_history),
            history_outcome: self.history.as_ref().and_then(|o| serde_json::to_value(o).ok()),
            host: std::env::var("HOSTNAME")
                .ok()
                .or_else(|| std::fs::read_to_string("/etc/hostname").ok().map(|s| s.trim().to_string())),
            interrupted: Some(interrupted),
            jobs: Some(self.jobs),
            linear_ordering: Some(ordering.as_str().into()),
            mapbench_version: Some(env!("CARGO_PKG_VERSION").into()),
            maps: Some(plan.maps),
            maps_keep: (!plan.maps_keep.is_empty()).then(|| plan.maps_keep.clone()),
            expected_to_fail: (!plan.expected_to_fail.is_empty()).then(|| plan.expected_to_fail.clone()),
            merged_from: None,
            meshes_dir: std::env::var(crate::plan::registry::MESHES_ENV).ok(),
            only: Some(plan.only.clone()),
            plan: Some(plan.runs.iter().map(|p| p.stem.clone()).collect()),
            references: serde_json::to_value(&self.references).ok(),
            repeat: Some(plan.repeat),
            resume: Some(self.resume),
            rustc: Some(env!("MAPBENCH_RUSTC").into()),
            settings_per_energy: Some(settings_per_energy),
            shard: self.shard.map(|s| s.to_string()),
            started_unix: Some(secs(self.started)),
            stop_per_energy: Some(stop_per_energy),
            targets: Some(plan.targets.default.clone()),
            targets_per_energy: (!plan.targets.by_energy.is_empty()).then(|| plan.targets.by_energy.clone()),
            threads_per_run: Some(self.threads),
        })
    }
}

/// The build this binary is, set at build time (`harness/build.rs`): the code's git revision,
/// whether the code differed from it, and a hash of the difference.
#[derive(Clone, Debug, PartialEq)]
pub struct BinaryBuild {
    pub revision: Option<String>,
    pub dirty: Option<bool>,
    pub diff: Option<String>,
}

/// This binary's [`BinaryBuild`].
pub fn build() -> BinaryBuild {
    let some = |s: &str| (!s.is_empty()).then(|| s.to_string());
    BinaryBuild {
        revision: some(env!("MAPBENCH_GIT_REVISION")),
        dirty: some(env!("MAPBENCH_GIT_DIRTY")).map(|d| d == "true"),
        diff: some(env!("MAPBENCH_GIT_DIFF")),
    }
}

/// What identifies the code of a batch in its runs' `--resume` keys and a reference's
/// provenance: version, the build's revision, and the hash of its uncommitted difference.
pub fn code_id() -> String {
    let b = build();
    let mut id = format!("mapbench {} {}", env!("CARGO_PKG_VERSION"), b.revision.as_deref().unwrap_or("unknown"));
    if b.dirty == Some(true) {
        id += &format!("-dirty {}", b.diff.as_deref().unwrap_or(""));
    }
    id
}

/// The git revision of the folder holding the config, and whether its tree is dirty (what
/// `meta.json` records as `config_git_revision`, beside the code's own).
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
