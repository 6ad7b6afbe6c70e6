//! One run of an external solver: the problem folder from the common start, the process, and
//! the run's rows and outcome from what it wrote, every snapshot recomputed by our code.

use super::child::{self, ChildRun, Exit};
use super::confine;
use super::probe::ended;
use super::protocol::{self, quoted, ExternalStop, HandlesSpec, ProblemSpec, Record, StopSpec, TargetSpec};
use super::records::{check_clock, record_cost, rows_and_outcome, Read};
use super::sandbox::{self, SandboxError, Spec};
use crate::plan::external::Declared;
use solvers::energy::EnergyKind;
use solvers::mesh::Handle;
use solvers::mesh::Mesh;
use solvers::problem::MapProblem;
use solvers::solver::{IterationRecord, Outcome, StartMap, StopReason, StopSettings};
use solvers::tasks::deform::{deform_start, DeformSettings};
use solvers::tasks::param::{param_start, ParamSettings};
use solvers::tasks::Task;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

/// The most of each output stream kept in the run folder.
pub const KEEP_OUTPUT: usize = 64 * 1024;

/// Without a config `timeout`, an external run is killed after this long: a solver that
/// hangs fails its run instead of holding a worker for ever.
pub const DEFAULT_KILL: Duration = Duration::from_secs(3600);

/// A repeat of a run that timed out replays it to the same iteration (asked as `max_iters`),
/// killed after this many times the timeout.
const REPLAY_KILL_FACTOR: u32 = 4;

/// The variables that set how many threads the usual runtimes and libraries start.
pub const THREAD_VARIABLES: [&str; 9] = [
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "NUMEXPR_NUM_THREADS",
    "NUMEXPR_MAX_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "BLIS_NUM_THREADS",
    "RAYON_NUM_THREADS",
    "JULIA_NUM_THREADS",
];

/// One external run to do.
pub struct Job<'a> {
    pub name: &'a str,
    pub declared: &'a Declared,
    /// The config's folder: the files its command names are there.
    pub cwd: &'a Path,
    /// The problem folder to write (made anew, removed after unless `keep_problem`).
    pub dir: PathBuf,
    /// Where the child's output goes: `<logs>.stdout.txt`, `<logs>.stderr.txt`.
    pub logs: PathBuf,
    pub setup: Setup<'a>,
    pub timeout: Option<Duration>,
    /// Stop after this iteration (a repeat of a run that timed out): asked as `max_iters`,
    /// recorded as a timeout.
    pub stop_at: Option<usize>,
    pub threads: usize,
    pub interrupt: &'a AtomicBool,
    /// The verdict's targets as energies, loosest first (`problem.json`'s `targets`).
    pub targets: Vec<TargetSpec>,
}

/// The task's side of a job: what makes its problem and start.
pub enum Setup<'a> {
    Param {
        energy: EnergyKind,
        settings: &'a ParamSettings,
        /// The SD minimum of a chained start (`judge::reference::chained`).
        sd_min: Option<&'a [f64]>,
    },
    Deform {
        energy: EnergyKind,
        settings: &'a DeformSettings,
        handles: &'a [Handle],
        /// The dataset's own start (a generated shape's), else the rest pose.
        init: Option<&'a [[f64; 2]]>,
    },
}

impl Setup<'_> {
    /// The normalized mesh, the problem (with the handles' penalty for `deform`), the start
    /// and which start it is: what our solvers of the task get.
    fn problem(&self, mesh: &Mesh) -> Result<(Mesh, MapProblem, Vec<f64>, StartMap), String> {
        match self {
            Setup::Param { energy, settings, sd_min } => {
                let (problem, x0, start) =
                    param_start(mesh, *energy, settings, *sd_min).map_err(|e| format!("{e:#}"))?;
                Ok((mesh.normalized(), problem, x0, start))
            }
            Setup::Deform { energy, settings, handles, init } => {
                let (problem, x0, start) =
                    deform_start(mesh, handles, *init, *energy, settings).map_err(|e| format!("{e:#}"))?;
                Ok((mesh.normalized(), problem, x0, start))
            }
        }
    }

    fn task(&self) -> (Task, EnergyKind, StopSettings) {
        match self {
            Setup::Param { energy, settings, .. } => (Task::Param, *energy, settings.solver.stop),
            Setup::Deform { energy, settings, .. } => (Task::Deform, *energy, settings.solver.stop),
        }
    }
}

