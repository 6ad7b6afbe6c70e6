//! The run configuration (design.md "Config"): TOML, unknown keys are an error, every key has
//! a documented default (see README.md).

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use solvers::energy::{EnergyKind, ENERGY_NAMES};
use solvers::init::TutteBoundary;
use solvers::linear::LinearSettings;
use solvers::param::{default_stop, ParamSettings};
use solvers::solver::{solver_names, LineSearchSettings, Settings, StopSettings};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Task {
    Param,
    Deform,
    Authalic,
}

impl Task {
    pub fn as_str(&self) -> &'static str {
        match self {
            Task::Param => "param",
            Task::Deform => "deform",
            Task::Authalic => "authalic",
        }
    }
}

/// A dataset given inline in the config (`[[dataset]]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InlineDataset {
    pub name: String,
    /// OBJ file; relative paths resolve against the config file's folder.
    pub path: PathBuf,
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
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitConfig {
    /// `uniform` (default) or `arclength`.
    pub tutte_boundary: Option<TutteBoundary>,
    /// Jump threshold of the global-scaling heuristic, default 0.1.
    pub scaling_jump: Option<f64>,
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
}

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
        let config: Config = toml::from_str(&text).with_context(|| format!("{}: invalid config", path.display()))?;
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
        if self.task != Task::Param {
            bail!(
                "task '{}' is not available yet in this version of mapbench (only 'param' runs today)",
                self.task.as_str()
            );
        }
        if self.energies.is_empty() {
            bail!("'energies' is empty: name at least one of {}", ENERGY_NAMES.join(", "));
        }
        if self.solvers.is_empty() {
            bail!("'solvers' is empty: name at least one of {}", solver_names().join(", "));
        }
        if self.datasets.is_empty() && self.dataset.is_empty() {
            bail!("no datasets: give 'datasets = [...]' (names or tag:<tag>) or [[dataset]] entries");
        }
        for s in &self.solvers {
            if !solver_names().contains(&s.as_str()) {
                bail!("unknown solver '{s}' (known: {})", solver_names().join(", "));
            }
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
        let mut seen = std::collections::HashSet::new();
        for d in &self.dataset {
            if !seen.insert(d.name.as_str()) {
                bail!("[[dataset]] name '{}' appears twice", d.name);
            }
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
        Ok(kind)
    }

    /// The solver settings for one energy: design.md conventions overridden by the config.
    pub fn param_settings(&self, energy: &EnergyKind) -> ParamSettings {
        let d = default_stop(energy);
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
        };
        ParamSettings {
            solver: Settings { stop, line_search, linear },
            tutte_boundary: self.init.tutte_boundary.unwrap_or_default(),
            scaling_jump: self.init.scaling_jump.unwrap_or(0.1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert_eq!(s.solver.linear, LinearSettings { tikhonov: 1e-10, jacobi: true });
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
        assert!(err(&format!("task = \"deform\"\n{MIN}")).contains("not available yet"));
        assert!(err(&format!("{MIN}[stop]\ngrad_tol = \"x\"\n")).contains("invalid type"));
    }
}
