//! An external solver's process. A run's solver is started through the sandbox
//! (`super::sandbox`, `mapbench sandbox`): confined to its problem folder, every process it
//! starts ended with it, its CPU time measured. Where the harness cannot start that (the
//! library used outside the `mapbench` binary) and for version commands, the command runs
//! directly in a process group of its own, which the timeout, an interrupt and
//! the end of the run reach; its wall time and peak memory are measured from outside; its
//! output is kept, truncated, and never waited for past its end.

pub use super::confine::program_in;
use super::processes::{self, Seen};
use serde::{Deserialize, Serialize};
use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

/// How often the harness looks at the child (exit, deadline, interrupt, memory).
pub(super) const POLL: Duration = Duration::from_millis(10);

/// How long the output of a child that ended is waited for: a process it left behind may
/// hold the pipes open (the sandbox ends those; a direct child's group is killed, but a
/// process that left the group is not).
pub(super) const OUTPUT_GRACE: Duration = Duration::from_millis(500);

/// What became of the child.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Exit {
    /// It exited with this code.
    Code(i32),
    /// A signal it did not handle ended it.
    Signal(i32),
    /// Still running at the deadline: it was killed with everything it started.
    TimedOut,
    /// The batch was interrupted: it was killed with everything it started.
    Interrupted,
    /// It had more than this many processes at once: all were killed.
    TooManyProcesses(usize),
    /// Its processes had more than this many MiB resident together: all were killed.
    TooMuchMemory(u64),
    /// Its problem folder held more than this many MiB: all its processes were killed.
    TooMuchDisk(u64),
}

/// A finished child.
#[derive(Clone, Debug)]
pub struct ChildRun {
    pub exit: Exit,
    /// Wall time from its start to its exit (or the kill).
    pub wall_s: f64,
    /// CPU time (user + system) of all its processes; `None` outside the sandbox.
    pub cpu_s: Option<f64>,
    /// The sum over its processes of each one's peak resident memory (`VmHWM`, sampled every
    /// 10 ms while it ran: an upper bound of its peak), in MB; `None` where `/proc` does not
    /// say or the child was gone before the first look.
    pub peak_rss_mb: Option<f64>,
    /// The sandbox's protections that held (none outside the sandbox).
    pub held: Vec<super::confine::Protection>,
    /// Why the others did not hold; empty when all did.
    pub unconfined: Vec<String>,
    /// Its standard output and error, each cut at the limit it was run with.
    pub stdout: String,
    pub stderr: String,
}

/// Why a child did not start: the pairs are skipped, not failed (like a missing mesh).
#[derive(Debug, thiserror::Error)]
#[error("cannot start `{command}`: {why}")]
pub struct CannotStart {
    pub command: String,
    pub why: std::io::Error,
}

/// Run `command` directly in the folder `cwd`, with `last` appended to its arguments when
/// given, until it exits, the `timeout` passes or `interrupt` is set; keep at most `keep`
/// bytes of each output stream. A program given as a relative path with a `/` is taken
/// relative to `cwd`.
pub fn run(
    command: &[String],
    cwd: &Path,
    last: Option<&Path>,
    timeout: Option<Duration>,
    interrupt: &AtomicBool,
    keep: usize,
) -> Result<ChildRun, CannotStart> {
    let env: Vec<(String, String)> = std::env::vars().collect();
    run_with(command, cwd, last, timeout, interrupt, keep, &env)
}

/// [`run`] with exactly the environment `env`.
pub(super) fn run_with(
    command: &[String],
    cwd: &Path,
    last: Option<&Path>,
    timeout: Option<Duration>,
    interrupt: &AtomicBool,
    keep: usize,
    env: &[(String, String)],
) -> Result<ChildRun, CannotStart> {
    let shown = command.join(" ");
    let (program, args) = command.split_first().ok_or_else(|| CannotStart {
        command: shown.clone(),
        why: std::io::Error::new(std::io::ErrorKind::InvalidInput, "the command is empty"),
    })?;
    let mut cmd = Command::new(program_in(program, cwd));
    cmd.args(args)
        .args(last)
        .current_dir(cwd)
        .env_clear()
        .envs(env.iter().map(|(k, v)| (k, v)))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    std::os::unix::process::CommandExt::process_group(&mut cmd, 0);
    let t0 = Instant::now();
    let mut child = cmd.spawn().map_err(|why| CannotStart { command: shown, why })?;
    let readers =
        [child.stdout.take().map(|s| Reading::start(s, keep)), child.stderr.take().map(|s| Reading::start(s, keep))];
    let mut seen = Seen::default();
    let group = child.id() as i32;
    let exit = loop {
        let members: Vec<_> = processes::all().into_iter().filter(|&(p, s)| p == group || s.group == group).collect();
        seen.sample(&members);
        match child.try_wait() {
            Ok(Some(status)) => break exit_of(status),
            Ok(None) => {}
            Err(_) => break Exit::Signal(0),
        }
        let stop = if interrupt.load(Ordering::Relaxed) {
            Some(Exit::Interrupted)
        } else if timeout.is_some_and(|t| t0.elapsed() >= t) {
            Some(Exit::TimedOut)
        } else {
            None
        };
        if let Some(stop) = stop {
            kill_group(&mut child);
            let _ = child.wait();
            break stop;
        }
        thread::sleep(POLL);
    };
    let wall_s = t0.elapsed().as_secs_f64();
    // What the child left running (a daemon, a worker pool) ends with it.
    kill_group(&mut child);
    let [stdout, stderr] = readers.map(|r| r.map(|r| r.finish(OUTPUT_GRACE)).unwrap_or_default());
    let peak_rss_mb = seen.peak_rss_mb();
    Ok(ChildRun { exit, wall_s, cpu_s: None, peak_rss_mb, held: Vec::new(), unconfined: Vec::new(), stdout, stderr })
}

