//! The problem a run of a batch is judged on, built once from the plan: its mesh (and
//! handles), the energy with the smoothness term and the handles' penalty (`param`,
//! `deform`) or the normalized authalic energy on the disk scaled to area pi (`authalic`), the
//! common start, and the energy's isometry value. The reference minima are computed, polished
//! and verified on it, and a run's final map is polished on it to confirm another minimum.

use crate::plan::{Plan, PlannedRun, RunSettings, Task};
use anyhow::{anyhow, bail, Context, Result};
use solvers::energy::EnergyKind;
use solvers::mesh::Mesh;
use solvers::problem::{norm, Evaluation, MapProblem};
use solvers::solver::{Observer, Outcome, StartMap, StopSettings};
use solvers::tasks::authalic::{AuthalicProblem, AuthalicSettings};

/// What a judged problem minimizes.
pub enum Objective {
    /// `param`, `deform`: the energy with the smoothness term (and the handles' penalty),
    /// normalized frame.
    Map { energy: EnergyKind, problem: MapProblem },
    /// `authalic`: the normalized authalic energy of Eq. 4 (its value at an area-preserving
    /// map, 0, is its lower bound).
    Authalic { problem: Box<AuthalicProblem>, settings: AuthalicSettings },
}

impl Objective {
    /// The energy of the map `x`.
    pub fn energy_of(&self, x: &[f64]) -> f64 {
        match self {
            Objective::Map { problem, .. } => problem.energy(x),
            Objective::Authalic { problem, .. } => problem.terms(&problem.vars_of(x)).energy,
        }
    }
}

/// A judged problem: what determines a group's reference minimum and its yardstick.
pub struct Problem {
    /// The dataset's mesh as loaded (the maps' checksum names it).
    pub mesh: Mesh,
    settings: RunSettings,
    handles: Vec<solvers::mesh::Handle>,
    pub objective: Objective,
    /// The common start, interleaved `u0 v0 u1 v1 ...` in the normalized frame.
    pub x0: Vec<f64>,
    pub start: StartMap,
    /// The energy at the common start: `E0` of every run of the group.
    pub e0: f64,
    /// The energy's value at an isometry, its lower bound (`E_iso` of the accuracy scale).
    pub ideal: f64,
}

/// What a map measures on a problem.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measured {
    pub energy: f64,
    /// `None` where the energy is not finite.
    pub grad_norm: Option<f64>,
    pub flips: usize,
}

impl Problem {
    /// The problem of `run` of `plan` (a `param` or `deform` run).
    pub fn of(plan: &Plan, run: &PlannedRun) -> Result<Problem> {
        Problem::with_mesh(plan, run, plan.dataset(run).load()?)
    }

    /// [`Problem::of`] with the dataset's mesh already loaded.
    pub fn with_mesh(plan: &Plan, run: &PlannedRun, mesh: Mesh) -> Result<Problem> {
        let ds = plan.dataset(run);
        let (objective, handles, x0, start) = match &run.settings {
            RunSettings::Param { energy, settings } => {
                // resolved by `reference::chained::resolve` (`reference::prepare`) before the runs
                let sd_min = plan
                    .starts
                    .of(plan, run)
                    .transpose()
                    .map_err(|e| anyhow!("{}: the sd-minimum start: {e}", ds.name))?;
                let (problem, x0, start) =
                    solvers::tasks::param::judged_problem(&mesh, *energy, settings, sd_min.as_ref().map(|x| &x[..]))?;
                (Objective::Map { energy: *energy, problem }, Vec::new(), x0, start)
            }
            RunSettings::Deform { energy, settings } => {
                let handles = ds.handles.load(&mesh)?;
                let init = ds.initial_map();
                let (problem, x0, start) =
                    solvers::tasks::deform::deform_start(&mesh, &handles, init.as_deref(), *energy, settings)?;
                (Objective::Map { energy: *energy, problem }, handles, x0, start)
            }
            RunSettings::Authalic(settings) => {
                let (problem, x0) = solvers::tasks::authalic::authalic_start(&mesh, settings)?;
                let objective = Objective::Authalic { problem: Box::new(problem), settings: *settings };
                (objective, Vec::new(), x0, StartMap::ArclengthStretch)
            }
        };
        let e0 = objective.energy_of(&x0);
        if !e0.is_finite() {
            bail!("{}: the common start's energy is {e0}", mesh.source);
        }
        let ideal = match &objective {
            Objective::Map { energy, .. } => ideal(*energy),
            // E_A at an area-preserving map
            Objective::Authalic { .. } => 0.0,
        };
        Ok(Problem { mesh, settings: run.settings.clone(), handles, objective, x0, start, e0, ideal })
    }

