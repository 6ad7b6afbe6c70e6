//! One run of an external solver: the problem folder from the common start, the process, and
//! the run's rows and outcome from what it wrote, every snapshot recomputed by our code.

use super::child::{self, ChildRun, Exit};
use super::probe::ended;
use super::protocol::{self, quoted, ExternalStop, HandlesSpec, ProblemSpec, Record, Snapshot, StopSpec};
use super::sandbox::{self, Limits, Spec};
use crate::column_names::{intern, is_column_name};
use crate::plan::external::Declared;
use crate::run_folder::ITERATION_COLUMNS;
use solvers::deform::{deform_start, DeformSettings};
use solvers::energy::EnergyKind;
use solvers::handle::Handle;
use solvers::mesh::{Mesh, Task};
use solvers::param::{param_start, ParamSettings};
use solvers::problem::MapProblem;
use solvers::solver::{IterationRecord, Outcome, StartMap, StopReason, StopSettings};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

/// The most of each output stream kept in the run folder.
pub const KEEP_OUTPUT: usize = 64 * 1024;

/// The extra column that says which rows the harness recomputed (1) and which it took from the
/// solver's record (0).
pub const VERIFIED_COLUMN: &str = "verified";

/// Without a config `timeout`, an external run is killed after this long: a solver that
/// hangs fails its run instead of holding a worker for ever.
pub const DEFAULT_KILL: Duration = Duration::from_secs(3600);

/// A repeat of a run that timed out replays it to the same iteration (asked as `max_iters`),
/// killed after this many times the timeout.
const REPLAY_KILL_FACTOR: u32 = 4;

/// The record key whose value is the time the solver spent on the record and its snapshot
/// (left out of the run's time like our solvers' `t_record_s`), not an extra column.
pub const RECORD_TIME_KEY: &str = "record_s";

/// The extra column with the energy the solver recorded at each row (the `energy` column is
/// ours, at the verified rows only).
pub const REPORTED_ENERGY_COLUMN: &str = "reported_energy";

/// What a solver may leave out of its time as recording, over the run: this many times what
/// the harness takes here to write the same files (each record line, and each map it wrote;
/// measured on the run's problem folder). An interpreter formats numbers some 10 to 20 times
/// slower than we do; the sum over the run absorbs a write a busy machine delayed.
pub const RECORD_FACTOR: f64 = 50.0;

/// ... and at least this much per row.
pub const RECORD_FLOOR_S: f64 = 0.005;

/// Slack of the solver's clock against the wall time the sandbox measured (two clocks, read
/// at slightly different moments), on top of 0.1 % of it.
const CLOCK_SLACK_S: f64 = 0.002;

/// A run's file-size limit without `file_size_mb`, MiB.
pub const DEFAULT_FILE_SIZE_MB: u64 = 1024;

/// A run's process limit without `processes`.
pub const DEFAULT_PROCESSES: u64 = 64;

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
    /// Why it was not (wholly) confined; empty when the sandbox held it.
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
        StopSpec {
            max_iters: job.stop_at.unwrap_or(stop.max_iters),
            grad_tol: stop.grad_tol,
            energy_decrease_tol: stop.energy_decrease_tol,
        },
        job.timeout.filter(|_| job.stop_at.is_none()).map(|t| t.as_secs_f64()),
        job.threads,
        job.declared.snapshot_every,
    );
    spec.handles = problem.penalty.as_ref().map(HandlesSpec::of);
    let _ = std::fs::remove_dir_all(&job.dir);
    std::fs::create_dir_all(&job.dir)
        .map_err(|e| failed(format!("{}: cannot create the problem folder: {e}", job.dir.display())))?;
    let result = protocol::write_problem(&job.dir, &spec, &mesh, &x0)
        .map_err(|e| failed(format!("{e:#}")))
        .and_then(|()| run_and_read(job, &problem, &x0, &failed));
    if !job.declared.keep_problem {
        let _ = std::fs::remove_dir_all(&job.dir);
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
    command.push(dir.display().to_string());
    let spec = Spec {
        command,
        cwd: dir.clone(),
        writable: Some(dir.clone()),
        env: environment(&dir, job.threads).map_err(|e| failed(e.to_string()))?,
        timeout_s: Some(kill.as_secs_f64()),
        limits: limits(job.declared),
        keep: KEEP_OUTPUT,
    };
    let child = sandbox::run_sandboxed(&spec, job.interrupt).map_err(|e| ExternalError::CannotStart(e.to_string()))?;
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
    let killed = child.exit == Exit::TimedOut;
    let records = protocol::read_records(&dir, killed, max_iters);
    let records = if killed {
        // Killed at the deadline: the run ends at its last map (a line the kill cut is no
        // record; no file at all, none).
        let mut records = match records {
            Ok(r) => r,
            Err(_) if std::fs::symlink_metadata(dir.join("iterations.jsonl")).is_err() => Vec::new(),
            Err(e) => return Err(failed(format!("{e:#}"))),
        };
        let last = (0..records.len())
            .rev()
            .find(|k| std::fs::symlink_metadata(protocol::snapshot_path(&dir, *k)).is_ok())
            .ok_or_else(|| {
                failed(format!("{} passed its timeout before it wrote the start map (maps/0.uv)", job.name))
            })?;
        records.truncate(last + 1);
        records
    } else {
        records.map_err(|e| failed(format!("{e:#}")))?
    };
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
    let read = rows_and_outcome(&records, snapshots, stop, &cost).map_err(|e| failed(format!("{}: {e}", job.name)))?;
    Ok((read, child))
}

