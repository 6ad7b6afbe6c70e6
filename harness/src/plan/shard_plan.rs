//! `shards.json`: a batch split into shards by expected cost (`mapbench submit` writes it,
//! `run --shard-plan FILE --shard I/N` runs shard I of it). Each run of the batch's plan is in
//! exactly one shard; a file planned for another batch (another config, `--only`, `--repeat`,
//! or a registry that now resolves other datasets) is refused rather than run in part.

use super::select::Shard;
use super::Plan;
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeSet, HashMap};
use std::path::Path;

/// The version of the file's layout.
pub const SHARD_PLAN_VERSION: u32 = 1;

/// Where a run's expected time came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CostSource {
    /// The median `time_norm` of the same run (dataset, task, energy, solver) in past batches
    /// of the history database.
    History,
    /// No past time: the stated estimate from the mesh's vertices, the solver's family and the
    /// energy.
    Estimate,
    /// A run the batch records as skipped (outside its solver's definition): no work.
    Skipped,
}

/// One run of a shard.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlannedShardRun {
    /// `<dataset>__<energy>__<solver>`.
    pub run: String,
    /// Expected seconds with every repeat.
    pub predicted_s: f64,
    pub source: CostSource,
}

/// One shard: its runs in the batch's order and their expected seconds in all.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlannedShard {
    /// 1-based, as `--shard I/N` and `$SLURM_ARRAY_TASK_ID`.
    pub index: usize,
    pub predicted_s: f64,
    pub runs: Vec<PlannedShardRun>,
}

/// The whole file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShardPlanFile {
    pub version: u32,
    /// The config file the shards run (absolute), and its `name`.
    pub config: std::path::PathBuf,
    pub config_name: String,
    /// [`plan_hash`] of the batch planned: its runs with their settings, repeats, timeout and
    /// targets. A config edited since (a new `max_iters` as much as a new solver) is refused.
    pub plan_hash: String,
    /// The `--only` globs and the repeats the batch was planned with.
    pub only: Vec<String>,
    pub repeat: usize,
    /// Runs of the batch.
    pub runs: usize,
    /// Seconds of the calibration workload the expected times are scaled by (`time_norm` x
    /// this = seconds), and where it came from.
    pub calibration_s: f64,
    pub calibration_source: String,
    /// The history database past times were looked up in, if any.
    pub history: Option<std::path::PathBuf>,
    /// How many runs' times came from the history and how many were estimated.
    pub from_history: usize,
    pub estimated: usize,
    /// No split can finish before this: the longest run, or the total work spread evenly.
    pub lower_bound_s: f64,
    /// The busiest shard's expected seconds.
    pub makespan_s: f64,
    pub shards: Vec<PlannedShard>,
}

