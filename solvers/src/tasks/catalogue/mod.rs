//! The solver catalogue: every solver of every task, with the tasks it runs, the energies it
//! is defined for, the extra CSV columns it writes, its labels, its options and how it is
//! built. Config checks, `list solvers`, dispatch and table labels all read it. Adding a
//! solver is its file, its `mod` line and one entry here (the book's "Adding your own
//! solver" page lists the rest).

use crate::energy::{EnergyKind, ENERGY_NAMES};
use crate::hessian::pn::Filtered;
use crate::hessian::trust_region::{Filter, Space, TrustRegion, TRUST_REGION_COLUMNS};
use crate::hessian::{
    akvf::Akvf, cm::Cm, fp::Fp4, fp::Fp6, fp::Fp6Abs, kp::Kp, none::Unprojected, slim::Slim, SystemBlock,
};
use crate::smoothness::Projection;
use crate::solver::aqp::{Aqp, AQP_COLUMNS};
use crate::solver::lbfgs::{Variant, LBFGS_COLUMNS};
use crate::solver::newton::{SolverSpec, SystemSolve};
use crate::solver::options::{check, read, NoOptions, Options, RawOptions};
use crate::solver::planar::PlanarSolver;
use crate::solver::truncated::{NewtonCgOptions, Preconditioner, CG_COLUMNS};
use crate::solver::Observer;
use crate::tasks::authalic::iterate::AUTHALIC_COLUMNS;
use crate::tasks::authalic::problem::{AuthalicOutcome, AuthalicProblem, AuthalicSettings, AUTHALIC_ENERGY};
use crate::tasks::authalic::{aem, sem};
use crate::tasks::solver_error::SolverError;
use crate::tasks::Task;

/// Where a solver's runs start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// The task's common start, the same map for every solver, so that a ranking compares
    /// methods and not starts: `param` the Tutte map globally scaled (Section 4.2) for the
    /// energies that define the scaling, `deform` the rest pose (or the dataset's own start).
    Common,
    /// `param`'s Tutte map without the global scaling (`kp-newton-noscale`, the variant that
    /// isolates what the scaling does).
    TutteUnscaled,
}

/// How an entry builds a `param`/`deform` solver for an energy with its options (checked
/// already), or why the combination is not defined.
pub type BuildPlanar = fn(&EnergyKind, &RawOptions) -> Result<Box<dyn PlanarSolver>, String>;

/// How an authalic entry solves.
pub type SolveAuthalic = fn(&AuthalicProblem, Vec<f64>, &AuthalicSettings, &mut dyn Observer) -> AuthalicOutcome;

/// How an entry runs: the task family decides what a solver is given.
#[derive(Clone, Copy)]
pub enum Build {
    /// A `param`/`deform` solver, built for an energy and its options.
    Planar(BuildPlanar),
    /// An authalic solver, run directly on the problem.
    Authalic(SolveAuthalic),
}

/// `[solver.pn-trust-region]` and `[solver.fp-trust-region-6x6]`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrustRegionOptions {
    /// Clamp when the last step's model fit has `|rho - 1| < tau`, else abs (the authors'
    /// `--tr`, default 0.01).
    pub tau: f64,
}

impl Default for TrustRegionOptions {
    fn default() -> Self {
        TrustRegionOptions { tau: crate::hessian::trust_region::DEFAULT_TAU }
    }
}

impl Options for TrustRegionOptions {
    fn check(&self) -> Result<(), String> {
        if !(self.tau.is_finite() && self.tau > 0.0) {
            return Err(format!("tau = {}: it must be a positive number (default 0.01)", self.tau));
        }
        Ok(())
    }
}

/// `[solver.slim]`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SlimOptions {
    /// Run on every energy, also those whose SLIM weights are not defined everywhere
    /// (`w_k^2 <= 0`); such weights are clamped to `MIN_WEIGHT_SQ` and counted per
    /// iteration (the `clamped` column).
    pub clamp_weights: bool,
}

