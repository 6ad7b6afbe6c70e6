//! Machine calibration: a fixed reference workload timed at the start of a batch, between
//! its repeat rounds and at the end, so that run times can be divided by what this machine,
//! at this moment, takes for a known amount of work (`time_norm`), and so that a batch during
//! which the machine changed speed says so.
//!
//! The workload is four KP-Newton iterations of SD on the generated `bumpy_10k` (assembly,
//! analytic projection, symbolic analysis, four numeric factorizations and line searches):
//! the same kinds of work the benchmarked runs spend their time on, about half a second.

use crate::stats::median;
use serde::{Deserialize, Serialize};
use solvers::energy::EnergyKind;
use solvers::solver::StopAt;
use solvers::tasks::param::{solve_param, ParamSettings};
use std::time::Instant;

/// The generated mesh of the reference workload.
pub const WORKLOAD_MESH: &str = "bumpy_10k";
/// Newton iterations of the reference workload.
pub const WORKLOAD_ITERATIONS: usize = 4;
/// A spread of the samples above this fraction of their median means the machine changed
/// speed during the batch: the report warns.
pub const SPREAD_WARNING: f64 = 0.10;

/// The calibration samples of one batch (`meta.json`'s `calibration`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// What was timed, for the reader of `meta.json`.
    pub workload: String,
    /// Wall seconds of each sample, in the order taken (start, between rounds, end).
    pub samples_s: Vec<f64>,
}

impl Calibration {
    pub fn new() -> Calibration {
        Calibration {
            workload: format!("kp-newton sd, {WORKLOAD_ITERATIONS} iterations on generated {WORKLOAD_MESH}"),
            samples_s: Vec::new(),
        }
    }

    /// Time the workload once more and keep the sample: `copies` copies at once (the batch's
    /// `--jobs`, so that the workload meets the load its runs meet), each on a rayon pool of
    /// `threads` (the runs' `threads_per_run`); the sample is their median. The first sample
    /// is preceded by an untimed round (page faults, allocator, caches), which would
    /// otherwise make it the slowest.
    pub fn sample(&mut self, copies: usize, threads: usize) -> anyhow::Result<f64> {
        if self.samples_s.is_empty() {
            concurrently(copies, threads)?;
        }
        let s = concurrently(copies, threads)?;
        self.samples_s.push(s);
        Ok(s)
    }

    /// The batch's calibration time: the median sample (`None` before any sample).
    pub fn median_s(&self) -> Option<f64> {
        median(&mut self.samples_s.clone())
    }

    /// (max - min) / median of the samples: 0 for one sample.
    pub fn spread(&self) -> Option<f64> {
        let m = self.median_s()?;
        let max = self.samples_s.iter().copied().fold(f64::MIN, f64::max);
        let min = self.samples_s.iter().copied().fold(f64::MAX, f64::min);
        Some(if m > 0.0 { (max - min) / m } else { 0.0 })
    }

    /// The machine changed speed during the batch (spread above [`SPREAD_WARNING`]).
    pub fn unsteady(&self) -> bool {
        self.spread().is_some_and(|s| s > SPREAD_WARNING)
    }

    /// `time_s` divided by the batch's calibration time.
    pub fn normalize(&self, time_s: f64) -> Option<f64> {
        self.median_s().filter(|m| *m > 0.0).map(|m| time_s / m)
    }
}

/// The median time of `copies` copies of the workload run at once.
fn concurrently(copies: usize, threads: usize) -> anyhow::Result<f64> {
    let times: Vec<anyhow::Result<f64>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..copies.max(1))
            .map(|_| {
                scope.spawn(move || match rayon::ThreadPoolBuilder::new().num_threads(threads.max(1)).build() {
                    Ok(pool) => pool.install(time_workload),
                    Err(_) => time_workload(),
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap_or_else(|_| Err(anyhow::anyhow!("calibration panicked")))).collect()
    });
    let mut times = times.into_iter().collect::<anyhow::Result<Vec<f64>>>()?;
    median(&mut times).ok_or_else(|| anyhow::anyhow!("no calibration copy ran"))
}

/// One timing of the reference workload, on the calling thread's rayon pool.
fn time_workload() -> anyhow::Result<f64> {
    let mesh = solvers::generate::generate(WORKLOAD_MESH)?;
    let energy = EnergyKind::default_for("sd").ok_or_else(|| anyhow::anyhow!("no energy sd"))?;
    let mut settings = ParamSettings::for_energy(&energy);
    settings.solver.stop.max_iters = WORKLOAD_ITERATIONS;
    let t0 = Instant::now();
    let out = solve_param(&mesh, energy, "kp-newton", &settings, &mut StopAt(usize::MAX))?;
    let t = t0.elapsed().as_secs_f64();
    // A workload that stopped early would time less work than it claims.
    anyhow::ensure!(
        out.iterations == WORKLOAD_ITERATIONS,
        "calibration workload stopped after {} iterations ({})",
        out.iterations,
        out.stop_reason.as_str()
    );
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_spread_and_normalization_follow_the_samples() {
        let mut c = Calibration::new();
        assert_eq!(c.median_s(), None);
        assert_eq!(c.normalize(1.0), None);
        c.samples_s = vec![0.5, 0.4, 0.6];
        assert_eq!(c.median_s(), Some(0.5));
        assert!((c.spread().unwrap() - 0.4).abs() < 1e-12);
        assert!(c.unsteady());
        assert_eq!(c.normalize(2.0), Some(4.0));
        c.samples_s = vec![0.50, 0.52, 0.51];
        assert!(!c.unsteady());
    }

    #[test]
    fn the_workload_runs_its_iterations() {
        let mut c = Calibration::new();
        let t = c.sample(2, 1).unwrap();
        assert!(t > 0.0 && c.samples_s == vec![t]);
    }
}
