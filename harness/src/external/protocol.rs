//! The problem folder an external solver receives and what it writes back
//! (`peers/PROTOCOL.md`), and the harness's check of every snapshot with its own code.

use crate::evaluate::measure;
use crate::run_folder::map::{obj_text, uv_text};
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use solvers::energy::EnergyKind;
use solvers::mesh::Mesh;
use solvers::problem::MapProblem;
use solvers::solver::{StopSettings, STALL_RTOL};
use solvers::tasks::Task;
use std::collections::BTreeMap;
use std::path::Path;

pub const PROTOCOL: u32 = 1;

const CONVENTION: &str = "the mesh is centred and scaled to area 1; the energy is the area-weighted mean of the \
                          density, SD = 1/2 (|J|^2 + |J^-1|^2), 2 at an isometry; deform adds lambda * sum \
                          |x_v - target|^2 over the handles";

/// `problem.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProblemSpec {
    pub protocol: u32,
    pub task: Task,
    pub energy: EnergyKind,
    pub convention: String,
    pub mesh: String,
    pub start: String,
    pub stop: StopSpec,
    pub timeout_s: Option<f64>,
    pub threads: usize,
    pub snapshot_every: usize,
    /// `deform`: the soft handles whose penalty is part of the energy.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub handles: Option<HandlesSpec>,
    /// The verdict's targets as energies, loosest first: the solver may stop at the last
    /// (`result.json`'s `target`), as ours end there. Empty without a reference minimum.
    #[serde(default)]
    pub targets: Vec<TargetSpec>,
}

/// A target of the verdict as the problem's energy: a map with no flipped face and an energy
/// at or below `energy` passes the convergence test at `tau`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TargetSpec {
    pub tau: f64,
    pub energy: f64,
}

/// The handles of a `deform` problem: the energy adds `lambda * sum |x_v - target|^2` over
/// them, targets in the normalized frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HandlesSpec {
    pub lambda: f64,
    /// 0-based vertex indices of `mesh.obj`.
    pub vertices: Vec<usize>,
    pub targets: Vec<[f64; 2]>,
}

impl HandlesSpec {
    pub fn of(penalty: &solvers::problem::Penalty) -> HandlesSpec {
        HandlesSpec {
            lambda: penalty.lambda,
            vertices: penalty.handles.iter().map(|h| h.0).collect(),
            targets: penalty.handles.iter().map(|h| h.1).collect(),
        }
    }
}

/// The stop rules the solver is asked to apply (the harness judges the run either way): the
/// papers' rules, and the stationary ends ours use where a run goes on to its target.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StopSpec {
    pub max_iters: usize,
    pub grad_tol: f64,
    pub energy_decrease_tol: f64,
    /// `|grad| <= grad_floor` is stationary (`grad_floor`; 0: none).
    #[serde(default)]
    pub grad_floor: f64,
    /// The lowest energy falling by no more than `stall_rtol * max(1, |E|)` over this many
    /// iterations is stationary (`no_decrease`; 0: none).
    #[serde(default)]
    pub stall_window: usize,
    #[serde(default)]
    pub stall_rtol: f64,
}

impl StopSpec {
    /// The rules of `stop` as a solver is asked to apply them, its cap `max_iters`.
    pub fn of(stop: &StopSettings, max_iters: usize) -> StopSpec {
        StopSpec {
            max_iters,
            grad_tol: stop.grad_tol,
            energy_decrease_tol: stop.energy_decrease_tol,
            grad_floor: stop.grad_floor,
            stall_window: stop.stall_window,
            stall_rtol: if stop.stall_window > 0 { STALL_RTOL } else { 0.0 },
        }
    }
}

impl ProblemSpec {
    pub fn new(
        task: Task,
        energy: EnergyKind,
        stop: StopSpec,
        timeout_s: Option<f64>,
        threads: usize,
        snapshot_every: usize,
    ) -> ProblemSpec {
        ProblemSpec {
            protocol: PROTOCOL,
            task,
            energy,
            convention: CONVENTION.into(),
            mesh: "mesh.obj".into(),
            start: "start.uv".into(),
            stop,
            timeout_s,
            threads,
            snapshot_every,
            handles: None,
            targets: Vec::new(),
        }
    }
}

