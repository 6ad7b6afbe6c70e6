//! The solver's own process before it becomes the solver (`mapbench confine`, a hidden verb the
//! sandbox starts): it takes its limits, leaves the network, confines itself with Landlock and
//! then executes the solver's command in its place. The sandbox that started it and the harness
//! stay outside its Landlock domain, so nothing the solver does can signal, trace or open the
//! descriptors of the processes that measure and judge it (the book's security page).
//!
//! Its first line on standard error, before anything of the solver's, is a [`Line`]: which
//! [`Protection`]s hold and why the others do not, or why the command could not start. The
//! solver can add lines after it but not take it back.

use crate::plan::external::Declared;
use nix::sched::CloneFlags;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What starts the line the confining process writes first on standard error.
pub const LINE_PREFIX: &str = "mapbench-confine ";

/// How the solver is confined.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Rules {
    /// The one folder it may write in (`None`: none, as for a version command).
    pub writable: Option<PathBuf>,
    /// The folders (or files) it may read and execute, on top of `writable`.
    pub readable: Vec<PathBuf>,
    /// Whether it may use the network (`network = true` in its declaration).
    pub network: bool,
    pub limits: Limits,
}

/// The rlimits of the solver's processes (`None`: the harness's own).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// Address space of each process (`RLIMIT_AS`), MiB.
    pub memory_mb: Option<u64>,
    /// The largest file it may write (`RLIMIT_FSIZE`), MiB: a write past it fails and the
    /// process gets `SIGXFSZ`.
    pub file_size_mb: Option<u64>,
    /// Processes at once below the sandbox (counted every 10 ms; `RLIMIT_NPROC`, which counts
    /// every task of the user, is set to the user's tasks at the start plus this).
    pub processes: Option<u64>,
    /// What it may write in its problem folder, all its files together, MiB (measured by the
    /// sandbox every [`DISK_EVERY`] polls at most; no rlimit holds it).
    #[serde(default)]
    pub disk_mb: Option<u64>,
}

/// One protection of the sandbox; a run records those that held (`confined`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Protection {
    /// It writes only beneath its problem folder (Landlock, Linux 5.13+).
    Writes,
    /// It reads only its problem, its own files, the system's and what its declaration grants:
    /// not the references, the reports or the history (Landlock).
    Reads,
    /// It cannot trace the harness or the sandbox, nor open their descriptors in `/proc`
    /// (Landlock).
    Tracing,
    /// It can signal only its own processes (Landlock ABI 6, Linux 6.12+).
    Signals,
    /// No TCP, UDP or other internet traffic: a network namespace of its own (else TCP alone,
    /// by Landlock ABI 4, does not make it whole).
    Network,
    /// No unix sockets outside its folder: abstract ones (a network namespace or Landlock ABI
    /// 6) and those named by a path (Landlock ABI 9, Linux 7.1+).
    UnixSockets,
    /// Its SysV IPC objects (shared memory, semaphores, message queues) and POSIX message
    /// queues are its own and go with it: an IPC namespace of its own.
    Ipc,
    /// Its memory, file size and process limits are set.
    Limits,
    /// It kept to the threads it was granted: its processes' CPU time is at most
    /// [`THREADS_SLACK`] times its wall time times its threads, plus [`THREADS_GRACE_S`]
    /// (checked by the harness after the run, not by the kernel).
    Threads,
}

/// How far a run's CPU time may pass its wall time times its threads (timer granularity, the
/// interpreter's start-up threads) before it did not keep to them.
pub const THREADS_SLACK: f64 = 1.2;
pub const THREADS_GRACE_S: f64 = 0.2;

/// Whether a run of `cpu_s` over `wall_s` kept to `threads`; `Err` says by how much it did not.
pub fn kept_to_threads(cpu_s: f64, wall_s: f64, threads: usize) -> Result<(), String> {
    let allowed = THREADS_SLACK * wall_s * threads.max(1) as f64 + THREADS_GRACE_S;
    match cpu_s <= allowed {
        true => Ok(()),
        false => Err(format!(
            "its processes used {cpu_s:.2} s of CPU in {wall_s:.2} s with {} thread(s) granted: more than {allowed:.2} s",
            threads.max(1)
        )),
    }
}

