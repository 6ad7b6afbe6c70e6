//! The solver catalogue: every solver of every task, with the tasks it runs, the energies it
//! is defined for, the extra CSV columns it writes, its labels and how it is built. Config
//! checks, `list solvers`, dispatch and table labels all read it. Adding a solver is one
//! strategy file plus one entry here.

use crate::energy::{EnergyKind, AUTHALIC_ENERGY, ENERGY_NAMES};
use crate::hessian::pn::{Filter, Filtered, Space, TrustRegion, TRUST_REGION_COLUMNS};
use crate::hessian::{
    akvf::Akvf, cm::Cm, fp::Fp4, fp::Fp6, fp::Fp6Abs, kp::Kp, none::Unprojected, slim::Slim, SystemBlock,
};
use crate::mesh::Task;
use crate::smoothness::Projection;
use crate::solver::aqp::AQP_COLUMNS;
use crate::solver::lbfgs::LBFGS_COLUMNS;
use crate::solver::newton::SystemSolve;
use crate::solver::truncated::{NewtonCgOptions, Preconditioner, CG_COLUMNS};

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

/// A Newton-type solver built for one energy: its system-matrix strategy and options.
pub struct SolverSpec {
    pub block: Box<dyn SystemBlock>,
    /// Overrides how the smoothness term's 8x8 blocks are projected.
    pub smoothness_projection: Option<Projection>,
    /// How each Newton system is solved.
    pub solve: SystemSolve,
}

/// How an entry solves.
#[derive(Clone, Copy)]
pub enum Method {
    /// A system-matrix strategy of the shared Newton driver (`param`, `deform`): builds it for
    /// an energy with the solver options, or says why the combination is not defined.
    Newton(Build),
    /// The SEM fixed point (`authalic`).
    Sem,
    /// AEM's preconditioned nonlinear CG, faithful or with the safeguards (`authalic`).
    AemCg { safe: bool },
    /// L-BFGS with the scaled identity or the Laplacian proxy as initial Hessian (`param`,
    /// `deform`; `solver::lbfgs`). It needs no Newton system.
    Lbfgs { laplacian: bool },
    /// The Accelerated Quadratic Proxy (`param`, `deform`; `solver::aqp`): the constant
    /// Dirichlet proxy factored once, momentum and a proxy step. It needs no Newton system.
    Aqp,
}

/// How a Newton-type entry builds its strategy.
pub type Build = fn(&EnergyKind, &SolverOptions) -> Result<SolverSpec, String>;

/// Options of individual solvers (`[solver.<name>]` in a config), one field per solver that
/// has any; the defaults are the solvers as published.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SolverOptions {
    pub slim: SlimOptions,
    #[serde(rename = "pn-trust-region")]
    pub trust_region: TrustRegionOptions,
    #[serde(rename = "fp-trust-region-6x6")]
    pub fp_trust_region: TrustRegionOptions,
    #[serde(rename = "kp-newton-cg")]
    pub newton_cg: NewtonCgOptions,
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
        TrustRegionOptions { tau: crate::hessian::pn::DEFAULT_TAU }
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

impl SolverOptions {
    /// The options that concern the solver `name` (the others at their defaults): what a run
    /// of that solver depends on.
    pub fn of(&self, name: &str) -> SolverOptions {
        let d = SolverOptions::default();
        SolverOptions {
            slim: if name == "slim" { self.slim } else { d.slim },
            trust_region: if name == "pn-trust-region" { self.trust_region } else { d.trust_region },
            fp_trust_region: if name == "fp-trust-region-6x6" { self.fp_trust_region } else { d.fp_trust_region },
            newton_cg: if name == "kp-newton-cg" { self.newton_cg } else { d.newton_cg },
        }
    }
}

