//! The process between the harness and an external solver (`mapbench sandbox`, a hidden verb):
//! it starts the solver confined, measures it from outside and ends every process the solver
//! started, whatever they do. It is not confined itself: the solver's process confines itself
//! before it executes the solver's command (`super::confine`), so neither this process nor the
//! harness is in the solver's Landlock domain, and what this process reports is its own.
//!
//! - **Confinement** (`super::confine`): writes beneath the problem folder only, reads of the
//!   system, the solver's own files and what its declaration grants, no tracing of or signals to
//!   anything outside, no network, the rlimits; each run records which protections held.
//! - **Processes**: this process is a child subreaper, so every process the solver starts
//!   stays below it, one that calls `setsid` or whose parent exits included; when the solver
//!   exits, passes its timeout, starts more processes than allowed or the harness says stop
//!   (it closes our standard input, or dies), every one of them is killed and reaped. Nothing
//!   then holds the output pipes open.
//! - **Environment**: exactly the one the harness gives, nothing of its own.
//! - **Measures** (`super::processes`): the solver's wall time from its start, the CPU time
//!   (user + system) of every process of it (those nobody waits for included), the sum of each
//!   process's peak resident memory, its problem folder's size against `disk_mb`, and the first
//!   bytes of its output.
//!
//! The harness writes the [`Spec`] as one JSON line to our standard input and keeps it open;
//! we write the [`Report`] as JSON to our standard output.

use super::child::{self, program_in, CannotStart, ChildRun, Exit, Reading, OUTPUT_GRACE, POLL};
use super::confine::{Line, Protection, Rules, DISK_EVERY};
use super::processes::{self, Seen};
use serde::{Deserialize, Serialize};
use std::io::{BufRead, Write};
use std::path::Path;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::thread;
use std::time::{Duration, Instant};

/// How long past the timeout the sandbox is given to end the solver and report before it is
/// killed itself.
const SANDBOX_GRACE: Duration = Duration::from_secs(5);

/// Room in the error output for the confining process's line, on top of what is kept.
const LINE_ROOM: usize = 4096;

/// What to run and how.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Spec {
    /// The program (resolved against `cwd` as [`program_in`] does) and its arguments.
    pub command: Vec<String>,
    pub cwd: PathBuf,
    /// How it is confined: what it may write and read, the network, its limits.
    pub rules: Rules,
    /// Its whole environment.
    pub env: Vec<(String, String)>,
    pub timeout_s: Option<f64>,
    /// Bytes of each output stream kept.
    pub keep: usize,
}

/// What became of the solver.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// `None`: it could not start (`cannot_start` says why).
    pub exit: Option<Exit>,
    pub cannot_start: Option<String>,
    pub wall_s: f64,
    pub cpu_s: f64,
    pub peak_rss_mb: Option<f64>,
    /// The protections that held.
    pub held: Vec<Protection>,
    /// Why the others did not, and anything else not whole; empty when all held.
    pub unconfined: Vec<String>,
    pub stdout: String,
    pub stderr: String,
}

