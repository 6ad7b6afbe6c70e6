//! An external solver as a config declares it (`[external.<name>]`): the command, what it
//! solves, how its version is read, and what the harness keeps of its runs.

use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};
use solvers::energy::ENERGY_NAMES;
use solvers::tasks::Task;

/// The tasks the protocol covers (`authalic`, with its own disk energy and boundary, is not
/// part of protocol 1).
pub const PROTOCOL_TASKS: [Task; 2] = [Task::Param, Task::Deform];

/// `[external.<name>]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Declared {
    /// The program and its arguments; the problem folder is appended as the last argument.
    /// It runs in the config's folder; a program given as a relative path with a `/` is
    /// found there too.
    pub command: Vec<String>,
    /// The tasks it solves (protocol 1: `param`, `deform`).
    pub tasks: Vec<Task>,
    /// The energies it minimizes; the other pairs of a batch are skipped with the reason.
    pub energies: Vec<String>,
    /// A command printing its version (recorded in `meta.json` and the report, part of every
    /// run's `--resume` key); when it cannot start or fails, the solver's runs are skipped
    /// with its error (a missing package is found here, once per batch).
    pub version: Option<Vec<String>>,
    /// Write the map every this many iterations, each one verified (0: only the first and the
    /// last). Default 1: every iteration.
    #[serde(default = "every_iteration")]
    pub snapshot_every: usize,
    /// Keep each run's problem folder (`external/<run>/`) instead of removing it.
    #[serde(default)]
    pub keep_problem: bool,
    /// The address space each of its processes may have, and the resident memory of all of
    /// them together, MiB (default: the machine's memory).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub memory_mb: Option<u64>,
    /// The largest file it may write, MiB (default: 1024).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file_size_mb: Option<u64>,
    /// Processes it may have at once (default: 64).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub processes: Option<u64>,
    /// What it may write in its problem folder, all files together, MiB (default: 32768, or
    /// half the space free on the run folder's disk when that is less).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub disk_mb: Option<u64>,
    /// Folders or files it may read besides its problem folder, its program's and its
    /// arguments' folders and the system's (relative to the config's folder): a licence file,
    /// a package installed elsewhere.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub read: Vec<String>,
    /// The harness's environment variables it is given (besides the sandbox's own: `PATH`,
    /// the locale, the thread variables, `HOME` and `TMPDIR` in its problem folder).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pass_env: Vec<String>,
    /// Whether it may use the network (a licence server); default no.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub network: bool,
}

fn every_iteration() -> usize {
    1
}

impl Declared {
    /// What serde cannot check: a command, tasks of the protocol, known energies.
    pub fn check(&self, name: &str) -> Result<()> {
        if self.command.first().is_none_or(|p| p.trim().is_empty()) {
            bail!("[external.{name}] command is empty: give the program and its arguments");
        }
        if self.version.as_ref().is_some_and(|v| v.first().is_none_or(|p| p.trim().is_empty())) {
            bail!("[external.{name}] version is empty: give a command that prints the version, or leave it out");
        }
        if self.tasks.is_empty() {
            bail!("[external.{name}] tasks is empty: name the tasks it solves (\"param\")");
        }
        if let Some(t) = self.tasks.iter().find(|t| !PROTOCOL_TASKS.contains(t)) {
            bail!(
                "[external.{name}] tasks: {} is not in the external-solver protocol (it covers {}; see peers/PROTOCOL.md)",
                t.as_str(),
                PROTOCOL_TASKS.map(|t| t.as_str()).join(", ")
            );
        }
        if self.energies.is_empty() {
            bail!("[external.{name}] energies is empty: name the energies it minimizes");
        }
        for (key, value) in [
            ("memory_mb", self.memory_mb),
            ("file_size_mb", self.file_size_mb),
            ("processes", self.processes),
            ("disk_mb", self.disk_mb),
        ] {
            if value == Some(0) {
                bail!("[external.{name}] {key} = 0: give a limit above 0, or leave it out for the default");
            }
        }
        if let Some(e) = self.energies.iter().find(|e| !ENERGY_NAMES.contains(&e.as_str())) {
            bail!("[external.{name}] energies: unknown energy '{e}' (known: {})", ENERGY_NAMES.join(", "));
        }
        Ok(())
    }

    /// Why a run of this solver on `energy` is outside what it declares (`None`: it runs).
    pub fn skip_reason(&self, name: &str, energy: &str, smoothness: bool) -> Option<String> {
        if !self.energies.iter().any(|e| e == energy) {
            return Some(format!("{name} is an external solver of {} only", self.energies.join(", ")));
        }
        smoothness.then(|| format!("{name}: the smoothness term is not part of the external-solver protocol"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn declared(text: &str) -> Result<Declared> {
        let d: Declared = toml::from_str(text)?;
        d.check("peer")?;
        Ok(d)
    }

    #[test]
    fn a_declaration_reads_with_its_defaults_and_is_checked() {
        let d = declared("command = [\"python3\", \"x.py\"]\ntasks = [\"param\"]\nenergies = [\"sd\"]\n").unwrap();
        assert_eq!((d.snapshot_every, d.keep_problem, d.version.as_ref()), (1, false, None));
        let err = |text: &str| format!("{:#}", declared(text).unwrap_err());
        assert!(err("command = []\ntasks = [\"param\"]\nenergies = [\"sd\"]\n").contains("command is empty"));
        assert!(err("command = [\"x\"]\ntasks = [\"authalic\"]\nenergies = [\"sd\"]\n")
            .contains("tasks: authalic is not in the external-solver protocol (it covers param, deform"));
        assert!(err("command = [\"x\"]\ntasks = [\"param\"]\nenergies = [\"sdd\"]\n").contains("unknown energy 'sdd'"));
        assert!(err("command = [\"x\"]\ntasks = [\"param\"]\nenergies = [\"sd\"]\nversion = []\n")
            .contains("version is empty"));
        assert!(err("command = [\"x\"]\ntasks = [\"param\"]\nenergies = [\"sd\"]\nthreads = 2\n")
            .contains("unknown field `threads`"));
        assert!(err("command = [\"x\"]\ntasks = [\"param\"]\nenergies = [\"sd\"]\nprocesses = 0\n")
            .contains("[external.peer] processes = 0: give a limit above 0"));
        let d = declared("command = [\"x\"]\ntasks = [\"param\"]\nenergies = [\"sd\"]\nmemory_mb = 512\n").unwrap();
        assert_eq!((d.memory_mb, d.file_size_mb, d.processes), (Some(512), None, None));
        assert_eq!(d.skip_reason("peer", "sd", false), None);
        assert_eq!(d.skip_reason("peer", "nh", false).unwrap(), "peer is an external solver of sd only");
        assert!(d.skip_reason("peer", "sd", true).unwrap().contains("smoothness term"));
    }
}
