//! Peak resident memory per run, from the operating system: `peak_rss_mb`, the process's
//! peak while the run was in flight, and `peak_growth_mb`, how far that peak rose above the
//! process's resident set when the run started.
//!
//! The runs of a batch share one process. A sampler thread reads the process's resident set
//! (`VmRSS` of `/proc/self/status`) every [`PERIOD`] while runs are in flight, and each run
//! keeps the largest value seen between its start and its end (both also sampled): the
//! process's peak, the loaded meshes and the runs beside it included. A run that had the
//! process to itself (no other worker busy with a run or its mesh at any moment of it: always
//! with `--jobs 1`, where only the batch's own thread writing the previous run's files runs
//! beside it)
//! also resets the kernel's high-water mark at its start (`5` written to
//! `/proc/self/clear_refs`, Linux 4.0 and later: one small write, no page walk) and reads it
//! (`VmHWM`) at its end, so that its peak is exact and not sampled; its growth is that peak
//! less the resident set when it started. The growth is the run's own memory less what it
//! found free in the allocator (left by earlier runs and not given back to the system): the
//! run's own peak when the process was fresh, a lower bound after large runs (a method that
//! needs a few vectors after one that factorized a large system can read 0). With other runs
//! in flight the memory cannot be told apart in one process, and `peak_growth_mb` stays
//! empty. Where `/proc` is not there (not Linux) both columns stay empty.

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

/// The kernel's high-water mark of the process's resident set in kB.
fn high_water_kb() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    vm_field(&status, "VmHWM:")
}

/// Reset the kernel's high-water mark to the current resident set; whether it could.
fn reset_high_water() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// What [`Monitor::finish`] measured of one run, in MB (MiB).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RunMemory {
    /// The process's peak resident set while the run was in flight.
    pub process_mb: Option<f64>,
    /// The peak less the resident set at the run's start, when no other run was in flight
    /// beside it.
    pub growth_mb: Option<f64>,
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
    /// Whether each worker is measuring a run (what the sampler samples for).
    active: Vec<AtomicBool>,
    /// Who is doing what, under one lock: runs start and end a few times a second at most.
    flight: Mutex<Flight>,
    stopped: Mutex<bool>,
    wake: Condvar,
    /// Whether the OS reports the resident set at all.
    supported: bool,
}

/// The workers' state: busy from taking a run to handing it over (its mesh loaded and
/// released included), measuring while the run itself runs.
struct Flight {
    busy: Vec<bool>,
    measuring: Vec<bool>,
    /// Another worker was busy at some moment of each measuring worker's run.
    shared: Vec<bool>,
    /// The run reset the kernel's high-water mark at its start.
    exact: Vec<bool>,
    /// The resident set (kB) at the run's start.
    base: Vec<u64>,
}

/// A worker's busy spell; it ends when dropped.
pub struct Busy<'a> {
    monitor: &'a Monitor,
    worker: usize,
}

impl Drop for Busy<'_> {
    fn drop(&mut self) {
        if let Some(b) = self.monitor.flight().busy.get_mut(self.worker) {
            *b = false;
        }
    }
}

impl Monitor {
    pub fn new(workers: usize) -> Monitor {
        Monitor {
            peaks: (0..workers).map(|_| AtomicU64::new(0)).collect(),
            active: (0..workers).map(|_| AtomicBool::new(false)).collect(),
            flight: Mutex::new(Flight {
                busy: vec![false; workers],
                measuring: vec![false; workers],
                shared: vec![false; workers],
                exact: vec![false; workers],
                base: vec![0; workers],
            }),
            stopped: Mutex::new(false),
            wake: Condvar::new(),
            supported: resident_kb().is_some(),
        }
    }

    fn flight(&self) -> std::sync::MutexGuard<'_, Flight> {
        self.flight.lock().unwrap_or_else(|e| e.into_inner())
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