/// Why a sandboxed run has no report.
#[derive(Debug, thiserror::Error)]
pub enum SandboxError {
    /// The command could not start: its runs are skipped with the reason.
    #[error(transparent)]
    CannotStart(#[from] CannotStart),
    /// The sandbox ended without a report: the run fails with the reason.
    #[error("{0}")]
    Lost(String),
}

/// The `mapbench` binary, which runs the sandbox (`mapbench sandbox`); set by its `main`.
static SANDBOX_PROGRAM: OnceLock<PathBuf> = OnceLock::new();

/// Run external solvers through the sandbox of `program` (the `mapbench` binary).
pub fn use_sandbox(program: PathBuf) {
    let _ = SANDBOX_PROGRAM.set(program);
}

/// The harness's side: run `spec` in the sandbox until it ends, passes its timeout or `interrupt` is set; without
/// the sandbox program (the library outside `mapbench`), directly, recorded as not confined.
pub fn run_sandboxed(spec: &Spec, interrupt: &AtomicBool) -> Result<ChildRun, SandboxError> {
    let shown = spec.command.join(" ");
    let Some(program) = SANDBOX_PROGRAM.get() else {
        let timeout = spec.timeout_s.map(Duration::from_secs_f64);
        let mut run = child::run_with(&spec.command, &spec.cwd, None, timeout, interrupt, spec.keep, &spec.env)?;
        run.unconfined.push("run without the sandbox (not through the mapbench binary)".into());
        return Ok(run);
    };
    let cannot = |why: std::io::Error| CannotStart { command: shown.clone(), why };
    let mut cmd = Command::new(program);
    // Nothing of the harness's environment: the solver gets the spec's, and /proc would show
    // this process's to anyone who may read it.
    cmd.arg("sandbox").env_clear().stdin(Stdio::piped()).stdout(Stdio::piped()).stderr(Stdio::piped());
    // Its own group: a Ctrl-C at the terminal reaches the harness, which stops it.
    std::os::unix::process::CommandExt::process_group(&mut cmd, 0);
    let mut sandbox = cmd.spawn().map_err(cannot)?;
    let mut stdin = sandbox.stdin.take();
    let line = serde_json::to_string(spec).map_err(|e| cannot(e.into()))? + "\n";
    if let Some(pipe) = stdin.as_mut() {
        pipe.write_all(line.as_bytes()).map_err(cannot)?;
    }
    // The report holds at most `keep` bytes of each stream, escaped in JSON.
    let report = sandbox.stdout.take().map(|s| Reading::start(s, 16 * spec.keep + (1 << 20)));
    let errors = sandbox.stderr.take().map(|s| Reading::start(s, 4096));
    let t0 = Instant::now();
    let backstop = spec.timeout_s.map(|t| Duration::from_secs_f64(t) + SANDBOX_GRACE);
    let mut stopped_at: Option<Instant> = None;
    loop {
        match sandbox.try_wait() {
            // Ended (or killed from outside: what it started in its group goes too).
            Ok(Some(_)) | Err(_) => {
                child::kill_group(&mut sandbox);
                break;
            }
            Ok(None) => {}
        }
        if stopped_at.is_none() && interrupt.load(Ordering::Relaxed) {
            // Our end of its standard input closed: it ends the solver and reports.
            stdin = None;
            stopped_at = Some(Instant::now());
        }
        let late =
            backstop.is_some_and(|b| t0.elapsed() >= b) || stopped_at.is_some_and(|s| s.elapsed() >= SANDBOX_GRACE);
        if late {
            child::kill_group(&mut sandbox);
            let _ = sandbox.wait();
            break;
        }
        thread::sleep(POLL);
    }
    drop(stdin);
    let text = report.map(|r| r.finish(OUTPUT_GRACE)).unwrap_or_default();
    let said = errors.map(|r| r.finish(OUTPUT_GRACE)).unwrap_or_default();
    let report: Report = serde_json::from_str(text.trim()).map_err(|_| {
        let said = super::protocol::quoted(said.trim());
        SandboxError::Lost(format!("the sandbox (`{} sandbox`) ended without a report: {said}", program.display()))
    })?;
    if let Some(why) = report.cannot_start {
        return Err(cannot(std::io::Error::other(why)).into());
    }
    Ok(ChildRun {
        exit: report.exit.unwrap_or(Exit::Interrupted),
        wall_s: report.wall_s,
        cpu_s: Some(report.cpu_s),
        peak_rss_mb: report.peak_rss_mb,
        held: report.held,
        unconfined: report.unconfined,
        stdout: report.stdout,
        stderr: report.stderr,
    })
}

/// `mapbench sandbox`: read the spec from standard input, run it, print the report. The exit
/// code is 0 when a report was printed.
pub fn supervise() -> u8 {
    let mut line = String::new();
    let stdin = std::io::stdin();
    if let Err(e) = stdin.lock().read_line(&mut line) {
        eprintln!("mapbench sandbox: cannot read the spec: {e}");
        return 2;
    }
    let spec: Spec = match serde_json::from_str(&line) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("mapbench sandbox: not a spec: {e}");
            return 2;
        }
    };
    let report = run(&spec);
    match serde_json::to_string(&report) {
        Ok(json) => {
            println!("{json}");
            0
        }
        Err(e) => {
            eprintln!("mapbench sandbox: {e}");
            2
        }
    }
}

