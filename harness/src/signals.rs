//! Ctrl-C, SIGTERM (what Slurm sends at a job's time limit and on `scancel`) and SIGHUP stop a
//! batch cleanly: the running runs stop, the finished ones stay on disk, the report is written.
//!
//! The three signals are blocked in every thread of the process and one thread takes them
//! with `sigwait`, so no signal handler ever runs in a thread of the batch. A handler would
//! not be safe: while METIS orders a graph, its GKlib replaces the process's SIGTERM handler
//! with one that `longjmp`s to a buffer only the ordering thread has (`gk_sigtrap`), and the
//! kernel hands a process-wide signal to any thread that does not block it, so a SIGTERM
//! during an ordering jumped into another thread's empty buffer and crashed the process.
//! A blocked signal stays pending, whatever handler is installed, until `sigwait` takes it.

use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::sync::Arc;

/// The signals that stop a batch.
#[cfg(unix)]
pub const STOP_SIGNALS: [nix::sys::signal::Signal; 3] =
    [nix::sys::signal::Signal::SIGINT, nix::sys::signal::Signal::SIGTERM, nix::sys::signal::Signal::SIGHUP];

/// Block [`STOP_SIGNALS`] in the calling thread, which every thread it starts afterwards
/// inherits, and start the thread that takes them one at a time and calls `on_signal` with
/// each one's number. Call it before any other thread is started (the first thing `run`
/// does): a thread started earlier keeps its mask, and a signal given to it would run
/// whatever handler is installed.
#[cfg(unix)]
pub fn watch(mut on_signal: impl FnMut(i32) + Send + 'static) -> Result<(), String> {
    use nix::sys::signal::SigSet;
    let set: SigSet = STOP_SIGNALS.into_iter().collect();
    set.thread_block().map_err(|e| format!("cannot block SIGINT, SIGTERM and SIGHUP: {e}"))?;
    std::thread::Builder::new()
        .name("mapbench-signals".into())
        .spawn(move || {
            // `sigwait` fails only on an invalid set; looping on the error would spin.
            while let Ok(sig) = set.wait() {
                on_signal(sig as i32);
            }
        })
        .map(|_| ())
        .map_err(|e| format!("cannot start the signal thread: {e}"))
}

/// Stop a batch cleanly on the first SIGINT (Ctrl-C), SIGTERM or SIGHUP: set `interrupt`
/// and say so on stderr. A second signal exits at once with 128 + its number. Returns the
/// first signal's number once one arrived (0 before).
#[cfg(unix)]
pub fn on_interrupt(interrupt: Arc<AtomicBool>) -> Arc<AtomicI32> {
    use nix::sys::signal::Signal;
    let first = Arc::new(AtomicI32::new(0));
    let seen = first.clone();
    let watching = watch(move |sig| {
        if seen.compare_exchange(0, sig, Ordering::SeqCst, Ordering::SeqCst).is_err() {
            std::process::exit(128 + sig);
        }
        interrupt.store(true, Ordering::SeqCst);
        let name = match Signal::try_from(sig) {
            Ok(Signal::SIGINT) => "Ctrl-C",
            Ok(Signal::SIGTERM) => "SIGTERM",
            _ => "SIGHUP",
        };
        eprintln!("\ninterrupt ({name}): stopping the running runs (a second signal exits at once)");
    });
    if let Err(e) = watching {
        eprintln!("warning: {e}: an interrupt loses the report");
    }
    first
}

/// Ctrl-C only (no signal masks here): the same clean stop, exit code 130.
#[cfg(not(unix))]
pub fn on_interrupt(interrupt: Arc<AtomicBool>) -> Arc<AtomicI32> {
    let first = Arc::new(AtomicI32::new(0));
    let seen = first.clone();
    let _ = ctrlc::set_handler(move || {
        if interrupt.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
        seen.store(2, Ordering::SeqCst);
        eprintln!("\ninterrupt: stopping the running runs (Ctrl-C again to exit at once)");
    });
    first
}
