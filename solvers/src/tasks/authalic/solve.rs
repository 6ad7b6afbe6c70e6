//! A run of the `authalic` task: the catalogue's solver on the prepared disk.

use super::problem::{AuthalicError, AuthalicOutcome, AuthalicProblem, AuthalicSettings};
use crate::mesh::Mesh;
use crate::solver::{Observer, RawOptions};
use crate::tasks::catalogue::{lookup, Build, SolveAuthalic};
use crate::tasks::Task;

/// Run the named authalic solver (of the catalogue) on `mesh` (validated here).
pub fn solve_authalic(
    mesh: &Mesh,
    solver: &str,
    settings: &AuthalicSettings,
    observer: &mut dyn Observer,
) -> Result<AuthalicOutcome, AuthalicError> {
    let solve = authalic_solver(solver)?;
    let problem = AuthalicProblem::new(mesh)?;
    let z0 = problem.initial_map(settings.init_steps)?;
    Ok(solve(&problem, z0, settings, observer))
}

/// The prepared disk of `mesh` (validated here) and the common start of every authalic
/// solver, as interleaved image positions: what the harness judges runs on.
pub fn authalic_start(mesh: &Mesh, settings: &AuthalicSettings) -> Result<(AuthalicProblem, Vec<f64>), AuthalicError> {
    let problem = AuthalicProblem::new(mesh)?;
    let z0 = problem.initial_map(settings.init_steps)?;
    let x0 = problem.positions_of(&z0);
    Ok((problem, x0))
}

/// The named authalic solver on `problem` from the map `x` (interleaved positions, boundary
/// on the unit circle in its loop's order) instead of the initial map: how the harness
/// computes and polishes the authalic reference minimum.
pub fn solve_authalic_from(
    problem: &AuthalicProblem,
    solver: &str,
    settings: &AuthalicSettings,
    x: &[f64],
    observer: &mut dyn Observer,
) -> Result<AuthalicOutcome, AuthalicError> {
    let solve = authalic_solver(solver)?;
    if x.len() != 2 * problem.n {
        return Err(AuthalicError::BadMap {
            source_name: problem.source.clone(),
            detail: format!("{} coordinates for {} vertices", x.len(), problem.n),
        });
    }
    Ok(solve(problem, problem.vars_of(x), settings, observer))
}

/// The catalogue's authalic solver `solver` (decided before the mesh is looked at).
fn authalic_solver(solver: &str) -> Result<SolveAuthalic, AuthalicError> {
    let entry = lookup(solver, Task::Authalic)?;
    let Build::Authalic(solve) = entry.build else { return Err(entry.wrong_task(Task::Authalic).into()) };
    entry.check_options(&RawOptions::new())?;
    Ok(solve)
}