/// Run `spec`: start its solver through `mapbench confine` (this binary), which confines
/// itself and becomes the solver, and watch it to its end.
fn run(spec: &Spec) -> Report {
    let mut report = Report {
        exit: None,
        cannot_start: None,
        wall_s: 0.0,
        cpu_s: 0.0,
        peak_rss_mb: None,
        held: Vec::new(),
        unconfined: Vec::new(),
        stdout: String::new(),
        stderr: String::new(),
    };
    if let Err(e) = nix::sys::prctl::set_child_subreaper(true) {
        report
            .unconfined
            .push(format!("not a child subreaper ({e}): a process that leaves its parent may outlive the run"));
    }
    let stop = stop_when_stdin_closes();
    let Some(program) = spec.command.first() else {
        report.cannot_start = Some("the command is empty".into());
        return report;
    };
    let me = match std::env::current_exe() {
        Ok(me) => me,
        Err(e) => {
            report.cannot_start = Some(format!("the sandbox cannot find its own program: {e}"));
            return report;
        }
    };
    let rules = serde_json::to_string(&spec.rules).unwrap_or_default();
    let t0 = Instant::now();
    let spawned = Command::new(me)
        .arg("confine")
        .arg(rules)
        .arg("--")
        .arg(program_in(program, &spec.cwd))
        .args(&spec.command[1..])
        .current_dir(&spec.cwd)
        .env_clear()
        .envs(spec.env.iter().map(|(k, v)| (k, v)))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn();
    let mut child = match spawned {
        Ok(c) => c,
        Err(e) => {
            report.cannot_start = Some(e.to_string());
            return report;
        }
    };
    let outputs = [
        child.stdout.take().map(|s| Reading::start(s, spec.keep)),
        child.stderr.take().map(|s| Reading::start(s, spec.keep + LINE_ROOM)),
    ];
    let mut seen = Seen::default();
    let exit = watch(child.id() as i32, spec, t0, &stop, &mut seen);
    report.wall_s = t0.elapsed().as_secs_f64();
    end_all();
    report.exit = Some(exit);
    // Both count too little: the first misses processes nobody waits for (a parent ignoring
    // SIGCHLD), the second what each did after its last sample.
    if let Ok(usage) = nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_CHILDREN) {
        let s = |t: nix::sys::time::TimeVal| t.tv_sec() as f64 + t.tv_usec() as f64 * 1e-6;
        report.cpu_s = s(usage.user_time()) + s(usage.system_time());
    }
    report.cpu_s = report.cpu_s.max(seen.cpu_s());
    report.peak_rss_mb = seen.peak_rss_mb();
    // Every writer of the pipes is gone: they end now.
    let [stdout, stderr] = outputs.map(|o| o.map(|r| r.finish(Duration::from_secs(5))).unwrap_or_default());
    let (lines, solver) = Line::split(&stderr);
    (report.stdout, report.stderr) = (stdout, child::recut(solver, spec.keep));
    take_lines(&mut report, lines);
    report
}

