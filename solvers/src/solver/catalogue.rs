//! The solver catalogue: every solver of every task, with the tasks it runs, the energies it
//! is defined for, the extra CSV columns it writes, its labels and how it is built. Config
//! checks, `list solvers`, dispatch and table labels all read it. Adding a solver is one
//! strategy file plus one entry here.

use crate::energy::{EnergyKind, AUTHALIC_ENERGY, ENERGY_NAMES};
use crate::hessian::{akvf::Akvf, cm::Cm, fp::Fp4, fp::Fp6, kp::Kp, none::Unprojected, slim::Slim, SystemBlock};
use crate::mesh::Task;
use crate::smoothness::Projection;

/// A Newton-type solver built for one energy: its system-matrix strategy and options.
pub struct SolverSpec {
    pub block: Box<dyn SystemBlock>,
    /// Apply the global-scaling heuristic of Section 4.2 to the `param` initialization
    /// (for the energies that define it: SD, BCONF, BARAP).
    pub global_scaling: bool,
    /// Overrides how the smoothness term's 8x8 blocks are projected.
    pub smoothness_projection: Option<Projection>,
}

/// How an entry solves.
#[derive(Clone, Copy)]
pub enum Method {
    /// A system-matrix strategy of the shared Newton driver (`param`, `deform`): builds it for
    /// an energy, or says why the combination is not defined.
    Newton(fn(&EnergyKind) -> Result<SolverSpec, String>),
    /// The SEM fixed point (`authalic`).
    Sem,
    /// AEM's preconditioned nonlinear CG, faithful or with the safeguards (`authalic`).
    AemCg { safe: bool },
}

/// One solver of the catalogue.
pub struct SolverEntry {
    /// The name in configs, file names and CSVs.
    pub name: &'static str,
    pub tasks: &'static [Task],
    /// Names of the energies it is defined for (`ENERGY_NAMES`, or the authalic energy).
    /// Some combinations are refused for some parameters, with the reason, when built.
    pub energies: &'static [&'static str],
    /// The solver-specific columns after the design.md ones in its iteration CSVs, in order
    /// (`IterationRecord::extra`).
    pub extra_columns: &'static [&'static str],
    /// Short name for tables and plots.
    pub label: &'static str,
    /// One line for `list solvers`.
    pub description: &'static str,
    pub method: Method,
}

const NEWTON_TASKS: &[Task] = &[Task::Param, Task::Deform];
const AUTHALIC_TASKS: &[Task] = &[Task::Authalic];

/// The extra columns of the authalic solvers (they share one reporter, so all three write
/// all of them): image area and stretch energy, then what the step rule did.
pub const AUTHALIC_COLUMNS: [&str; 8] =
    ["image_area", "stretch_energy", "ascent", "wolfe", "backtracks", "restarted", "fold_rejects", "quad_fallback"];

const fn newton(
    name: &'static str,
    label: &'static str,
    description: &'static str,
    build: fn(&EnergyKind) -> Result<SolverSpec, String>,
) -> SolverEntry {
    SolverEntry {
        name,
        tasks: NEWTON_TASKS,
        energies: &ENERGY_NAMES,
        extra_columns: &[],
        label,
        description,
        method: Method::Newton(build),
    }
}

const fn authalic(name: &'static str, label: &'static str, description: &'static str, method: Method) -> SolverEntry {
    SolverEntry {
        name,
        tasks: AUTHALIC_TASKS,
        energies: &[AUTHALIC_ENERGY],
        extra_columns: &AUTHALIC_COLUMNS,
        label,
        description,
        method,
    }
}

fn spec(block: impl SystemBlock + 'static, global_scaling: bool) -> Result<SolverSpec, String> {
    Ok(SolverSpec { block: Box::new(block), global_scaling, smoothness_projection: None })
}