/// Write the problem folder `dir`: `problem.json`, `mesh.obj` (the normalized `mesh`, exact
/// decimals) and `start.uv` (the start map `x`, `[u0, v0, u1, ...]`).
pub fn write_problem(dir: &Path, spec: &ProblemSpec, mesh: &Mesh, x: &[f64]) -> Result<()> {
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.join(name);
        std::fs::write(&path, bytes).with_context(|| format!("{}: cannot write", path.display()))
    };
    write("problem.json", (serde_json::to_string_pretty(spec)? + "\n").as_bytes())?;
    write(&spec.mesh, obj_text(mesh).as_bytes())?;
    let uv: Vec<[f64; 2]> = x.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
    write(&spec.start, uv_text(&uv).as_bytes())?;
    std::fs::create_dir_all(dir.join("maps")).with_context(|| format!("{}: cannot create maps/", dir.display()))
}

/// The longest line of `iterations.jsonl`, in bytes.
pub const RECORD_LINE_BYTES: usize = 4096;

/// The most keys of a record besides `iter`, `energy`, `time_s` and `record_s` (the solver's
/// extra columns; the same bound holds for the distinct names over all records).
pub const EXTRA_COLUMNS_MAX: usize = 32;

/// The largest `result.json`, in bytes.
pub const RESULT_BYTES: u64 = 64 * 1024;

/// A map file may have at most this many bytes per vertex (a `u v` line of shortest
/// round-trip decimals has at most 50), plus [`MAP_SLACK_BYTES`].
pub const MAP_BYTES_PER_VERTEX: u64 = 128;
pub const MAP_SLACK_BYTES: u64 = 4096;

/// The most characters of a solver's own text (its result message, an error line, a value it
/// wrote) quoted in a run's `error`.
pub const QUOTED_CHARS: usize = 300;

/// `text` cut at [`QUOTED_CHARS`], saying how much was left out, its control characters
/// escaped (`\u{1b}`): a solver's text reaches the console and the CSV's cells, where an
/// escape sequence would act.
pub fn quoted(text: &str) -> String {
    let shown = |t: &str| -> String {
        t.chars().map(|c| if c.is_control() { c.escape_default().to_string() } else { c.to_string() }).collect()
    };
    match text.char_indices().nth(QUOTED_CHARS) {
        None => shown(text),
        Some((at, _)) => format!("{}... ({} more characters)", shown(&text[..at]), text[at..].chars().count()),
    }
}

/// Open `path` for reading when it is a regular file of at most `cap` bytes: not a link, a
/// FIFO (which would block), a device (which may never end) nor a folder; opened without
/// following a link and without blocking, and checked again once open.
pub fn open_regular(path: &Path, cap: u64) -> Result<std::fs::File> {
    use std::os::unix::fs::OpenOptionsExt;
    let what = |t: std::fs::FileType| match () {
        _ if t.is_symlink() => "a symbolic link",
        _ if t.is_dir() => "a folder",
        _ => "a FIFO, socket or device",
    };
    let meta = std::fs::symlink_metadata(path).with_context(|| format!("{}: cannot read", path.display()))?;
    if !meta.file_type().is_file() {
        bail!("{}: is {}, not a regular file", path.display(), what(meta.file_type()));
    }
    let flags = nix::fcntl::OFlag::O_NOFOLLOW | nix::fcntl::OFlag::O_NONBLOCK;
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(flags.bits())
        .open(path)
        .with_context(|| format!("{}: cannot open", path.display()))?;
    let meta = file.metadata().with_context(|| format!("{}: cannot read", path.display()))?;
    if !meta.file_type().is_file() {
        bail!("{}: is {}, not a regular file", path.display(), what(meta.file_type()));
    }
    if meta.len() > cap {
        bail!("{}: {} bytes, more than the {cap} it may have", path.display(), meta.len());
    }
    Ok(file)
}

/// The text of the regular file `path` of at most `cap` bytes ([`open_regular`]).
pub fn read_capped(path: &Path, cap: u64) -> Result<String> {
    use std::io::Read;
    let mut text = String::new();
    open_regular(path, cap)?
        .take(cap + 1)
        .read_to_string(&mut text)
        .with_context(|| format!("{}: cannot read (not UTF-8 text?)", path.display()))?;
    if text.len() as u64 > cap {
        bail!("{}: grew past the {cap} bytes it may have", path.display());
    }
    Ok(text)
}