/// The harness closes our standard input to stop the run (or dies, which closes it too).
fn stop_when_stdin_closes() -> Arc<AtomicBool> {
    let stop = Arc::new(AtomicBool::new(false));
    let stopped = stop.clone();
    thread::spawn(move || {
        let mut sink = String::new();
        while std::io::stdin().lock().read_line(&mut sink).is_ok_and(|n| n > 0) {
            sink.clear();
        }
        stopped.store(true, Ordering::SeqCst);
    });
    stop
}

/// What the solver's process said of its confinement, into `report`.
fn take_lines(report: &mut Report, lines: Vec<Line>) {
    let mut said = false;
    for line in lines {
        match line {
            Line::Held { held, not_held } => {
                report.held = held;
                report.unconfined.extend(not_held.into_iter().map(|(p, why)| format!("{}: {why}", p.as_str())));
                said = true;
            }
            // Its command could not be executed.
            Line::CannotStart(why) => report.cannot_start = Some(why),
        }
    }
    if !said && report.cannot_start.is_none() {
        report.unconfined.push("the solver's process said nothing of its confinement".into());
    }
}

/// Poll the solver (`solver`, started at `t0`) until it ends, passes a limit, the harness stops
/// the run or its time is up; what its processes use goes to `seen`.
fn watch(solver: i32, spec: &Spec, t0: Instant, stop: &AtomicBool, seen: &mut Seen) -> Exit {
    let timeout = spec.timeout_s.map(Duration::from_secs_f64);
    let limits = &spec.rules.limits;
    let max_processes = limits.processes.map(|p| p as usize);
    let max_kb = limits.memory_mb.map(|m| m.saturating_mul(1024));
    let mut disk = spec.rules.writable.as_deref().zip(limits.disk_mb).map(|(f, mb)| Disk::new(f, mb));
    loop {
        if let Some(exit) = reap(solver) {
            return exit;
        }
        let tree = descendants();
        let resident_kb = seen.sample(&tree);
        if let Some(max) = max_processes.filter(|&m| tree.len() > m) {
            return Exit::TooManyProcesses(max);
        }
        // `RLIMIT_AS` caps each process; this caps them together.
        if let Some(max) = max_kb.filter(|&m| resident_kb > m) {
            return Exit::TooMuchMemory(max / 1024);
        }
        // `RLIMIT_FSIZE` caps each file; this caps them together.
        if let Some(exit) = disk.as_mut().and_then(Disk::check) {
            return exit;
        }
        if stop.load(Ordering::SeqCst) {
            return Exit::Interrupted;
        }
        if timeout.is_some_and(|t| t0.elapsed() >= t) {
            return Exit::TimedOut;
        }
        thread::sleep(POLL);
    }
}

/// The problem folder's size against `disk_mb`: what the solver wrote beyond the problem the
/// harness wrote, walked every [`DISK_EVERY`] polls, and less often when a walk takes long (a
/// folder of many maps), so that measuring never takes more than a tenth of a core.
struct Disk<'a> {
    folder: &'a Path,
    mb: u64,
    problem_kb: u64,
    next: Instant,
}

impl<'a> Disk<'a> {
    fn new(folder: &'a Path, mb: u64) -> Self {
        Disk { folder, mb, problem_kb: processes::folder_kb(folder), next: Instant::now() }
    }

    fn check(&mut self) -> Option<Exit> {
        let t = Instant::now();
        if t < self.next {
            return None;
        }
        let written = processes::folder_kb(self.folder).saturating_sub(self.problem_kb);
        self.next = Instant::now() + (POLL * DISK_EVERY).max(t.elapsed() * 10);
        (written > self.mb.saturating_mul(1024)).then_some(Exit::TooMuchDisk(self.mb))
    }
}