impl Options for SlimOptions {}

/// One solver of the catalogue.
pub struct SolverEntry {
    /// The name in configs, file names and CSVs.
    pub name: &'static str,
    /// The tasks it runs.
    pub tasks: &'static [Task],
    /// Names of the energies it is defined for (`ENERGY_NAMES`, or the authalic energy).
    /// Some combinations are refused for some parameters, with the reason, when built.
    /// Outside them a run is skipped, unless [`SolverEntry::opt_in`] says the options ask
    /// for it anyway.
    pub energies: &'static [&'static str],
    /// Why the energies outside `energies` are outside its definition (empty when it has
    /// none outside).
    pub outside_reason: &'static str,
    /// Whether its options ask to run it outside `energies` anyway.
    pub opt_in: fn(&RawOptions) -> bool,
    /// Reads its `[solver.<name>]` table as its typed options: why it does not.
    pub options: fn(&RawOptions) -> Result<(), String>,
    /// The solver-specific columns after the common ones in its iteration CSVs, in order
    /// (`IterationRecord::extra`).
    pub extra_columns: &'static [&'static str],
    /// Short name for tables and plots.
    pub label: &'static str,
    /// One line for `list solvers`.
    pub description: &'static str,
    /// How it is built or run.
    pub build: Build,
    /// Where its runs start: the task's common start, unless its method defines its own.
    pub start: Start,
}

const PLANAR_TASKS: &[Task] = &[Task::Param, Task::Deform];
const AUTHALIC_TASKS: &[Task] = &[Task::Authalic];

/// A `param`/`deform` solver for every energy, without options.
const fn planar(
    name: &'static str,
    label: &'static str,
    description: &'static str,
    extra_columns: &'static [&'static str],
    build: BuildPlanar,
) -> SolverEntry {
    SolverEntry {
        name,
        tasks: PLANAR_TASKS,
        energies: ENERGY_NAMES,
        outside_reason: "",
        opt_in: never,
        options: check::<NoOptions>,
        extra_columns,
        label,
        description,
        build: Build::Planar(build),
        start: Start::Common,
    }
}

/// A Newton-type strategy of the shared driver (its columns: the strategy's counters).
const fn newton(name: &'static str, label: &'static str, description: &'static str, build: BuildPlanar) -> SolverEntry {
    planar(name, label, description, &[], build)
}

/// No option runs the solver outside its energies.
fn never(_: &RawOptions) -> bool {
    false
}

/// The energies whose SLIM weights `w_k^2 = (dpsi/dsigma_k) / (2 (sigma_k - 1))` are positive
/// at every orientation-preserving map: those that are sums of per-singular-value terms each
/// falling towards its minimum at `sigma_k = 1`, so the per-triangle minimum is a rotation
/// and the local step's target `R` is right. On the others (NH, BARAP, BCONF) the barrier or
/// volume term couples the singular values, `dpsi/dsigma_k` often has the other sign, and the
/// weight is clamped: at the Tutte map of `bumpy_1k` none is for SD, exp-SD and SARAP, and
/// some are for each of the others (test `slim_weights_are_clamped_outside_its_energies_only`).
pub const SLIM_ENERGIES: [&str; 3] = ["sd", "exp-sd", "sarap"];

/// The energies AQP is defined for: those whose quadratic part is the Dirichlet energy
/// `c |J|^2` the proxy is the Hessian of (`EnergyKind::dirichlet_part`), the rest being the barrier
/// or rotation terms the proxy leaves out. The authors define the proxy for their isometric
/// distortion `|J|^2 + |J^-1|^2` (our `sd` is half of it) and for ARAP `|J - R|^2`; our
/// `barap` is ARAP plus the barrier `k (|J| + 1/|J|)`.
pub const AQP_ENERGIES: [&str; 2] = ["sd", "barap"];