impl ShardPlanFile {
    pub fn read(path: &Path) -> Result<ShardPlanFile> {
        let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))?;
        let file: ShardPlanFile = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a shard plan (shards.json)", path.display()))?;
        if file.version != SHARD_PLAN_VERSION {
            bail!(
                "{}: shard plan version {} (this mapbench reads {SHARD_PLAN_VERSION}): plan it again with `mapbench \
                 submit`",
                path.display(),
                file.version
            );
        }
        file.check_layout().with_context(|| format!("{}: invalid shard plan", path.display()))?;
        Ok(file)
    }

    pub fn write(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self)? + "\n";
        crate::run_folder::write_atomic(path, text.as_bytes())
    }

    /// Shards numbered 1..=N in order, each run in one shard only.
    fn check_layout(&self) -> Result<()> {
        if self.shards.is_empty() {
            bail!("no shards");
        }
        let mut seen = BTreeSet::new();
        for (i, s) in self.shards.iter().enumerate() {
            if s.index != i + 1 {
                bail!("shard {} is listed in place {} (shards are numbered 1..N in order)", s.index, i + 1);
            }
            for r in &s.runs {
                if !seen.insert(r.run.as_str()) {
                    bail!("run {} is in more than one shard", r.run);
                }
            }
        }
        if seen.len() != self.runs {
            bail!("the shards hold {} runs, the file says the batch has {}", seen.len(), self.runs);
        }
        Ok(())
    }

    /// The runs of `shard` (`I/N`, N the file's shard count), after checking that the file
    /// was planned for exactly `plan`'s runs.
    pub fn runs_of(&self, shard: Shard, plan: &Plan) -> Result<BTreeSet<String>> {
        if shard.count != self.shards.len() {
            bail!("--shard {shard}: the shard plan has {} shards, not {}", self.shards.len(), shard.count);
        }
        let planned: HashMap<&str, usize> =
            self.shards.iter().flat_map(|s| s.runs.iter().map(move |r| (r.run.as_str(), s.index))).collect();
        let mine: BTreeSet<&str> = plan.runs.iter().map(|r| r.stem.as_str()).collect();
        if let Some(new) = mine.iter().find(|s| !planned.contains_key(*s)) {
            bail!(
                "run {new} of {} is in no shard of the plan: the plan was made for another batch (another config, \
                 --only or registry); plan it again",
                plan.config.path.display()
            );
        }
        if let Some(gone) = planned.keys().find(|s| !mine.contains(*s)) {
            bail!(
                "run {gone} of the shard plan is not in the batch of {}: the plan was made for another batch; plan \
                 it again",
                plan.config.path.display()
            );
        }
        if self.repeat != plan.repeat {
            bail!("the shard plan was made for --repeat {}, this batch repeats {}", self.repeat, plan.repeat);
        }
        if self.plan_hash != plan_hash(plan) {
            bail!(
                "the settings of {} changed since the shards were planned (the same runs, other settings: a stop \
                 rule, an energy parameter, the timeout or the targets); plan it again",
                plan.config.path.display()
            );
        }
        Ok(self.shards[shard.index - 1].runs.iter().map(|r| r.run.clone()).collect())
    }
}