/// The solver's environment on top of ours: HOME and the temporary folder inside its problem
/// folder (made here), its threads in the usual variables, Python's bytecode cache off
/// (it would be written beside the adapter's modules) and Python's user packages where they
/// were (under the real HOME).
fn environment(dir: &Path, threads: usize) -> std::io::Result<Vec<(String, String)>> {
    let (home, tmp) = (dir.join("home"), dir.join("tmp"));
    std::fs::create_dir_all(&home)?;
    std::fs::create_dir_all(&tmp)?;
    let mut env: Vec<(String, String)> = vec![("HOME".into(), home.display().to_string())];
    for name in ["TMPDIR", "TMP", "TEMP"] {
        env.push((name.into(), tmp.display().to_string()));
    }
    env.extend(THREAD_VARIABLES.map(|name| (name.to_string(), threads.max(1).to_string())));
    env.push(("PYTHONDONTWRITEBYTECODE".into(), "1".into()));
    if let (None, Some(real)) = (std::env::var_os("PYTHONUSERBASE"), std::env::var_os("HOME")) {
        env.push(("PYTHONUSERBASE".into(), Path::new(&real).join(".local").display().to_string()));
    }
    Ok(env)
}

/// The declared limits, with the defaults: the machine's memory, [`DEFAULT_FILE_SIZE_MB`],
/// [`DEFAULT_PROCESSES`].
fn limits(d: &Declared) -> Limits {
    let memory = d.memory_mb.or_else(|| crate::hardware::Hardware::detect().memory_mb);
    Limits {
        memory_mb: memory,
        file_size_mb: Some(d.file_size_mb.unwrap_or(DEFAULT_FILE_SIZE_MB)),
        processes: Some(d.processes.unwrap_or(DEFAULT_PROCESSES)),
    }
}

/// Whether the solver wrote no record (Python adapters open `iterations.jsonl` first).
fn wrote_nothing(dir: &Path) -> bool {
    std::fs::symlink_metadata(dir.join("iterations.jsonl")).map_or(true, |m| m.len() == 0)
}

/// Whether a child's error output ends with Python's error for a module it could not import.
fn missing_module(stderr: &str) -> bool {
    stderr.lines().map(str::trim).rfind(|l| !l.is_empty()).is_some_and(|l| l.starts_with("ModuleNotFoundError: "))
}

/// What writing a record costs here, measured on the problem folder `dir`: a line appended
/// and flushed, and the map `x` formatted, written and renamed as the protocol asks (the
/// fastest of three of each).
#[derive(Clone, Copy, Debug, PartialEq)]
struct RecordCost {
    line_s: f64,
    map_s: f64,
}

fn record_cost(dir: &Path, x: &[f64]) -> RecordCost {
    use std::io::Write as _;
    let probe = dir.join(".record-cost");
    let (mut line_s, mut map_s) = (f64::INFINITY, f64::INFINITY);
    let uv: Vec<[f64; 2]> = x.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
    for _ in 0..3 {
        let t = std::time::Instant::now();
        let written = std::fs::File::create(&probe).and_then(|mut f| {
            f.write_all(
                b"{\"iter\": 1, \"energy\": 2.0000000000000004, \"time_s\": 0.0123456789, \"record_s\": 0.001}\n",
            )?;
            f.flush()
        });
        line_s = line_s.min(if written.is_ok() { t.elapsed().as_secs_f64() } else { 0.0 });
        let t = std::time::Instant::now();
        let tmp = dir.join(".record-cost.tmp");
        let written =
            std::fs::write(&tmp, crate::run_folder::map::uv_text(&uv)).and_then(|()| std::fs::rename(&tmp, &probe));
        map_s = map_s.min(if written.is_ok() { t.elapsed().as_secs_f64() } else { 0.0 });
    }
    let _ = std::fs::remove_file(&probe);
    RecordCost { line_s, map_s }
}