impl Protection {
    pub const ALL: [Protection; 9] = [
        Protection::Writes,
        Protection::Reads,
        Protection::Tracing,
        Protection::Signals,
        Protection::Network,
        Protection::UnixSockets,
        Protection::Ipc,
        Protection::Limits,
        Protection::Threads,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            Protection::Writes => "writes",
            Protection::Reads => "reads",
            Protection::Tracing => "tracing",
            Protection::Signals => "signals",
            Protection::Network => "network",
            Protection::UnixSockets => "unix_sockets",
            Protection::Ipc => "ipc",
            Protection::Threads => "threads",
            Protection::Limits => "limits",
        }
    }

    /// `confined`'s text: the protections, space-separated.
    pub fn join(held: &[Protection]) -> String {
        held.iter().map(|p| p.as_str()).collect::<Vec<_>>().join(" ")
    }
}

/// What the confining process says first.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Line {
    /// The protections that hold, and why each other one does not.
    Held { held: Vec<Protection>, not_held: Vec<(Protection, String)> },
    /// The command could not be executed.
    CannotStart(String),
}

impl Line {
    /// The line as written, newline included.
    pub fn text(&self) -> String {
        format!("{LINE_PREFIX}{}\n", serde_json::to_string(self).unwrap_or_default())
    }

    /// The confining process's lines at the head of `stderr` and the rest, the solver's own.
    pub fn split(stderr: &str) -> (Vec<Line>, &str) {
        let mut lines = Vec::new();
        let mut rest = stderr;
        while let Some(tail) = rest.strip_prefix(LINE_PREFIX) {
            let (json, after) = tail.split_once('\n').unwrap_or((tail, ""));
            match serde_json::from_str(json) {
                Ok(line) => lines.push(line),
                Err(_) => break,
            }
            rest = after;
        }
        (lines, rest)
    }
}

/// The folders every solver may read: the system's programs, libraries and configuration,
/// `/sys` and the machine-wide files of `/proc` (which runtimes read for the CPU and memory),
/// its own process's `/proc/self` (taken when it confines itself, so the solver's process's
/// alone: not the harness's or the sandbox's, whose environment and command line it would
/// show), and the harmless devices. Not `/home`, `/root`, `/tmp`, `/var`, `/run`, `/srv`,
/// `/mnt` nor the project's folder.
pub const SYSTEM_READABLE: [&str; 25] = [
    "/usr",
    "/bin",
    "/sbin",
    "/lib",
    "/lib32",
    "/lib64",
    "/libx32",
    "/etc",
    "/opt",
    "/nix/store",
    "/sys",
    "/proc/self",
    "/proc/cpuinfo",
    "/proc/meminfo",
    "/proc/stat",
    "/proc/loadavg",
    "/proc/uptime",
    "/proc/version",
    "/proc/filesystems",
    "/proc/sys",
    "/dev/null",
    "/dev/zero",
    "/dev/full",
    "/dev/random",
    "/dev/urandom",
];

/// What a solver run as `command` in `cwd` may read besides its problem folder: the system's
/// folders; its program's folder and, for a program found on `PATH` or in a `bin` folder, that
/// folder's parent (the prefix of an interpreter: a virtual environment's, pyenv's or conda's
/// packages), the same for the file a link to the program names; the folder of each file its
/// arguments name; and `grants` (its declaration's `read`). Paths that do not exist are left
/// out.
pub fn readable(command: &[String], cwd: &Path, grants: &[PathBuf]) -> Vec<PathBuf> {
    let mut paths: Vec<PathBuf> = SYSTEM_READABLE.iter().map(PathBuf::from).collect();
    if let Some((program, on_path)) = command.first().and_then(|p| located(p, cwd)) {
        let real = std::fs::canonicalize(&program).ok();
        for (file, prefix) in [(Some(program), on_path), (real, false)] {
            let Some(dir) = file.as_deref().and_then(Path::parent) else { continue };
            paths.push(dir.to_path_buf());
            if prefix || dir.file_name().is_some_and(|n| n == "bin") {
                paths.extend(dir.parent().filter(|p| p.parent().is_some()).map(Path::to_path_buf));
            }
        }
    }
    for arg in command.iter().skip(1) {
        let p = Path::new(arg);
        if p.is_absolute() && p.is_file() {
            paths.extend(p.parent().map(Path::to_path_buf));
        } else if p.is_absolute() && p.is_dir() {
            paths.push(p.to_path_buf());
        }
    }
    paths.extend(grants.iter().cloned());
    paths.retain(|p| p.exists());
    paths.sort();
    paths.dedup();
    paths
}

