//! The problem a run of a `param` or `deform` batch is judged on, built once from the plan:
//! its mesh (and handles), the energy with the smoothness term and the handles' penalty, the
//! common start, and the energy's isometry value. The reference minima are computed, polished
//! and verified on it, and a run's final map is polished on it to confirm another minimum.

use crate::plan::{Plan, PlannedRun, RunSettings, Task};
use anyhow::{bail, Context, Result};
use solvers::energy::EnergyKind;
use solvers::mesh::Mesh;
use solvers::problem::{norm, Evaluation, MapProblem};
use solvers::solver::{Observer, Outcome, StartMap, StopSettings};

/// A judged problem: what determines a group's reference minimum and its yardstick.
pub struct Problem {
    /// The dataset's mesh as loaded (the maps' checksum names it).
    pub mesh: Mesh,
    energy: EnergyKind,
    settings: RunSettings,
    handles: Vec<solvers::deform::Handle>,
    /// The energy with the smoothness term (and the handles' penalty), normalized frame.
    pub problem: MapProblem,
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
        let (energy, handles, built) = match &run.settings {
            RunSettings::Param { energy, settings } => {
                (*energy, Vec::new(), solvers::param::judged_problem(&mesh, *energy, settings)?)
            }
            RunSettings::Deform { energy, settings } => {
                let handles = ds.handles.load(&mesh)?;
                let init = ds.initial_map();
                let built = solvers::deform::deform_start(&mesh, &handles, init.as_deref(), *energy, settings)?;
                (*energy, handles, built)
            }
            RunSettings::Authalic(_) => bail!("the authalic task has no reference minima"),
        };
        let (problem, x0, start) = built;
        let e0 = problem.energy(&x0);
        if !e0.is_finite() {
            bail!("{}: the common start's energy is {e0}", mesh.source);
        }
        Ok(Problem {
            mesh,
            energy,
            settings: run.settings.clone(),
            handles,
            problem,
            x0,
            start,
            e0,
            ideal: ideal(energy),
        })
    }

    pub fn task(&self) -> Task {
        self.settings.task()
    }

    /// Energy, gradient norm and flips of the map `x` (normalized frame).
    pub fn measure(&self, x: &[f64]) -> Measured {
        let energy = self.problem.energy(x);
        let grad_norm = energy
            .is_finite()
            .then(|| {
                let mut ev = Evaluation::default();
                self.problem.evaluate_without_inertia(x, &mut ev).ok().map(|()| norm(&ev.grad))
            })
            .flatten();
        Measured { energy, grad_norm, flips: self.problem.flips(x) }
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
                solvers::param::solve_param_from(&self.mesh, *energy, solver, &settings, x, observer)
                    .with_context(|| format!("{name}: {solver}"))?
            }
            RunSettings::Deform { energy, settings } => {
                let mut settings = settings.clone();
                settings.solver.stop = stop;
                settings.solver.options = Default::default();
                settings.solver.analyses = None;
                solvers::deform::solve_deform_from(&self.mesh, &self.handles, *energy, solver, &settings, x, observer)
                    .with_context(|| format!("{name}: {solver}"))?
            }
            RunSettings::Authalic(_) => bail!("the authalic task has no reference minima"),
        })
    }

    /// The energy's kind.
    pub fn energy(&self) -> EnergyKind {
        self.energy
    }

    /// Whether the catalogue's `solver` is defined for this problem's task and energy.
    pub fn defines(&self, solver: &str) -> bool {
        let task = self.task();
        solvers::solver::catalogue::lookup(solver, task)
            .is_ok_and(|e| e.skip_reason(task, &self.energy(), &solvers::solver::RawOptions::new()).is_none())
    }
}

/// The isometry value of `energy`, its lower bound on any mesh (the smoothness term and the
/// handles' penalty are never negative).
pub fn ideal(energy: EnergyKind) -> f64 {
    energy.isometry_value()
}