/// What an external run produced.
#[derive(Debug)]
pub struct Executed {
    pub outcome: Outcome,
    pub rows: Vec<IterationRecord>,
    /// Snapshots the harness recomputed (the first and the last among them).
    pub verified: usize,
    /// The child's wall time on the harness's clock (the run's `time_s` leaves out the
    /// `t_record_s` of its rows, the time it said it spent on records and snapshots).
    pub wall_s: f64,
    /// The CPU time of all its processes (`None` outside the sandbox).
    pub cpu_s: Option<f64>,
    pub peak_rss_mb: Option<f64>,
    /// The sandbox's protections that held.
    pub held: Vec<confine::Protection>,
    /// Why the others did not; empty when all held.
    pub unconfined: Vec<String>,
}

/// Why an external run has no result.
#[derive(Debug, thiserror::Error)]
pub enum ExternalError {
    /// The command could not start: the run is skipped with this reason.
    #[error("{0}")]
    CannotStart(String),
    /// The batch was interrupted: no result, nothing written.
    #[error("interrupted")]
    Interrupted,
    /// The run failed with this message.
    #[error("{0}")]
    Failed(String),
}

/// Do `job` on `mesh` (as the dataset has it: validated and normalized here, as our solvers
/// do), the problem folder and output files under the run folder.
pub fn execute(job: &Job, mesh: &Mesh) -> Result<Executed, ExternalError> {
    // Errors of our own code name the mesh already; name it where they do not.
    let failed = |what: String| match what.starts_with(&mesh.source) {
        true => ExternalError::Failed(what),
        false => ExternalError::Failed(format!("{}: {what}", mesh.source)),
    };
    let (mesh, problem, x0, start) = job.setup.problem(mesh).map_err(failed)?;
    let (task, energy, stop) = job.setup.task();
    let mut spec = ProblemSpec::new(
        task,
        energy,
        StopSpec::of(&stop, job.stop_at.unwrap_or(stop.max_iters)),
        job.timeout.filter(|_| job.stop_at.is_none()).map(|t| t.as_secs_f64()),
        job.threads,
        job.declared.snapshot_every,
    );
    spec.handles = problem.penalty.as_ref().map(HandlesSpec::of);
    spec.targets = job.targets.clone();
    let _ = super::processes::remove_folder(&job.dir);
    std::fs::create_dir_all(&job.dir)
        .map_err(|e| failed(format!("{}: cannot create the problem folder: {e}", job.dir.display())))?;
    let result = protocol::write_problem(&job.dir, &spec, &mesh, &x0)
        .map_err(|e| failed(format!("{e:#}")))
        .and_then(|()| run_and_read(job, &problem, &x0, &failed));
    if !job.declared.keep_problem {
        let _ = super::processes::remove_folder(&job.dir);
    }
    let (done, child) = result?;
    let mut outcome = done.outcome;
    outcome.start = Some(start);
    Ok(Executed {
        outcome,
        verified: done.verified,
        rows: done.rows,
        wall_s: child.wall_s,
        cpu_s: child.cpu_s,
        peak_rss_mb: child.peak_rss_mb,
        held: child.held,
        unconfined: child.unconfined,
    })
}

