//! Before a batch runs an external solver: can its command start, and which version is it?
//! Asked once per batch; a solver that cannot start has its runs skipped with the reason, like
//! a missing mesh, and the batch goes on.

use super::child::{program_in, Exit};
use super::confine;
use super::sandbox::{run_sandboxed, Spec};
use crate::plan::external::Declared;
use serde::Serialize;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

/// How long a version command may take.
const VERSION_TIMEOUT: Duration = Duration::from_secs(60);

/// The longest version string kept (one line).
const VERSION_CHARS: usize = 200;

/// What the harness found out about one external solver (recorded in `meta.json`).
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct Probe {
    pub name: String,
    pub command: Vec<String>,
    /// The first line its version command printed.
    pub version: Option<String>,
    /// Why its runs are skipped: the program is not there, or the version command failed.
    pub unavailable: Option<String>,
}

/// Probe `declared` (named `name`), whose commands run in `cwd`.
pub fn probe(name: &str, declared: &Declared, cwd: &Path, interrupt: &AtomicBool) -> Probe {
    let mut p = Probe { name: name.into(), command: declared.command.clone(), version: None, unavailable: None };
    if let Some(why) = declared.command.first().and_then(|program| missing(program, cwd)) {
        p.unavailable = Some(format!("cannot start `{}`: {why}", declared.command.join(" ")));
        return p;
    }
    let Some(version) = &declared.version else { return p };
    let shown = version.join(" ");
    // In the sandbox too, under the solver's limits, with no folder it may write: it only has
    // to print.
    let command = super::child::absolute_in(version, cwd);
    let rules = confine::rules_for(declared, &command, cwd, None);
    let (env, timeout_s) = (confine::base_environment(), Some(VERSION_TIMEOUT.as_secs_f64()));
    let spec = Spec { command, cwd: cwd.to_path_buf(), rules, env, timeout_s, keep: 4096 };
    match run_sandboxed(&spec, interrupt) {
        Err(e) => p.unavailable = Some(format!("version command: {e}")),
        Ok(run) if run.exit == Exit::Code(0) => {
            let line = run.stdout.lines().map(str::trim).find(|l| !l.is_empty()).unwrap_or("");
            p.version = Some(line.chars().filter(|c| !c.is_control()).take(VERSION_CHARS).collect());
        }
        Ok(run) => {
            let said = run.stderr.lines().map(str::trim).rfind(|l| !l.is_empty()).unwrap_or("no error output");
            let said = super::protocol::quoted(said);
            p.unavailable = Some(format!("version command `{shown}` {}: {said}", ended(&run.exit)));
        }
    }
    p
}

/// How a child ended, as a phrase.
pub fn ended(exit: &Exit) -> String {
    match exit {
        Exit::Code(c) => format!("exited with code {c}"),
        Exit::Signal(s) => format!("was killed by signal {s}"),
        Exit::TimedOut => "passed its timeout".into(),
        Exit::Interrupted => "was interrupted".into(),
        Exit::TooManyProcesses(n) => format!("was killed with more than {n} processes at once (`processes`)"),
        Exit::TooMuchMemory(mb) => {
            format!("was killed with more than {mb} MiB resident in its processes together (`memory_mb`)")
        }
        Exit::TooMuchDisk(mb) => format!("was killed with more than {mb} MiB in its problem folder (`disk_mb`)"),
    }
}

/// Why `program` cannot be started from `cwd` (`None` when it can, as far as the file system
/// says): a path that is not an executable file, or a bare name on no `PATH` folder.
fn missing(program: &str, cwd: &Path) -> Option<String> {
    let path = program_in(program, cwd);
    if path.components().count() > 1 {
        return (!executable(&path)).then(|| format!("{} is not an executable file", path.display()));
    }
    let dirs = std::env::var_os("PATH").unwrap_or_default();
    let found = std::env::split_paths(&dirs).any(|d| executable(&d.join(program)));
    (!found).then(|| format!("no program '{program}' on PATH"))
}

fn executable(path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        path.metadata().is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    }
    #[cfg(not(unix))]
    path.is_file()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn declared(command: &[&str], version: Option<&[&str]>) -> Declared {
        let strings = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        Declared {
            command: strings(command),
            tasks: vec![solvers::tasks::Task::Param],
            energies: vec!["sd".into()],
            version: version.map(strings),
            snapshot_every: 1,
            keep_problem: false,
            memory_mb: None,
            file_size_mb: None,
            processes: None,
            disk_mb: None,
            read: Vec::new(),
            pass_env: Vec::new(),
            network: false,
        }
    }

    #[test]
    fn a_version_is_read_and_a_missing_program_or_package_makes_the_solver_unavailable() {
        let dir = tempfile::tempdir().unwrap();
        let no = AtomicBool::new(false);
        let p =
            probe("a", &declared(&["sh"], Some(&["sh", "-c", "echo; echo '  1.2.3 '; echo more"])), dir.path(), &no);
        assert_eq!((p.version.as_deref(), p.unavailable), (Some("1.2.3"), None));
        // no version command: nothing run, the program found on PATH
        assert_eq!(probe("a", &declared(&["sh", "x"], None), dir.path(), &no).unavailable, None);
        let p = probe("a", &declared(&["no-such-peer-xyz"], None), dir.path(), &no);
        assert_eq!(p.unavailable.unwrap(), "cannot start `no-such-peer-xyz`: no program 'no-such-peer-xyz' on PATH");
        let p = probe("a", &declared(&["./peer.sh"], None), dir.path(), &no);
        assert!(p.unavailable.unwrap().ends_with("peer.sh is not an executable file"));
        // the package is missing: the version command fails, its last error line is the reason
        let p = probe(
            "a",
            &declared(&["sh"], Some(&["sh", "-c", "echo Traceback >&2; echo \"No module named 'igl'\" >&2; exit 1"])),
            dir.path(),
            &no,
        );
        assert_eq!(
            p.unavailable.unwrap(),
            "version command `sh -c echo Traceback >&2; echo \"No module named 'igl'\" >&2; exit 1` exited with \
             code 1: No module named 'igl'"
        );
    }
}
