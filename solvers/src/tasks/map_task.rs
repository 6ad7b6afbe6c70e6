//! What the two planar-map tasks, `param` and `deform`, share: the preamble of a run (the
//! solver from the catalogue, the energy's parameters, the mesh checked for the task, the
//! problem on the normalized mesh with its smoothness term) and the error type.

use crate::energy::EnergyKind;
use crate::init::InitError;
use crate::mesh::Handle;
use crate::mesh::{Mesh, MeshError};
use crate::problem::{DegenerateFace, MapProblem};
use crate::smoothness::Projection;
use crate::solver::planar::PlanarSolver;
use crate::solver::{RawOptions, SolveError};
use crate::tasks::catalogue::planar_solver;
use crate::tasks::solver_error::SolverError;
use crate::tasks::{validate_for, Task};

/// Why a `param` or `deform` run could not start.
#[derive(Debug, thiserror::Error)]
pub enum MapError {
    /// The solver is unknown, runs another task, or refuses the energy or its options.
    #[error(transparent)]
    Solver(#[from] SolverError),
    /// The energy's parameters are unusable (also: an iterate's Newton system failed, in `system`).
    #[error("{0}")]
    Energy(String),
    /// The mesh could not be read or failed validation for the task.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A face of the normalized mesh has no local operator.
    #[error(transparent)]
    Degenerate(#[from] DegenerateFace),
    /// The Tutte start of a `param` run could not be built.
    #[error("{source_name}: initialization failed: {err}")]
    Init {
        /// The mesh source.
        source_name: String,
        /// Why Tutte's embedding failed.
        err: InitError,
    },
    /// A `deform` run was given no handles.
    #[error("{source_name}: no handles; the deform task needs positional constraints")]
    NoHandles {
        /// The mesh source.
        source_name: String,
    },
    /// A handle names a vertex the mesh does not have.
    #[error("{source_name}: handle {index} names vertex {vertex}, but the mesh has {n} vertices")]
    HandleOutOfRange {
        /// The mesh source.
        source_name: String,
        /// Position of the handle in the list (0-based).
        index: usize,
        /// The vertex it names.
        vertex: usize,
        /// Number of vertices of the mesh.
        n: usize,
    },
    /// A handle's target has a NaN or infinite coordinate.
    #[error("{source_name}: handle {index} has a non-finite target {target:?}")]
    BadTarget {
        /// The mesh source.
        source_name: String,
        /// Position of the handle in the list (0-based).
        index: usize,
        /// The target as given, in the file's frame.
        target: [f64; 2],
    },
    /// The given initial map of a `deform` run has the wrong length or a non-finite point.
    #[error("{source_name}: initial map: {detail}")]
    BadInit {
        /// The mesh source.
        source_name: String,
        /// What is wrong with it.
        detail: String,
    },
    /// The solver could not start: the start map cannot be evaluated or the linear setup failed.
    #[error("{source_name}: {err}")]
    Solve {
        /// The mesh source.
        source_name: String,
        /// Why it could not start.
        err: SolveError,
    },
}

/// The catalogue's `solver` for `task` and `energy` with its `options`, once the energy's
/// parameters and the mesh (validated for `task`) are known to be usable. In this order: a
/// misspelt solver is reported before anything about the mesh.
pub(crate) fn checked_solver(
    mesh: &Mesh,
    task: Task,
    energy: &EnergyKind,
    solver: &str,
    options: &RawOptions,
) -> Result<Box<dyn PlanarSolver>, MapError> {
    let built = planar_solver(solver, task, energy, options)?;
    energy.check().map_err(MapError::Energy)?;
    validate_for(mesh, task).into_result()?;
    Ok(built)
}

/// The problem on the normalized mesh `rest`, with the smoothness term projected as the
/// solver says (`own_projection`, `kp-newton-eig8`'s) or as configured.
pub(crate) fn map_problem(
    rest: &Mesh,
    energy: EnergyKind,
    own_projection: Option<Projection>,
    smoothness: Option<(f64, Projection)>,
) -> Result<MapProblem, MapError> {
    let mut problem = MapProblem::new(rest, energy)?;
    if let Some((w, proj)) = smoothness {
        problem = problem.with_smoothness(rest, w, own_projection.unwrap_or(proj));
    }
    Ok(problem)
}

/// `handles` all name a vertex of `mesh` and have finite targets; there is at least one.
pub(crate) fn check_handles(mesh: &Mesh, handles: &[Handle]) -> Result<(), MapError> {
    let source_name = mesh.source.clone();
    if handles.is_empty() {
        return Err(MapError::NoHandles { source_name });
    }
    let n = mesh.n_vertices();
    for (index, h) in handles.iter().enumerate() {
        if h.vertex >= n {
            return Err(MapError::HandleOutOfRange { source_name, index, vertex: h.vertex, n });
        }
        if !h.target.iter().all(|c| c.is_finite()) {
            return Err(MapError::BadTarget { source_name, index, target: h.target });
        }
    }
    Ok(())
}