/// `command` with every argument that names a file of `folder` (relative, as a config gives
/// it) made absolute, and the program too when it is a relative path: the command runs in
/// another folder then.
pub fn absolute_in(command: &[String], folder: &Path) -> Vec<String> {
    command
        .iter()
        .enumerate()
        .map(|(i, arg)| {
            let p = if i == 0 { program_in(arg, folder) } else { folder.join(arg) };
            let named = Path::new(arg).is_relative() && (i > 0 || p != Path::new(arg)) && p.exists();
            match named {
                true => std::path::absolute(&p).unwrap_or(p).display().to_string(),
                false => arg.clone(),
            }
        })
        .collect()
}

/// What follows the count of bytes cut from a kept output stream.
const CUT_NOTE: &str = "more bytes not kept";

/// Whether `line` is the note [`Reading`] appends to a stream it cut.
pub fn is_cut_note(line: &str) -> bool {
    line.starts_with('[') && line.ends_with(&format!(" {CUT_NOTE}]"))
}

/// An output stream read to its end on a thread (a full pipe would block the child), keeping
/// the first `keep` bytes and saying how many were cut.
pub struct Reading(mpsc::Receiver<String>);

impl Reading {
    pub fn start(mut stream: impl Read + Send + 'static, keep: usize) -> Reading {
        let (tx, rx) = mpsc::channel();
        thread::spawn(move || {
            let (mut kept, mut total, mut buf) = (Vec::new(), 0usize, [0u8; 8192]);
            while let Ok(n) = stream.read(&mut buf) {
                if n == 0 {
                    break;
                }
                total += n;
                let room = keep.saturating_sub(kept.len());
                kept.extend_from_slice(&buf[..n.min(room)]);
            }
            let mut text = String::from_utf8_lossy(&kept).into_owned();
            if total > kept.len() {
                text.push_str(&format!("\n[{} {CUT_NOTE}]\n", total - kept.len()));
            }
            let _ = tx.send(text);
        });
        Reading(rx)
    }

    /// What was read, waiting at most `grace` for the end of the stream (a process that
    /// outlived the child may hold it open: then nothing).
    pub fn finish(self, grace: Duration) -> String {
        self.0.recv_timeout(grace).unwrap_or_default()
    }
}

/// `text` as [`Reading`] would have kept it with `keep` bytes: what it read with a larger
/// limit (and its note of what it cut, if any) cut again.
pub fn recut(text: &str, keep: usize) -> String {
    let (body, cut) = match text.rsplit_once("\n[") {
        Some((body, note)) if is_cut_note(&format!("[{}", note.trim_end())) => {
            let n = note.split(' ').next().and_then(|n| n.parse::<usize>().ok()).unwrap_or(0);
            (body, n)
        }
        _ => (text, 0),
    };
    if body.len() <= keep {
        return text.to_string();
    }
    let at = (0..=keep).rev().find(|&i| body.is_char_boundary(i)).unwrap_or(0);
    format!("{}\n[{} {CUT_NOTE}]\n", &body[..at], cut + body.len() - at)
}

fn exit_of(status: std::process::ExitStatus) -> Exit {
    if let Some(sig) = std::os::unix::process::ExitStatusExt::signal(&status) {
        return Exit::Signal(sig);
    }
    Exit::Code(status.code().unwrap_or(-1))
}

