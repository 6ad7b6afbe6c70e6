//! Chained starts: a `param` problem with `start = "sd-minimum"` (exp-SD's default) starts
//! from the SD minimum of its SD problem ([`sd_problem`]). The maps a batch has resolved
//! (`judge::reference::chained` looks them up or computes them) are kept with the plan
//! ([`super::resolved_starts`]), so that the references, every run and every external solver
//! of the batch start from the same map.

use super::resolved_starts::{Resolved, Starts};
use super::settings::RunSettings;
use super::{Plan, PlannedRun};
use solvers::energy::{EnergyKind, Sd};
use solvers::tasks::param::{default_stop, ParamStart};

impl Starts {
    /// The resolved start of `run` of `plan`: `None` without a chained start, an error when
    /// it has not been resolved (or could not be).
    pub fn of(&self, plan: &Plan, run: &PlannedRun) -> Option<Resolved> {
        let key = memo_key(plan, &sd_problem(plan, run)?);
        Some(self.lock().get(&key).cloned().unwrap_or_else(|| Err("not resolved before the run".into())))
    }
}

/// The memo's key of the SD problem `sd`: its dataset and what determines its minimum.
pub fn memo_key(plan: &Plan, sd: &PlannedRun) -> String {
    format!("{}\n{}", plan.dataset(sd).name, sd.settings.problem_key_text())
}

/// The SD problem whose minimum `run` starts from: the same dataset and start settings with
/// the SD energy and the Tutte start. `None` for a run with another start.
pub fn sd_problem(plan: &Plan, run: &PlannedRun) -> Option<PlannedRun> {
    let RunSettings::Param { settings, .. } = &run.settings else { return None };
    if settings.start != ParamStart::SdMinimum {
        return None;
    }
    let energy = EnergyKind::Sd(Sd);
    let mut settings = settings.clone();
    settings.start = ParamStart::Tutte;
    settings.solver.stop = default_stop(&energy);
    settings.solver.options = Default::default();
    Some(PlannedRun {
        energy: "sd".into(),
        solver: "kp-newton".into(),
        stem: crate::names::run_stem(&plan.dataset(run).name, "sd", "kp-newton"),
        settings: RunSettings::Param { energy, settings },
        skip: None,
        dataset: run.dataset,
    })
}
