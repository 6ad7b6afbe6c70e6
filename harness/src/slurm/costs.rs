//! The expected time of each run of a batch, which the shards are balanced by: the median
//! `time_norm` of the same run (dataset, task, energy, solver) in past batches of the history
//! database (the same config's batches first, then any config's), else a stated estimate from
//! the mesh's vertices, the solver's family and the energy ([`estimate_norm`]). Times are kept
//! in `time_norm` units (multiples of the calibration workload) and turned into seconds by
//! one calibration time, so one slow night in the history does not skew a plan.

use crate::family::Family;
use crate::history::db::PastTime;
use crate::history::HistoryDb;
use crate::plan::registry::{Dataset, MeshSource};
use crate::plan::shard_plan::CostSource;
use crate::plan::{Plan, PlannedRun};
use crate::stats::median;
use anyhow::Result;
use std::collections::HashMap;
use std::io::BufRead;

/// Seconds a run recorded as skipped is planned at (it loads nothing and solves nothing).
pub const SKIPPED_S: f64 = 0.01;

/// The expected times of a batch's runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Costs {
    /// Expected seconds of each run of the plan (every repeat), in the plan's order.
    pub seconds: Vec<f64>,
    pub sources: Vec<CostSource>,
    /// Seconds of the calibration workload the `time_norm`s were scaled by.
    pub calibration_s: f64,
    /// Where that calibration time came from.
    pub calibration_source: String,
}

/// Past times of one run key: of the same config, of any other.
#[derive(Default)]
struct Past {
    same: Vec<f64>,
    other: Vec<f64>,
}

/// The expected time of each of `plan`'s runs. `past` are the history's times (empty without
/// a database); `calibrate` times the calibration workload here when the history has no
/// calibrated batch to take the scale from.
pub fn costs(plan: &Plan, past: &[PastTime], calibrate: impl FnOnce() -> Result<f64>) -> Result<Costs> {
    let config = plan.config.config.name.as_str();
    let task = plan.task;
    let mut by_run: HashMap<(&str, &str, &str), Past> = HashMap::new();
    for p in past.iter().filter(|p| p.task == task && p.time_norm.is_finite() && p.time_norm >= 0.0) {
        let entry = by_run.entry((p.dataset.as_str(), p.energy.as_str(), p.solver.as_str())).or_default();
        if p.config_name == config {
            entry.same.push(p.time_norm);
        } else {
            entry.other.push(p.time_norm);
        }
    }
    let (calibration_s, calibration_source) = match past_calibration(past, config) {
        Some(c) => c,
        None => (calibrate()?, "the calibration workload timed by `submit` on this machine".to_string()),
    };
    let mut vertices: HashMap<usize, Option<usize>> = HashMap::new();
    let mut seconds = Vec::with_capacity(plan.runs.len());
    let mut sources = Vec::with_capacity(plan.runs.len());
    let repeat = plan.repeat.max(1) as f64;
    let timeout = plan.timeout.map(|t| t.as_secs_f64());
    for run in &plan.runs {
        if run.skip.is_some() {
            seconds.push(SKIPPED_S);
            sources.push(CostSource::Skipped);
            continue;
        }
        let ds = plan.dataset(run);
        let known = by_run.get_mut(&(ds.name.as_str(), run.energy.as_str(), run.solver.as_str()));
        let from_history = known.and_then(|p| median(&mut p.same).or_else(|| median(&mut p.other)));
        let (norm, source) = match from_history {
            Some(t) => (t, CostSource::History),
            None => {
                let v = *vertices.entry(run.dataset).or_insert_with(|| vertex_count(ds));
                (estimate_norm(v.unwrap_or(10_000), family_of(plan, run), &run.energy), CostSource::Estimate)
            }
        };
        // A run stops at its timeout (each repeat of a timed-out run replays to where it stopped).
        let once = timeout.map_or(norm * calibration_s, |t| (norm * calibration_s).min(t));
        seconds.push(once * repeat);
        sources.push(source);
    }
    Ok(Costs { seconds, sources, calibration_s, calibration_source })
}

