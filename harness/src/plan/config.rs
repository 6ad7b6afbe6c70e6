//! The run configuration (design.md "Config"): TOML, unknown keys are an error, every key has
//! a documented default (see README.md).

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use solvers::authalic::{AuthalicSettings, FoldGuard, AUTHALIC_ENERGY};
use solvers::deform::DeformSettings;
use solvers::energy::{EnergyKind, ENERGY_NAMES};
use solvers::init::TutteBoundary;
use solvers::linear::LinearSettings;
use solvers::param::{default_stop, ParamSettings};
use solvers::smoothness::Projection;
use solvers::solver::catalogue::{self, names_for, SolverError};
use solvers::solver::{LineSearchSettings, Settings, StopSettings};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The task of a config: the solvers' own enum (one definition from the config to the CSV).
pub use solvers::mesh::Task;

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

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StopConfig {
    /// Default 1e-3.
    pub grad_tol: Option<f64>,
    /// Default 0 (off), 1e-8 for SARAP in `param`.
    pub energy_decrease_tol: Option<f64>,
    /// Default 1000.
    pub max_iters: Option<usize>,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LineSearchConfig {
    /// `t0 = min(1, max_step_fraction * t_max)`, default 0.9.
    pub max_step_fraction: Option<f64>,
    /// Armijo constant, default 0.2.
    pub armijo_c: Option<f64>,
    /// Backtracking factor, default 0.5.
    pub shrink: Option<f64>,
    /// Give up when `t |d| <= min_step`, default 1e-12.
    pub min_step: Option<f64>,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearConfig {
    /// Tikhonov shift, default 1e-10.
    pub tikhonov: Option<f64>,
    /// Symmetric Jacobi scaling, default true.
    pub jacobi: Option<bool>,
    /// Fill-reducing ordering of the Newton system: `metis` (default: nested dissection of the
    /// vertex graph, postordered) or `amd`.
    pub ordering: Option<solvers::ordering::Ordering>,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitConfig {
    /// `uniform` (default) or `arclength`.
    pub tutte_boundary: Option<TutteBoundary>,
    /// Jump threshold of the global-scaling heuristic, default 0.1.
    pub scaling_jump: Option<f64>,
}

/// The `deform` task's settings (`[deform]`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeformConfig {
    /// Handle penalty weight on the area-1 mesh, default `solvers::deform::DEFAULT_LAMBDA`.
    pub lambda: Option<f64>,
}

/// The `authalic` task's solver settings (`[authalic]`); defaults in `AuthalicSettings`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AuthalicConfig {
    /// Fixed-boundary stretch steps of the initial map, default 5.
    pub init_steps: Option<usize>,
    /// First trial step of the quadratic step rule (Eq. 18), default 2.
    pub alpha0: Option<f64>,
    /// `aem-cg-safe` Armijo constant, default 1e-4.
    pub armijo_c: Option<f64>,
    /// Curvature constant of the recorded strong-Wolfe check, default 0.45.
    pub wolfe_c2: Option<f64>,
    /// `aem-cg-safe` step halvings before restart, default 30.
    pub max_backtracks: Option<usize>,
    /// `aem-cg-safe` fold guard: `boundary` (default), `all` or `none`.
    pub fold_guard: Option<FoldGuard>,
    /// `sem` stops at the first energy increase (reference code SEMc), default false.
    pub sem_stop_on_increase: Option<bool>,
}

/// Parameters of one energy (`[energy.<name>]`); which keys apply depends on the energy.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnergyParams {
    /// exp-sd exponent weight.
    pub s: Option<f64>,
    /// nh shear modulus.
    pub mu: Option<f64>,
    /// nh bulk modulus.
    pub kappa: Option<f64>,
    /// barap / bconf barrier weight.
    pub k: Option<f64>,
    /// Weight `w` of the smoothness term `w sum_e l_e (psi_i - psi_j)^2` (Section 4.3), any
    /// energy; default 0 (off).
    pub smoothness: Option<f64>,
    /// `analytic` (default, Appendix B), `numeric` (8x8 eigen-decomposition), or `exact`
    /// (no projection, a diagnostic: the system may be indefinite).
    pub smoothness_projection: Option<Projection>,
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
    #[serde(default)]
    pub stop: StopConfig,
    #[serde(default)]
    pub line_search: LineSearchConfig,
    #[serde(default)]
    pub linear: LinearConfig,
    #[serde(default)]
    pub init: InitConfig,
    #[serde(default)]
    pub energy: BTreeMap<String, EnergyParams>,
    #[serde(default)]
    pub authalic: Option<AuthalicConfig>,
    #[serde(default)]
    pub deform: Option<DeformConfig>,
    /// Wall-clock limit per run, e.g. "90s", "10m", "1h" (checked after every iteration;
    /// a run that passes it stops with `stop_reason = timeout`). Default: none.
    pub timeout: Option<String>,
    /// rayon threads inside each run. Default: 1 while the batch has at least as many runs as
    /// `--jobs` workers, otherwise the cores divided among the runs. Results do not depend on
    /// it (every reduction is in a fixed order); timings do.
    pub threads_per_run: Option<usize>,
}

