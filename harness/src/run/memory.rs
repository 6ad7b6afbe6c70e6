//! Peak resident memory per run (`peak_rss_mb` in `summary.csv`), from the operating system.
//!
//! The runs of a batch share one process, so the kernel's own high-water mark (`VmHWM`)
//! covers the whole batch. Instead a sampler thread reads the process's resident set
//! (`VmRSS` of `/proc/self/status`) every [`PERIOD`] while runs are in flight, and each run
//! keeps the largest value seen between its start and its end (both also sampled). A run's
//! peak is therefore the process's: the loaded meshes and, with `--jobs` above 1, the runs
//! beside it are included. Nothing is written anywhere; where `/proc` is not there (not
//! Linux) the column stays empty.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

/// How often the sampler reads the resident set: short next to the runs whose memory
/// matters (a 200k-vertex factorization takes about a second) and cheap (one small read).
pub const PERIOD: Duration = Duration::from_millis(10);

/// The process's resident set in kB, if the OS tells it.
pub fn resident_kb() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    vm_field(&status, "VmRSS:")
}

/// A `Vm*:   1234 kB` line of `/proc/<pid>/status`, in kB.
fn vm_field(status: &str, key: &str) -> Option<u64> {
    let line = status.lines().find(|l| l.starts_with(key))?;
    let mut parts = line[key.len()..].split_whitespace();
    let value = parts.next()?.parse().ok()?;
    (parts.next() == Some("kB")).then_some(value)
}

/// Per worker, the peak resident set of its current run; fed by [`Monitor::sample_until`].
pub struct Monitor {
    /// Largest resident set (kB) seen during each worker's current run; 0 when idle.
    peaks: Vec<AtomicU64>,
    active: Vec<AtomicBool>,
    stopped: Mutex<bool>,
    wake: Condvar,
    /// Whether the OS reports the resident set at all.
    supported: bool,
}

impl Monitor {
    pub fn new(workers: usize) -> Monitor {
        Monitor {
            peaks: (0..workers).map(|_| AtomicU64::new(0)).collect(),
            active: (0..workers).map(|_| AtomicBool::new(false)).collect(),
            stopped: Mutex::new(false),
            wake: Condvar::new(),
            supported: resident_kb().is_some(),
        }
    }

    /// Record one sample for every worker with a run in flight.
    fn sample(&self) {
        let Some(kb) = resident_kb() else { return };
        for (peak, active) in self.peaks.iter().zip(&self.active) {
            if active.load(Ordering::Acquire) {
                peak.fetch_max(kb, Ordering::AcqRel);
            }
        }
    }

    /// The sampler's loop: a sample every [`PERIOD`] until [`Monitor::stop`]. Run it on its
    /// own thread; without OS support it returns at once.
    pub fn sample_until_stopped(&self) {
        if !self.supported {
            return;
        }
        let mut stopped = self.stopped.lock().unwrap_or_else(|e| e.into_inner());
        while !*stopped {
            self.sample();
            stopped = self.wake.wait_timeout(stopped, PERIOD).unwrap_or_else(|e| e.into_inner()).0;
        }
    }

    pub fn stop(&self) {
        *self.stopped.lock().unwrap_or_else(|e| e.into_inner()) = true;
        self.wake.notify_all();
    }

    /// `worker` starts a run.
    pub fn start(&self, worker: usize) {
        if let (Some(peak), Some(active)) = (self.peaks.get(worker), self.active.get(worker)) {
            peak.store(resident_kb().unwrap_or(0), Ordering::Release);
            active.store(true, Ordering::Release);
        }
    }

    /// `worker`'s run ended: its peak in MB (MiB), `None` without OS support.
    pub fn finish(&self, worker: usize) -> Option<f64> {
        let (peak, active) = (self.peaks.get(worker)?, self.active.get(worker)?);
        let last = resident_kb()?;
        active.store(false, Ordering::Release);
        let kb = peak.swap(0, Ordering::AcqRel).max(last);
        Some(kb as f64 / 1024.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_fields_parse_in_kb_only() {
        let status = "Name:\tmapbench\nVmHWM:\t  204800 kB\nVmRSS:\t  102400 kB\n";
        assert_eq!(vm_field(status, "VmRSS:"), Some(102400));
        assert_eq!(vm_field(status, "VmHWM:"), Some(204800));
        assert_eq!(vm_field(status, "VmSwap:"), None);
        assert_eq!(vm_field("VmRSS:\t12 MB\n", "VmRSS:"), None);
        assert_eq!(vm_field("VmRSS:\tmany kB\n", "VmRSS:"), None);
    }

    /// A run that holds 64 MB keeps a peak of at least that, also when the memory is
    /// released before the run ends (a sample saw it); the sampler thread samples by itself.
    #[test]
    #[cfg(target_os = "linux")]
    fn a_run_that_allocates_sees_its_peak() {
        let monitor = Monitor::new(2);
        monitor.start(1);
        {
            // Every page touched, so resident.
            let big = vec![1u8; 64 << 20];
            monitor.sample();
            assert_eq!(big.iter().step_by(4096).map(|&b| usize::from(b)).sum::<usize>(), (64 << 20) / 4096);
        }
        let peak = monitor.finish(1).unwrap();
        assert!(peak >= 64.0, "peak {peak} MB");
        // an idle worker's run has no samples: only what finish reads
        assert!(monitor.finish(0).unwrap() > 0.0);
        std::thread::scope(|s| {
            s.spawn(|| monitor.sample_until_stopped());
            monitor.start(0);
            // forget the start's reading: what is there after a while came from the sampler
            monitor.peaks[0].store(0, Ordering::Release);
            std::thread::sleep(PERIOD * 5);
            assert!(monitor.peaks[0].load(Ordering::Acquire) > 0);
            monitor.stop();
        });
        assert!(monitor.finish(0).unwrap() > 0.0);
    }
}