/// The calibration time of the config's latest batches (the median of the last five), else
/// of any config's.
fn past_calibration(past: &[PastTime], config: &str) -> Option<(f64, String)> {
    let pick = |same: bool| {
        // `past` is in batch order; a batch's calibration repeats on each of its runs.
        let mut per_batch: Vec<f64> = Vec::new();
        for p in past.iter().filter(|p| (p.config_name == config) == same) {
            if let Some(c) = p.calibration_median_s.filter(|c| c.is_finite() && *c > 0.0) {
                if per_batch.last() != Some(&c) {
                    per_batch.push(c);
                }
            }
        }
        let last = per_batch.len().saturating_sub(5);
        median(&mut per_batch[last..].to_vec())
    };
    match (pick(true), pick(false)) {
        (Some(c), _) => Some((c, format!("the history's last batches of config {config}"))),
        (None, Some(c)) => Some((c, "the history's last batches of other configs".to_string())),
        (None, None) => None,
    }
}

/// The history's past times, or none when there is no database yet. A database that cannot
/// be read is an error: a plan made blind to it would be silently worse.
pub fn past_times(db: Option<&std::path::Path>) -> Result<Vec<PastTime>> {
    match db {
        Some(p) if p.is_file() => Ok(HistoryDb::open_existing(p)?.past_times()?),
        _ => Ok(Vec::new()),
    }
}

/// The family of a run's solver; `None` for an external solver.
fn family_of(plan: &Plan, run: &PlannedRun) -> Option<Family> {
    if plan.external(run).is_some() {
        return None;
    }
    crate::family::family(&run.solver)
}

/// The stated estimate of a run's `time_norm` when the history has none: proportional to the
/// vertices (a run's iterations cost about linearly in the mesh; how many it needs depends on
/// the mesh more than on its size, so the estimate is rough, but it keeps the large meshes
/// apart, which is what balances shards), times the solver family's time at 10,000 vertices
/// and the energy's factor. An external solver adds its process start. At least
/// 0.05 (loading and judging a run).
pub fn estimate_norm(vertices: usize, family: Option<Family>, energy: &str) -> f64 {
    let at_10k = match family {
        Some(Family::AnalyticNewton) => 3.0,
        Some(Family::NumericNewton) => 6.0,
        Some(Family::FilteredNewton) => 3.0,
        Some(Family::Proxy) => 8.0,
        Some(Family::QuasiNewton) => 6.0,
        Some(Family::Authalic) => 4.0,
        None => 30.0,
    };
    let energy_factor = match energy {
        "sarap" => 1.4,
        "barap" => 0.9,
        "bconf" => 0.5,
        _ => 1.0,
    };
    let start = if family.is_none() { 5.0 } else { 0.0 };
    (at_10k * energy_factor * vertices as f64 / 10_000.0 + start).max(0.05)
}

