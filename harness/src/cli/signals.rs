//! Ctrl-C, SIGTERM and SIGHUP stop a batch cleanly (finished runs kept, report written).

use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::sync::Arc;

/// Stop a batch cleanly on the first SIGINT (Ctrl-C), SIGTERM (what Slurm sends at the time
/// limit) or SIGHUP: `interrupt` stops the running runs, the finished ones stay on disk and
/// the report is written. A second signal exits at once. Returns the first signal's number
/// once one arrived (0 before).
#[cfg(unix)]
pub fn on_interrupt(interrupt: Arc<AtomicBool>) -> Arc<AtomicI32> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let first = Arc::new(AtomicI32::new(0));
    let seen = first.clone();
    match signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) {
        Ok(mut signals) => {
            std::thread::spawn(move || {
                for sig in signals.forever() {
                    if seen.compare_exchange(0, sig, Ordering::SeqCst, Ordering::SeqCst).is_err() {
                        std::process::exit(128 + sig);
                    }
                    interrupt.store(true, Ordering::SeqCst);
                    let name = match sig {
                        SIGINT => "Ctrl-C",
                        SIGTERM => "SIGTERM",
                        _ => "SIGHUP",
                    };
                    eprintln!("\ninterrupt ({name}): stopping the running runs (a second signal exits at once)");
                }
            });
        }
        Err(e) => eprintln!("warning: cannot catch Ctrl-C or SIGTERM ({e}): an interrupt loses the report"),
    }
    first
}

/// Ctrl-C only (no signal iterator here): the same clean stop, exit code 130.
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