/// One solver of the catalogue.
pub struct SolverEntry {
    /// The name in configs, file names and CSVs.
    pub name: &'static str,
    pub tasks: &'static [Task],
    /// Names of the energies it is defined for (`ENERGY_NAMES`, or the authalic energy).
    /// Some combinations are refused for some parameters, with the reason, when built.
    /// Outside them a run is skipped, unless [`SolverEntry::opt_in`] says the options ask
    /// for it anyway.
    pub energies: &'static [&'static str],
    /// Why the energies outside `energies` are outside its definition (empty when it has
    /// none outside).
    pub outside_reason: &'static str,
    /// Whether the options ask to run it outside `energies` anyway.
    pub opt_in: fn(&SolverOptions) -> bool,
    /// The keys of its `[solver.<name>]` table (the fields of its [`SolverOptions`] part).
    pub options: &'static [&'static str],
    /// The solver-specific columns after the design.md ones in its iteration CSVs, in order
    /// (`IterationRecord::extra`).
    pub extra_columns: &'static [&'static str],
    /// Short name for tables and plots.
    pub label: &'static str,
    /// One line for `list solvers`.
    pub description: &'static str,
    pub method: Method,
    /// Where its runs start: the task's common start, unless its method defines its own.
    pub start: Start,
}

const NEWTON_TASKS: &[Task] = &[Task::Param, Task::Deform];
const AUTHALIC_TASKS: &[Task] = &[Task::Authalic];

/// The extra columns of the authalic solvers (they share one reporter, so all three write
/// all of them): image area and stretch energy, then what the step rule did.
pub const AUTHALIC_COLUMNS: [&str; 8] =
    ["image_area", "stretch_energy", "ascent", "wolfe", "backtracks", "restarted", "fold_rejects", "quad_fallback"];

const fn newton(name: &'static str, label: &'static str, description: &'static str, build: Build) -> SolverEntry {
    SolverEntry {
        name,
        tasks: NEWTON_TASKS,
        energies: &ENERGY_NAMES,
        outside_reason: "",
        opt_in: never,
        options: &[],
        extra_columns: &[],
        label,
        description,
        method: Method::Newton(build),
        start: Start::Common,
    }
}

/// A `param`/`deform` solver that is not a Newton-type strategy (every energy: only the
/// gradient is needed).
const fn planar(
    name: &'static str,
    label: &'static str,
    description: &'static str,
    extra_columns: &'static [&'static str],
    method: Method,
) -> SolverEntry {
    SolverEntry {
        name,
        tasks: NEWTON_TASKS,
        energies: &ENERGY_NAMES,
        outside_reason: "",
        opt_in: never,
        options: &[],
        extra_columns,
        label,
        description,
        method,
        start: Start::Common,
    }
}

/// No option runs the solver outside its energies.
fn never(_: &SolverOptions) -> bool {
    false
}

/// The energies whose SLIM weights `w_k^2 = (dpsi/dsigma_k) / (2 (sigma_k - 1))` are positive
/// at every orientation-preserving map: those that are sums of per-singular-value terms each
/// falling towards its minimum at `sigma_k = 1`, so the per-triangle minimum is a rotation
/// and the local step's target `R` is right. On the others (NH, BARAP, BCONF) the barrier or
/// volume term couples the singular values, `dpsi/dsigma_k` often has the other sign, and the
/// weight is clamped: at the Tutte map of `bumpy_1k` 0 of the weights are clamped for SD,
/// exp-SD and SARAP, and 24.2% (NH), 3.0% (BARAP) and 6.9% (BCONF) are (test
/// `slim_weights_are_clamped_outside_its_energies_only`).
pub const SLIM_ENERGIES: [&str; 3] = ["sd", "exp-sd", "sarap"];

/// The energies AQP is defined for: those whose quadratic part is the Dirichlet energy
/// `c |J|^2` the proxy is the Hessian of (`EnergyKind::dirichlet_part`), the rest being the barrier
/// or rotation terms the proxy leaves out. The authors define the proxy for their isometric
/// distortion `|J|^2 + |J^-1|^2` (our `sd` is half of it) and for ARAP `|J - R|^2`; our
/// `barap` is ARAP plus the barrier `k (|J| + 1/|J|)`.
pub const AQP_ENERGIES: [&str; 2] = ["sd", "barap"];