/// The solver's clock against the wall time `wall_s` of its process: no time past it, and its
/// times plus the recording it said it left out no more than it.
fn check_clock(records: &[Record], wall_s: f64) -> Result<(), String> {
    let within = wall_s * 1.001 + CLOCK_SLACK_S;
    let mut recorded = 0.0;
    for r in records {
        if r.time_s > within {
            return Err(format!(
                "iteration {}: time_s = {} is past the {wall_s:.3} s its process ran (the harness's clock)",
                r.iter, r.time_s
            ));
        }
        match number(r, RECORD_TIME_KEY)? {
            Some(t) if !(t.is_finite() && t >= 0.0) => {
                return Err(format!("iteration {}: record_s = {t} is not a time (finite, at least 0)", r.iter))
            }
            Some(t) => recorded += t,
            None => {}
        }
    }
    let last = records.last().map_or(0.0, |r| r.time_s);
    if last + recorded > within {
        return Err(format!(
            "its clock does not add up: time_s = {last} at the last record plus {recorded} s of record_s is more \
             than the {wall_s:.3} s its process ran (record_s is the writing since the previous line, not a total)"
        ));
    }
    Ok(())
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
        ExternalStop::MaxIters => StopReason::MaxIterations,
        ExternalStop::LineSearchFailed => StopReason::LineSearchFailed,
        ExternalStop::Timeout => StopReason::Timeout,
        // `execute` fails the run instead.
        ExternalStop::Error => StopReason::NonFinite(String::new()),
    }
}

/// What an external run's records and verified snapshots make of its rows and outcome.
struct Read {
    outcome: Outcome,
    rows: Vec<IterationRecord>,
    verified: usize,
}

/// The run's rows: at a verified iteration its energy, gradient norm and flips are ours,
/// elsewhere its energy is the one recorded (gradient norm NaN, flips 0, `verified` 0); the
/// times are the solver's clock; its numeric extras become columns.
fn rows_and_outcome(
    records: &[Record],
    snapshots: Vec<Snapshot>,
    stop: StopReason,
    cost: &RecordCost,
) -> Result<Read, String> {
    const OURS: [&str; 2] = [VERIFIED_COLUMN, REPORTED_ENERGY_COLUMN];
    let mut names: Vec<&'static str> = OURS.to_vec();
    for r in records {
        for key in r.extras.keys().filter(|k| k.as_str() != RECORD_TIME_KEY) {
            if !is_column_name(key) || ITERATION_COLUMNS.contains(&key.as_str()) || OURS.contains(&key.as_str()) {
                return Err(format!(
                    "iteration {}: `{}` cannot be an extra column (plain names, not ours)",
                    r.iter,
                    quoted(key)
                ));
            }
            if !names.contains(&key.as_str()) {
                if names.len() - OURS.len() >= protocol::EXTRA_COLUMNS_MAX {
                    return Err(format!(
                        "more than {} extra columns (at iteration {}: `{}`)",
                        protocol::EXTRA_COLUMNS_MAX,
                        r.iter,
                        quoted(key)
                    ));
                }
                names.push(intern(key));
            }
        }
    }
    // Row k's record_s is the writing since row k - 1: its line, and its map if any. What is
    // left out over the run is bounded; past the bound every row's share is scaled down.
    let allowed: f64 = (1..records.len())
        .map(|k| {
            let map = if snapshots.iter().any(|s| s.iter == k - 1) { cost.map_s } else { 0.0 };
            (RECORD_FACTOR * (cost.line_s + map)).max(RECORD_FLOOR_S)
        })
        .sum();
    let mut reported = Vec::with_capacity(records.len());
    for r in records {
        reported.push(number(r, RECORD_TIME_KEY)?.unwrap_or(0.0).max(0.0));
    }
    let total: f64 = reported.iter().sum();
    let share = if total > allowed { allowed / total } else { 1.0 };
    let mut rows = Vec::with_capacity(records.len());
    let mut snaps = snapshots.iter().peekable();
    for (k, r) in records.iter().enumerate() {
        let snap = snaps.next_if(|s| s.iter == k);
        let mut extra =
            vec![(VERIFIED_COLUMN, if snap.is_some() { 1.0 } else { 0.0 }), (REPORTED_ENERGY_COLUMN, r.energy)];
        for &name in &names[OURS.len()..] {
            extra.push((name, number(r, name)?.unwrap_or(f64::NAN)));
        }
        let since = |t: f64| (t - records[0].time_s).max(0.0);
        rows.push(IterationRecord {
            iter: k,
            // Only our energies are judged (the convergence test, iterations and time to a
            // target): a row without a verified map has none.
            energy: snap.map_or(f64::NAN, |s| s.energy),
            grad_norm: snap.and_then(|s| s.grad_norm).unwrap_or(f64::NAN),
            step: f64::NAN,
            flips: snap.map_or(0, |s| s.flips),
            t_iter_s: if k == 0 { 0.0 } else { (r.time_s - records[k - 1].time_s).max(0.0) },
            t_cum_s: since(r.time_s),
            t_record_s: if k == 0 { 0.0 } else { reported[k] * share },
            extra,
            ..Default::default()
        });
    }
    let (first, last) = (&snapshots[0], &snapshots[snapshots.len() - 1]);
    let outcome = Outcome {
        x: last.x.clone(),
        iterations: last.iter,
        stop_reason: stop,
        init_energy: first.energy,
        final_energy: last.energy,
        grad_norm: last.grad_norm.unwrap_or(f64::NAN),
        flips: last.flips,
        analysis: None,
        start: None,
    };
    Ok(Read { outcome, rows, verified: snapshots.len() })
}