/// The dataset's vertex count: what the registry says, else counted (an OBJ's `v` lines, a
/// generated mesh built). `None` when the mesh cannot be read (its runs will fail fast).
fn vertex_count(ds: &Dataset) -> Option<usize> {
    if let Some(v) = ds.expected.0 {
        return Some(v);
    }
    match &ds.source {
        MeshSource::Generated(g) => solvers::generate::generate(g).ok().map(|m| m.positions.len()),
        MeshSource::File(p) => {
            let file = std::fs::File::open(p).ok()?;
            let mut count = 0;
            for line in std::io::BufReader::new(file).lines() {
                let line = line.ok()?;
                if line.starts_with("v ") || line.starts_with("v\t") {
                    count += 1;
                }
            }
            Some(count)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::config::LoadedConfig;
    use crate::plan::Task;
    use std::path::Path;

    fn plan(extra: &str) -> Plan {
        let registry = Path::new(env!("CARGO_MANIFEST_DIR")).join("../datasets.toml");
        let text = format!(
            "name = \"p\"\nregistry = {:?}\ndatasets = [\"bumpy_1k\", \"bumpy_10k\"]\nenergies = [\"sd\", \"bconf\"]\n\
             solvers = [\"kp-newton\", \"slim\"]\n{extra}",
            registry.display().to_string()
        );
        Plan::resolve(LoadedConfig::parse(&text, Path::new("p.toml")).unwrap(), &[]).unwrap()
    }

    fn past(config: &str, dataset: &str, energy: &str, solver: &str, t: f64, cal: f64) -> PastTime {
        PastTime {
            config_name: config.into(),
            dataset: dataset.into(),
            task: Task::Param,
            energy: energy.into(),
            solver: solver.into(),
            time_norm: t,
            calibration_median_s: Some(cal),
        }
    }

    #[test]
    fn past_times_of_the_same_config_come_first_then_any_configs_then_the_estimate() {
        let p = plan("");
        let stems: Vec<&str> = p.runs.iter().map(|r| r.stem.as_str()).collect();
        assert_eq!(stems[..3], ["bumpy_1k__sd__kp-newton", "bumpy_1k__sd__slim", "bumpy_1k__bconf__kp-newton"]);
        let history = [
            past("p", "bumpy_1k", "sd", "kp-newton", 1.0, 0.2),
            past("p", "bumpy_1k", "sd", "kp-newton", 3.0, 0.2),
            past("p", "bumpy_1k", "sd", "kp-newton", 2.0, 0.4),
            past("other", "bumpy_1k", "sd", "kp-newton", 100.0, 0.4),
            past("other", "bumpy_1k", "sd", "slim", 10.0, 0.4),
        ];
        let c = costs(&p, &history, || panic!("the history has a calibration")).unwrap();
        // the config's last batches' calibration: median of 0.2, 0.4 (one per batch: 0.2, 0.4)
        assert!((c.calibration_s - 0.3).abs() < 1e-12, "{}", c.calibration_s);
        assert_eq!(c.sources[..3], [CostSource::History, CostSource::History, CostSource::Estimate]);
        // median of the same config's 1, 3, 2 (the other config's 100 is not looked at)
        assert!((c.seconds[0] - 2.0 * 0.3).abs() < 1e-12);
        assert!((c.seconds[1] - 10.0 * 0.3).abs() < 1e-12);
        // slim is not defined for bconf: skipped, no work
        let skipped = p.runs.iter().position(|r| r.stem == "bumpy_1k__bconf__slim").unwrap();
        assert_eq!((c.sources[skipped], c.seconds[skipped]), (CostSource::Skipped, SKIPPED_S));
        // estimates: the big mesh costs about 10x the small one
        let est = |stem: &str| c.seconds[p.runs.iter().position(|r| r.stem == stem).unwrap()];
        let ratio = est("bumpy_10k__sd__slim") / est("bumpy_1k__bconf__kp-newton");
        assert!(ratio > 10.0, "{ratio}");
        assert!(est("bumpy_10k__sd__kp-newton") > est("bumpy_10k__bconf__kp-newton"));
    }

    #[test]
    fn no_history_calibrates_here_and_repeats_and_timeouts_scale_the_times() {
        let p = plan("repeat = 3\ntimeout = \"0.5s\"\n");
        let c = costs(&p, &[], || Ok(0.25)).unwrap();
        assert_eq!(c.calibration_s, 0.25);
        assert!(c.calibration_source.contains("timed by `submit`"));
        assert!(c.sources.iter().all(|s| *s != CostSource::History));
        let i = p.runs.iter().position(|r| r.stem == "bumpy_10k__sd__slim").unwrap();
        // 8 x 10k/10k x 0.25 s = 2 s, capped at the 0.5 s timeout, times 3 repeats
        assert!((c.seconds[i] - 1.5).abs() < 0.01, "{}", c.seconds[i]);
        let j = p.runs.iter().position(|r| r.stem == "bumpy_1k__sd__kp-newton").unwrap();
        let v = solvers::generate::generate("bumpy_1k").unwrap().positions.len();
        let once = estimate_norm(v, Some(Family::AnalyticNewton), "sd") * 0.25;
        assert!((c.seconds[j] - 3.0 * once).abs() < 1e-9);
    }

    #[test]
    fn the_estimate_grows_with_the_mesh_and_has_a_floor() {
        let newton = Some(Family::AnalyticNewton);
        assert_eq!(estimate_norm(10_000, newton, "sd"), 3.0);
        assert_eq!(estimate_norm(20_000, newton, "sarap"), 2.0 * 3.0 * 1.4);
        assert_eq!(estimate_norm(0, newton, "sd"), 0.05);
        assert_eq!(estimate_norm(10_000, None, "sd"), 35.0);
    }
}
