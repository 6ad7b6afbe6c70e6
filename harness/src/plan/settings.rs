//! The fully resolved settings of a run: what the solver gets.

use serde::Serialize;
use solvers::energy::EnergyKind;
use solvers::solver::{RawOptions, StopSettings};
use solvers::tasks::authalic::AuthalicSettings;
use solvers::tasks::deform::DeformSettings;
use solvers::tasks::param::{ParamSettings, ParamStart};
use solvers::tasks::Task;
use std::collections::BTreeMap;

/// The fully resolved settings of one run: what the solver gets, defaults and overrides
/// applied, smoothness term included.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RunSettings {
    Param { energy: EnergyKind, settings: ParamSettings },
    Deform { energy: EnergyKind, settings: DeformSettings },
    Authalic(AuthalicSettings),
}

impl RunSettings {
    pub fn task(&self) -> Task {
        match self {
            RunSettings::Param { .. } => Task::Param,
            RunSettings::Deform { .. } => Task::Deform,
            RunSettings::Authalic(_) => Task::Authalic,
        }
    }

    /// The stop rules the run applies.
    pub fn stop(&self) -> StopSettings {
        match self {
            RunSettings::Param { settings, .. } => settings.solver.stop,
            RunSettings::Deform { settings, .. } => settings.solver.stop,
            RunSettings::Authalic(s) => s.stop,
        }
    }

    /// The settings of a run of `solver`, with that solver's own `[solver.<name>]` table of
    /// `options` (null without one): another solver's section does not change this run's
    /// `--resume` key.
    pub fn for_solver(&self, solver: &str, options: &BTreeMap<String, RawOptions>) -> RunSettings {
        let mut s = self.clone();
        let own = options.get(solver).cloned().unwrap_or_default();
        match &mut s {
            RunSettings::Param { settings, .. } => settings.solver.options = own,
            RunSettings::Deform { settings, .. } => settings.solver.options = own,
            RunSettings::Authalic(_) => {}
        }
        s
    }

    /// Why a run of `solver` with these settings is outside the solver's definition (the
    /// catalogue's `SolverEntry::skip_reason`): such a run is planned as skipped. `None`
    /// when it runs (and for a solver the catalogue does not have for the task, which the
    /// config check refuses).
    pub fn skip_reason(&self, solver: &str) -> Option<String> {
        let (energy, options) = match self {
            RunSettings::Param { energy, settings } => (energy, &settings.solver.options),
            RunSettings::Deform { energy, settings } => (energy, &settings.solver.options),
            RunSettings::Authalic(_) => return None,
        };
        let task = self.task();
        solvers::tasks::catalogue::lookup(solver, task).ok()?.skip_reason(task, energy, options)
    }

    /// Whether the run's problem has the smoothness term (Section 4.3).
    pub fn has_smoothness(&self) -> bool {
        match self {
            RunSettings::Param { settings, .. } => settings.smoothness.is_some(),
            RunSettings::Deform { settings, .. } => settings.smoothness.is_some(),
            RunSettings::Authalic(_) => false,
        }
    }

    /// The base Tikhonov shift of the run's Newton systems (`[linear] tikhonov`); `None` for
    /// the authalic task, which has none.
    pub fn base_shift(&self) -> Option<f64> {
        match self {
            RunSettings::Param { settings, .. } => Some(settings.solver.linear.tikhonov),
            RunSettings::Deform { settings, .. } => Some(settings.solver.linear.tikhonov),
            RunSettings::Authalic(_) => None,
        }
    }

    /// What determines the minimum a run's problem has from its start, as JSON for its
    /// reference key: the energy with its parameters, the start's settings (`param`; the
    /// chained start named only where it is one, so the Tutte start's keys stay; `authalic`:
    /// its stretch steps), the handles' penalty weight (`deform`) and the smoothness term's
    /// weight (not how a solver projects it).
    pub fn problem_key_text(&self) -> String {
        let weight = |s: &Option<(f64, solvers::smoothness::Projection)>| s.map(|(w, _)| w);
        let v = match self {
            RunSettings::Param { energy, settings } => {
                let mut v = serde_json::json!({
                    "task": "param", "energy": energy, "tutte_boundary": settings.tutte_boundary,
                    "scaling_jump": settings.scaling_jump, "smoothness": weight(&settings.smoothness),
                });
                if settings.start != ParamStart::Tutte {
                    v["start"] = serde_json::json!(settings.start);
                }
                v
            }
            RunSettings::Deform { energy, settings } => serde_json::json!({
                "task": "deform", "energy": energy, "lambda": settings.lambda,
                "smoothness": weight(&settings.smoothness),
            }),
            // The problem is the disk's; the start is its stretch steps.
            RunSettings::Authalic(settings) => serde_json::json!({
                "task": "authalic", "init_steps": settings.init_steps,
            }),
        };
        v.to_string()
    }

    /// Everything that determines the run's result, as JSON for its `--resume` key: every
    /// setting (floats round-trip exactly; the shared analyses are not a setting and are
    /// skipped), the energy with its parameters, the stop rule.
    pub fn key_text(&self) -> String {
        serde_json::to_string(self).unwrap_or_else(|e| format!("unserializable settings: {e}"))
    }
}