/// SIGKILL to the child's process group (the child itself where there are none).
pub(super) fn kill_group(child: &mut std::process::Child) {
    use nix::sys::signal::{killpg, Signal};
    use nix::unistd::Pid;
    // ESRCH: the group is gone already.
    let _ = killpg(Pid::from_raw(child.id() as i32), Signal::SIGKILL);
    let _ = child.kill();
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sh(script: &str) -> Vec<String> {
        vec!["sh".into(), "-c".into(), script.into(), "sh".into()]
    }

    fn go(cmd: &[String], timeout_s: f64) -> ChildRun {
        let dir = tempfile::tempdir().unwrap();
        run(cmd, dir.path(), Some(dir.path()), Some(Duration::from_secs_f64(timeout_s)), &AtomicBool::new(false), 64)
            .unwrap()
    }

    #[test]
    fn exit_codes_outputs_and_the_folder_argument_come_back() {
        let r = go(&sh("echo out; echo err >&2; test \"$1\" = \"$PWD\" || exit 9; sleep 0.2; exit 3"), 10.0);
        assert_eq!(r.exit, Exit::Code(3));
        assert_eq!((r.stdout.as_str(), r.stderr.as_str()), ("out\n", "err\n"));
        // sampled while it ran (a child gone before the first look has no number)
        assert!(r.peak_rss_mb.is_some_and(|m| m > 0.0), "{:?}", r.peak_rss_mb);
        let r = go(&sh("kill -SEGV $$"), 10.0);
        assert_eq!(r.exit, Exit::Signal(11));
    }

    #[test]
    fn output_past_the_limit_is_cut_and_counted() {
        let r = go(&sh("i=0; while [ $i -lt 100 ]; do echo 0123456789; i=$((i+1)); done"), 10.0);
        assert!(r.stdout.starts_with("0123456789\n0123456789\n"));
        assert!(r.stdout.ends_with("[1036 more bytes not kept]\n"), "{}", r.stdout);
    }

    #[test]
    fn a_stream_kept_with_a_larger_limit_is_cut_again_as_with_the_smaller() {
        assert_eq!(recut("0123456789", 10), "0123456789");
        assert_eq!(recut("0123456789", 4), "0123\n[6 more bytes not kept]\n");
        assert_eq!(recut("0123456789\n[5 more bytes not kept]\n", 4), "0123\n[11 more bytes not kept]\n");
        assert_eq!(recut("01\n[5 more bytes not kept]\n", 4), "01\n[5 more bytes not kept]\n");
    }

    #[test]
    fn the_timeout_kills_the_whole_process_group() {
        let dir = tempfile::tempdir().unwrap();
        let pidfile = dir.path().join("grandchild");
        let script = format!("sleep 60 & echo $! > {}; wait", pidfile.display());
        let t0 = Instant::now();
        let r =
            run(&sh(&script), dir.path(), None, Some(Duration::from_millis(300)), &AtomicBool::new(false), 64).unwrap();
        assert_eq!(r.exit, Exit::TimedOut);
        assert!(t0.elapsed() < Duration::from_secs(30));
        let pid = std::fs::read_to_string(&pidfile).unwrap().trim().to_string();
        // the grandchild is gone (or a zombie reaped by init in a moment)
        thread::sleep(Duration::from_millis(200));
        let state = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
        assert!(state.is_empty() || state.contains(") Z"), "grandchild still alive: {state}");
    }

    #[test]
    fn an_interrupt_stops_the_child_and_a_missing_program_cannot_start() {
        let dir = tempfile::tempdir().unwrap();
        let r = run(&sh("sleep 60"), dir.path(), None, None, &AtomicBool::new(true), 64).unwrap();
        assert_eq!(r.exit, Exit::Interrupted);
        let no = AtomicBool::new(false);
        let err = run(&["no-such-solver-xyz".into()], dir.path(), None, None, &no, 64).unwrap_err();
        assert!(err.to_string().starts_with("cannot start `no-such-solver-xyz`: "), "{err}");
        assert!(run(&[], dir.path(), None, None, &no, 64).is_err());
        // a relative program path is the child's folder's
        std::fs::write(dir.path().join("peer.sh"), "#!/bin/sh\nexit 4\n").unwrap();
        std::fs::set_permissions(dir.path().join("peer.sh"), std::os::unix::fs::PermissionsExt::from_mode(0o755))
            .unwrap();
        assert_eq!(run(&["./peer.sh".into()], dir.path(), None, None, &no, 64).unwrap().exit, Exit::Code(4));
        // from another folder: the files the command names, made absolute
        let cmd: Vec<String> = ["./peer.sh", "sh", "peer.sh", "--x", "absent.py"].map(String::from).to_vec();
        let abs = absolute_in(&cmd, dir.path());
        let peer = std::path::absolute(dir.path().join("peer.sh")).unwrap().display().to_string();
        assert_eq!(abs, [peer.as_str(), "sh", peer.as_str(), "--x", "absent.py"]);
        let elsewhere = tempfile::tempdir().unwrap();
        assert_eq!(run(&abs[..1], elsewhere.path(), None, None, &no, 64).unwrap().exit, Exit::Code(4));
    }

    #[test]
    fn a_process_left_holding_the_pipes_does_not_hold_the_run() {
        let t0 = Instant::now();
        // the leftover holds stderr only, so its pid on stdout comes back
        let r = go(&sh("setsid sleep 30 >/dev/null & echo $!; exit 0"), 10.0);
        assert!(t0.elapsed() < Duration::from_secs(5), "{:?}", t0.elapsed());
        assert_eq!(r.exit, Exit::Code(0));
        // outside the sandbox it outlives the child (the sandbox's test is in tests/external.rs)
        let pid =
            std::fs::read_to_string(format!("/proc/{}/stat", r.stdout.trim())).map(|_| r.stdout.trim().to_string());
        if let Ok(pid) = pid {
            let _ = nix::sys::signal::kill(
                nix::unistd::Pid::from_raw(pid.parse().unwrap()),
                nix::sys::signal::Signal::SIGKILL,
            );
        }
    }
}