const fn authalic(
    name: &'static str,
    label: &'static str,
    description: &'static str,
    solve: SolveAuthalic,
) -> SolverEntry {
    SolverEntry {
        name,
        tasks: AUTHALIC_TASKS,
        energies: &[AUTHALIC_ENERGY],
        outside_reason: "",
        opt_in: never,
        options: check::<NoOptions>,
        extra_columns: &AUTHALIC_COLUMNS,
        label,
        description,
        build: Build::Authalic(solve),
        start: Start::Common,
    }
}

/// The shared Newton driver with `block`, factorizing every system.
fn spec(block: impl SystemBlock + 'static) -> Result<Box<dyn PlanarSolver>, String> {
    Ok(Box::new(SolverSpec::factorized(block)))
}

/// `kp-newton`'s strategy with truncated steps preconditioned as `preconditioner` says.
fn truncated(preconditioner: Preconditioner, options: NewtonCgOptions) -> Result<Box<dyn PlanarSolver>, String> {
    Ok(Box::new(SolverSpec { solve: SystemSolve::Truncated(preconditioner, options), ..SolverSpec::factorized(Kp) }))
}

/// Every solver, `param`/`deform` first (the order of `list solvers` and of the known-names
/// lists in messages).
pub static SOLVERS: &[SolverEntry] = &[
    newton(
        "kp-newton",
        "KP",
        "Newton, K of each element Hessian projected analytically (complex view, Eq. 4)",
        |_, _| spec(Kp),
    ),
    SolverEntry {
        options: check::<NewtonCgOptions>,
        ..planar(
            "kp-newton-cg",
            "KP-CG",
            "kp-newton with truncated steps: CG to an Eisenstat-Walker forcing term, preconditioned by the \
             Laplacian weighted by each block's stiffness",
            &CG_COLUMNS,
            |_, o| truncated(Preconditioner::Stiffness, read(o)?),
        )
    },
    planar(
        "kp-newton-cg-laplacian",
        "KP-CG-Lap",
        "kp-newton-cg preconditioned by the constant Dirichlet Laplacian, factored once",
        &CG_COLUMNS,
        |_, _| truncated(Preconditioner::Laplacian, NewtonCgOptions::default()),
    ),
    SolverEntry {
        start: Start::TutteUnscaled,
        ..newton(
            "kp-newton-noscale",
            "KP-noscale",
            "kp-newton from the Tutte map without the global scaling",
            |_, _| spec(Kp),
        )
    },
    // Table 7's numeric column; the same as kp-newton without a smoothness term.
    newton("kp-newton-eig8", "KP-eig8", "kp-newton with the smoothness term's 8x8 blocks eigen-projected", |_, _| {
        Ok(Box::new(SolverSpec { smoothness_projection: Some(Projection::Numeric), ..SolverSpec::factorized(Kp) }))
    }),
    newton(
        "fp-newton-4x4",
        "FP4",
        "Newton, element Hessians projected numerically via the reduced 4x4 matrix",
        |_, _| spec(Fp4),
    ),
    newton("fp-newton-6x6", "FP6", "Newton, 6x6 element Hessians eigen-projected numerically", |_, _| spec(Fp6)),
    newton("cm", "CM", "composite majorization (Shtengel et al. 2017), a convex-concave split", |e, _| {
        spec(Cm::for_energy(e)?)
    }),
    newton("newton", "Newton", "Newton on the unmodified Hessians (may stop on an indefinite system)", |_, _| {
        spec(Unprojected)
    }),
    SolverEntry {
        energies: &SLIM_ENERGIES,
        outside_reason: "its reweighting assumes the per-triangle minimum is a rotation, and many of its \
                         weights would be clamped (set [solver.slim] clamp_weights = true to run it with \
                         clamped weights)",
        opt_in: |o| read::<SlimOptions>(o).is_ok_and(|o| o.clamp_weights),
        options: check::<SlimOptions>,
        ..planar(
            "slim",
            "SLIM",
            "SLIM (Rabinovich et al. 2017): the local-global proxy as system matrix",
            &crate::hessian::slim::CLAMPED_COLUMN,
            |_, _| spec(Slim),
        )
    },
    newton("akvf", "AKVF", "AKVF (Claici et al. 2017): Killing-energy preconditioned gradient", |_, _| spec(Akvf)),
    newton(
        "pn-abs",
        "PN-abs",
        "projected Newton with K's eigenvalues made absolute (Chen et al. 2024), otherwise kp-newton",
        |_, _| spec(Filtered(Filter::Abs)),
    ),
    newton(
        "fp-abs-6x6",
        "FP6-abs",
        "6x6 element Hessians with their eigenvalues made absolute numerically (Chen et al. 2024)",
        |_, _| spec(Fp6Abs),
    ),
    SolverEntry {
        options: check::<TrustRegionOptions>,
        ..planar(
            "pn-trust-region",
            "PN-TR",
            "trust-region eigenvalue filtering (Chen et al. 2024): abs or clamp per iteration from the model fit",
            &TRUST_REGION_COLUMNS,
            |_, o| spec(TrustRegion { tau: read::<TrustRegionOptions>(o)?.tau, space: Space::K }),
        )
    },
    SolverEntry {
        options: check::<TrustRegionOptions>,
        ..planar(
            "fp-trust-region-6x6",
            "FP6-TR",
            "trust-region eigenvalue filtering as the authors' code: abs or clamp of the 6x6 element Hessians \
             per iteration from the model fit",
            &TRUST_REGION_COLUMNS,
            |_, o| spec(TrustRegion { tau: read::<TrustRegionOptions>(o)?.tau, space: Space::Element }),
        )
    },
    planar("lbfgs", "L-BFGS", "L-BFGS (Liu and Nocedal 1989), 10 pairs, H0 = s^T y / y^T y", &LBFGS_COLUMNS, |_, _| {
        Ok(Box::new(Variant::new(false)))
    }),
    planar(
        "lbfgs-laplacian",
        "L-BFGS-Lap",
        "L-BFGS, 5 pairs, H0 = the constant Laplacian proxy factored once (as in BCQN's code)",
        &LBFGS_COLUMNS,
        |_, _| Ok(Box::new(Variant::new(true))),
    ),
    SolverEntry {
        energies: &AQP_ENERGIES,
        outside_reason: "its constant proxy is the Hessian of the Dirichlet energy |J|^2, the quadratic part \
                         of the energies the authors define it for (the isometric distortion, our sd, and \
                         ARAP, our barap without its barrier); exp-sd (exponential), sarap (quadratic in \
                         sigma1 only), nh (no |J|^2 term) and bconf (conformal, |f_zbar|^2) have no such part",
        ..planar(
            "aqp",
            "AQP",
            "Accelerated Quadratic Proxy (Kovalsky et al. 2016): the Dirichlet proxy factored once, kappa = 1000",
            &AQP_COLUMNS,
            |_, _| Ok(Box::new(Aqp)),
        )
    },
    authalic("sem", "SEM", "stretch energy minimization (Yueh et al. 2019), the fixed point", sem::sem),
    authalic("aem-cg", "AEM-CG", "authalic energy minimization by preconditioned nonlinear CG", |p, z, s, o| {
        aem::aem_cg(p, z, s, false, o)
    }),
    authalic(
        "aem-cg-safe",
        "AEM-CG-safe",
        "aem-cg with restarts, Armijo backtracking and a fold guard",
        |p, z, s, o| aem::aem_cg(p, z, s, true, o),
    ),
];

