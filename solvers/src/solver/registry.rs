//! Solver registry: name -> system-matrix strategy and options. Adding a solver is one
//! strategy file plus one line here.

use crate::energy::EnergyKind;
use crate::hessian::{akvf::Akvf, cm::Cm, fp::Fp4, fp::Fp6, kp::Kp, none::Unprojected, slim::Slim, SystemBlock};
use crate::smoothness::Projection;

pub struct SolverSpec {
    pub name: &'static str,
    pub block: Box<dyn SystemBlock>,
    /// Apply the global-scaling heuristic of Section 4.2 to the `param` initialization
    /// (for the energies that define it: SD, BCONF, BARAP).
    pub global_scaling: bool,
    /// Overrides how the smoothness term's 8x8 blocks are projected.
    pub smoothness_projection: Option<Projection>,
}

/// Builds a solver for an energy, or says why the combination is not defined.
type Builder = fn(&EnergyKind) -> Result<SolverSpec, String>;

fn spec(name: &'static str, block: impl SystemBlock + 'static, global_scaling: bool) -> Result<SolverSpec, String> {
    Ok(SolverSpec { name, block: Box::new(block), global_scaling, smoothness_projection: None })
}

const REGISTRY: &[(&str, Builder)] = &[
    ("kp-newton", |_| spec("kp-newton", Kp, true)),
    ("kp-newton-noscale", |_| spec("kp-newton-noscale", Kp, false)),
    // KP with the smoothness term's 8x8 blocks eigen-projected (Table 7's numeric column);
    // the same as kp-newton without a smoothness term.
    ("kp-newton-eig8", |_| {
        spec("kp-newton-eig8", Kp, true).map(|s| SolverSpec { smoothness_projection: Some(Projection::Numeric), ..s })
    }),
    ("fp-newton-4x4", |_| spec("fp-newton-4x4", Fp4, false)),
    ("fp-newton-6x6", |_| spec("fp-newton-6x6", Fp6, false)),
    ("cm", |e| spec("cm", Cm::for_energy(e)?, false)),
    ("newton", |_| spec("newton", Unprojected, false)),
    ("slim", |_| spec("slim", Slim, false)),
    ("akvf", |_| spec("akvf", Akvf, false)),
];

/// Why a solver could not be built.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum SpecError {
    #[error("unknown solver '{0}' (known: {known})", known = solver_names().join(", "))]
    Unknown(String),
    #[error("{0}")]
    Unsupported(String),
}

impl SolverSpec {
    pub fn build(name: &str, energy: &EnergyKind) -> Result<SolverSpec, SpecError> {
        let (_, builder) =
            REGISTRY.iter().find(|(n, _)| *n == name).ok_or_else(|| SpecError::Unknown(name.to_string()))?;
        builder(energy).map_err(SpecError::Unsupported)
    }
}

/// Names of all registered solvers, in registry order.
pub fn solver_names() -> Vec<&'static str> {
    REGISTRY.iter().map(|(n, _)| *n).collect()
}
