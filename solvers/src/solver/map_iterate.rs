//! The iterate of the planar-map solvers (`param`, `deform`): the map with its evaluation.

use super::executor::Iterate;
use super::observer::IterationRecord;
use super::outcome::SolveError;
use super::stop::StopReason;
use crate::problem::{Evaluation, MapProblem};
use std::time::Instant;

/// The iterate of the `param` and `deform` solvers: a map with its evaluation.
pub struct MapIterate<'a> {
    /// The problem the map is evaluated on.
    pub problem: &'a MapProblem,
    /// The map, interleaved `[u0, v0, u1, v1, ...]`.
    pub x: Vec<f64>,
    /// Its evaluation (energy, gradient, element states, inertia).
    pub ev: Evaluation,
}

impl<'a> MapIterate<'a> {
    /// `x0` evaluated; an inverted or degenerate start is an error naming the element.
    pub fn new(problem: &'a MapProblem, x0: Vec<f64>) -> Result<MapIterate<'a>, SolveError> {
        let mut ev = Evaluation::default();
        problem.evaluate(&x0, &mut ev)?;
        Ok(MapIterate { problem, x: x0, ev })
    }

    /// Evaluate the map after a step moved it: the energy, gradient and states the next step
    /// needs (the method's time), then the inertia counts for the row only (the projections
    /// find their negative eigenvalues themselves). The two times, in seconds.
    pub fn evaluate_moved(&mut self) -> Result<(f64, f64), StopReason> {
        let t0 = Instant::now();
        if let Err(e) = self.problem.evaluate_without_inertia(&self.x, &mut self.ev) {
            // A line search only accepts finite energies, so this is a derivative overflow.
            return Err(StopReason::NonFinite(e.to_string()));
        }
        let t_eval = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        self.problem.count_inertia(&mut self.ev);
        Ok((t_eval, t0.elapsed().as_secs_f64()))
    }
}

impl Iterate for MapIterate<'_> {
    fn row(&self, iter: usize, step: f64) -> IterationRecord {
        IterationRecord::of(iter, &self.ev, self.problem.flips(&self.x), step)
    }

    fn take_map(&mut self) -> Vec<f64> {
        std::mem::take(&mut self.x)
    }
}