/// A run's file-size limit without `file_size_mb`, MiB.
pub const DEFAULT_FILE_SIZE_MB: u64 = 1024;

/// A run's process limit without `processes`.
pub const DEFAULT_PROCESSES: u64 = 64;

/// A run's disk limit without `disk_mb`, MiB, unless half of the free space is less: a map
/// takes about 40 bytes a vertex, and every map a run writes is kept until it is verified.
pub const DEFAULT_DISK_MB: u64 = 32768;

/// The sandbox measures the problem folder every this many polls (of 10 ms): a walk of the
/// folder costs more than a read of `/proc`.
pub const DISK_EVERY: u32 = 5;

/// How a command of `declared` (`command` as it runs: the files it names absolute) is confined,
/// run from the config's folder `cwd`, writing only in `writable`.
pub fn rules_for(declared: &Declared, command: &[String], cwd: &Path, writable: Option<PathBuf>) -> Rules {
    let grants: Vec<PathBuf> =
        declared.read.iter().map(|p| std::path::absolute(cwd.join(p)).unwrap_or_else(|_| cwd.join(p))).collect();
    let mut limits = limits(declared);
    limits.disk_mb = declared.disk_mb.or_else(|| Some(default_disk_mb(writable.as_deref()?)));
    Rules { writable, readable: readable(command, cwd, &grants), network: declared.network, limits }
}

/// [`DEFAULT_DISK_MB`], or half the space free where `folder` is at the run's start when that
/// is less: one solver alone cannot fill the disk the harness writes its reports on (runs in
/// parallel each get half of what is free when they start).
fn default_disk_mb(folder: &Path) -> u64 {
    let free = nix::sys::statvfs::statvfs(folder)
        .map(|s| s.blocks_available().saturating_mul(s.fragment_size()) / (1 << 20))
        .unwrap_or(u64::MAX);
    DEFAULT_DISK_MB.min((free / 2).max(1))
}

/// The declared limits, with the defaults: the machine's memory, [`DEFAULT_FILE_SIZE_MB`],
/// [`DEFAULT_PROCESSES`].
fn limits(d: &Declared) -> Limits {
    let memory = d.memory_mb.or_else(|| crate::hardware::Hardware::detect().memory_mb);
    Limits {
        memory_mb: memory,
        file_size_mb: Some(d.file_size_mb.unwrap_or(DEFAULT_FILE_SIZE_MB)),
        processes: Some(d.processes.unwrap_or(DEFAULT_PROCESSES)),
        disk_mb: None,
    }
}

/// The variables every solver gets, of the harness's: `PATH` (where its interpreter is) and
/// the locale; and Python's bytecode cache off (it would be written beside the adapter's
/// modules, outside the problem folder).
pub fn base_environment() -> Vec<(String, String)> {
    let mut env: Vec<(String, String)> = ["PATH", "LANG", "LC_ALL", "LC_CTYPE"]
        .into_iter()
        .filter_map(|name| std::env::var(name).ok().map(|v| (name.to_string(), v)))
        .collect();
    env.push(("PYTHONDONTWRITEBYTECODE".into(), "1".into()));
    env
}

/// `program` as the child finds it: a relative path with a separator is relative to `cwd`
/// (the child's folder; which folder the OS would take is not defined), a bare name is looked
/// up in `PATH`.
pub fn program_in(program: &str, cwd: &Path) -> PathBuf {
    let p = Path::new(program);
    if p.is_relative() && p.components().count() > 1 {
        cwd.join(p)
    } else {
        p.to_path_buf()
    }
}

/// `program` as a path, and whether it was found on `PATH`: relative to `cwd` when it has a
/// separator, else the first `PATH` folder that holds it.
fn located(program: &str, cwd: &Path) -> Option<(PathBuf, bool)> {
    let p = program_in(program, cwd);
    if p.components().count() > 1 {
        return Some((std::path::absolute(&p).unwrap_or(p), false));
    }
    let dirs = std::env::var_os("PATH")?;
    std::env::split_paths(&dirs).map(|d| d.join(program)).find(|c| c.is_file()).map(|c| (c, true))
}