/// The entry named `name`.
pub fn find(name: &str) -> Option<&'static SolverEntry> {
    SOLVERS.iter().find(|s| s.name == name)
}

/// The entry named `name`, if it runs `task`.
pub fn lookup(name: &str, task: Task) -> Result<&'static SolverEntry, SolverError> {
    let entry =
        find(name).ok_or_else(|| SolverError::Unknown { name: name.to_string(), task, known: names_for(task) })?;
    if entry.runs(task) {
        Ok(entry)
    } else {
        Err(entry.wrong_task(task))
    }
}

/// Names of the solvers of `task`, in catalogue order.
pub fn names_for(task: Task) -> Vec<&'static str> {
    SOLVERS.iter().filter(|s| s.runs(task)).map(|s| s.name).collect()
}

/// The `param`/`deform` solver `name` of `task` built for `energy` with its `options`.
pub fn planar_solver(
    name: &str,
    task: Task,
    energy: &EnergyKind,
    options: &RawOptions,
) -> Result<Box<dyn PlanarSolver>, SolverError> {
    lookup(name, task)?.planar(task, energy, options)
}

impl SolverEntry {
    /// Whether it runs `task`.
    pub fn runs(&self, task: Task) -> bool {
        self.tasks.contains(&task)
    }

    /// Whether the energy called `energy` is one it is defined for.
    pub fn is_defined_for(&self, energy: &str) -> bool {
        self.energies.contains(&energy)
    }