const fn authalic(name: &'static str, label: &'static str, description: &'static str, method: Method) -> SolverEntry {
    SolverEntry {
        name,
        tasks: AUTHALIC_TASKS,
        energies: &[AUTHALIC_ENERGY],
        outside_reason: "",
        opt_in: never,
        options: &[],
        extra_columns: &AUTHALIC_COLUMNS,
        label,
        description,
        method,
        start: Start::Common,
    }
}

fn spec(block: impl SystemBlock + 'static) -> Result<SolverSpec, String> {
    Ok(SolverSpec { block: Box::new(block), smoothness_projection: None, solve: SystemSolve::Factorized })
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
        options: &["eta_max", "max_cg_iters"],
        extra_columns: &CG_COLUMNS,
        ..newton(
            "kp-newton-cg",
            "KP-CG",
            "kp-newton with truncated steps: CG to an Eisenstat-Walker forcing term, preconditioned by the \
             Laplacian weighted by each block's stiffness",
            |_, _| spec(Kp).map(|s| SolverSpec { solve: SystemSolve::Truncated(Preconditioner::Stiffness), ..s }),
        )
    },
    SolverEntry {
        extra_columns: &CG_COLUMNS,
        ..newton(
            "kp-newton-cg-laplacian",
            "KP-CG-Lap",
            "kp-newton-cg preconditioned by the constant Dirichlet Laplacian, factored once",
            |_, _| spec(Kp).map(|s| SolverSpec { solve: SystemSolve::Truncated(Preconditioner::Laplacian), ..s }),
        )
    },
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
        spec(Kp).map(|s| SolverSpec { smoothness_projection: Some(Projection::Numeric), ..s })
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
        opt_in: |o| o.slim.clamp_weights,
        options: &["clamp_weights"],
        extra_columns: &crate::hessian::slim::CLAMPED_COLUMN,
        ..newton("slim", "SLIM", "SLIM (Rabinovich et al. 2017): the local-global proxy as system matrix", |_, _| {
            spec(Slim)
        })
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
        options: &["tau"],
        extra_columns: &TRUST_REGION_COLUMNS,
        ..newton(
            "pn-trust-region",
            "PN-TR",
            "trust-region eigenvalue filtering (Chen et al. 2024): abs or clamp per iteration from the model fit",
            |_, o| spec(TrustRegion { tau: o.trust_region.tau, space: Space::K }),
        )
    },
    SolverEntry {
        options: &["tau"],
        extra_columns: &TRUST_REGION_COLUMNS,
        ..newton(
            "fp-trust-region-6x6",
            "FP6-TR",
            "trust-region eigenvalue filtering as the authors' code: abs or clamp of the 6x6 element Hessians \
             per iteration from the model fit",
            |_, o| spec(TrustRegion { tau: o.fp_trust_region.tau, space: Space::Element }),
        )
    },
    planar(
        "lbfgs",
        "L-BFGS",
        "L-BFGS (Liu and Nocedal 1989), 10 pairs, H0 = s^T y / y^T y",
        &LBFGS_COLUMNS,
        Method::Lbfgs { laplacian: false },
    ),
    planar(
        "lbfgs-laplacian",
        "L-BFGS-Lap",
        "L-BFGS, 5 pairs, H0 = the constant Laplacian proxy factored once (as in BCQN's code)",
        &LBFGS_COLUMNS,
        Method::Lbfgs { laplacian: true },
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
            Method::Aqp,
        )
    },
    authalic("sem", "SEM", "stretch energy minimization (Yueh et al. 2019), the fixed point", Method::Sem),
    authalic(
        "aem-cg",
        "AEM-CG",
        "authalic energy minimization by preconditioned nonlinear CG",
        Method::AemCg { safe: false },
    ),
    authalic(
        "aem-cg-safe",
        "AEM-CG-safe",
        "aem-cg with restarts, Armijo backtracking and a fold guard",
        Method::AemCg { safe: true },
    ),
];

