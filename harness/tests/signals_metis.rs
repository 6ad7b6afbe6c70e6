//! SIGTERM sent to the whole process while METIS orders a graph on another thread, 40 times:
//! with the harness's signal handling (`mapbench::signals::watch`, what `run` installs first),
//! every signal reaches the watcher and none reaches METIS's own handler, which crashed the
//! process (exit 139, `__longjmp` in the main thread). Its own `main`
//! (`harness = false`): the mask must be set before any other thread starts.

#[cfg(unix)]
fn main() {
    use nix::sys::signal::{kill, Signal};
    use nix::unistd::getpid;
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering::SeqCst};
    use std::sync::Arc;
    use std::time::{Duration, Instant};

    const SIGNALS: usize = 40;
    let received = Arc::new(AtomicUsize::new(0));
    let seen = received.clone();
    mapbench::signals::watch(move |sig| {
        assert_eq!(sig, Signal::SIGTERM as i32);
        seen.fetch_add(1, SeqCst);
    })
    .expect("the signal thread starts");

    // The lower triangle (CSC) of a 90 x 90 grid's 5-point pattern: 8100 nodes, enough for
    // nested dissection (about 10 ms an ordering).
    let side = 90;
    let n = side * side;
    let mut col_ptr = vec![0];
    let mut row_idx = Vec::new();
    for c in 0..n {
        row_idx.push(c);
        if c % side + 1 < side {
            row_idx.push(c + 1);
        }
        if c + side < n {
            row_idx.push(c + side);
        }
        col_ptr.push(row_idx.len());
    }
    let (started, stop, orderings) = (AtomicUsize::new(0), AtomicBool::new(false), AtomicUsize::new(0));
    std::thread::scope(|s| {
        s.spawn(|| {
            while !stop.load(SeqCst) {
                started.fetch_add(1, SeqCst);
                let perm =
                    solvers::linear::ordering::metis_order(n, &col_ptr, &row_idx, 1).expect("METIS orders the grid");
                assert!(perm.is_some_and(|(fwd, _)| fwd.len() == n));
                orderings.fetch_add(1, SeqCst);
            }
        });
        for k in 0..SIGNALS {
            // Each signal goes out in an ordering of its own, a little later into it each time.
            let before = started.load(SeqCst);
            while started.load(SeqCst) == before {
                std::hint::spin_loop();
            }
            std::thread::sleep(Duration::from_micros(250 * (k as u64 % 20)));
            kill(getpid(), Signal::SIGTERM).expect("kill");
            let sent = Instant::now();
            while received.load(SeqCst) < k + 1 {
                assert!(sent.elapsed() < Duration::from_secs(10), "signal {} never reached the watcher", k + 1);
                std::thread::sleep(Duration::from_millis(1));
            }
        }
        stop.store(true, SeqCst);
    });
    assert_eq!(received.load(SeqCst), SIGNALS);
    println!(
        "signals_metis: {SIGNALS} SIGTERMs during {} METIS orderings, each taken by the watcher: ok",
        orderings.load(SeqCst)
    );
}

#[cfg(not(unix))]
fn main() {}
