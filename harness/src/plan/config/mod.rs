//! The run configuration: TOML, unknown keys are an error, every key has
//! a documented default (docs/src/reference/config.md).

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use solvers::init::TutteBoundary;
use solvers::linear::LinearSettings;
use solvers::smoothness::Projection;
use solvers::solver::{LineSearchSettings, RawOptions, StopOverrides};
use solvers::tasks::authalic::AuthalicSettings;
use solvers::tasks::param::ParamStart;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The task of a config: the solvers' own enum (one definition from the config to the CSV).
pub use solvers::tasks::Task;

/// The `maps` key's values: the run folder owns the maps.
pub use crate::run_folder::keep::Maps;

/// A dataset given inline in the config (`[[dataset]]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InlineDataset {
    pub name: String,
    /// OBJ file; relative paths resolve against the config file's folder.
    pub path: PathBuf,
    /// `deform`: a `*.p2p.json` handles file (relative to the config's folder) ...
    pub handles: Option<PathBuf>,
    /// ... and its constraint set (default 0);
    pub handles_set: Option<usize>,
    /// or a handles rule (`stretch`, `twist`).
    pub handles_rule: Option<String>,
}

/// `[init]`: the `param` task's initial map; a key not given keeps
/// `ParamSettings::for_energy`'s value.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitConfig {
    /// `uniform` (default) or `arclength`.
    pub tutte_boundary: Option<TutteBoundary>,
    /// Jump threshold of the global-scaling heuristic, default 0.1.
    pub scaling_jump: Option<f64>,
}

/// The `deform` task's settings (`[deform]`); a key not given keeps `DeformSettings`'s default.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeformConfig {
    /// Handle penalty weight on the area-1 mesh, default `solvers::tasks::deform::DEFAULT_LAMBDA`.
    pub lambda: Option<f64>,
}

/// The keys of an `[energy.<name>]` table any energy has (the smoothness term, the start of a
/// `param` run); the other keys are the energy's parameters (`EnergyKind::from_table`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProblemKeys {
    /// Weight `w` of the smoothness term `w sum_e l_e (psi_i - psi_j)^2` (Section 4.3);
    /// default 0 (off).
    pub smoothness: Option<f64>,
    /// `analytic` (default, Appendix B), `numeric` (8x8 eigen-decomposition), or `exact`
    /// (no projection, a diagnostic: the system may be indefinite).
    pub smoothness_projection: Option<Projection>,
    /// `param`: `"tutte"` (the papers' start; the default but for exp-sd) or `"sd-minimum"`
    /// (the SD minimum of the same problem; exp-sd's default, which overflows at the Tutte
    /// map of most real meshes).
    pub start: Option<ParamStart>,
}

