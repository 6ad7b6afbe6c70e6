//! A run of the `authalic` task: the catalogue's solver on the prepared disk.

use super::{AuthalicError, AuthalicOutcome, AuthalicProblem, AuthalicSettings};
use crate::mesh::{Mesh, Task};
use crate::solver::catalogue::{lookup, Build};
use crate::solver::{Observer, RawOptions};

/// Run the named authalic solver (of the catalogue) on `mesh` (validated here).
pub fn solve_authalic(
    mesh: &Mesh,
    solver: &str,
    settings: &AuthalicSettings,
    observer: &mut dyn Observer,
) -> Result<AuthalicOutcome, AuthalicError> {
    // decided before the mesh is looked at
    let entry = lookup(solver, Task::Authalic)?;
    let Build::Authalic(solve) = entry.build else { return Err(entry.wrong_task(Task::Authalic).into()) };
    entry.check_options(&RawOptions::new())?;
    let problem = AuthalicProblem::new(mesh)?;
    let z0 = problem.initial_map(settings.init_steps)?;
    Ok(solve(&problem, z0, settings, observer))
}