/// The child on the problem folder in the sandbox, its output kept, then what it wrote read
/// and verified.
fn run_and_read(
    job: &Job,
    problem: &MapProblem,
    x0: &[f64],
    failed: &dyn Fn(String) -> ExternalError,
) -> Result<(Read, ChildRun), ExternalError> {
    let dir = std::path::absolute(&job.dir).unwrap_or_else(|_| job.dir.clone());
    let kill = match (job.timeout, job.stop_at) {
        (Some(t), None) => t,
        (Some(t), Some(_)) => t * REPLAY_KILL_FACTOR,
        (None, _) => DEFAULT_KILL,
    };
    let cost = record_cost(&dir, x0);
    // It runs in its problem folder, where alone it may write; what its command names in the
    // config's folder is given as absolute paths.
    let mut command = child::absolute_in(&job.declared.command, job.cwd);
    let rules = confine::rules_for(job.declared, &command, job.cwd, Some(dir.clone()));
    command.push(dir.display().to_string());
    let env = environment(&dir, job.threads, &job.declared.pass_env).map_err(|e| failed(e.to_string()))?;
    let spec = Spec { command, cwd: dir.clone(), rules, env, timeout_s: Some(kill.as_secs_f64()), keep: KEEP_OUTPUT };
    let mut child = sandbox::run_sandboxed(&spec, job.interrupt).map_err(|e| match e {
        SandboxError::CannotStart(e) => ExternalError::CannotStart(e.to_string()),
        SandboxError::Lost(why) => failed(format!("{}: {why}", job.name)),
    })?;
    if let Some(cpu) = child.cpu_s {
        match confine::kept_to_threads(cpu, child.wall_s, job.threads) {
            Ok(()) => child.held.push(confine::Protection::Threads),
            Err(why) => child.unconfined.push(format!("threads: {why}")),
        }
    }
    keep_output(&job.logs, &child);
    let said = || {
        let last = child.stderr.lines().map(str::trim).rfind(|l| !l.is_empty() && !child::is_cut_note(l));
        last.map_or(String::new(), |l| format!(" (its last error line: {})", quoted(l)))
    };
    let max_iters = job.stop_at.unwrap_or(job.setup.task().2.max_iters);
    let stop = match &child.exit {
        Exit::Interrupted => return Err(ExternalError::Interrupted),
        Exit::Code(0) => {
            let result = protocol::read_result(&dir).map_err(|e| failed(format!("{e:#}")))?;
            match result.stop_reason {
                ExternalStop::Error => {
                    return Err(failed(format!("{} reported an error: {}", job.name, quoted(&result.message))))
                }
                s => stop_reason(s, job.stop_at.is_some()),
            }
        }
        Exit::TimedOut => StopReason::Timeout,
        Exit::Code(_) if missing_module(&child.stderr) && wrote_nothing(&dir) => {
            // A package its interpreter cannot import: skipped, like a failing version command.
            return Err(ExternalError::CannotStart(format!("{} {}{}", job.name, ended(&child.exit), said())));
        }
        other => return Err(failed(format!("{} {}{}", job.name, ended(other), said()))),
    };
    let records = kept_records(&dir, child.exit == Exit::TimedOut, max_iters, job.name).map_err(failed)?;
    check_clock(&records, child.wall_s).map_err(|e| failed(format!("{}: {e}", job.name)))?;
    let snapshots =
        protocol::verify(&dir, problem, &records, job.declared.snapshot_every).map_err(|e| failed(format!("{e:#}")))?;
    if let Some(i) = (0..x0.len()).find(|&i| snapshots[0].x[i].to_bits() != x0[i].to_bits()) {
        return Err(failed(format!(
            "iteration 0's map is not start.uv (vertex {}: {} where the start has {})",
            i / 2,
            snapshots[0].x[i],
            x0[i]
        )));
    }
    let rules = job.setup.task().2;
    let read =
        rows_and_outcome(&records, snapshots, stop, &rules, &cost).map_err(|e| failed(format!("{}: {e}", job.name)))?;
    Ok((read, child))
}

/// The records of a run that ended; killed at the deadline, it ends at its last map (a line
/// the kill cut is no record; no file at all, none).
fn kept_records(dir: &Path, killed: bool, max_iters: usize, name: &str) -> Result<Vec<Record>, String> {
    let records = protocol::read_records(dir, killed, max_iters);
    if !killed {
        return records.map_err(|e| format!("{e:#}"));
    }
    let mut records = match records {
        Ok(r) => r,
        Err(_) if std::fs::symlink_metadata(dir.join("iterations.jsonl")).is_err() => Vec::new(),
        Err(e) => return Err(format!("{e:#}")),
    };
    let last = (0..records.len())
        .rev()
        .find(|k| std::fs::symlink_metadata(protocol::snapshot_path(dir, *k)).is_ok())
        .ok_or_else(|| format!("{name} passed its timeout before it wrote the start map (maps/0.uv)"))?;
    records.truncate(last + 1);
    Ok(records)
}

