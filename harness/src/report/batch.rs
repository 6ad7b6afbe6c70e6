//! What the report needs of a batch beyond its summary rows, read from `meta.json`: each
//! energy's iteration limit and the config's `timeout` (the caps at which unsolved runs enter
//! the corpus aggregates) and the machine calibration. Every field is optional: a folder
//! without `meta.json`, or written before these keys existed, still renders.

use crate::calibration::Calibration;
use crate::external::probe::Probe;
use crate::run_folder::meta::{Meta, Stop};
use std::collections::BTreeMap;
use std::path::Path;

/// The batch facts the report reads from `meta.json`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Batch {
    /// `stop_per_energy.<energy>.max_iters`.
    pub max_iters: BTreeMap<String, usize>,
    /// `stop_per_energy`: each energy's stop rules and ends (the first screen's words).
    pub stop: BTreeMap<String, Stop>,
    /// `external`: what the batch found out about its external solvers.
    pub external: Vec<Probe>,
    /// `expected_to_fail`.
    pub expected_to_fail: Vec<String>,
    /// The config's `timeout`, in seconds.
    pub timeout_s: Option<f64>,
    /// `calibration`: the reference workload's samples.
    pub calibration: Option<Calibration>,
    /// The config's `name` (the explorer's title; the papers' claims it answers).
    pub config: Option<String>,
}

impl Batch {
    /// Read from `run_dir/meta.json`; missing or unreadable keys stay `None`/empty (the
    /// tables then fall back to what the summary shows and say so).
    pub fn read(run_dir: &Path) -> Batch {
        Meta::read(run_dir).map(|m| Batch::from_meta(&m)).unwrap_or_default()
    }

    /// The caps and calibration of a parsed `meta.json`.
    pub fn from_meta(meta: &Meta) -> Batch {
        let max_iters =
            meta.stop_per_energy.iter().flatten().filter_map(|(e, s)| Some((e.clone(), s.max_iters?))).collect();
        let timeout_s = meta.config_str("timeout").and_then(timeout_secs);
        let config = meta.config_name().map(str::to_string);
        let stop = meta.stop_per_energy.clone().unwrap_or_default();
        let external = meta.external.clone().and_then(|v| serde_json::from_value(v).ok()).unwrap_or_default();
        let expected_to_fail = meta.expected_to_fail.clone().unwrap_or_default();
        Batch { max_iters, timeout_s, calibration: meta.calibration.clone(), config, stop, external, expected_to_fail }
    }

    /// The batch's median calibration time, when it has a positive one.
    pub fn calibration_s(&self) -> Option<f64> {
        self.calibration.as_ref().and_then(Calibration::median_s).filter(|m| *m > 0.0)
    }
}

/// A config `timeout` string in seconds, parsed by the config's own rule.
fn timeout_secs(text: &str) -> Option<f64> {
    let config = serde_json::json!({ "name": "meta", "solvers": [], "timeout": text });
    let config: crate::plan::config::Config = serde_json::from_value(config).ok()?;
    config.timeout_secs().ok().flatten()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn caps_and_calibration_come_from_meta_json() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(Batch::read(dir.path()), Batch::default(), "no meta.json: nothing known");
        let meta = serde_json::json!({
            "config": { "name": "x", "timeout": "2m" },
            "stop_per_energy": { "sd": { "max_iters": 1000, "grad_tol": 1e-3 }, "bconf": { "max_iters": 50 } },
            "calibration": { "workload": "w", "samples_s": [0.5, 0.4, 0.6] },
        });
        std::fs::write(dir.path().join("meta.json"), meta.to_string()).unwrap();
        let b = Batch::read(dir.path());
        assert_eq!(b.max_iters.get("sd"), Some(&1000));
        assert_eq!(b.max_iters.get("bconf"), Some(&50));
        assert_eq!(b.timeout_s, Some(120.0));
        assert_eq!(b.calibration_s(), Some(0.5));
        assert!(b.calibration.unwrap().unsteady());
        // A timeout the config would refuse is no cap.
        let meta = serde_json::from_value(serde_json::json!({ "config": { "timeout": "soon" } })).unwrap();
        let b = Batch::from_meta(&meta);
        assert_eq!(b.timeout_s, None);
    }
}