/// One line of `iterations.jsonl`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct Record {
    pub iter: usize,
    pub energy: f64,
    pub time_s: f64,
    /// Any other key: an extra column.
    #[serde(flatten)]
    pub extras: BTreeMap<String, serde_json::Value>,
}

/// `iterations.jsonl`, checked: iterations 0, 1, 2, ... in order up to `max_iters`, times
/// that are not negative and do not go back, lines of at most [`RECORD_LINE_BYTES`] with at
/// most [`EXTRA_COLUMNS_MAX`] extra keys. With `cut`, the solver was killed: a last line it
/// did not finish is no record.
pub fn read_records(dir: &Path, cut: bool, max_iters: usize) -> Result<Vec<Record>> {
    use std::io::{BufRead, Read};
    let path = dir.join("iterations.jsonl");
    let cap = (max_iters as u64 + 2).saturating_mul(RECORD_LINE_BYTES as u64);
    let mut file = std::io::BufReader::new(open_regular(&path, cap)?);
    let mut records: Vec<Record> = Vec::new();
    let mut line = Vec::new();
    for i in 0.. {
        line.clear();
        let n = (&mut file)
            .take(RECORD_LINE_BYTES as u64 + 1)
            .read_until(b'\n', &mut line)
            .with_context(|| format!("{}: cannot read", path.display()))?;
        if n == 0 {
            break;
        }
        let at = || format!("{} line {}", path.display(), i + 1);
        let finished = line.last() == Some(&b'\n');
        if !finished && line.len() > RECORD_LINE_BYTES {
            bail!("{}: longer than the {RECORD_LINE_BYTES} bytes a record may have", at());
        }
        if !finished && cut {
            break;
        }
        let text = std::str::from_utf8(&line).with_context(|| format!("{}: not UTF-8 text", at()))?;
        if text.trim().is_empty() {
            continue;
        }
        let r: Record = serde_json::from_str(text).with_context(|| format!("{}: not a record", at()))?;
        if r.iter != records.len() {
            bail!("{}: iteration {} where {} was due", at(), r.iter, records.len());
        }
        if r.iter > max_iters {
            bail!("{}: iteration {} is past max_iters = {max_iters}", at(), r.iter);
        }
        if !(r.time_s.is_finite() && r.time_s >= 0.0) || records.last().is_some_and(|p| r.time_s < p.time_s) {
            bail!("{}: time_s = {} goes back, is negative or is not finite", at(), r.time_s);
        }
        let extras = r.extras.keys().filter(|k| k.as_str() != "record_s").count();
        if extras > EXTRA_COLUMNS_MAX {
            bail!("{}: {extras} extra keys, more than the {EXTRA_COLUMNS_MAX} a record may have", at());
        }
        records.push(r);
    }
    if records.is_empty() && !cut {
        bail!("{}: no records (iteration 0 is the start map)", path.display());
    }
    Ok(records)
}

/// `result.json`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct ResultFile {
    pub stop_reason: ExternalStop,
    #[serde(default)]
    pub message: String,
}

/// The stop reasons a solver may give.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ExternalStop {
    Converged,
    /// At or below the tightest of `problem.json`'s `targets`.
    Target,
    /// The lowest energy fell by no more than round-off over `stall_window` iterations (the
    /// harness checks it on the records).
    NoDecrease,
    /// The final map's gradient is within `grad_floor` (the harness checks it on the map).
    GradFloor,
    MaxIters,
    LineSearchFailed,
    Timeout,
    Error,
}

pub fn read_result(dir: &Path) -> Result<ResultFile> {
    let path = dir.join("result.json");
    let text = read_capped(&path, RESULT_BYTES)?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a result", path.display()))
}

/// A snapshot measured by the harness.
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    pub iter: usize,
    pub energy: f64,
    /// `None` where the energy is not finite.
    pub grad_norm: Option<f64>,
    pub flips: usize,
    pub x: Vec<f64>,
}

/// How far a reported energy may be from the recomputed one: round-off of a sum over the
/// faces in another order and of another formula for the same density.
pub const ENERGY_RTOL: f64 = 1e-9;

/// `maps/<iter>.uv` of the problem folder `dir`.
pub fn snapshot_path(dir: &Path, iter: usize) -> std::path::PathBuf {
    dir.join("maps").join(format!("{iter}.uv"))
}