impl ProblemKeys {
    pub const KEYS: [&'static str; 3] = ["smoothness", "smoothness_projection", "start"];
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Output folder `reports/<name>/` unless `--out`.
    pub name: String,
    #[serde(default = "default_task")]
    pub task: Task,
    /// Names or `tag:<tag>` selectors of `datasets.toml` entries.
    #[serde(default)]
    pub datasets: Vec<String>,
    /// `param`/`deform`: energy names. `authalic` has one energy and may omit this.
    #[serde(default)]
    pub energies: Vec<String>,
    pub solvers: Vec<String>,
    /// Inline datasets.
    #[serde(default)]
    pub dataset: Vec<InlineDataset>,
    /// The dataset registry, relative to the config's folder; default: the nearest
    /// `datasets.toml` in the config's folder or above.
    pub registry: Option<PathBuf>,
    /// `[stop]`: the keys given replace the task's and energy's default rule (SARAP,
    /// `deform` and `authalic` have their own).
    #[serde(default)]
    pub stop: StopOverrides,
    /// `[line_search]`, straight into the solvers' settings (their `Default` for the keys not
    /// given); `None` when the section is absent.
    pub line_search: Option<LineSearchSettings>,
    /// `[linear]`, likewise.
    pub linear: Option<LinearSettings>,
    #[serde(default)]
    pub init: InitConfig,
    #[serde(default)]
    pub energy: BTreeMap<String, toml::Table>,
    /// `[external.<name>]`: solvers outside the catalogue, run as processes under the
    /// external-solver protocol (`peers/PROTOCOL.md`); `solvers` names them like the others.
    #[serde(default)]
    pub external: BTreeMap<String, crate::plan::external::Declared>,
    /// `[solver.<name>]`: options of individual solvers (a solver of the config's task), as
    /// given: each solver's catalogue entry reads its own table.
    #[serde(default)]
    pub solver: BTreeMap<String, RawOptions>,
    /// `[authalic]`, straight into `AuthalicSettings` (the paper's protocol for the keys not
    /// given; its stop rule comes from `[stop]`).
    pub authalic: Option<AuthalicSettings>,
    pub deform: Option<DeformConfig>,
    /// Wall-clock limit per run, e.g. "90s", "10m", "1h" (checked after every iteration;
    /// a run that passes it stops with `stop_reason = timeout`). Default: none.
    pub timeout: Option<String>,
    /// rayon threads inside each run. Default: 1 while the batch has at least as many runs as
    /// `--jobs` workers, otherwise the cores divided among the runs. Results do not depend on
    /// it (every reduction is in a fixed order); timings do.
    pub threads_per_run: Option<usize>,
    /// Times each run is repeated, round-robin over the plan (every run once, then every run
    /// again), so that a slow phase of the machine hits every solver alike; `time_s` is the
    /// median. Default 1; `--repeat N` overrides.
    pub repeat: Option<usize>,
    /// Which runs the repeats are for: `ranked` (default: those whose time decides a ranking,
    /// the runs that reached their target within twice the fastest of their problem) or
    /// `all` (every run that ran, for a study of every run's time).
    pub repeat_runs: Option<RepeatRuns>,
    /// The history database every batch is appended to, relative to the config's folder;
    /// default `reports/history.sqlite` relative to the current directory (`--history`,
    /// `--no-history` override).
    pub history: Option<PathBuf>,
    /// Which final maps the run folder keeps: `all`, `best` (default: per dataset and energy
    /// the best run's) or `none`.
    pub maps: Option<Maps>,
    /// With `maps = "best"`, the solvers whose maps are kept besides the best, so that the
    /// report shows them side by side with it.
    pub maps_keep: Option<Vec<String>>,
    /// Solvers known to leave problems of this config unsolved (plain `newton`'s failed
    /// factorizations, say): the report's first screen rolls their unsolved runs up apart
    /// from the problems that are news. Their runs are judged like any other.
    pub expected_to_fail: Option<Vec<String>>,
    /// The tolerances of the convergence test (`param`, `deform`): a run solves its problem
    /// at `tau` once its energy is within `tau` of the way from its start to the reference
    /// minimum; it is `ok` at the tightest. Default `[1e-3, 1e-6]`.
    pub targets: Option<Vec<f64>>,
    /// The reference store the batch adds the minima it computes to, relative to the
    /// config's folder; default `references.json` beside the history database. The
    /// committed `references.json` beside the registry is read first.
    pub references: Option<PathBuf>,
    /// Whether a batch computes the reference minimum of a problem no store holds (default
    /// true). `false` judges such groups by the batch's best final energy, uncertified, as
    /// when the computation fails: for scaling batches whose references would cost hours
    /// (the authalic reference runs AEM-CG 5000 iterations twice). `mapbench references`
    /// computes them regardless.
    pub compute_references: Option<bool>,
}

/// Which runs of a batch with `repeat` above 1 are repeated (`repeat_runs`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RepeatRuns {
    /// The runs whose time decides a ranking (`run::repeats::worth_repeating`).
    #[default]
    Ranked,
    /// Every run that ran.
    All,
}

/// The default targets of the convergence test.
pub const DEFAULT_TARGETS: [f64; 2] = [1e-3, 1e-6];

/// Targets are tolerances strictly between 0 and 1, given at most once each (at least one).
pub fn check_targets(targets: &[f64]) -> Result<()> {
    if targets.is_empty() {
        bail!("targets = []: give at least one tolerance, e.g. [1e-3, 1e-6]");
    }
    for (i, t) in targets.iter().enumerate() {
        if !(*t > 0.0 && *t < 1.0) {
            bail!("targets: {t} is not a tolerance between 0 and 1 (exclusive)");
        }
        if targets[..i].contains(t) {
            bail!("targets: {t} is given twice");
        }
    }
    Ok(())
}

/// The most repeats a batch may ask for (a typo like 10000 would run the plan that often).
pub const MAX_REPEAT: usize = 100;

/// `repeat` is at least 1 and at most [`MAX_REPEAT`].
pub fn check_repeat(repeat: usize) -> Result<()> {
    if !(1..=MAX_REPEAT).contains(&repeat) {
        bail!("repeat = {repeat}: give 1 to {MAX_REPEAT} (each repeat runs the whole plan again)");
    }
    Ok(())
}

/// The cores this process may use.
pub fn available_cores() -> usize {
    std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
}