/// `mapbench confine RULES PROGRAM ARGS...`: confine this process by `rules` (JSON), say what
/// held, and become the program. Returns only when it could not: the exit code then.
pub fn become_solver(rules: &str, command: &[String]) -> u8 {
    use std::os::unix::process::CommandExt;
    let say = |line: Line| eprint!("{}", line.text());
    let rules: Rules = match serde_json::from_str(rules) {
        Ok(r) => r,
        Err(e) => {
            say(Line::CannotStart(format!("mapbench confine: not rules: {e}")));
            return 126;
        }
    };
    let Some((program, args)) = command.split_first() else {
        say(Line::CannotStart("the command is empty".into()));
        return 126;
    };
    let mut not_held = Vec::new();
    if let Some(why) = limit(&rules.limits) {
        not_held.push((Protection::Limits, why));
    }
    let own_network = match rules.network {
        true => {
            if let Err(why) = namespaces(CloneFlags::CLONE_NEWIPC) {
                not_held.push((Protection::Ipc, why));
            }
            Err("allowed by its declaration (`network = true`)".to_string())
        }
        false => namespaces(CloneFlags::CLONE_NEWNET | CloneFlags::CLONE_NEWIPC).inspect_err(|why| {
            not_held.push((Protection::Ipc, why.clone()));
        }),
    };
    not_held.extend(landlock(&rules, own_network));
    // The harness checks `threads` after the run.
    let held = Protection::ALL
        .into_iter()
        .filter(|p| *p != Protection::Threads && !not_held.iter().any(|(q, _)| q == p))
        .collect();
    say(Line::Held { held, not_held });
    // Signals the harness's threads block (to take Ctrl-C in one place) are the solver's to
    // handle; the environment and folder are those the sandbox gave this process.
    // Should the sandbox die (killed from outside), so does the solver.
    let _ = nix::sys::prctl::set_pdeathsig(Some(nix::sys::signal::Signal::SIGKILL));
    let none = nix::sys::signal::SigSet::empty();
    let _ = nix::sys::signal::sigprocmask(nix::sys::signal::SigmaskHow::SIG_SETMASK, Some(&none), None);
    let err = std::process::Command::new(program).args(args).exec();
    say(Line::CannotStart(err.to_string()));
    127
}

/// Set the rlimits; what could not be set, said.
fn limit(limits: &Limits) -> Option<String> {
    use nix::sys::resource::{setrlimit, Resource};
    let mb = |m: u64| m.saturating_mul(1 << 20);
    let mut failed = Vec::new();
    let mut set = |what: &str, r: Resource, value: Option<u64>| {
        if let Some(v) = value {
            if let Err(e) = setrlimit(r, v, v) {
                failed.push(format!("{what} limit not set ({e})"));
            }
        }
    };
    set("memory", Resource::RLIMIT_AS, limits.memory_mb.map(mb));
    set("file size", Resource::RLIMIT_FSIZE, limits.file_size_mb.map(mb));
    // RLIMIT_NPROC counts the user's tasks (threads included) everywhere.
    set("process", Resource::RLIMIT_NPROC, limits.processes.map(|p| user_tasks().saturating_add(p)));
    (!failed.is_empty()).then(|| failed.join("; "))
}

/// Namespaces of its own (`what`): a network namespace has only a loopback that is down, so no
/// internet socket reaches anything, abstract unix sockets included; an IPC namespace keeps
/// its IPC objects apart and ends them with it. Root may make them; another user makes a user
/// namespace first, mapping its own ids. `Err` says why not.
fn namespaces(what: CloneFlags) -> Result<(), String> {
    use nix::sched::unshare;
    let (uid, gid) = (nix::unistd::geteuid(), nix::unistd::getegid());
    if unshare(what).is_ok() {
        return Ok(());
    }
    unshare(CloneFlags::CLONE_NEWUSER | what)
        .map_err(|e| format!("no namespace of its own ({e}): neither root nor user namespaces"))?;
    // The ids outside, the same inside (writing gid_map needs setgroups denied first).
    let map = [
        ("setgroups", "deny".to_string()),
        ("uid_map", format!("{uid} {uid} 1")),
        ("gid_map", format!("{gid} {gid} 1")),
    ];
    for (file, text) in map {
        std::fs::write(format!("/proc/self/{file}"), text).map_err(|e| format!("user namespace: {file}: {e}"))?;
    }
    Ok(())
}