/// A record's extra `name` as a number (`true`/`false` as 1/0, `null` as none).
fn number(r: &Record, name: &str) -> Result<Option<f64>, String> {
    match r.extras.get(name) {
        None | Some(serde_json::Value::Null) => Ok(None),
        Some(serde_json::Value::Bool(b)) => Ok(Some(if *b { 1.0 } else { 0.0 })),
        Some(serde_json::Value::Number(n)) => Ok(n.as_f64()),
        Some(other) => {
            Err(format!("iteration {}: extra `{name}` = {} is not a number", r.iter, quoted(&other.to_string())))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(iter: usize, energy: f64, time_s: f64, extras: serde_json::Value) -> Record {
        let serde_json::Value::Object(map) = extras else { panic!() };
        Record { iter, energy, time_s, extras: map.into_iter().collect() }
    }

    fn snapshot(iter: usize, energy: f64) -> Snapshot {
        Snapshot { iter, energy, grad_norm: Some(0.5), flips: 1, x: vec![iter as f64; 4] }
    }

    /// Writing costs that allow 0.25 s after a map and 0.0125 s after a line alone.
    const COST: RecordCost = RecordCost { line_s: 0.0125 / RECORD_FACTOR, map_s: 0.2375 / RECORD_FACTOR };
    /// Writing that costs nothing here: the floor alone.
    const FREE: RecordCost = RecordCost { line_s: 0.0, map_s: 0.0 };

    #[test]
    fn rows_take_our_numbers_where_verified_and_the_solvers_extras_as_columns() {
        let records = [
            record(0, 3.0, 0.5, serde_json::json!({})),
            record(1, 2.5, 1.5, serde_json::json!({"decrease": 0.2, "record_s": 0.75})),
            record(2, 2.25, 1.75, serde_json::json!({"accepted": true, "record_s": 0.125})),
        ];
        let snaps = vec![snapshot(0, 3.0 + 1e-12), snapshot(2, 2.25)];
        let read = rows_and_outcome(&records, snaps.clone(), StopReason::SolverRule, &COST).unwrap();
        let r = &read.rows;
        // the energy of a row without its map is not ours: left out of every judgement
        assert_eq!(r[0].energy, 3.0 + 1e-12);
        assert!(r[1].energy.is_nan() && r[1].grad_norm.is_nan() && r[1].step.is_nan());
        assert_eq!(r[2].energy, 2.25);
        assert_eq!((r[0].grad_norm, r[0].flips, r[1].flips), (0.5, 1, 0));
        // record_s over the run (0.875 s) past what writing row 0's line and map and row 1's
        // line cost here (0.2625 s): each row's share scaled down to it
        assert_eq!(
            r.iter().map(|r| (r.t_iter_s, r.t_cum_s)).collect::<Vec<_>>(),
            [(0.0, 0.0), (1.0, 1.0), (0.25, 1.25)]
        );
        let near = |got: &[f64], want: [f64; 3]| got.iter().zip(want).all(|(g, w)| (g - w).abs() <= 1e-15);
        let kept: Vec<f64> = r.iter().map(|r| r.t_record_s).collect();
        assert!(near(&kept, [0.0, 0.75 * 0.3, 0.125 * 0.3]), "{kept:?}");
        // writing that costs nothing here still leaves 5 ms a row
        let free = rows_and_outcome(&records, snaps, StopReason::SolverRule, &FREE).unwrap();
        let kept: Vec<f64> = free.rows.iter().map(|r| r.t_record_s).collect();
        assert!(near(&kept, [0.0, 0.75 * 0.01 / 0.875, 0.125 * 0.01 / 0.875]), "{kept:?}");
        // within the bound, as reported
        let cheap =
            [record(0, 3.0, 0.5, serde_json::json!({})), record(1, 2.5, 1.5, serde_json::json!({"record_s": 0.2}))];
        let within = rows_and_outcome(&cheap, vec![snapshot(0, 3.0), snapshot(1, 2.5)], StopReason::SolverRule, &COST);
        assert_eq!(within.unwrap().rows[1].t_record_s, 0.2);
        let names: Vec<&str> = r[1].extra.iter().map(|e| e.0).collect();
        assert_eq!(names, [VERIFIED_COLUMN, REPORTED_ENERGY_COLUMN, "decrease", "accepted"]);
        assert_eq!((r[1].extra[0].1, r[1].extra[1].1), (0.0, 2.5));
        assert_eq!((r[2].extra[0].1, r[2].extra[3].1), (1.0, 1.0));
        assert!(r[0].extra[2].1.is_nan() && r[2].extra[2].1.is_nan());
        let o = &read.outcome;
        assert_eq!((o.iterations, o.init_energy, o.final_energy, o.flips, read.verified), (2, 3.0 + 1e-12, 2.25, 1, 2));
        assert_eq!((o.x.clone(), o.stop_reason.clone()), (vec![2.0; 4], StopReason::SolverRule));

        // a name of ours, a name that is no column, a value that is no number
        for (extras, says) in [
            (serde_json::json!({"grad_norm": 1.0}), "`grad_norm` cannot be an extra column"),
            (serde_json::json!({"reported_energy": 1.0}), "`reported_energy` cannot be an extra column"),
            (serde_json::json!({"a b": 1.0}), "`a b` cannot be an extra column"),
            (serde_json::json!({"note": "x"}), "extra `note` = \"x\" is not a number"),
        ] {
            let bad = [record(0, 3.0, 0.0, extras)];
            let err = rows_and_outcome(&bad, vec![snapshot(0, 3.0)], StopReason::MaxIterations, &COST).err().unwrap();
            assert!(err.contains(says), "{err}");
        }
        // more names than a record may have, over the records
        let wide: Vec<Record> = (0..=protocol::EXTRA_COLUMNS_MAX)
            .map(|k| record(k, 3.0, k as f64, serde_json::json!({ format!("c{k}"): 1 })))
            .collect();
        let err = rows_and_outcome(&wide, vec![snapshot(0, 3.0)], StopReason::MaxIterations, &COST).err().unwrap();
        assert_eq!(err, "more than 32 extra columns (at iteration 32: `c32`)");
    }

    #[test]
    fn a_clock_past_the_wall_time_or_that_does_not_add_up_fails() {
        let at = |t: &[(f64, Option<f64>)]| -> Vec<Record> {
            t.iter()
                .enumerate()
                .map(|(k, &(time_s, rec))| {
                    record(k, 3.0, time_s, rec.map_or(serde_json::json!({}), |r| serde_json::json!({"record_s": r})))
                })
                .collect()
        };
        assert_eq!(check_clock(&at(&[(0.1, None), (0.5, Some(0.2)), (0.9, Some(0.05))]), 1.2), Ok(()));
        let err = check_clock(&at(&[(0.1, None), (1e9, None)]), 1.2).unwrap_err();
        assert_eq!(err, "iteration 1: time_s = 1000000000 is past the 1.200 s its process ran (the harness's clock)");
        // record_s reported as a running total
        let err = check_clock(&at(&[(0.1, None), (0.4, Some(0.3)), (0.7, Some(0.6))]), 1.2).unwrap_err();
        assert!(err.starts_with("its clock does not add up: time_s = 0.7 at the last record plus 0.899"), "{err}");
        let err = check_clock(&at(&[(0.1, None), (0.4, Some(-0.3))]), 1.2).unwrap_err();
        assert_eq!(err, "iteration 1: record_s = -0.3 is not a time (finite, at least 0)");
    }

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
    }
}