/// The most threads per run, and runs at once, on `cores` cores: 4 x the cores.
pub fn max_threads(cores: usize) -> usize {
    cores.saturating_mul(4)
}

/// `threads_per_run` is at least 1 and at most [`max_threads`]: more threads than that only
/// slow a run down (they share the cores), and a typo like 100000 would spawn that many.
pub fn check_threads_per_run(threads: Option<usize>, cores: usize) -> Result<()> {
    match threads {
        Some(0) => bail!("threads_per_run must be at least 1"),
        Some(t) if t > max_threads(cores) => bail!(
            "threads_per_run = {t} is more than 4 x the {cores} cores of this machine ({}): threads beyond the \
             cores share them and only slow each run down",
            max_threads(cores)
        ),
        _ => Ok(()),
    }
}

/// `--jobs` is at least 1 and at most [`max_threads`], like `threads_per_run`: runs beyond the
/// cores wait for each other while their clocks run, and each is a thread with its own pool
/// (a typo like 100000 spawned threads until the process could not start another).
pub fn check_jobs(jobs: Option<usize>, cores: usize) -> Result<()> {
    match jobs {
        Some(0) => bail!("--jobs must be at least 1"),
        Some(j) if j > max_threads(cores) => bail!(
            "--jobs {j} is more than 4 x the {cores} cores of this machine ({}): runs beyond the cores wait for \
             each other while their times are taken",
            max_threads(cores)
        ),
        _ => Ok(()),
    }
}

/// The longest `timeout`: any run deadline `now + timeout` fits an `Instant`.
pub const MAX_TIMEOUT_SECS: f64 = 1e9;

fn default_task() -> Task {
    Task::Param
}

/// A config read from a file, with the folder its relative paths resolve against.
#[derive(Clone, Debug)]
pub struct LoadedConfig {
    pub path: PathBuf,
    pub dir: PathBuf,
    pub config: Config,
    /// The file's tables as read (`meta.json` echoes them; `merge` compares them).
    pub raw: toml::Table,
}

impl LoadedConfig {
    pub fn load(path: &Path) -> Result<LoadedConfig> {
        let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read config", path.display()))?;
        Self::parse(&text, path)
    }

    /// A config from its text; `path` is the file it came from (errors name it, relative paths
    /// resolve against its folder). Nothing is read from disk.
    pub fn parse(text: &str, path: &Path) -> Result<LoadedConfig> {
        let config: Config = toml::from_str(text).with_context(|| format!("{}: invalid config", path.display()))?;
        let raw: toml::Table = toml::from_str(text).with_context(|| format!("{}: invalid config", path.display()))?;
        config.check().with_context(|| format!("{}: invalid config", path.display()))?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let dir = if dir.as_os_str().is_empty() { PathBuf::from(".") } else { dir };
        Ok(LoadedConfig { path: path.to_path_buf(), dir, config, raw })
    }

    /// The registry file: the configured one, or the nearest `datasets.toml` upwards.
    pub fn registry_path(&self) -> Option<PathBuf> {
        if let Some(p) = &self.config.registry {
            return Some(self.dir.join(p));
        }
        let start = std::fs::canonicalize(&self.dir).unwrap_or_else(|_| self.dir.clone());
        start.ancestors().map(|d| d.join("datasets.toml")).find(|p| p.is_file())
    }
}

impl Config {
    /// `timeout` in seconds (`None` when not set).
    pub fn timeout_secs(&self) -> Result<Option<f64>> {
        let Some(t) = &self.timeout else { return Ok(None) };
        let t = t.trim();
        let (num, unit) = t.split_at(t.find(|c: char| c.is_ascii_alphabetic()).unwrap_or(t.len()));
        let factor = match unit {
            "" | "s" => 1.0,
            "m" | "min" => 60.0,
            "h" => 3600.0,
            _ => bail!("timeout = \"{t}\": unknown unit '{unit}' (use s, m or h, e.g. \"10m\")"),
        };
        match num.trim().parse::<f64>() {
            // The runner adds it to `Instant::now()`, which panics far below f64's range.
            Ok(v) if v > 0.0 && v * factor > MAX_TIMEOUT_SECS => {
                bail!("timeout = \"{t}\" is too long (at most {MAX_TIMEOUT_SECS:e} s, about 30 years)")
            }
            Ok(v) if v > 0.0 && v.is_finite() => Ok(Some(v * factor)),
            _ => bail!("timeout = \"{t}\" is not a positive duration (e.g. \"90s\", \"10m\", \"1h\")"),
        }
    }
}

mod checks;
mod settings;
#[cfg(test)]
mod tests;