/// Confine this process (and what it executes) with Landlock: read and execute the
/// `readable` paths, write beneath `writable` and to `/dev/null`, no TCP unless allowed, no
/// signals or abstract sockets outside. The protections that did not hold, with why (given
/// whether the network namespace held).
fn landlock(rules: &Rules, own_network: Result<(), String>) -> Vec<(Protection, String)> {
    use landlock::{
        path_beneath_rules, Access, AccessFs, AccessNet, LandlockStatus, Ruleset, RulesetAttr, RulesetCreatedAttr,
        Scope, ABI,
    };
    // The newest rights this crate knows; an older kernel's Landlock enforces what it has.
    let abi = ABI::V10;
    let file = AccessFs::from_file(abi);
    let mut ruleset = Ruleset::default().handle_access(AccessFs::from_all(abi));
    if !rules.network {
        ruleset = ruleset.and_then(|r| r.handle_access(AccessNet::from_all(abi)));
    }
    let status = ruleset
        .and_then(|r| r.scope(Scope::from_all(abi)))
        .and_then(|r| r.create())
        .and_then(|r| r.add_rules(path_beneath_rules(&rules.readable, AccessFs::from_read(abi))))
        .and_then(|r| r.add_rules(path_beneath_rules(["/dev/null"], file)))
        .and_then(|r| r.add_rules(path_beneath_rules(rules.writable.iter(), AccessFs::from_all(abi))))
        .and_then(|r| r.restrict_self());
    let effective = match status {
        Ok(s) => match s.landlock {
            LandlockStatus::Available { effective_abi, .. } => effective_abi as i32,
            _ => 0,
        },
        Err(e) => {
            let why = format!("no Landlock sandbox ({e})");
            return held_by(0, &why, own_network);
        }
    };
    held_by(effective, "no Landlock on this kernel", own_network)
}

/// The protections that do not hold with Landlock ABI `abi` (0: none; `none` says why) and the
/// network namespace as it went.
fn held_by(abi: i32, none: &str, own_network: Result<(), String>) -> Vec<(Protection, String)> {
    let mut not = Vec::new();
    let landlock = |needed: i32, linux: &str| -> Option<String> {
        match abi {
            0 => Some(none.to_string()),
            a if a < needed => Some(format!("needs Landlock ABI {needed} (Linux {linux}); this kernel has {a}")),
            _ => None,
        }
    };
    for p in [Protection::Writes, Protection::Reads, Protection::Tracing] {
        not.extend(landlock(1, "5.13").map(|w| (p, w)));
    }
    not.extend(landlock(6, "6.12").map(|w| (Protection::Signals, w)));
    if let Err(why) = &own_network {
        not.push((Protection::Network, why.clone()));
    }
    let by_path = landlock(9, "7.1").map(|w| format!("unix sockets named by a path: {w}"));
    let abstract_ = match (&own_network, landlock(6, "6.12")) {
        (Err(_), Some(w)) => Some(format!("abstract unix sockets: {w}")),
        _ => None,
    };
    let sockets: Vec<String> = by_path.into_iter().chain(abstract_).collect();
    if !sockets.is_empty() {
        not.push((Protection::UnixSockets, sockets.join("; ")));
    }
    not
}