    /// Whether it runs the energy called `energy` with `options`: an energy it is defined
    /// for, or any energy when the options opt in.
    pub fn runs_energy(&self, energy: &str, options: &RawOptions) -> bool {
        self.is_defined_for(energy) || (self.opt_in)(options)
    }

    /// The error for a run of `task` with this solver.
    pub fn wrong_task(&self, task: Task) -> SolverError {
        SolverError::WrongTask { name: self.name, runs: self.tasks, task, known: names_for(task) }
    }

    /// Its `[solver.<name>]` table read as its options: the error naming the section.
    pub fn check_options(&self, options: &RawOptions) -> Result<(), SolverError> {
        (self.options)(options).map_err(|message| SolverError::Options { name: self.name, message })
    }

    /// Its `param`/`deform` solver for `energy` with `options`, for a run of `task`; outside
    /// its energies (unless the options opt in), or for parameters its builder refuses, the
    /// reason as [`SolverError::Unsupported`].
    pub fn planar(
        &self,
        task: Task,
        energy: &EnergyKind,
        options: &RawOptions,
    ) -> Result<Box<dyn PlanarSolver>, SolverError> {
        match self.build {
            Build::Planar(_) if !self.runs(task) => Err(self.wrong_task(task)),
            Build::Authalic(_) => Err(self.wrong_task(task)),
            Build::Planar(build) => {
                self.check_options(options)?;
                if !self.runs_energy(energy.name(), options) {
                    return Err(SolverError::Unsupported(format!(
                        "{} is not defined for {}: {}",
                        self.name,
                        energy.name(),
                        self.outside_reason
                    )));
                }
                build(energy, options).map_err(SolverError::Unsupported)
            }
        }
    }

    /// Its Newton system for `energy` with `options` (`export-system`): [`SolverEntry::planar`]'s
    /// errors, and [`SolverError::NoSystem`] for a solver without one.
    pub fn newton_spec(
        &self,
        task: Task,
        energy: &EnergyKind,
        options: &RawOptions,
    ) -> Result<SolverSpec, SolverError> {
        self.planar(task, energy, options)?
            .into_newton()
            .ok_or(SolverError::NoSystem { name: self.name, description: self.description })
    }

    /// Why a run of `task` with `energy` and `options` is outside this solver's definition
    /// (the harness records such a run as skipped), `None` when it runs: an energy outside
    /// its energies without an opt-in, or parameters its builder refuses (CM for BCONF with
    /// k > 1).
    pub fn skip_reason(&self, task: Task, energy: &EnergyKind, options: &RawOptions) -> Option<String> {
        match self.planar(task, energy, options) {
            Err(SolverError::Unsupported(why)) => Some(why),
            Ok(_) | Err(_) => None,
        }
    }
}

#[cfg(test)]
mod tests;