/// Reap every child that ended; the solver's exit when it was among them.
fn reap(solver: i32) -> Option<Exit> {
    use nix::sys::wait::{waitpid, WaitPidFlag, WaitStatus};
    let mut exit = None;
    loop {
        match waitpid(None, Some(WaitPidFlag::WNOHANG)) {
            Ok(WaitStatus::Exited(pid, code)) if pid.as_raw() == solver => exit = Some(Exit::Code(code)),
            Ok(WaitStatus::Signaled(pid, sig, _)) if pid.as_raw() == solver => exit = Some(Exit::Signal(sig as i32)),
            Ok(WaitStatus::StillAlive) | Err(_) => return exit,
            Ok(_) => {}
        }
    }
}

/// Kill every process below this one and reap them all: those killed leave their children to
/// us (the subreaper), so the tree is walked again until nothing is left.
fn end_all() {
    use nix::sys::signal::{kill, Signal};
    use nix::sys::wait::{waitpid, WaitPidFlag, WaitStatus};
    use nix::unistd::Pid;
    let give_up = Instant::now() + Duration::from_secs(30);
    loop {
        let tree = descendants();
        for &(pid, _) in &tree {
            let _ = kill(Pid::from_raw(pid), Signal::SIGKILL);
        }
        loop {
            match waitpid(None, Some(WaitPidFlag::WNOHANG)) {
                Ok(WaitStatus::StillAlive) => break,
                Ok(_) => {}
                // ECHILD: no child left at all.
                Err(_) if tree.is_empty() => return,
                Err(_) => break,
            }
        }
        if Instant::now() > give_up {
            return;
        }
        thread::sleep(Duration::from_millis(1));
    }
}

/// The processes below this one (zombies included).
fn descendants() -> Vec<(i32, processes::Stat)> {
    processes::below(std::process::id() as i32, &processes::all())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::external::confine::Limits;

    #[test]
    fn without_the_sandbox_program_a_run_says_it_was_not_confined() {
        let dir = tempfile::tempdir().unwrap();
        let spec = Spec {
            command: vec!["sh".into(), "-c".into(), "echo \"$HOME\" \"$CARGO\"; exit 3".into()],
            cwd: dir.path().to_path_buf(),
            rules: Rules { writable: Some(dir.path().to_path_buf()), ..Rules::default() },
            env: vec![("HOME".into(), "/nowhere".into()), ("PATH".into(), "/usr/bin:/bin".into())],
            timeout_s: Some(10.0),
            keep: 64,
        };
        // the library's tests run outside the mapbench binary, which never registered itself;
        // the environment is the spec's alone (cargo's variables are not passed on)
        let run = run_sandboxed(&spec, &AtomicBool::new(false)).unwrap();
        assert_eq!((run.exit, run.stdout.as_str(), run.cpu_s), (Exit::Code(3), "/nowhere \n", None));
        assert_eq!(run.unconfined, ["run without the sandbox (not through the mapbench binary)"]);
        assert!(run.held.is_empty());
    }

    #[test]
    fn a_spec_and_a_report_cross_the_pipes_as_json() {
        let spec = Spec {
            command: vec!["python3".into(), "a b.py".into()],
            cwd: "/x".into(),
            rules: Rules {
                writable: None,
                readable: vec!["/usr".into()],
                network: true,
                limits: Limits { memory_mb: Some(512), file_size_mb: None, processes: Some(8), disk_mb: Some(64) },
            },
            env: vec![("OMP_NUM_THREADS".into(), "2".into())],
            timeout_s: None,
            keep: 10,
        };
        let back: Spec = serde_json::from_str(&serde_json::to_string(&spec).unwrap()).unwrap();
        assert_eq!(back, spec);
        let report = Report {
            exit: Some(Exit::TooManyProcesses(8)),
            cannot_start: None,
            wall_s: 1.5,
            cpu_s: 0.25,
            peak_rss_mb: Some(12.0),
            held: vec![Protection::Writes],
            unconfined: vec!["no Landlock".into()],
            stdout: "out\n".into(),
            stderr: String::new(),
        };
        assert_eq!(serde_json::from_str::<Report>(&serde_json::to_string(&report).unwrap()).unwrap(), report);
    }
}
