//! A `param`/`deform` solver as its catalogue entry builds it for one energy with its
//! options: what a run of those tasks calls.

use super::newton::{newton_with, SolverSpec};
use super::observer::Observer;
use super::outcome::{Outcome, SolveError};
use super::settings::Settings;
use crate::problem::MapProblem;
use crate::smoothness::Projection;

/// A `param`/`deform` solver built for one energy and its options.
pub trait PlanarSolver {
    /// Run from the orientation-preserving map `x0`.
    fn solve(
        &self,
        problem: &MapProblem,
        x0: Vec<f64>,
        settings: &Settings,
        observer: &mut dyn Observer,
    ) -> Result<Outcome, SolveError>;

    /// Its own projection of the smoothness term's blocks, if it has one.
    fn smoothness_projection(&self) -> Option<Projection> {
        None
    }

    /// Its Newton system's strategy and solve (`export-system`); `None` for a solver without
    /// a Newton system.
    fn into_newton(self: Box<Self>) -> Option<SolverSpec> {
        None
    }
}

/// The shared Newton driver with the spec's strategy (here, not in `newton`, which the
/// trait's `into_newton` names).
impl PlanarSolver for SolverSpec {
    fn solve(
        &self,
        problem: &MapProblem,
        x0: Vec<f64>,
        settings: &Settings,
        observer: &mut dyn Observer,
    ) -> Result<Outcome, SolveError> {
        newton_with(problem, x0, self.block.as_ref(), self.solve, settings, observer)
    }

    fn smoothness_projection(&self) -> Option<Projection> {
        self.smoothness_projection
    }

    fn into_newton(self: Box<Self>) -> Option<SolverSpec> {
        Some(*self)
    }
}