/// The tasks (threads) of this process's user now: what `RLIMIT_NPROC` counts.
fn user_tasks() -> u64 {
    use std::os::unix::fs::MetadataExt;
    let Ok(uid) = std::fs::metadata("/proc/self").map(|m| m.uid()) else { return 0 };
    let Ok(dir) = std::fs::read_dir("/proc") else { return 0 };
    let mut n = 0;
    for entry in dir.flatten() {
        let name = entry.file_name();
        let Some(pid) = name.to_str().filter(|s| s.bytes().all(|b| b.is_ascii_digit())) else { continue };
        if entry.metadata().is_ok_and(|m| m.uid() == uid) {
            let threads = std::fs::read_to_string(format!("/proc/{pid}/status"))
                .ok()
                .and_then(|s| s.lines().find_map(|l| l.strip_prefix("Threads:").and_then(|t| t.trim().parse().ok())));
            n += threads.unwrap_or(1);
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_confining_lines_come_off_the_head_of_the_error_output_and_no_further() {
        let held = Line::Held { held: vec![Protection::Writes], not_held: vec![(Protection::Signals, "old".into())] };
        let text = format!("{}solver says\n{}", held.text(), Line::CannotStart("x".into()).text());
        let (lines, rest) = Line::split(&text);
        assert_eq!(lines, [held]);
        // a line the solver writes later in the same form is its own
        assert!(rest.starts_with("solver says\nmapbench-confine "), "{rest}");
        assert_eq!(Line::split("plain\n"), (vec![], "plain\n"));
    }

    #[test]
    fn what_holds_follows_the_kernels_landlock_and_the_network_namespace() {
        let names = |not: Vec<(Protection, String)>| not.into_iter().map(|(p, _)| p).collect::<Vec<_>>();
        assert_eq!(names(held_by(9, "", Ok(()))), []);
        // Linux 6.18 (ABI 7): sockets by path are open
        let not = held_by(7, "", Ok(()));
        assert_eq!(not.len(), 1);
        assert_eq!(not[0].0, Protection::UnixSockets);
        assert!(not[0].1.starts_with("unix sockets named by a path: needs Landlock ABI 9 (Linux 7.1)"), "{}", not[0].1);
        assert_eq!(
            names(held_by(5, "", Err("no".into()))),
            [Protection::Signals, Protection::Network, Protection::UnixSockets]
        );
        assert_eq!(
            names(held_by(0, "none", Ok(()))),
            [Protection::Writes, Protection::Reads, Protection::Tracing, Protection::Signals, Protection::UnixSockets]
        );
    }

    #[test]
    fn a_run_keeps_to_its_threads_up_to_the_slack() {
        assert!(kept_to_threads(2.3, 1.0, 2).is_ok());
        assert!(kept_to_threads(0.15, 0.0, 1).is_ok(), "start-up within the grace");
        let err = kept_to_threads(4.0, 1.0, 2).unwrap_err();
        assert!(err.contains("4.00 s of CPU in 1.00 s with 2 thread(s) granted: more than 2.60 s"), "{err}");
    }

    #[test]
    fn a_solver_reads_the_system_its_own_folder_and_its_grants_only() {
        let dir = tempfile::tempdir().unwrap();
        let venv = dir.path().join("venv/bin");
        std::fs::create_dir_all(&venv).unwrap();
        std::fs::write(venv.join("python3"), "").unwrap();
        let script = dir.path().join("peer/solve.py");
        std::fs::create_dir_all(script.parent().unwrap()).unwrap();
        std::fs::write(&script, "").unwrap();
        let command = [venv.join("python3"), script.clone()].map(|p| p.display().to_string()).to_vec();
        let grant = dir.path().join("licence");
        std::fs::create_dir_all(&grant).unwrap();
        let r = readable(&command, dir.path(), &[grant.clone(), dir.path().join("absent")]);
        for p in [dir.path().join("venv/bin"), dir.path().join("venv"), dir.path().join("peer"), grant] {
            assert!(r.contains(&p), "{p:?} not in {r:?}");
        }
        assert!(!r.contains(&dir.path().to_path_buf()) && !r.iter().any(|p| p.ends_with("absent")), "{r:?}");
        assert!(r.contains(&PathBuf::from("/usr")) && !r.contains(&PathBuf::from("/tmp")), "{r:?}");
    }

    #[test]
    fn the_limits_come_from_the_declaration_or_the_defaults() {
        let dir = tempfile::tempdir().unwrap();
        let mut d: Declared = toml::from_str("command = [\"x\"]\ntasks = [\"param\"]\nenergies = [\"sd\"]\n").unwrap();
        let rules = |d: &Declared, w: Option<PathBuf>| rules_for(d, &["x".to_string()], dir.path(), w).limits;
        let l = rules(&d, Some(dir.path().to_path_buf()));
        assert_eq!((l.file_size_mb, l.processes), (Some(DEFAULT_FILE_SIZE_MB), Some(DEFAULT_PROCESSES)));
        assert!(l.disk_mb.is_some_and(|mb| (1..=DEFAULT_DISK_MB).contains(&mb)), "{l:?}");
        // a version command writes nowhere: nothing to measure
        assert_eq!(rules(&d, None).disk_mb, None);
        (d.disk_mb, d.memory_mb) = (Some(3), Some(100));
        let l = rules(&d, Some(dir.path().to_path_buf()));
        assert_eq!((l.disk_mb, l.memory_mb), (Some(3), Some(100)));
    }
}