/// Whether the map of iteration `k` is due: the first, the last and every `snapshot_every`-th.
pub fn map_due(k: usize, last: usize, snapshot_every: usize) -> bool {
    k == 0 || k == last || (snapshot_every > 0 && k.is_multiple_of(snapshot_every))
}

/// Read every `maps/<iter>.uv` the solver wrote (regular files of at most
/// [`MAP_BYTES_PER_VERTEX`] bytes a vertex), recompute energy, gradient norm and flips on
/// `problem`, and check each against the energy the solver recorded for that iteration: a
/// map not finite, or whose energy is not finite or not the one recorded, fails. The maps
/// [`map_due`] names must be there.
pub fn verify(dir: &Path, problem: &MapProblem, records: &[Record], snapshot_every: usize) -> Result<Vec<Snapshot>> {
    let n = problem.n_dofs() / 2;
    let last = records.len() - 1;
    let maps = dir.join("maps");
    if !std::fs::symlink_metadata(&maps).is_ok_and(|m| m.is_dir()) {
        bail!("{}: not a folder", maps.display());
    }
    let cap = MAP_BYTES_PER_VERTEX * n as u64 + MAP_SLACK_BYTES;
    let mut snapshots = Vec::new();
    for (k, r) in records.iter().enumerate() {
        let path = snapshot_path(dir, k);
        if std::fs::symlink_metadata(&path).is_err() {
            if map_due(k, last, snapshot_every) {
                bail!(
                    "{}: the map of iteration {k} is missing (due: the first, the last and every \
                     snapshot_every = {snapshot_every})",
                    path.display()
                );
            }
            continue;
        }
        let text = read_capped(&path, cap)?;
        let x: Vec<f64> = parse_uv(&text, &path, n)?.into_iter().flatten().collect();
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            bail!("iteration {k}: vertex {} of its map is not finite ({})", i / 2, x[i]);
        }
        let (energy, grad_norm, flips) = measure(problem, &x);
        if !agree(r.energy, energy) {
            let why = if energy.is_finite() { factor(r.energy, energy) } else { format!(" ({flips} flipped faces)") };
            bail!("iteration {k}: the solver reported energy {} but its map has {energy}{why}", r.energy);
        }
        snapshots.push(Snapshot { iter: k, energy, grad_norm, flips, x });
    }
    Ok(snapshots)
}

/// A map's text (`read_uv_text`'s format) of `n` vertices.
fn parse_uv(text: &str, path: &Path, n: usize) -> Result<Vec<[f64; 2]>> {
    let mut uv = Vec::with_capacity(n);
    for (i, line) in text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let mut it = line.split_whitespace().map(str::parse::<f64>);
        match (it.next(), it.next(), it.next()) {
            (Some(Ok(u)), Some(Ok(v)), None) => uv.push([u, v]),
            _ => bail!("{}: line {}: not `u v`", path.display(), i + 1),
        }
        if uv.len() > n {
            break;
        }
    }
    if uv.len() != n {
        bail!("{}: {} map vertices, but the mesh has {n}", path.display(), uv.len());
    }
    Ok(uv)
}

/// Whether a reported energy is ours up to round-off; a map whose energy is not finite (a
/// flipped or degenerate face) agrees with none.
fn agree(reported: f64, ours: f64) -> bool {
    ours.is_finite() && (reported - ours).abs() <= ENERGY_RTOL * ours.abs().max(1.0)
}

/// " (a factor of 2: ...)" when the reported energy is a round multiple of ours.
fn factor(reported: f64, ours: f64) -> String {
    let r = reported / ours;
    for (f, name) in [(2.0, "2"), (0.5, "1/2"), (4.0, "4"), (0.25, "1/4")] {
        if (r - f).abs() <= 1e-6 * f {
            return format!(" (a factor of {name}: another convention of the energy?)");
        }
    }
    String::new()
}

#[cfg(test)]
mod tests {
    use super::*;
    use solvers::energy::Sd;

    fn setup() -> (tempfile::TempDir, Mesh, MapProblem, Vec<f64>) {
        let mesh = solvers::generate::generate("bumpy_1k").unwrap().normalized();
        let problem = MapProblem::new(&mesh, EnergyKind::Sd(Sd)).unwrap();
        let x: Vec<f64> = mesh.positions.iter().flat_map(|p| [p[0] * 1.3, p[1] * 0.9]).collect();
        (tempfile::tempdir().unwrap(), mesh, problem, x)
    }