    /// `worker` took a run: until the returned guard drops, every run measured beside it
    /// shares the process with it.
    pub fn busy(&self, worker: usize) -> Busy<'_> {
        let mut f = self.flight();
        if worker < f.busy.len() {
            f.busy[worker] = true;
            let Flight { measuring, shared, .. } = &mut *f;
            for (m, s) in measuring.iter().zip(shared.iter_mut()) {
                *s |= *m;
            }
        }
        Busy { monitor: self, worker }
    }

    /// `worker` starts measuring its run.
    pub fn start(&self, worker: usize) {
        let mut f = self.flight();
        if worker >= f.busy.len() {
            return;
        }
        let others = (0..f.busy.len()).any(|w| w != worker && f.busy[w]);
        f.shared[worker] = others;
        f.exact[worker] = !others && self.supported && reset_high_water();
        let kb = resident_kb().unwrap_or(0);
        f.base[worker] = kb;
        f.measuring[worker] = true;
        self.peaks[worker].store(kb, Ordering::Release);
        self.active[worker].store(true, Ordering::Release);
    }

    /// `worker`'s run ended: what it measured (nothing without OS support, nor for a worker
    /// that was not measuring).
    pub fn finish(&self, worker: usize) -> RunMemory {
        let mut f = self.flight();
        if !f.measuring.get(worker).copied().unwrap_or(false) {
            return RunMemory::default();
        }
        f.measuring[worker] = false;
        self.active[worker].store(false, Ordering::Release);
        let peak = self.peaks[worker].swap(0, Ordering::AcqRel);
        let Some(last) = resident_kb() else { return RunMemory::default() };
        let mut kb = peak.max(last);
        let alone = !f.shared[worker];
        if alone && f.exact[worker] {
            kb = kb.max(high_water_kb().unwrap_or(0));
        }
        let mb = |kb: u64| kb as f64 / 1024.0;
        let growth = alone.then(|| mb(kb.saturating_sub(f.base[worker])));
        RunMemory { process_mb: Some(mb(kb)), growth_mb: growth }
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
        let _busy = monitor.busy(1);
        monitor.start(1);
        {
            // Every page touched, so resident.
            let big = vec![1u8; 64 << 20];
            monitor.sample();
            assert_eq!(big.iter().step_by(4096).map(|&b| usize::from(b)).sum::<usize>(), (64 << 20) / 4096);
        }
        let peak = monitor.finish(1);
        assert!(peak.process_mb.unwrap() >= 64.0, "peak {peak:?}");
        // It was alone in the monitor: it has an own peak (tests beside it in this process
        // make its size unknowable here: tests/memory.rs measures it in a process of its own).
        assert!(peak.growth_mb.is_some_and(|own| own <= peak.process_mb.unwrap()), "{peak:?}");
        // a run with no sample between its start and end: what start and finish read
        monitor.start(0);
        assert!(monitor.finish(0).process_mb.unwrap() > 0.0);
        std::thread::scope(|s| {
            s.spawn(|| monitor.sample_until_stopped());
            monitor.start(0);
            // forget the start's reading: what is there after a while came from the sampler
            monitor.peaks[0].store(0, Ordering::Release);
            std::thread::sleep(PERIOD * 5);
            assert!(monitor.peaks[0].load(Ordering::Acquire) > 0);
            monitor.stop();
        });
        assert!(monitor.finish(0).process_mb.unwrap() > 0.0);
    }

    /// A run with another worker busy beside it (running, or loading a mesh) at any moment
    /// has no growth; a later one alone has; a worker that did not start measures nothing.
    #[test]
    #[cfg(target_os = "linux")]
    fn runs_beside_other_busy_workers_have_no_growth() {
        let monitor = Monitor::new(2);
        // Both at once.
        let (b0, b1) = (monitor.busy(0), monitor.busy(1));
        monitor.start(0);
        monitor.start(1);
        let (a, b) = (monitor.finish(0), monitor.finish(1));
        assert_eq!((a.growth_mb, b.growth_mb), (None, None), "overlapping runs");
        assert!(a.process_mb.is_some() && b.process_mb.is_some());
        drop((b0, b1));
        // Worker 1 takes a run (loads its mesh) while worker 0's run is measured.
        let b0 = monitor.busy(0);
        monitor.start(0);
        let b1 = monitor.busy(1);
        drop(b1);
        assert_eq!(monitor.finish(0).growth_mb, None, "another worker was busy during the run");
        drop(b0);
        // Alone.
        let b1 = monitor.busy(1);
        monitor.start(1);
        assert!(monitor.finish(1).growth_mb.is_some(), "alone again");
        drop(b1);
        assert_eq!(monitor.finish(1), RunMemory::default(), "not measuring");
        assert!(monitor.flight().busy.iter().all(|b| !b));
    }
}