    pub fn task(&self) -> Task {
        self.settings.task()
    }

    /// Energy, gradient norm and flips of the map `x` (normalized frame).
    pub fn measure(&self, x: &[f64]) -> Measured {
        match &self.objective {
            Objective::Map { problem, .. } => {
                let energy = problem.energy(x);
                let grad_norm = energy
                    .is_finite()
                    .then(|| {
                        let mut ev = Evaluation::default();
                        problem.evaluate_without_inertia(x, &mut ev).ok().map(|()| norm(&ev.grad))
                    })
                    .flatten();
                Measured { energy, grad_norm, flips: problem.flips(x) }
            }
            Objective::Authalic { problem, .. } => {
                let z = problem.vars_of(x);
                let (terms, grad) = problem.terms_and_gradient(&z);
                let grad_norm = terms.energy.is_finite().then(|| norm(&grad));
                // A map whose boundary leaves its loop's order is no map of the disk: at least
                // one face folds.
                let folded = if problem.boundary_ordered(&z) { terms.folded } else { terms.folded.max(1) };
                Measured { energy: terms.energy, grad_norm, flips: folded }
            }
        }
    }

    /// The energy of the map `x`.
    pub fn energy_of(&self, x: &[f64]) -> f64 {
        self.objective.energy_of(x)
    }

    /// Solve with the catalogue's `solver` (its default options) from the map `x` with the
    /// rule `stop`, the batch's line search and linear settings otherwise.
    pub fn solve_from(
        &self,
        solver: &str,
        x: Vec<f64>,
        stop: StopSettings,
        observer: &mut dyn Observer,
    ) -> Result<Outcome> {
        let name = &self.mesh.source;
        Ok(match &self.settings {
            RunSettings::Param { energy, settings } => {
                let mut settings = settings.clone();
                settings.solver.stop = stop;
                settings.solver.options = Default::default();
                settings.solver.analyses = None;
                solvers::tasks::param::solve_param_from(&self.mesh, *energy, solver, &settings, x, observer)
                    .with_context(|| format!("{name}: {solver}"))?
            }
            RunSettings::Deform { energy, settings } => {
                let mut settings = settings.clone();
                settings.solver.stop = stop;
                settings.solver.options = Default::default();
                settings.solver.analyses = None;
                solvers::tasks::deform::solve_deform_from(
                    &self.mesh,
                    &self.handles,
                    *energy,
                    solver,
                    &settings,
                    x,
                    observer,
                )
                .with_context(|| format!("{name}: {solver}"))?
            }
            RunSettings::Authalic(_) => {
                let Objective::Authalic { problem, settings } = &self.objective else { bail!("{name}: not authalic") };
                let settings = AuthalicSettings { stop, ..*settings };
                solvers::tasks::authalic::solve_authalic_from(problem, solver, &settings, &x, observer)
                    .with_context(|| format!("{name}: {solver}"))?
                    .outcome
            }
        })
    }

    /// Whether the energy is smooth (its reference is certified by a small gradient; SARAP's
    /// and the authalic energy's, whose minimum the boundary's order may hold, by a stall).
    pub fn smooth(&self) -> bool {
        match &self.objective {
            Objective::Map { energy, .. } => energy.smooth(),
            Objective::Authalic { .. } => false,
        }
    }

    /// Whether the catalogue's `solver` is defined for this problem's task and energy.
    pub fn defines(&self, solver: &str) -> bool {
        let task = self.task();
        let Ok(entry) = solvers::tasks::catalogue::lookup(solver, task) else { return false };
        match &self.objective {
            Objective::Map { energy, .. } => {
                entry.skip_reason(task, energy, &solvers::solver::RawOptions::new()).is_none()
            }
            Objective::Authalic { .. } => true,
        }
    }
}

/// The isometry value of `energy`, its lower bound on any mesh (the smoothness term and the
/// handles' penalty are never negative).
pub fn ideal(energy: EnergyKind) -> f64 {
    energy.isometry_value()
}