/// 16 hex digits of what the shards of `plan` run: each run's name and settings, the repeats,
/// the timeout and the targets.
pub fn plan_hash(plan: &Plan) -> String {
    let mut h = crate::hash::Fnv::new();
    for r in &plan.runs {
        h.bytes(r.stem.as_bytes()).bytes(r.settings.key_text().as_bytes());
    }
    h.word(plan.repeat as u64);
    h.word(plan.timeout.map_or(u64::MAX, |t| t.as_nanos() as u64));
    for t in &plan.targets.default {
        h.word(t.to_bits());
    }
    for (energy, targets) in &plan.targets.by_energy {
        h.bytes(energy.as_bytes());
        for t in targets {
            h.word(t.to_bits());
        }
    }
    format!("{:016x}", h.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(shards: &[&[&str]]) -> ShardPlanFile {
        file_of(shards, &plan())
    }

    fn file_of(shards: &[&[&str]], p: &Plan) -> ShardPlanFile {
        let shards: Vec<PlannedShard> = shards
            .iter()
            .enumerate()
            .map(|(i, runs)| PlannedShard {
                index: i + 1,
                predicted_s: runs.len() as f64,
                runs: runs
                    .iter()
                    .map(|r| PlannedShardRun { run: r.to_string(), predicted_s: 1.0, source: CostSource::Estimate })
                    .collect(),
            })
            .collect();
        ShardPlanFile {
            version: SHARD_PLAN_VERSION,
            config: "/c/t.toml".into(),
            config_name: "t".into(),
            plan_hash: plan_hash(p),
            only: vec![],
            repeat: 1,
            runs: shards.iter().map(|s| s.runs.len()).sum(),
            calibration_s: 0.2,
            calibration_source: "test".into(),
            history: None,
            from_history: 0,
            estimated: 4,
            lower_bound_s: 2.0,
            makespan_s: 2.0,
            shards,
        }
    }

    fn plan() -> Plan {
        let text = "name = \"t\"\nenergies = [\"sd\", \"sarap\"]\nsolvers = [\"kp-newton\"]\n[[dataset]]\nname = \
                    \"a\"\npath = \"a.obj\"\n[[dataset]]\nname = \"b\"\npath = \"b.obj\"\n";
        let cfg = super::super::config::LoadedConfig::parse(text, Path::new("t.toml")).unwrap();
        let datasets = super::super::registry::resolve_inline(&cfg, &[]).unwrap();
        Plan::with_datasets(cfg, datasets, Vec::new(), &[]).unwrap()
    }

    const RUNS: [&str; 4] = ["a__sd__kp-newton", "a__sarap__kp-newton", "b__sd__kp-newton", "b__sarap__kp-newton"];

    #[test]
    fn a_shard_gets_its_runs_and_the_file_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let f = file(&[&[RUNS[0], RUNS[3]], &[RUNS[1], RUNS[2]]]);
        let path = dir.path().join("shards.json");
        f.write(&path).unwrap();
        let back = ShardPlanFile::read(&path).unwrap();
        assert_eq!(back, f);
        let runs = back.runs_of(Shard { index: 2, count: 2 }, &plan()).unwrap();
        assert_eq!(runs.into_iter().collect::<Vec<_>>(), [RUNS[1], RUNS[2]]);
    }

    #[test]
    fn a_plan_of_another_batch_or_a_broken_file_is_refused() {
        let p = plan();
        let short = file(&[&[RUNS[0]], &[RUNS[1], RUNS[2]]]);
        let e = short.runs_of(Shard { index: 1, count: 2 }, &p).unwrap_err().to_string();
        assert!(e.contains("run b__sarap__kp-newton of t.toml is in no shard"), "{e}");
        let extra = file(&[&[RUNS[0], RUNS[3], "c__sd__kp-newton"], &[RUNS[1], RUNS[2]]]);
        let e = extra.runs_of(Shard { index: 1, count: 2 }, &p).unwrap_err().to_string();
        assert!(e.contains("run c__sd__kp-newton of the shard plan is not in the batch"), "{e}");
        let two = file(&[&[RUNS[0], RUNS[3]], &[RUNS[1], RUNS[2]]]);
        let e = two.runs_of(Shard { index: 1, count: 3 }, &p).unwrap_err().to_string();
        assert!(e.contains("the shard plan has 2 shards, not 3"), "{e}");
        let mut repeated = two.clone();
        repeated.repeat = 3;
        assert!(repeated.runs_of(Shard { index: 1, count: 2 }, &p).unwrap_err().to_string().contains("--repeat 3"));
        // the same runs with another stop rule
        let mut tighter = plan();
        if let crate::plan::RunSettings::Param { settings, .. } = &mut tighter.runs[0].settings {
            settings.solver.stop.max_iters = 3;
        }
        let e = two.runs_of(Shard { index: 1, count: 2 }, &tighter).unwrap_err().to_string();
        assert!(e.contains("the settings of t.toml changed since the shards were planned"), "{e}");
        assert!(file_of(&[&[RUNS[0], RUNS[3]], &[RUNS[1], RUNS[2]]], &tighter)
            .runs_of(Shard { index: 1, count: 2 }, &tighter)
            .is_ok());

        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("shards.json");
        let twice = file(&[&[RUNS[0], RUNS[1]], &[RUNS[1], RUNS[2]]]);
        twice.write(&path).unwrap();
        let e = format!("{:#}", ShardPlanFile::read(&path).unwrap_err());
        assert!(
            e.contains("shards.json: invalid shard plan: run a__sarap__kp-newton is in more than one shard"),
            "{e}"
        );
        let mut newer = two;
        newer.version = 99;
        newer.write(&path).unwrap();
        let e = format!("{:#}", ShardPlanFile::read(&path).unwrap_err());
        assert!(e.contains("shard plan version 99"), "{e}");
        let mut empty = file(&[]);
        empty.runs = 0;
        empty.write(&path).unwrap();
        assert!(format!("{:#}", ShardPlanFile::read(&path).unwrap_err()).contains("invalid shard plan: no shards"));
        std::fs::write(&path, "{}").unwrap();
        assert!(format!("{:#}", ShardPlanFile::read(&path).unwrap_err()).contains("not a shard plan"));
    }
}
