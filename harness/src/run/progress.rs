//! What a batch tells its user while it runs: indicatif bars on a terminal (one overall bar
//! with ETA, one line per active run), plain lines otherwise (CI logs, pipes, tests).

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::Duration;

/// Receives the events of a batch from the runner's worker threads.
pub trait Progress: Sync {
    /// The batch will run `total` solves (its runs times their repeats) on `workers` threads.
    fn start(&self, total: usize, workers: usize);
    /// Worker `worker` starts run `label`.
    fn run_started(&self, worker: usize, label: &str);
    /// Worker `worker`'s run reached iteration `iter` at `energy` (called every iteration).
    fn iteration(&self, worker: usize, iter: usize, energy: f64);
    /// A run ended; `line` says how (one line, no newline).
    fn run_finished(&self, worker: usize, line: &str);
    /// `n` of the announced solves will not run (a run that is not repeated: failed,
    /// skipped or resumed).
    fn fewer_solves(&self, n: usize);
    /// Anything else worth a line (skipped datasets, interrupts).
    fn notice(&self, line: &str);
    /// The batch is over: clear any live display.
    fn finish(&self);
}

/// The display the CLI uses: bars when stderr is a terminal, plain lines otherwise.
pub fn for_stderr() -> Box<dyn Progress> {
    if std::io::stderr().is_terminal() {
        Box::new(Bars::new())
    } else {
        Box::new(Lines)
    }
}

/// One line per finished run and notice, on stderr.
pub struct Lines;

impl Progress for Lines {
    fn start(&self, total: usize, workers: usize) {
        eprintln!("{total} solves on {workers} worker(s)");
    }
    fn run_started(&self, _: usize, _: &str) {}
    fn iteration(&self, _: usize, _: usize, _: f64) {}
    fn run_finished(&self, _: usize, line: &str) {
        eprintln!("{line}");
    }
    fn fewer_solves(&self, _: usize) {}
    fn notice(&self, line: &str) {
        eprintln!("{line}");
    }
    fn finish(&self) {}
}

/// indicatif: an overall bar and a spinner line per worker.
pub struct Bars {
    multi: MultiProgress,
    overall: Mutex<Option<ProgressBar>>,
    workers: Mutex<Vec<(ProgressBar, String)>>,
}

impl Bars {
    fn new() -> Bars {
        Bars::to(ProgressDrawTarget::stderr())
    }

    fn to(target: ProgressDrawTarget) -> Bars {
        Bars {
            multi: MultiProgress::with_draw_target(target),
            overall: Mutex::new(None),
            workers: Mutex::new(Vec::new()),
        }
    }
}

impl Progress for Bars {
    fn start(&self, total: usize, workers: usize) {
        let style =
            ProgressStyle::with_template("{bar:40.cyan/blue} {pos}/{len} solves  {elapsed_precise} (ETA {eta})")
                .unwrap_or_else(|_| ProgressStyle::default_bar());
        let bar = self.multi.add(ProgressBar::new(total as u64).with_style(style));
        *self.overall.lock().unwrap_or_else(|e| e.into_inner()) = Some(bar);
        let line =
            ProgressStyle::with_template("  {spinner} {msg}").unwrap_or_else(|_| ProgressStyle::default_spinner());
        let mut w = self.workers.lock().unwrap_or_else(|e| e.into_inner());
        for _ in 0..workers {
            let pb = self.multi.add(ProgressBar::new_spinner().with_style(line.clone()));
            pb.enable_steady_tick(Duration::from_millis(200));
            w.push((pb, String::new()));
        }
    }

    fn run_started(&self, worker: usize, label: &str) {
        if let Some((pb, l)) = self.workers.lock().unwrap_or_else(|e| e.into_inner()).get_mut(worker) {
            *l = label.to_string();
            pb.set_message(format!("{label}: starting"));
        }
    }

    fn iteration(&self, worker: usize, iter: usize, energy: f64) {
        if let Some((pb, l)) = self.workers.lock().unwrap_or_else(|e| e.into_inner()).get(worker) {
            pb.set_message(format!("{l}: iteration {iter}, E = {energy:.8}"));
        }
    }

    fn run_finished(&self, worker: usize, line: &str) {
        let _ = self.multi.println(line);
        if let Some(bar) = self.overall.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            bar.inc(1);
        }
        if let Some((pb, _)) = self.workers.lock().unwrap_or_else(|e| e.into_inner()).get(worker) {
            pb.set_message("idle");
        }
    }

    fn fewer_solves(&self, n: usize) {
        if let Some(bar) = self.overall.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            bar.set_length(bar.length().unwrap_or(0).saturating_sub(n as u64));
        }
    }

    fn notice(&self, line: &str) {
        let _ = self.multi.println(line);
    }

    fn finish(&self) {
        for (pb, _) in self.workers.lock().unwrap_or_else(|e| e.into_inner()).drain(..) {
            pb.finish_and_clear();
        }
        if let Some(bar) = self.overall.lock().unwrap_or_else(|e| e.into_inner()).take() {
            bar.finish_and_clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_that_are_not_repeated_shorten_the_overall_bar() {
        let bars = Bars::to(ProgressDrawTarget::hidden());
        bars.start(3 * 4, 2);
        bars.run_finished(0, "a failed run");
        bars.fewer_solves(2);
        let overall = bars.overall.lock().unwrap();
        let bar = overall.as_ref().unwrap();
        assert_eq!((bar.position(), bar.length()), (1, Some(10)));
    }
}
