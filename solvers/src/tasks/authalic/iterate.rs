//! The authalic iterate as the executor sees it: the variables `z` with their terms.

use crate::problem::norm;

use super::problem::{AuthalicOutcome, AuthalicProblem, Terms};
use crate::solver::executor::{Finished, Iterate};
use crate::solver::{IterationRecord, Metric, StartMap};

pub(crate) struct AuthalicIterate<'a> {
    pub problem: &'a AuthalicProblem,
    /// `[f_I^1; f_I^2; theta]` (Eq. 7).
    pub z: Vec<f64>,
    pub terms: Terms,
    pub grad_norm: f64,
}

impl<'a> AuthalicIterate<'a> {
    /// `z` with its terms and gradient `g`.
    pub fn new(problem: &'a AuthalicProblem, z: Vec<f64>, terms: Terms, g: &[f64]) -> AuthalicIterate<'a> {
        AuthalicIterate { problem, z, terms, grad_norm: norm(g) }
    }
}

impl Iterate for AuthalicIterate<'_> {
    fn row(&self, iter: usize, step: f64) -> IterationRecord {
        let t = &self.terms;
        IterationRecord {
            iter,
            energy: t.energy,
            grad_norm: self.grad_norm,
            step,
            // Each face's term |f(tau)|^2 / |tau| of E_S has a Hessian with exactly two negative
            // eigenvalues whenever |f(tau)| != 0 (see `element_hessian_inertia` test).
            neg_eig: 2 * t.nonzero,
            indefinite_elems: t.nonzero,
            flips: t.folded,
            // No Newton system, no Tikhonov shift; nothing is computed for the row alone.
            ..IterationRecord::default()
        }
    }

    fn initial_extra(&self) -> Vec<Metric> {
        Extras::default().values(&self.terms)
    }

    fn take_map(&mut self) -> Vec<f64> {
        self.problem.positions_of(&self.z)
    }
}

/// The extra columns of the authalic solvers (they share one iterate, so all of them write
/// all of them): image area and stretch energy, then what the step rule did.
pub const AUTHALIC_COLUMNS: [&str; 8] =
    [IMAGE_AREA, STRETCH_ENERGY, ASCENT, WOLFE, BACKTRACKS, RESTARTED, FOLD_REJECTS, QUAD_FALLBACK];

const IMAGE_AREA: &str = "image_area";
const STRETCH_ENERGY: &str = "stretch_energy";
const ASCENT: &str = "ascent";
const WOLFE: &str = "wolfe";
const BACKTRACKS: &str = "backtracks";
const RESTARTED: &str = "restarted";
const FOLD_REJECTS: &str = "fold_rejects";
const QUAD_FALLBACK: &str = "quad_fallback";

/// What the step rule of one iteration did (the extra columns, [`AUTHALIC_COLUMNS`]).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Extras {
    pub ascent: bool,
    pub wolfe: Option<bool>,
    pub backtracks: usize,
    pub restarted: bool,
    pub fold_rejects: usize,
    pub quad_fallback: bool,
    /// Energy evaluations of the step rule.
    pub ls_evals: usize,
}

impl Extras {
    /// The row's extra columns at the iterate with terms `t`, by name.
    pub fn values(&self, t: &Terms) -> Vec<Metric> {
        let b = |v: bool| f64::from(u8::from(v));
        vec![
            (IMAGE_AREA, t.area),
            (STRETCH_ENERGY, t.stretch),
            (ASCENT, b(self.ascent)),
            (WOLFE, self.wolfe.map_or(f64::NAN, b)),
            (BACKTRACKS, self.backtracks as f64),
            (RESTARTED, b(self.restarted)),
            (FOLD_REJECTS, self.fold_rejects as f64),
            (QUAD_FALLBACK, b(self.quad_fallback)),
        ]
    }
}

/// The outcome of a finished run, with the area metrics of its last iterate.
pub(crate) fn finished(run: Finished<AuthalicIterate>) -> AuthalicOutcome {
    let Finished { mut outcome, last } = run;
    outcome.start = Some(StartMap::ArclengthStretch);
    AuthalicOutcome { outcome, metrics: last.problem.metrics(&last.z) }
}