/// The solver's whole environment: [`base_environment`], HOME and the temporary folder inside
/// its problem folder (made here), its threads in the usual variables, and the harness's
/// variables its declaration passes (`pass_env`). Nothing else of the harness's.
fn environment(dir: &Path, threads: usize, pass: &[String]) -> std::io::Result<Vec<(String, String)>> {
    let (home, tmp) = (dir.join("home"), dir.join("tmp"));
    std::fs::create_dir_all(&home)?;
    std::fs::create_dir_all(&tmp)?;
    let mut env = confine::base_environment();
    env.push(("HOME".into(), home.display().to_string()));
    for name in ["TMPDIR", "TMP", "TEMP"] {
        env.push((name.into(), tmp.display().to_string()));
    }
    env.extend(THREAD_VARIABLES.map(|name| (name.to_string(), threads.max(1).to_string())));
    for name in pass {
        if let Ok(value) = std::env::var(name) {
            env.retain(|(k, _)| k != name);
            env.push((name.clone(), value));
        }
    }
    Ok(env)
}

/// Whether the solver wrote no record (Python adapters open `iterations.jsonl` first).
fn wrote_nothing(dir: &Path) -> bool {
    std::fs::symlink_metadata(dir.join("iterations.jsonl")).map_or(true, |m| m.len() == 0)
}

/// Whether a child's error output ends with Python's error for a module it could not import.
fn missing_module(stderr: &str) -> bool {
    stderr.lines().map(str::trim).rfind(|l| !l.is_empty()).is_some_and(|l| l.starts_with("ModuleNotFoundError: "))
}

/// The child's output beside the run's files (the last repeat's), when there is any.
fn keep_output(logs: &Path, child: &ChildRun) {
    let stem = logs.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    for (stream, text) in [("stdout", &child.stdout), ("stderr", &child.stderr)] {
        // Run names may hold dots: the stream's suffix is appended, never substituted.
        let path = logs.with_file_name(format!("{stem}.{stream}.txt"));
        if text.is_empty() {
            let _ = std::fs::remove_file(&path);
        } else {
            let _ = std::fs::write(&path, text);
        }
    }
}

/// Our stop reason for the one the solver gave; a replay asked to stop at the first run's
/// timeout stops as a timeout.
fn stop_reason(s: ExternalStop, replay: bool) -> StopReason {
    match s {
        _ if replay => StopReason::Timeout,
        ExternalStop::Converged => StopReason::SolverRule,
        ExternalStop::Target => StopReason::Target,
        ExternalStop::NoDecrease => StopReason::NoDecrease,
        ExternalStop::GradFloor => StopReason::GradientFloor,
        ExternalStop::MaxIters => StopReason::MaxIterations,
        ExternalStop::LineSearchFailed => StopReason::LineSearchFailed,
        ExternalStop::Timeout => StopReason::Timeout,
        // `execute` fails the run instead.
        ExternalStop::Error => StopReason::NonFinite(String::new()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_module_python_cannot_import_is_told_from_other_errors() {
        assert!(missing_module("Traceback:\n  ...\nModuleNotFoundError: No module named 'numpy'\n\n"));
        assert!(!missing_module("ModuleNotFoundError: No module named 'numpy'\nValueError: later\n"));
        assert!(!missing_module(""));
    }

    #[test]
    fn the_solvers_stop_reasons_map_to_ours_and_a_replay_stops_as_a_timeout() {
        assert_eq!(stop_reason(ExternalStop::Converged, false), StopReason::SolverRule);
        assert!(StopReason::SolverRule.is_converged());
        assert_eq!(stop_reason(ExternalStop::MaxIters, false), StopReason::MaxIterations);
        assert_eq!(stop_reason(ExternalStop::LineSearchFailed, false), StopReason::LineSearchFailed);
        assert_eq!(stop_reason(ExternalStop::MaxIters, true), StopReason::Timeout);
        assert_eq!(stop_reason(ExternalStop::NoDecrease, false), StopReason::NoDecrease);
        assert_eq!(stop_reason(ExternalStop::GradFloor, false), StopReason::GradientFloor);
        assert!(StopReason::NoDecrease.is_stationary() && StopReason::GradientFloor.is_stationary());
    }
}