/// Why a solver cannot run as asked.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum SolverError {
    #[error("unknown {}solver '{name}' (known: {})", task_qualifier(*task), names_for(*task).join(", "))]
    Unknown { name: String, task: Task },
    #[error(
        "'{name}' is {} solver: task {task} runs {} only",
        kind_of(runs),
        names_for(*task).join(", ")
    )]
    WrongTask { name: &'static str, runs: &'static [Task], task: Task },
    /// The solver is not defined for this energy (or these parameters), with the reason.
    #[error("{0}")]
    Unsupported(String),
    /// The solver runs the task without a Newton system (nothing to build or export).
    #[error("'{name}' has no Newton system ({description})")]
    NoSystem { name: &'static str, description: &'static str },
}

/// "authalic " in "unknown authalic solver": the Newton-type solvers are the unqualified ones.
fn task_qualifier(task: Task) -> &'static str {
    match task {
        Task::Param | Task::Deform => "",
        Task::Authalic => "authalic ",
    }
}

/// "an authalic", "a param/deform".
fn kind_of(tasks: &[Task]) -> String {
    let tasks: Vec<&str> = tasks.iter().map(|t| t.as_str()).collect();
    let tasks = tasks.join("/");
    let article = if tasks.starts_with(['a', 'e', 'i', 'o', 'u']) { "an" } else { "a" };
    format!("{article} {tasks}")
}

/// The entry named `name`.
pub fn find(name: &str) -> Option<&'static SolverEntry> {
    SOLVERS.iter().find(|s| s.name == name)
}

/// The entry named `name`, if it runs `task`.
pub fn lookup(name: &str, task: Task) -> Result<&'static SolverEntry, SolverError> {
    let entry = find(name).ok_or_else(|| SolverError::Unknown { name: name.to_string(), task })?;
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

/// The Newton-type solver `name` of `task` built for `energy` with `options`.
pub fn newton_spec(
    name: &str,
    task: Task,
    energy: &EnergyKind,
    options: &SolverOptions,
) -> Result<SolverSpec, SolverError> {
    lookup(name, task)?.newton_spec(task, energy, options)
}

impl SolverEntry {
    pub fn runs(&self, task: Task) -> bool {
        self.tasks.contains(&task)
    }

    /// Whether the energy called `energy` is one it is defined for.
    pub fn is_defined_for(&self, energy: &str) -> bool {
        self.energies.contains(&energy)
    }

    /// Whether it runs the energy called `energy` with `options`: an energy it is defined
    /// for, or any energy when the options opt in.
    pub fn runs_energy(&self, energy: &str, options: &SolverOptions) -> bool {
        self.is_defined_for(energy) || (self.opt_in)(options)
    }

    /// The error for a run of `task` with this solver.
    pub fn wrong_task(&self, task: Task) -> SolverError {
        SolverError::WrongTask { name: self.name, runs: self.tasks, task }
    }

    /// Its Newton-type solver for `energy` with `options`, for a run of `task`; outside its
    /// energies (unless the options opt in), or for parameters its builder refuses, the
    /// reason as [`SolverError::Unsupported`].
    pub fn newton_spec(
        &self,
        task: Task,
        energy: &EnergyKind,
        options: &SolverOptions,
    ) -> Result<SolverSpec, SolverError> {
        match self.method {
            Method::Newton(build) if self.runs_energy(energy.name(), options) => {
                build(energy, options).map_err(SolverError::Unsupported)
            }
            Method::Newton(_) => Err(self.not_defined_for(energy)),
            Method::Sem | Method::AemCg { .. } => Err(self.wrong_task(task)),
            Method::Lbfgs { .. } if !self.runs(task) => Err(self.wrong_task(task)),
            Method::Lbfgs { .. } => Err(SolverError::NoSystem { name: self.name, description: self.description }),
            Method::Aqp if !self.runs(task) => Err(self.wrong_task(task)),
            Method::Aqp if !self.runs_energy(energy.name(), options) => Err(self.not_defined_for(energy)),
            Method::Aqp => Err(SolverError::NoSystem { name: self.name, description: self.description }),
        }
    }

    /// The error for `energy` outside its energies.
    fn not_defined_for(&self, energy: &EnergyKind) -> SolverError {
        SolverError::Unsupported(format!("{} is not defined for {}: {}", self.name, energy.name(), self.outside_reason))
    }

