//! The one place where config sections become solver settings: the task's defaults (the
//! solvers' own `Default`s), the config's overrides, the energy's parameters.

use super::{Config, ProblemKeys, Task};
use crate::convergence::Targets;
use crate::plan::settings::RunSettings;
use anyhow::{bail, Context, Result};
use serde::Deserialize;
use solvers::energy::{EnergyKind, ENERGY_NAMES};
use solvers::smoothness::Projection;
use solvers::solver::Settings;
use solvers::tasks::authalic::AuthalicSettings;
use solvers::tasks::authalic::AUTHALIC_ENERGY;
use solvers::tasks::deform::DeformSettings;
use solvers::tasks::param::{ParamSettings, ParamStart};

/// The key of `[energy.<name>]` that sets the energy's own targets.
pub const TARGETS_KEY: &str = "targets";

impl Config {
    /// The energies of the runs: the configured ones, or the authalic task's one energy.
    pub fn energy_names(&self) -> Vec<String> {
        if self.task == Task::Authalic {
            vec![AUTHALIC_ENERGY.to_string()]
        } else {
            self.energies.clone()
        }
    }

    /// The `authalic` settings: `[authalic]` (the paper's Table 1 protocol for the keys not
    /// given: 100 iterations, no tolerance stop) with `[stop]` laid over its stop rule.
    pub(super) fn authalic_settings(&self) -> AuthalicSettings {
        let mut s = self.authalic.unwrap_or_default();
        s.stop = self.stop.over(s.stop);
        s
    }

    /// The energy `name` with the config's parameters applied over the defaults.
    pub fn energy_kind(&self, name: &str) -> Result<EnergyKind> {
        EnergyKind::default_for(name)
            .with_context(|| format!("unknown energy '{name}' (known: {})", ENERGY_NAMES.join(", ")))?;
        let (parameters, smoothness) = self.energy_table(name)?;
        let kind = EnergyKind::from_table(name, &parameters).map_err(|e| anyhow::anyhow!("[energy.{name}] {e}"))?;
        match smoothness.start {
            Some(_) if self.task != Task::Param => bail!("[energy.{name}] start applies to the param task only"),
            Some(ParamStart::SdMinimum) if matches!(kind, EnergyKind::Sd(_)) => {
                bail!("[energy.{name}] start = \"sd-minimum\" would start SD at its own minimum")
            }
            _ => {}
        }
        match (smoothness.smoothness, smoothness.smoothness_projection) {
            (Some(w), _) if !(w >= 0.0 && w.is_finite()) => {
                bail!("[energy.{name}] smoothness = {w} must be non-negative and finite")
            }
            (None, Some(_)) => bail!("[energy.{name}] smoothness_projection needs smoothness = <weight>"),
            _ => {}
        }
        Ok(kind)
    }

    /// `[energy.<name>]` split into the energy's parameters and the keys every energy has
    /// (`targets` is read by [`Config::targets`]).
    fn energy_table(&self, name: &str) -> Result<(toml::Table, ProblemKeys)> {
        let mut parameters = self.energy.get(name).cloned().unwrap_or_default();
        parameters.remove(TARGETS_KEY);
        let smoothness: toml::Table = ProblemKeys::KEYS.iter().filter_map(|k| parameters.remove_entry(*k)).collect();
        let keys = ProblemKeys::deserialize(toml::Value::Table(smoothness))
            .map_err(|e| anyhow::anyhow!("[energy.{name}] {}", e.to_string().trim()))?;
        Ok((parameters, keys))
    }

    /// The tolerances of the convergence test: `targets` (default `[1e-3, 1e-6]`) for every
    /// energy, `[energy.<name>] targets` for one that sets its own, each checked.
    pub fn targets(&self) -> Result<Targets> {
        let default = self.targets.clone().unwrap_or(super::DEFAULT_TARGETS.to_vec());
        super::check_targets(&default)?;
        let mut by_energy = std::collections::BTreeMap::new();
        for (name, table) in &self.energy {
            let Some(value) = table.get(TARGETS_KEY) else { continue };
            let given: Vec<f64> = value
                .clone()
                .try_into()
                .map_err(|e: toml::de::Error| anyhow::anyhow!("[energy.{name}] targets: {}", e.to_string().trim()))?;
            super::check_targets(&given).with_context(|| format!("[energy.{name}]"))?;
            by_energy.insert(name.clone(), given);
        }
        Ok(Targets::new(default, by_energy))
    }

    /// The resolved settings of the runs of energy `name` (the one place where config sections
    /// become solver settings): the task's defaults, the config's overrides, the energy's
    /// parameters and its smoothness term.
    pub fn run_settings(&self, name: &str) -> Result<RunSettings> {
        Ok(match self.task {
            Task::Authalic => RunSettings::Authalic(self.authalic_settings()),
            Task::Param => {
                let energy = self.energy_kind(name)?;
                let mut settings = self.param_settings(&energy);
                settings.smoothness = self.smoothness_for(name);
                settings.start = self.start_for(name, &energy);
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
    pub(super) fn smoothness_for(&self, name: &str) -> Option<(f64, Projection)> {
        let (_, p) = self.energy_table(name).ok()?;
        p.smoothness.filter(|w| *w > 0.0).map(|w| (w, p.smoothness_projection.unwrap_or_default()))
    }

    /// The start of the `param` runs of energy `name`: `[energy.<name>] start`, else the SD
    /// minimum for exp-SD (its density overflows at the Tutte map of most real meshes) and the
    /// Tutte map for the others (the book's numerics page, "Starts").
    fn start_for(&self, name: &str, energy: &EnergyKind) -> ParamStart {
        let given = self.energy_table(name).ok().and_then(|(_, keys)| keys.start);
        given.unwrap_or(match energy {
            EnergyKind::ExpSd(_) => ParamStart::SdMinimum,
            _ => ParamStart::Tutte,
        })
    }

    /// The `deform` settings (the same for every energy): `DeformSettings`'s defaults
    /// (|grad| <= 1e-6, no global scaling) overridden by `[stop]`, `[line_search]`, `[linear]`,
    /// `[deform]`.
    pub(super) fn deform_settings(&self) -> DeformSettings {
        let mut s = DeformSettings::default();
        self.solver_overrides(&mut s.solver);
        s.lambda = self.deform.as_ref().and_then(|d| d.lambda).unwrap_or(s.lambda);
        s
    }

    /// The `param` settings of one energy: `ParamSettings::for_energy` overridden by the config.
    pub(super) fn param_settings(&self, energy: &EnergyKind) -> ParamSettings {
        let mut s = ParamSettings::for_energy(energy);
        self.solver_overrides(&mut s.solver);
        s.tutte_boundary = self.init.tutte_boundary.unwrap_or(s.tutte_boundary);
        s.scaling_jump = self.init.scaling_jump.unwrap_or(s.scaling_jump);
        s
    }

    /// `[stop]` over the default stop rule, the `[line_search]` and `[linear]` sections (the
    /// `[solver.<name>]` options are each run's: `RunSettings::for_solver`).
    fn solver_overrides(&self, s: &mut Settings) {
        s.stop = self.stop.over(s.stop);
        s.line_search = self.line_search.unwrap_or(s.line_search);
        s.linear = self.linear.unwrap_or(s.linear);
    }
}