/// The cores this process may use.
pub fn available_cores() -> usize {
    std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
}

/// `threads_per_run` is at least 1 and at most 4 x the cores: more threads than that only
/// slow a run down (they share the cores), and a typo like 100000 would spawn that many.
pub fn check_threads_per_run(threads: Option<usize>, cores: usize) -> Result<()> {
    match threads {
        Some(0) => bail!("threads_per_run must be at least 1"),
        Some(t) if t > 4 * cores => bail!(
            "threads_per_run = {t} is more than 4 x the {cores} cores of this machine ({}): threads beyond the \
             cores share them and only slow each run down",
            4 * cores
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
        config.check().with_context(|| format!("{}: invalid config", path.display()))?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let dir = if dir.as_os_str().is_empty() { PathBuf::from(".") } else { dir };
        Ok(LoadedConfig { path: path.to_path_buf(), dir, config })
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
    /// Checks names and values that serde cannot (unknown solver/energy names, parameters
    /// that do not belong to an energy, out-of-range values).
    pub fn check(&self) -> Result<()> {
        self.timeout_secs()?;
        check_threads_per_run(self.threads_per_run, available_cores())?;
        self.check_names()?;
        if self.task != Task::Deform && self.deform.is_some() {
            bail!("[deform] applies only to task = \"deform\"");
        }
        if self.task == Task::Deform {
            if self.init != InitConfig::default() {
                bail!("[init] does not apply to task deform (it starts from the rest pose)");
            }
            if let Some(l) = self.deform.as_ref().and_then(|d| d.lambda) {
                if !(l > 0.0 && l.is_finite()) {
                    bail!("[deform] lambda = {l} must be positive and finite");
                }
            }
        }
        for d in &self.dataset {
            crate::plan::registry::check_handles(d.handles.is_some(), d.handles_set, d.handles_rule.as_deref())
                .with_context(|| format!("[[dataset]] '{}'", d.name))?;
            // Handles only mean something to `deform`: silently ignoring them would hide a
            // config that was meant to be a deform batch.
            if self.task != Task::Deform && (d.handles.is_some() || d.handles_rule.is_some()) {
                bail!(
                    "[[dataset]] '{}': handles apply only to task = \"deform\" (this config's task is {}); \
                     remove them or set the task",
                    d.name,
                    self.task.as_str()
                );
            }
        }
        if self.task == Task::Authalic {
            return self.check_authalic();
        }
        if self.authalic.is_some() {
            bail!("[authalic] applies only to task = \"authalic\"");
        }
        if self.energies.is_empty() {
            bail!("'energies' is empty: name at least one of {}", ENERGY_NAMES.join(", "));
        }
        self.check_solvers()?;
        if self.datasets.is_empty() && self.dataset.is_empty() {
            bail!("no datasets: give 'datasets = [...]' (names or tag:<tag>) or [[dataset]] entries");
        }
        for e in &self.energies {
            self.energy_kind(e)?;
        }
        for name in self.energy.keys() {
            if !ENERGY_NAMES.contains(&name.as_str()) {
                bail!("[energy.{name}]: unknown energy (known: {})", ENERGY_NAMES.join(", "));
            }
            self.energy_kind(name)?;
        }
        let positive = |key: &str, v: Option<f64>| match v {
            Some(x) if !(x > 0.0 && x.is_finite()) => bail!("{key} = {x} must be positive and finite"),
            _ => Ok(()),
        };
        positive("[stop] grad_tol", self.stop.grad_tol)?;
        positive("[line_search] max_step_fraction", self.line_search.max_step_fraction)?;
        positive("[line_search] armijo_c", self.line_search.armijo_c)?;
        positive("[line_search] min_step", self.line_search.min_step)?;
        positive("[init] scaling_jump", self.init.scaling_jump)?;
        if let Some(s) = self.line_search.shrink {
            if !(s > 0.0 && s < 1.0) {
                bail!("[line_search] shrink = {s} must be in (0, 1)");
            }
        }
        if let Some(c) = self.line_search.armijo_c {
            if c >= 1.0 {
                bail!("[line_search] armijo_c = {c} must be below 1");
            }
        }
        if let Some(t) = self.stop.energy_decrease_tol {
            if !(t >= 0.0 && t.is_finite()) {
                bail!("[stop] energy_decrease_tol = {t} must be non-negative");
            }
        }
        if let Some(t) = self.linear.tikhonov {
            if !(t >= 0.0 && t.is_finite()) {
                bail!("[linear] tikhonov = {t} must be non-negative");
            }
        }
        Ok(())
    }

    /// Names that become file names are file-name safe (`crate::plan::names`), and no list repeats
    /// an entry (a repeated energy or solver would run the same run twice into one file).
    fn check_names(&self) -> Result<()> {
        // `name` is the default run folder, reports/<name>.
        crate::plan::names::check_name("config", &self.name).context("'name'")?;
        for d in &self.dataset {
            crate::plan::names::check_name("dataset", &d.name).context("[[dataset]]")?;
        }
        for e in &self.energies {
            crate::plan::names::check_name("energy", e).context("'energies'")?;
        }
        for s in &self.solvers {
            crate::plan::names::check_name("solver", s).context("'solvers'")?;
        }
        let inline: Vec<String> = self.dataset.iter().map(|d| d.name.clone()).collect();
        for (key, list) in [
            ("datasets", &self.datasets),
            ("energies", &self.energies),
            ("solvers", &self.solvers),
            ("[[dataset]] name", &inline),
        ] {
            let mut seen = std::collections::HashSet::new();
            if let Some(dup) = list.iter().find(|x| !seen.insert(x.as_str())) {
                bail!("{key}: '{dup}' appears twice");
            }
        }
        Ok(())
    }

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

    /// Every solver is in the catalogue and runs this config's task.
    fn check_solvers(&self) -> Result<()> {
        if self.solvers.is_empty() {
            bail!("'solvers' is empty: name at least one of {}", names_for(self.task).join(", "));
        }
        for s in &self.solvers {
            match catalogue::lookup(s, self.task) {
                Ok(_) => {}
                Err(e @ SolverError::WrongTask { runs, .. }) => {
                    let tasks: Vec<String> = runs.iter().map(|t| format!("\"{t}\"")).collect();
                    bail!("{e}; it runs in a config with task = {}", tasks.join(" or "))
                }
                Err(e) => bail!("{e}"),
            }
        }
        Ok(())
    }

    /// The `authalic` task's rules: one energy, its own solvers, no Newton sections.
    fn check_authalic(&self) -> Result<()> {
        if self.energies.iter().any(|e| e != AUTHALIC_ENERGY) {
            bail!("task authalic has the one energy '{AUTHALIC_ENERGY}' (got {:?}); omit 'energies'", self.energies);
        }
        self.check_solvers()?;
        if self.datasets.is_empty() && self.dataset.is_empty() {
            bail!("no datasets: give 'datasets = [...]' (names or tag:<tag>) or [[dataset]] entries");
        }
        let defaults = (LineSearchConfig::default(), LinearConfig::default(), InitConfig::default());
        for (section, unused) in [
            ("[line_search]", self.line_search != defaults.0),
            ("[linear]", self.linear != defaults.1),
            ("[init]", self.init != defaults.2),
            ("[energy.*]", !self.energy.is_empty()),
        ] {
            if unused {
                bail!("{section} does not apply to task authalic (its settings are in [authalic])");
            }
        }
        if let Some(t) = self.stop.energy_decrease_tol {
            if !(t >= 0.0 && t.is_finite()) {
                bail!("[stop] energy_decrease_tol = {t} must be non-negative");
            }
        }
        if let Some(t) = self.stop.grad_tol {
            if !(t >= 0.0 && t.is_finite()) {
                bail!("[stop] grad_tol = {t} must be non-negative");
            }
        }
        if let Some(a) = &self.authalic {
            for (key, v) in [("alpha0", a.alpha0), ("armijo_c", a.armijo_c), ("wolfe_c2", a.wolfe_c2)] {
                if let Some(x) = v {
                    if !(x > 0.0 && x.is_finite()) {
                        bail!("[authalic] {key} = {x} must be positive and finite");
                    }
                }
            }
            if let Some(c) = a.armijo_c.or(a.wolfe_c2) {
                if c >= 1.0 {
                    bail!("[authalic] armijo_c and wolfe_c2 must be below 1");
                }
            }
        }
        Ok(())
    }

    /// The energies of the runs: the configured ones, or the authalic task's one energy.
    pub fn energy_names(&self) -> Vec<String> {
        if self.task == Task::Authalic {
            vec![AUTHALIC_ENERGY.to_string()]
        } else {
            self.energies.clone()
        }
    }

    /// The `authalic` settings: `AuthalicSettings` defaults (the paper's Table 1 protocol:
    /// 100 iterations, no tolerance stop) overridden by `[stop]` and `[authalic]`.
    fn authalic_settings(&self) -> AuthalicSettings {
        let d = AuthalicSettings::default();
        let a = self.authalic.clone().unwrap_or_default();
        AuthalicSettings {
            stop: StopSettings {
                grad_tol: self.stop.grad_tol.unwrap_or(d.stop.grad_tol),
                energy_decrease_tol: self.stop.energy_decrease_tol.unwrap_or(d.stop.energy_decrease_tol),
                max_iters: self.stop.max_iters.unwrap_or(d.stop.max_iters),
            },
            init_steps: a.init_steps.unwrap_or(d.init_steps),
            alpha0: a.alpha0.unwrap_or(d.alpha0),
            armijo_c: a.armijo_c.unwrap_or(d.armijo_c),
            wolfe_c2: a.wolfe_c2.unwrap_or(d.wolfe_c2),
            max_backtracks: a.max_backtracks.unwrap_or(d.max_backtracks),
            fold_guard: a.fold_guard.unwrap_or(d.fold_guard),
            sem_stop_on_increase: a.sem_stop_on_increase.unwrap_or(d.sem_stop_on_increase),
        }
    }

    /// The energy `name` with the config's parameters applied over the defaults.
    pub fn energy_kind(&self, name: &str) -> Result<EnergyKind> {
        let mut kind = EnergyKind::default_for(name)
            .with_context(|| format!("unknown energy '{name}' (known: {})", ENERGY_NAMES.join(", ")))?;
        if let Some(p) = self.energy.get(name) {
            let not_for = |key: &str| anyhow::anyhow!("[energy.{name}] has no parameter '{key}'");
            match &mut kind {
                EnergyKind::Sd | EnergyKind::Sarap => {
                    for (key, v) in [("s", p.s), ("mu", p.mu), ("kappa", p.kappa), ("k", p.k)] {
                        if v.is_some() {
                            return Err(not_for(key));
                        }
                    }
                }
                EnergyKind::ExpSd { s } => {
                    for (key, v) in [("mu", p.mu), ("kappa", p.kappa), ("k", p.k)] {
                        if v.is_some() {
                            return Err(not_for(key));
                        }
                    }
                    *s = p.s.unwrap_or(*s);
                }
                EnergyKind::Nh { mu, kappa } => {
                    for (key, v) in [("s", p.s), ("k", p.k)] {
                        if v.is_some() {
                            return Err(not_for(key));
                        }
                    }
                    *mu = p.mu.unwrap_or(*mu);
                    *kappa = p.kappa.unwrap_or(*kappa);
                }
                EnergyKind::Barap { k } | EnergyKind::Bconf { k } => {
                    for (key, v) in [("s", p.s), ("mu", p.mu), ("kappa", p.kappa)] {
                        if v.is_some() {
                            return Err(not_for(key));
                        }
                    }
                    *k = p.k.unwrap_or(*k);
                }
            }
        }
        kind.check().map_err(anyhow::Error::msg)?;
        if let Some(p) = self.energy.get(name) {
            match (p.smoothness, p.smoothness_projection) {
                (Some(w), _) if !(w >= 0.0 && w.is_finite()) => {
                    bail!("[energy.{name}] smoothness = {w} must be non-negative and finite")
                }
                (None, Some(_)) => bail!("[energy.{name}] smoothness_projection needs smoothness = <weight>"),
                _ => {}
            }
        }
        Ok(kind)
    }

    /// The resolved settings of the runs of energy `name` (the one place where config sections
    /// become solver settings): the task's defaults, the config's overrides, the energy's
    /// parameters and its smoothness term.
    pub fn run_settings(&self, name: &str) -> Result<crate::plan::RunSettings> {
        use crate::plan::RunSettings;
        Ok(match self.task {
            Task::Authalic => RunSettings::Authalic(self.authalic_settings()),
            Task::Param => {
                let energy = self.energy_kind(name)?;
                let mut settings = self.param_settings(&energy);
                settings.smoothness = self.smoothness_for(name);
                RunSettings::Param { energy, settings }
            }
            Task::Deform => {
                let energy = self.energy_kind(name)?;
                let mut settings = self.deform_settings();
                settings.smoothness = self.smoothness_for(name);
                RunSettings::Deform { energy, settings }
            }
        })
    }

    /// The smoothness term of energy `name`: weight and projection, `None` when off.
    fn smoothness_for(&self, name: &str) -> Option<(f64, Projection)> {
        let p = self.energy.get(name)?;
        p.smoothness.filter(|w| *w > 0.0).map(|w| (w, p.smoothness_projection.unwrap_or_default()))
    }

    /// The `deform` settings (the same for every energy): deform defaults (energy decrease < 1e-6, no
    /// global scaling) overridden by `[stop]`, `[line_search]`, `[linear]`, `[deform]`.
    fn deform_settings(&self) -> DeformSettings {
        let p = self.param_settings_with(solvers::deform::default_stop());
        DeformSettings {
            solver: p.solver,
            lambda: self.deform.as_ref().and_then(|d| d.lambda).unwrap_or(solvers::deform::DEFAULT_LAMBDA),
            smoothness: None,
        }
    }

    /// The solver settings for one energy: design.md conventions overridden by the config.
    fn param_settings(&self, energy: &EnergyKind) -> ParamSettings {
        self.param_settings_with(default_stop(energy))
    }

    fn param_settings_with(&self, d: StopSettings) -> ParamSettings {
        let stop = StopSettings {
            grad_tol: self.stop.grad_tol.unwrap_or(d.grad_tol),
            energy_decrease_tol: self.stop.energy_decrease_tol.unwrap_or(d.energy_decrease_tol),
            max_iters: self.stop.max_iters.unwrap_or(d.max_iters),
        };
        let ls = LineSearchSettings::default();
        let line_search = LineSearchSettings {
            max_step_fraction: self.line_search.max_step_fraction.unwrap_or(ls.max_step_fraction),
            armijo_c: self.line_search.armijo_c.unwrap_or(ls.armijo_c),
            shrink: self.line_search.shrink.unwrap_or(ls.shrink),
            min_step: self.line_search.min_step.unwrap_or(ls.min_step),
        };
        let lin = LinearSettings::default();
        let linear = LinearSettings {
            tikhonov: self.linear.tikhonov.unwrap_or(lin.tikhonov),
            jacobi: self.linear.jacobi.unwrap_or(lin.jacobi),
            ordering: self.linear.ordering.unwrap_or(lin.ordering),
        };
        ParamSettings {
            solver: Settings { stop, line_search, linear, analyses: None },
            tutte_boundary: self.init.tutte_boundary.unwrap_or_default(),
            scaling_jump: self.init.scaling_jump.unwrap_or(0.1),
            smoothness: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const AUTH: &str =
        "name = \"a\"\ntask = \"authalic\"\ndatasets = [\"bumpy_1k\"]\nsolvers = [\"sem\", \"aem-cg\"]\n";

    #[test]
    fn smoothness_is_an_energy_option() {
        let c = parse(&format!(
            "{MIN}[energy.sd]\nsmoothness = 0.25\n[energy.nh]\nsmoothness = 0.5\nsmoothness_projection = \"numeric\"\n"
        ))
        .unwrap();
        assert_eq!(c.smoothness_for("sd"), Some((0.25, Projection::Analytic)));
        assert_eq!(c.smoothness_for("nh"), Some((0.5, Projection::Numeric)));
        assert_eq!(c.smoothness_for("bconf"), None);
        let err = |t: &str| format!("{:#}", parse(t).unwrap_err());
        assert!(err(&format!("{MIN}[energy.sd]\nsmoothness = -1.0\n")).contains("must be non-negative"));
        assert!(err(&format!("{MIN}[energy.sd]\nsmoothness_projection = \"numeric\"\n")).contains("needs smoothness"));
    }

    #[test]
    fn timeouts_parse_with_units() {
        let t = |v: &str| parse(&format!("timeout = \"{v}\"\n{MIN}")).map(|c| c.timeout_secs().unwrap());
        assert_eq!(t("90s").unwrap(), Some(90.0));
        assert_eq!(t("10m").unwrap(), Some(600.0));
        assert_eq!(t("1.5h").unwrap(), Some(5400.0));
        assert_eq!(t("30").unwrap(), Some(30.0));
        assert!(format!("{:#}", t("10d").unwrap_err()).contains("unknown unit 'd'"));
        assert!(format!("{:#}", t("-1m").unwrap_err()).contains("not a positive duration"));
        assert_eq!(parse(MIN).unwrap().timeout_secs().unwrap(), None);
    }

    /// Found by the config fuzz target: a timeout that f64 holds but a run's deadline
    /// (`Instant::now() + timeout`) does not panicked in the runner.
    #[test]
    fn huge_timeouts_are_config_errors() {
        let t = |v: &str| parse(&format!("timeout = \"{v}\"\n{MIN}")).map(|c| c.timeout_secs().unwrap());
        let huge = format!("1{}", "0".repeat(300));
        for v in [format!("{huge}s"), format!("{huge}{}h", "0".repeat(6)), "1000000001".into()] {
            assert!(format!("{:#}", t(&v).unwrap_err()).contains("is too long"), "{v}");
        }
        assert_eq!(t("1000000000").unwrap(), Some(1e9));
    }

    #[test]
    fn authalic_configs_default_to_the_papers_protocol_and_reject_newton_sections() {
        let c = parse(AUTH).unwrap();
        assert_eq!(c.energy_names(), ["authalic"]);
        let s = c.authalic_settings();
        assert_eq!(s, AuthalicSettings::default());
        assert_eq!((s.stop.max_iters, s.stop.grad_tol, s.stop.energy_decrease_tol), (100, 0.0, 0.0));
        let c = parse(&format!(
            "{AUTH}[stop]\nmax_iters = 7\n[authalic]\nalpha0 = 0.5\nfold_guard = \"all\"\nsem_stop_on_increase = true\n"
        ))
        .unwrap();
        let s = c.authalic_settings();
        assert_eq!((s.stop.max_iters, s.alpha0, s.fold_guard, s.sem_stop_on_increase), (7, 0.5, FoldGuard::All, true));
        let err = |t: &str| format!("{:#}", parse(t).unwrap_err());
        assert!(err(&AUTH.replace("\"aem-cg\"", "\"kp-newton\"")).contains("'kp-newton' is a param/deform solver"));
        assert!(err(&format!("{AUTH}energies = [\"sd\"]\n")).contains("one energy 'authalic'"));
        assert!(err(&format!("{AUTH}[line_search]\narmijo_c = 0.1\n")).contains("[line_search] does not apply"));
        assert!(err(&format!("{AUTH}[authalic]\nalpha0 = -1.0\n")).contains("alpha0 = -1"));
        assert!(err(&format!("{AUTH}[authalic]\nfold_guard = \"some\"\n")).contains("unknown variant"));
        assert!(err(&format!("{AUTH}[authalic]\nalpha = 1.0\n")).contains("unknown field `alpha`"));
        assert!(parse(&format!("{AUTH}energies = [\"authalic\"]\n")).is_ok());
    }

    #[test]
    fn a_solver_of_another_task_is_named_as_such() {
        let err = |t: &str| format!("{:#}", parse(t).unwrap_err());
        let e = err(&MIN.replace("\"kp-newton\"", "\"sem\""));
        assert!(e.contains("'sem' is an authalic solver") && e.contains("task = \"authalic\""), "{e}");
        assert!(err(&MIN.replace("\"kp-newton\"", "\"sem2\"")).contains("unknown solver 'sem2'"));
        let e = err(&AUTH.replace("\"sem\"", "\"cm\""));
        assert!(e.contains("'cm' is a param/deform solver"), "{e}");
    }

    #[test]
    fn threads_per_run_is_bounded_by_the_cores() {
        assert!(check_threads_per_run(None, 2).is_ok());
        assert!(check_threads_per_run(Some(8), 2).is_ok());
        let e = format!("{:#}", check_threads_per_run(Some(9), 2).unwrap_err());
        assert!(e.contains("threads_per_run = 9 is more than 4 x the 2 cores") && e.contains("(8)"), "{e}");
        assert!(format!("{:#}", check_threads_per_run(Some(0), 2).unwrap_err()).contains("at least 1"));
        let e = format!("{:#}", parse(&format!("threads_per_run = 100000\n{MIN}")).unwrap_err());
        assert!(e.contains("threads_per_run = 100000 is more than"), "{e}");
    }

    #[test]
    fn repeated_energies_solvers_and_datasets_are_refused() {
        let err = |t: &str| format!("{:#}", parse(t).unwrap_err());
        assert!(err(&MIN.replace("[\"sd\"]", "[\"sd\", \"nh\", \"sd\"]")).contains("energies: 'sd' appears twice"));
        assert!(err(&MIN.replace("[\"kp-newton\"]", "[\"kp-newton\", \"kp-newton\"]"))
            .contains("solvers: 'kp-newton' appears twice"));
        assert!(err(&MIN.replace("[\"bumpy_1k\"]", "[\"bumpy_1k\", \"bumpy_1k\"]"))
            .contains("datasets: 'bumpy_1k' appears twice"));
        let two = "[[dataset]]\nname = \"m\"\npath = \"m.obj\"\n";
        assert!(err(&format!("{MIN}{two}{two}")).contains("[[dataset]] name: 'm' appears twice"));
    }

    #[test]
    fn inline_dataset_names_must_be_file_name_safe() {
        let err = |name: &str| {
            let t = format!("{MIN}[[dataset]]\nname = {name:?}\npath = \"m.obj\"\n");
            format!("{:#}", parse(&t).unwrap_err())
        };
        for (name, why) in [
            ("../../ESCAPED", "path separator"),
            ("/abs/x", "path separator"),
            ("a/b", "path separator"),
            ("a\nb", "U+000A"),
            ("", "is empty"),
            ("..", "'..'"),
        ] {
            let e = err(name);
            assert!(e.contains("[[dataset]]") && e.contains("dataset name") && e.contains(why), "{name:?}: {e}");
        }
    }

    #[test]
    fn handles_on_a_param_dataset_are_refused_not_ignored() {
        let t = format!("{MIN}[[dataset]]\nname = \"m\"\npath = \"m.obj\"\nhandles_rule = \"stretch\"\n");
        let e = format!("{:#}", parse(&t).unwrap_err());
        assert!(e.contains("'m': handles apply only to task = \"deform\"") && e.contains("task is param"), "{e}");
        let deform = t.replace("name = \"t\"", "name = \"t\"\ntask = \"deform\"");
        assert!(parse(&deform).is_ok());
    }

    fn parse(text: &str) -> Result<Config> {
        let c: Config = toml::from_str(text)?;
        c.check()?;
        Ok(c)
    }

    const MIN: &str = "name = \"t\"\ndatasets = [\"bumpy_1k\"]\nenergies = [\"sd\"]\nsolvers = [\"kp-newton\"]\n";

    #[test]
    fn minimal_config_gets_the_documented_defaults() {
        let c = parse(MIN).unwrap();
        assert_eq!(c.task, Task::Param);
        let s = c.param_settings(&EnergyKind::Sd);
        assert_eq!(s.solver.stop.grad_tol, 1e-3);
        assert_eq!(s.solver.stop.max_iters, 1000);
        assert_eq!(s.solver.stop.energy_decrease_tol, 0.0);
        assert_eq!(c.param_settings(&EnergyKind::Sarap).solver.stop.energy_decrease_tol, 1e-8);
        assert_eq!(s.solver.line_search, LineSearchSettings::default());
        assert_eq!(
            s.solver.linear,
            LinearSettings { tikhonov: 1e-10, jacobi: true, ordering: solvers::ordering::Ordering::Metis }
        );
        assert_eq!(s.tutte_boundary, TutteBoundary::Uniform);
        assert_eq!(s.scaling_jump, 0.1);
    }

    #[test]
    fn overrides_apply() {
        let text = format!(
            "{MIN}[stop]\nmax_iters = 7\n[init]\ntutte_boundary = \"arclength\"\n[energy.bconf]\nk = 0.5\n[line_search]\narmijo_c = 0.1\n"
        );
        let c = parse(&text).unwrap();
        let s = c.param_settings(&EnergyKind::Sd);
        assert_eq!(s.solver.stop.max_iters, 7);
        assert_eq!(s.solver.line_search.armijo_c, 0.1);
        assert_eq!(s.tutte_boundary, TutteBoundary::Arclength);
        assert_eq!(c.energy_kind("bconf").unwrap(), EnergyKind::Bconf { k: 0.5 });
    }

    #[test]
    fn bad_configs_name_what_is_wrong() {
        let err = |t: &str| format!("{:#}", parse(t).unwrap_err());
        assert!(err(&format!("{MIN}colour = 3\n")).contains("unknown field `colour`"));
        assert!(err(&format!("{MIN}[stop]\ngrad_tol = 1e-3\nmax_iter = 3\n")).contains("max_iter"));
        assert!(err(&MIN.replace("kp-newton", "kp-newtonn")).contains("unknown solver 'kp-newtonn'"));
        assert!(err(&MIN.replace("\"sd\"", "\"arap\"")).contains("unknown energy 'arap'"));
        assert!(err(&format!("{MIN}[energy.sd]\nk = 1.0\n")).contains("[energy.sd] has no parameter 'k'"));
        assert!(err(&format!("{MIN}[energy.bconf]\nk = -1.0\n")).contains("k = -1"));
        assert!(err(&format!("{MIN}[energy.foo]\nk = 1.0\n")).contains("[energy.foo]: unknown energy"));
        assert!(err(&format!("{MIN}[line_search]\nshrink = 1.5\n")).contains("shrink"));
        assert!(err(&MIN.replace("[\"bumpy_1k\"]", "[]")).contains("no datasets"));
        assert!(err(&format!("{MIN}[deform]\nlambda = 1.0\n")).contains("only to task = \"deform\""));
        let def = format!("task = \"deform\"\n{MIN}");
        assert!(err(&format!("{def}[deform]\nlambda = 0.0\n")).contains("lambda = 0 must be positive"));
        assert!(err(&format!("{def}[init]\nscaling_jump = 0.2\n")).contains("[init] does not apply to task deform"));
        let c = parse(&format!("{def}[deform]\nlambda = 50.0\n")).unwrap();
        let s = c.deform_settings();
        assert_eq!((s.lambda, s.solver.stop.energy_decrease_tol, s.solver.stop.grad_tol), (50.0, 1e-6, 1e-10));
        assert_eq!(parse(&def).unwrap().deform_settings().lambda, solvers::deform::DEFAULT_LAMBDA);
        let inline = "[[dataset]]\nname = \"x\"\npath = \"x.obj\"\nhandles = \"x.json\"\nhandles_rule = \"twist\"\n";
        assert!(err(&format!("{def}{inline}")).contains("not both"));
        assert!(err(&format!("{MIN}[authalic]\nalpha0 = 1.0\n")).contains("only to task = \"authalic\""));
        assert!(err(&format!("{MIN}[stop]\ngrad_tol = \"x\"\n")).contains("invalid type"));
    }
}