/// Every solver, `param`/`deform` first (the order of `list solvers` and of the known-names
/// lists in messages).
pub static SOLVERS: &[SolverEntry] = &[
    newton("kp-newton", "KP", "Newton, K of each element Hessian projected analytically (complex view, Eq. 4)", |_| {
        spec(Kp, true)
    }),
    newton("kp-newton-noscale", "KP-noscale", "kp-newton without the global scaling of the initial map", |_| {
        spec(Kp, false)
    }),
    // Table 7's numeric column; the same as kp-newton without a smoothness term.
    newton("kp-newton-eig8", "KP-eig8", "kp-newton with the smoothness term's 8x8 blocks eigen-projected", |_| {
        spec(Kp, true).map(|s| SolverSpec { smoothness_projection: Some(Projection::Numeric), ..s })
    }),
    newton("fp-newton-4x4", "FP4", "Newton, element Hessians projected numerically via the reduced 4x4 matrix", |_| {
        spec(Fp4, false)
    }),
    newton("fp-newton-6x6", "FP6", "Newton, 6x6 element Hessians eigen-projected numerically", |_| spec(Fp6, false)),
    newton("cm", "CM", "composite majorization (Shtengel et al. 2017), a convex-concave split", |e| {
        spec(Cm::for_energy(e)?, false)
    }),
    newton("newton", "Newton", "Newton on the unmodified Hessians (may stop on an indefinite system)", |_| {
        spec(Unprojected, false)
    }),
    SolverEntry {
        extra_columns: &crate::hessian::slim::CLAMPED_COLUMN,
        ..newton("slim", "SLIM", "SLIM (Rabinovich et al. 2017): the local-global proxy as system matrix", |_| {
            spec(Slim, false)
        })
    },
    newton("akvf", "AKVF", "AKVF (Claici et al. 2017): Killing-energy preconditioned gradient", |_| spec(Akvf, false)),
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

/// The Newton-type solver `name` of `task` built for `energy`.
pub fn newton_spec(name: &str, task: Task, energy: &EnergyKind) -> Result<SolverSpec, SolverError> {
    lookup(name, task)?.newton_spec(task, energy)
}

impl SolverEntry {
    pub fn runs(&self, task: Task) -> bool {
        self.tasks.contains(&task)
    }

    /// Whether the energy called `energy` is one it is defined for.
    pub fn is_defined_for(&self, energy: &str) -> bool {
        self.energies.contains(&energy)
    }

    /// The error for a run of `task` with this solver.
    pub fn wrong_task(&self, task: Task) -> SolverError {
        SolverError::WrongTask { name: self.name, runs: self.tasks, task }
    }

    /// Its Newton-type solver for `energy`, for a run of `task`.
    pub fn newton_spec(&self, task: Task, energy: &EnergyKind) -> Result<SolverSpec, SolverError> {
        match self.method {
            Method::Newton(build) if self.is_defined_for(energy.name()) => {
                build(energy).map_err(SolverError::Unsupported)
            }
            Method::Newton(_) => {
                Err(SolverError::Unsupported(format!("{}: not defined for energy {}", self.name, energy.name())))
            }
            Method::Sem | Method::AemCg { .. } => Err(self.wrong_task(task)),
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
        for s in SOLVERS {
            for task in Task::ALL {
                for e in energies() {
                    let built = s.newton_spec(task, &e);
                    match (s.method, s.is_defined_for(e.name())) {
                        (Method::Newton(_), true) => assert!(built.is_ok(), "{} {e:?}", s.name),
                        (Method::Newton(_), false) => {
                            let err = built.err().unwrap().to_string();
                            assert!(err.contains("not defined for energy"), "{}: {err}", s.name)
                        }
                        (Method::Sem | Method::AemCg { .. }, _) => {
                            assert!(!s.is_defined_for(e.name()), "{}", s.name);
                            let err = built.err().unwrap().to_string();
                            assert!(err.starts_with(&format!("'{}' is an authalic solver: task {task}", s.name)));
                        }
                    }
                }
            }
        }
        // parameters outside a solver's domain: refused with the reason
        let err = newton_spec("cm", Task::Param, &EnergyKind::Bconf { k: 1.5 }).err().unwrap().to_string();
        assert!(err.contains("not convex"), "{err}");
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

    /// Only unprojected Newton stops at its first failed factorization; the strategies with
    /// PSD blocks keep the retry with larger shifts as a safety net.
    #[test]
    fn only_newton_refuses_to_retry_a_failed_factorization() {
        for s in SOLVERS {
            if let Method::Newton(_) = s.method {
                let e = EnergyKind::default_for(s.energies[0]).unwrap();
                let spec = s.newton_spec(Task::Param, &e).unwrap();
                assert_eq!(spec.block.retries_failed_factorization(), s.name != "newton", "{}", s.name);
            }
        }
    }

    #[test]
    fn extra_columns_are_those_the_solvers_write() {
        for s in SOLVERS {
            let expected: &[&str] = match s.method {
                Method::Sem | Method::AemCg { .. } => &AUTHALIC_COLUMNS,
                // the Newton-type solvers write their strategy's counters
                Method::Newton(_) => {
                    let e = EnergyKind::default_for(s.energies[0]).unwrap();
                    let spec = s.newton_spec(Task::Param, &e).unwrap();
                    spec.block.counter_names()
                }
            };
            assert_eq!(s.extra_columns, expected, "{}", s.name);
        }
        assert_eq!(find("slim").unwrap().extra_columns, ["clamped"]);
    }
}