    fn stop() -> StopSpec {
        StopSpec::of(&StopSettings::default(), 10)
    }

    #[test]
    fn the_problem_asks_for_our_stationary_ends_only_where_the_run_has_them() {
        let ours = StopSpec::of(&StopSettings::default(), 7);
        assert_eq!(
            (ours.max_iters, ours.stall_window, ours.stall_rtol),
            (7, solvers::solver::STALL_WINDOW, STALL_RTOL)
        );
        assert_eq!(ours.grad_floor, solvers::solver::GRAD_FLOOR);
        let rules = StopSpec::of(&StopSettings::rules_only(1e-3, 1e-5, 10), 10);
        assert_eq!((rules.grad_floor, rules.stall_window, rules.stall_rtol), (0.0, 0, 0.0));
        assert_eq!((rules.grad_tol, rules.energy_decrease_tol), (1e-3, 1e-5));
    }

    #[test]
    fn the_problem_folder_reads_back_exactly() {
        let (dir, mesh, _, x) = setup();
        let spec = ProblemSpec::new(Task::Param, EnergyKind::Sd(Sd), stop(), Some(60.0), 2, 5);
        write_problem(dir.path(), &spec, &mesh, &x).unwrap();
        let back: ProblemSpec =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join("problem.json")).unwrap()).unwrap();
        assert_eq!(back, spec);
        let obj = solvers::mesh::load_obj(&dir.path().join("mesh.obj")).unwrap();
        assert_eq!((obj.positions, obj.faces), (mesh.positions.clone(), mesh.faces.clone()));
        let start: Vec<f64> =
            crate::run_folder::map::read_uv_text(&dir.path().join("start.uv"), mesh.n_vertices()).unwrap().concat();
        assert_eq!(start, x);
    }

    fn write_run(dir: &Path, energies: &[f64], maps: &[(usize, &[f64])]) {
        let lines: String = energies
            .iter()
            .enumerate()
            .map(|(k, e)| format!("{{\"iter\": {k}, \"energy\": {e:?}, \"time_s\": {}, \"note\": \"x\"}}\n", k as f64))
            .collect();
        std::fs::write(dir.join("iterations.jsonl"), lines).unwrap();
        std::fs::create_dir_all(dir.join("maps")).unwrap();
        for (k, x) in maps {
            let uv: Vec<[f64; 2]> = x.chunks(2).map(|c| [c[0], c[1]]).collect();
            std::fs::write(dir.join("maps").join(format!("{k}.uv")), uv_text(&uv)).unwrap();
        }
    }

    #[test]
    fn snapshots_are_recomputed_and_a_lie_is_named_with_its_factor() {
        let (dir, _, problem, x) = setup();
        let e = problem.energy(&x);
        let y: Vec<f64> = x.iter().map(|v| v * 1.1).collect();
        let ey = problem.energy(&y);
        write_run(dir.path(), &[e, 0.5 * (e + ey), ey], &[(0, &x), (2, &y)]);
        let records = read_records(dir.path(), false, 10).unwrap();
        assert_eq!(records[1].extras["note"], "x");
        let snaps = verify(dir.path(), &problem, &records, 0).unwrap();
        assert_eq!(snaps.iter().map(|s| (s.iter, s.energy, s.flips)).collect::<Vec<_>>(), [(0, e, 0), (2, ey, 0)]);
        assert!(snaps.iter().all(|s| s.grad_norm.is_some_and(|g| g > 0.0)));

        write_run(dir.path(), &[2.0 * e, ey], &[(0, &x), (1, &y)]);
        let err =
            verify(dir.path(), &problem, &read_records(dir.path(), false, 10).unwrap(), 0).unwrap_err().to_string();
        assert!(
            err.starts_with(&format!("iteration 0: the solver reported energy {:?} but its map has {e:?}", 2.0 * e))
        );
        assert!(err.ends_with("(a factor of 2: another convention of the energy?)"), "{err}");
        write_run(dir.path(), &[e, e * (1.0 + 1e-6)], &[(0, &x), (1, &x)]);
        let err =
            verify(dir.path(), &problem, &read_records(dir.path(), false, 10).unwrap(), 0).unwrap_err().to_string();
        assert!(err.starts_with("iteration 1: the solver reported energy") && !err.contains("factor"), "{err}");
        // round-off passes
        write_run(dir.path(), &[e * (1.0 + 1e-14), ey], &[(0, &x), (1, &y)]);
        assert!(verify(dir.path(), &problem, &read_records(dir.path(), false, 10).unwrap(), 0).is_ok());
    }

    #[test]
    fn missing_maps_bad_lines_and_a_wrong_sized_map_fail() {
        let (dir, _, problem, x) = setup();
        let e = problem.energy(&x);
        write_run(dir.path(), &[e, e], &[(0, &x)]);
        let err =
            verify(dir.path(), &problem, &read_records(dir.path(), false, 10).unwrap(), 0).unwrap_err().to_string();
        assert!(
            err.ends_with("the map of iteration 1 is missing (due: the first, the last and every snapshot_every = 0)"),
            "{err}"
        );
        write_run(dir.path(), &[e], &[(0, &x[..x.len() - 2])]);
        let err = format!(
            "{:#}",
            verify(dir.path(), &problem, &read_records(dir.path(), false, 10).unwrap(), 0).unwrap_err()
        );
        assert!(err.contains(&format!("map vertices, but the mesh has {}", x.len() / 2)), "{err}");
        std::fs::write(
            dir.path().join("iterations.jsonl"),
            "{\"iter\": 0, \"energy\": 1, \"time_s\": 0}\n{\"iter\": 2, \"energy\": 1, \"time_s\": 1}\n",
        )
        .unwrap();
        assert!(read_records(dir.path(), false, 10)
            .unwrap_err()
            .to_string()
            .ends_with("line 2: iteration 2 where 1 was due"));
        std::fs::write(
            dir.path().join("iterations.jsonl"),
            "{\"iter\": 0, \"energy\": 1, \"time_s\": 1}\n{\"iter\": 1, \"energy\": 1, \"time_s\": 0.5}\n",
        )
        .unwrap();
        assert!(read_records(dir.path(), false, 10).unwrap_err().to_string().contains("time_s = 0.5 goes back"));
        // a line the kill cut is dropped only when the solver was killed
        std::fs::write(
            dir.path().join("iterations.jsonl"),
            "{\"iter\": 0, \"energy\": 1, \"time_s\": 0}\n{\"iter\": 1, \"ene",
        )
        .unwrap();
        assert_eq!(read_records(dir.path(), true, 10).unwrap().len(), 1);
        assert!(read_records(dir.path(), false, 10).is_err());
        std::fs::write(dir.path().join("iterations.jsonl"), "garbage\n").unwrap();
        assert!(read_records(dir.path(), false, 10).unwrap_err().to_string().ends_with("line 1: not a record"));
        std::fs::write(dir.path().join("iterations.jsonl"), "").unwrap();
        assert!(read_records(dir.path(), false, 10).is_err());
        std::fs::write(dir.path().join("result.json"), "{\"stop_reason\": \"converged\"}").unwrap();
        assert_eq!(read_result(dir.path()).unwrap().stop_reason, ExternalStop::Converged);
        std::fs::write(dir.path().join("result.json"), "{\"stop_reason\": \"bored\"}").unwrap();
        assert!(read_result(dir.path()).is_err());
    }

    #[test]
    fn maps_are_due_at_every_multiple_and_a_map_whose_energy_is_not_finite_agrees_with_nothing() {
        let due: Vec<usize> = (0..=10).filter(|&k| map_due(k, 10, 3)).collect();
        assert_eq!(due, [0, 3, 6, 9, 10]);
        assert_eq!((0..=7).filter(|&k| map_due(k, 7, 0)).collect::<Vec<_>>(), [0, 7]);
        assert!(agree(2.5, 2.5 * (1.0 + 1e-12)) && !agree(2.5, 2.5 * (1.0 + 1e-6)));
        // the tolerance scaled by an infinite energy once let any number through
        for ours in [f64::INFINITY, f64::NAN] {
            assert!(!agree(2.5, ours) && !agree(f64::INFINITY, ours) && !agree(1e300, ours));
        }
        let (dir, _, problem, x) = setup();
        let e = problem.energy(&x);
        let mirrored: Vec<f64> = x.chunks(2).flat_map(|c| [-c[0], c[1]]).collect();
        write_run(dir.path(), &[e, e, e, e], &[(0, &x), (2, &x), (3, &mirrored)]);
        let records = read_records(dir.path(), false, 10).unwrap();
        let err = verify(dir.path(), &problem, &records, 2).unwrap_err().to_string();
        assert!(err.contains("iteration 3: the solver reported energy") && err.ends_with("flipped faces)"), "{err}");
        let err = format!("{:#}", verify(dir.path(), &problem, &records[..2], 1).unwrap_err());
        assert!(
            err.contains("the map of iteration 1 is missing (due: the first, the last and every snapshot_every = 1)")
        );
        let mut bad = x.clone();
        bad[9] = f64::NAN;
        write_run(dir.path(), &[e, e], &[(0, &x), (1, &bad)]);
        let err = verify(dir.path(), &problem, &read_records(dir.path(), false, 10).unwrap(), 1).unwrap_err();
        assert_eq!(err.to_string(), "iteration 1: vertex 4 of its map is not finite (NaN)");
    }

    #[test]
    fn records_are_bounded_in_length_keys_and_iterations() {
        let dir = tempfile::tempdir().unwrap();
        let records = |text: &str, max_iters: usize| {
            std::fs::write(dir.path().join("iterations.jsonl"), text).unwrap();
            read_records(dir.path(), false, max_iters).map_err(|e| e.to_string())
        };
        let line = |k: usize, t: f64| format!("{{\"iter\": {k}, \"energy\": 3, \"time_s\": {t}}}\n");
        assert_eq!(records(&(line(0, 0.0) + &line(1, 0.5)), 1).unwrap().len(), 2);
        assert!(records(&(line(0, 0.0) + &line(1, 0.5)), 0)
            .unwrap_err()
            .ends_with("iteration 1 is past max_iters = 0"));
        assert!(records(&line(0, -1.0), 5)
            .unwrap_err()
            .ends_with("time_s = -1 goes back, is negative or is not finite"));
        let long = format!("{{\"iter\": 0, \"energy\": 3, \"time_s\": 0, \"note\": \"{}\"}}\n", "x".repeat(5000));
        assert!(records(&long, 5).unwrap_err().ends_with("line 1: longer than the 4096 bytes a record may have"));
        let keys: String = (0..33).map(|i| format!(", \"k{i}\": 1")).collect();
        let wide = format!("{{\"iter\": 0, \"energy\": 3, \"time_s\": 0{keys}, \"record_s\": 0}}\n");
        assert!(records(&wide, 5).unwrap_err().ends_with("line 1: 33 extra keys, more than the 32 a record may have"));
        // the whole file: at most max_iters + 2 lines of the longest
        let many = line(0, 0.0).repeat(3000);
        assert!(records(&many, 5).unwrap_err().contains("bytes, more than the 28672 it may have"));
    }

    #[test]
    fn only_regular_files_of_at_most_their_cap_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let at = |name: &str| dir.path().join(name);
        std::fs::write(at("ok"), "12345").unwrap();
        assert_eq!(read_capped(&at("ok"), 5).unwrap(), "12345");
        assert!(read_capped(&at("ok"), 4).unwrap_err().to_string().ends_with("5 bytes, more than the 4 it may have"));
        std::os::unix::fs::symlink("/dev/zero", at("zero")).unwrap();
        assert!(read_capped(&at("zero"), 9)
            .unwrap_err()
            .to_string()
            .ends_with("is a symbolic link, not a regular file"));
        nix::unistd::mkfifo(&at("fifo"), nix::sys::stat::Mode::S_IRWXU).unwrap();
        // refused at once, not blocked on a writer that never comes
        let err = read_capped(&at("fifo"), 9).unwrap_err().to_string();
        assert!(err.ends_with("is a FIFO, socket or device, not a regular file"), "{err}");
        assert!(read_capped(dir.path(), 9).unwrap_err().to_string().ends_with("is a folder, not a regular file"));
        assert!(read_capped(&at("absent"), 9).unwrap_err().to_string().ends_with("absent: cannot read"));
        assert_eq!(quoted("short"), "short");
        assert_eq!(quoted("\u{1b}[31mred\u{1b}[0m\r"), "\\u{1b}[31mred\\u{1b}[0m\\r");
        let long = "é".repeat(QUOTED_CHARS + 7);
        assert_eq!(quoted(&long), format!("{}... (7 more characters)", "é".repeat(QUOTED_CHARS)));
    }
}