    /// Why a run of `task` with `energy` and `options` is outside this solver's definition
    /// (the harness records such a run as skipped), `None` when it runs: an energy outside
    /// its energies without an opt-in, or parameters its builder refuses (CM for BCONF with
    /// k > 1). The Newton-type solvers and AQP have energies to choose from.
    pub fn skip_reason(&self, task: Task, energy: &EnergyKind, options: &SolverOptions) -> Option<String> {
        match self.newton_spec(task, energy, options) {
            Err(SolverError::Unsupported(why)) => Some(why),
            Ok(_) | Err(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn energies() -> impl Iterator<Item = EnergyKind> {
        ENERGY_NAMES.iter().map(|n| EnergyKind::default_for(n).unwrap())
    }

    #[test]
    fn names_are_unique_and_every_entry_is_complete() {
        let mut names: Vec<_> = SOLVERS.iter().map(|s| s.name).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), SOLVERS.len());
        for s in SOLVERS {
            assert!(!s.tasks.is_empty() && !s.energies.is_empty(), "{}", s.name);
            assert!(!s.label.is_empty() && !s.description.is_empty(), "{}", s.name);
            assert_eq!(find(s.name).map(|e| e.name), Some(s.name));
        }
        let all: usize = Task::ALL.iter().map(|&t| names_for(t).len()).sum();
        assert_eq!(all, SOLVERS.iter().map(|s| s.tasks.len()).sum::<usize>());
    }

    #[test]
    fn every_entry_builds_for_the_energies_it_lists_and_refuses_the_others_with_a_reason() {
        let none = SolverOptions::default();
        for s in SOLVERS {
            for task in Task::ALL {
                for e in energies() {
                    let built = s.newton_spec(task, &e, &none);
                    match (s.method, s.is_defined_for(e.name())) {
                        (Method::Newton(_), true) => {
                            assert!(built.is_ok(), "{} {e:?}", s.name);
                            assert_eq!(s.skip_reason(task, &e, &none), None);
                        }
                        (Method::Newton(_), false) => {
                            let err = built.err().unwrap().to_string();
                            let want = format!("{} is not defined for {}: ", s.name, e.name());
                            assert!(err.starts_with(&want) && err.len() > want.len() + 10, "{}: {err}", s.name);
                            assert_eq!(s.skip_reason(task, &e, &none), Some(err));
                        }
                        (Method::Sem | Method::AemCg { .. }, _) => {
                            assert!(!s.is_defined_for(e.name()), "{}", s.name);
                            let err = built.err().unwrap().to_string();
                            assert!(err.starts_with(&format!("'{}' is an authalic solver: task {task}", s.name)));
                            // a wrong task is a config error, not a skipped run
                            assert_eq!(s.skip_reason(task, &e, &none), None);
                        }
                        // every energy, no Newton system to build (export-system refuses it)
                        (Method::Lbfgs { .. }, defined) => {
                            assert!(defined, "{} {e:?}", s.name);
                            let err = built.err().unwrap().to_string();
                            assert!(err.contains("has no Newton system") || task == Task::Authalic, "{err}");
                            assert_eq!(s.skip_reason(task, &e, &none), None);
                        }
                        // its energies: no Newton system; the others: skipped with the reason
                        (Method::Aqp, defined) => {
                            let err = built.err().unwrap().to_string();
                            assert_eq!(defined, AQP_ENERGIES.contains(&e.name()), "{e:?}");
                            if task == Task::Authalic {
                                assert!(err.starts_with("'aqp' is a param/deform solver"), "{err}");
                                assert_eq!(s.skip_reason(task, &e, &none), None);
                            } else if defined {
                                assert!(err.contains("has no Newton system"), "{err}");
                                assert_eq!(s.skip_reason(task, &e, &none), None);
                            } else {
                                let want = format!("aqp is not defined for {}: its constant proxy is", e.name());
                                assert!(err.starts_with(&want), "{err}");
                                assert_eq!(s.skip_reason(task, &e, &none), Some(err));
                            }
                        }
                    }
                }
            }
        }
        // parameters outside a solver's domain: refused with the builder's reason, a skip
        let cm = find("cm").unwrap();
        let err = newton_spec("cm", Task::Param, &EnergyKind::Bconf { k: 1.5 }, &none).err().unwrap().to_string();
        assert!(err.contains("not convex"), "{err}");
        assert_eq!(cm.skip_reason(Task::Param, &EnergyKind::Bconf { k: 1.5 }, &none), Some(err));
        assert_eq!(cm.skip_reason(Task::Deform, &EnergyKind::Bconf { k: 0.5 }, &none), None);
    }

    #[test]
    fn slim_runs_outside_its_energies_only_when_the_options_opt_in() {
        let slim = find("slim").unwrap();
        assert_eq!(slim.energies, SLIM_ENERGIES);
        let clamp = SolverOptions { slim: SlimOptions { clamp_weights: true }, ..SolverOptions::default() };
        let nh = EnergyKind::default_for("nh").unwrap();
        let why = slim.skip_reason(Task::Param, &nh, &SolverOptions::default()).unwrap();
        assert!(
            why.starts_with(
                "slim is not defined for nh: its reweighting assumes the per-triangle minimum is a rotation"
            ) && why.ends_with("(set [solver.slim] clamp_weights = true to run it with clamped weights)"),
            "{why}"
        );
        for e in energies() {
            assert!(slim.newton_spec(Task::Param, &e, &clamp).is_ok(), "{e:?}");
            assert_eq!(slim.skip_reason(Task::Deform, &e, &clamp), None);
        }
        // the option is slim's: no other solver runs outside its energies with it
        for s in SOLVERS.iter().filter(|s| s.name != "slim") {
            assert!(!(s.opt_in)(&clamp) && !s.options.contains(&"clamp_weights"), "{}", s.name);
            assert_eq!(clamp.of(s.name), SolverOptions::default());
        }
        assert_eq!(clamp.of("slim"), clamp);
        assert_eq!(slim.options, ["clamp_weights"]);
    }

    /// `[solver.pn-trust-region] tau` and `[solver.fp-trust-region-6x6] tau` reach their own
    /// strategy (in `K` and in the element space) and no other solver's options.
    #[test]
    fn each_trust_region_threshold_is_its_own_solver_s_option() {
        let loose = TrustRegionOptions { tau: 0.5 };
        let cases = [
            ("pn-trust-region", Space::K, SolverOptions { trust_region: loose, ..SolverOptions::default() }),
            (
                "fp-trust-region-6x6",
                Space::Element,
                SolverOptions { fp_trust_region: loose, ..SolverOptions::default() },
            ),
        ];
        for (name, space, set) in cases {
            let tr = find(name).unwrap();
            assert_eq!(tr.options, ["tau"]);
            assert_eq!(tr.extra_columns, TRUST_REGION_COLUMNS);
            assert_eq!(set.of(name), set);
            for other in SOLVERS.iter().filter(|s| s.name != name) {
                assert_eq!(set.of(other.name), SolverOptions::default(), "{}", other.name);
            }
            for (o, tau) in [(SolverOptions::default(), 0.01), (set, 0.5)] {
                let spec = tr.newton_spec(Task::Param, &EnergyKind::Sd, &o).unwrap();
                assert_eq!(spec.block.trust_region(), Some(TrustRegion { tau, space }), "{name}");
            }
        }
        // only they adapt their filter
        let both = SolverOptions { trust_region: loose, fp_trust_region: loose, ..SolverOptions::default() };
        for s in SOLVERS.iter().filter(|s| !s.name.contains("trust-region")) {
            if let Ok(spec) = s.newton_spec(Task::Param, &EnergyKind::Sd, &both) {
                assert_eq!(spec.block.trust_region(), None, "{}", s.name);
            }
        }
        let abs = find("pn-abs").unwrap().newton_spec(Task::Deform, &EnergyKind::Sd, &both).unwrap();
        assert!(abs.block.counter_names().is_empty());
    }

    /// The energies SLIM is declared for are exactly those where its weights need no clamping:
    /// counted at the Tutte map of a generated mesh (the numbers in `SLIM_ENERGIES`' doc).
    #[test]
    fn slim_weights_are_clamped_outside_its_energies_only() {
        use crate::hessian::slim::clamped_weights;
        use crate::init::{tutte, TutteBoundary};
        use crate::problem::{Evaluation, MapProblem};
        let mesh = crate::generate::generate("bumpy_1k").unwrap().normalized();
        let x = tutte(&mesh, TutteBoundary::Uniform).unwrap();
        let mut shares = Vec::new();
        for e in energies() {
            let problem = MapProblem::new(&mesh, e).unwrap();
            let mut ev = Evaluation::default();
            problem.evaluate(&x, &mut ev).unwrap();
            let clamped: usize = ev.states.iter().map(clamped_weights).sum();
            let share = clamped as f64 / (2 * ev.states.len()) as f64;
            shares.push((e.name(), (1000.0 * share).round() / 10.0));
            assert_eq!(clamped == 0, SLIM_ENERGIES.contains(&e.name()), "{e:?}: {clamped} clamped");
        }
        assert_eq!(
            shares,
            [("sd", 0.0), ("exp-sd", 0.0), ("sarap", 0.0), ("nh", 24.2), ("barap", 3.0), ("bconf", 6.9)]
        );
    }

    #[test]
    fn a_solver_of_another_task_or_no_solver_is_named_as_such() {
        let err = |n: &str, t: Task| lookup(n, t).err().unwrap().to_string();
        let newton = names_for(Task::Param).join(", ");
        assert_eq!(err("sem", Task::Param), format!("'sem' is an authalic solver: task param runs {newton} only"));
        assert_eq!(
            err("kp-newton", Task::Authalic),
            "'kp-newton' is a param/deform solver: task authalic runs sem, aem-cg, aem-cg-safe only"
        );
        assert_eq!(err("kp", Task::Deform), format!("unknown solver 'kp' (known: {newton})"));
        assert_eq!(err("sem2", Task::Authalic), "unknown authalic solver 'sem2' (known: sem, aem-cg, aem-cg-safe)");
        assert_eq!(names_for(Task::Param), names_for(Task::Deform));
        assert!(lookup("aem-cg-safe", Task::Authalic).is_ok());
    }

    #[test]
    fn extra_columns_are_those_the_solvers_write() {
        for s in SOLVERS {
            let expected: &[&str] = match s.method {
                Method::Sem | Method::AemCg { .. } => &AUTHALIC_COLUMNS,
                Method::Lbfgs { .. } => &LBFGS_COLUMNS,
                Method::Aqp => &AQP_COLUMNS,
                // the Newton-type solvers write their strategy's counters
                // the Newton-type solvers write their strategy's counters, then the truncated
                // steps' columns
                Method::Newton(_) => {
                    let e = EnergyKind::default_for(s.energies[0]).unwrap();
                    let spec = s.newton_spec(Task::Param, &e, &SolverOptions::default()).unwrap();
                    let mut names = spec.block.counter_names().to_vec();
                    if matches!(spec.solve, SystemSolve::Truncated(_)) {
                        names.extend(CG_COLUMNS);
                    }
                    assert_eq!(s.extra_columns, names, "{}", s.name);
                    continue;
                }
            };
            assert_eq!(s.extra_columns, expected, "{}", s.name);
        }
        assert_eq!(find("slim").unwrap().extra_columns, ["clamped"]);
    }

    /// Only unprojected Newton stops at its first failed factorization; the strategies with
    /// PSD blocks keep the retry with larger shifts as a safety net.
    #[test]
    fn only_newton_refuses_to_retry_a_failed_factorization() {
        for s in SOLVERS {
            if let Method::Newton(_) = s.method {
                let e = EnergyKind::default_for(s.energies[0]).unwrap();
                let spec = s.newton_spec(Task::Param, &e, &SolverOptions::default()).unwrap();
                assert_eq!(spec.block.retries_failed_factorization(), s.name != "newton", "{}", s.name);
            }
        }
    }
}
