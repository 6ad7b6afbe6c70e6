//! `sem`: the fixed-point iteration of stretch energy minimization with boundary update
//! (Yueh, Lin, Wu, Yau 2019), as restated in the AEM paper, Eq. 14a-e.
//!
//! Each iteration, with `L = L_S(f^(k))`:
//! interior `f_I = -L_II^{-1} L_IB f_B` (14a); boundary `f_B = -N C L_BB^{-1} L_BI R f_I` (14b)
//! with `R` the inversion `f_l / |f_l|^2` of the new interior points (14c), `C` the
//! centring (14d) and `N` the projection of each boundary point to the unit circle (14e).
//! Convergence is not guaranteed (AEM paper, Section 3): rows whose energy rose have
//! `ascent = 1` (human_face: the first step raises it fivefold, then it falls below the start
//! by iteration 5). With `sem_stop_on_increase` it stops and keeps the previous iterate
//! instead, as the reference code SEMc does.

use super::iterate::{finished, AuthalicIterate, Extras, AUTHALIC_COLUMNS};

use crate::problem::norm;

use super::problem::{AuthalicOutcome, AuthalicProblem, AuthalicSettings, EXACT};
use crate::linear::{LinearError, SpdSolver};
use crate::solver::executor::{execute, Method, ReadyMethod, Step};
use crate::solver::{Observer, StopReason};
use std::time::Instant;

/// Run `sem` from the variables `z0`.
pub fn sem(
    problem: &AuthalicProblem,
    z0: Vec<f64>,
    settings: &AuthalicSettings,
    observer: &mut dyn Observer,
) -> AuthalicOutcome {
    let (terms, g) = problem.terms_and_gradient(&z0);
    let at = AuthalicIterate::new(problem, z0, terms, &g);
    let solvers =
        problem.block_solver(&problem.block_i).and_then(|si| Ok((si, problem.block_solver(&problem.block_b)?)));
    let method = solvers
        .map(|(solver_i, solver_b)| Sem { settings, solver_i, solver_b, values: Vec::new() })
        .map_err(|e| StopReason::LinearSolveFailed(e.to_string()));
    let start = ReadyMethod { method, columns: AUTHALIC_COLUMNS.to_vec(), analysis: None, charged: 0.0 };
    finished(execute(start, at, &settings.stop, observer))
}

/// SEM's factorizations of `L_II` and `L_BB` (one analysis each, refactored every step).
struct Sem<'a> {
    settings: &'a AuthalicSettings,
    solver_i: SpdSolver,
    solver_b: SpdSolver,
    values: Vec<f64>,
}

impl<'a> Method for Sem<'a> {
    type Iterate = AuthalicIterate<'a>;

    fn step(&mut self, at: &mut AuthalicIterate<'a>, _: usize, _: &mut dyn Observer) -> Result<Step, StopReason> {
        let problem = at.problem;
        let t_start = Instant::now();
        let x = problem.positions_of(&at.z);
        problem.laplacian(Some(&x), &mut self.values);
        let t_assemble = t_start.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let x_new = update(problem, &mut self.solver_i, &mut self.solver_b, &self.values, &x)
            .map_err(|e| StopReason::LinearSolveFailed(e.to_string()))?;
        let t_solve = t0.elapsed().as_secs_f64();
        if let Some(i) = x_new.iter().position(|v| !v.is_finite()) {
            return Err(StopReason::NonFinite(format!("coordinate {i} of the SEM update")));
        }
        let t1 = Instant::now();
        let z_new = problem.vars_of(&x_new);
        let (t_new, g_new) = problem.terms_and_gradient(&z_new);
        let t_eval = t1.elapsed().as_secs_f64();
        if !t_new.energy.is_finite() {
            return Err(StopReason::NonFinite(format!("energy {} after the SEM update", t_new.energy)));
        }
        let ascent = t_new.energy > at.terms.energy;
        if ascent && self.settings.sem_stop_on_increase {
            return Err(StopReason::EnergyIncreased);
        }
        let decrease = at.terms.energy - t_new.energy;
        // |x_new - x| in image coordinates (angles may unwrap differently).
        let step_len = norm(&x_new.iter().zip(&x).map(|(a, b)| a - b).collect::<Vec<_>>());
        *at = AuthalicIterate::new(problem, z_new, t_new, &g_new);
        Ok(Step {
            step: step_len,
            decrease: Some(decrease),
            t_assemble: t_assemble + t_eval,
            t_solve,
            extra: Extras { ascent, ..Default::default() }.values(&at.terms),
            ..Step::default()
        })
    }
}

/// One SEM update (Eq. 14a-e) from interleaved positions `x` with `L = L_S(x)` in `values`,
/// in the order of the reference code SEMc: the boundary first, from the inverted interior
/// of `x` (14b-e), then the interior for that boundary (14a). The returned map is therefore
/// consistent (its interior solves the Dirichlet problem of its own boundary), as the initial
/// map is; the paper's order (interior first) would leave the interior one boundary behind.
fn update(
    problem: &AuthalicProblem,
    solver_i: &mut SpdSolver,
    solver_b: &mut SpdSolver,
    values: &[f64],
    x: &[f64],
) -> Result<Vec<f64>, LinearError> {
    let nb = problem.n_boundary();
    // R: inversion of the interior points in the unit circle (14c).
    let mut w = [vec![0.0; problem.n], vec![0.0; problem.n]];
    for &v in &problem.interior {
        let (u, t) = (x[2 * v], x[2 * v + 1]);
        let r2 = u * u + t * t;
        w[0][v] = u / r2;
        w[1][v] = t / r2;
    }
    solver_b.factorize(&problem.block_b.gather(values), &EXACT)?;
    let mut fb = [vec![0.0; nb], vec![0.0; nb]];
    for (out, wd) in fb.iter_mut().zip(&w) {
        let lw = problem.pattern.mul(values, wd);
        let rhs: Vec<f64> = problem.boundary.iter().map(|&v| -lw[v]).collect();
        let y = solver_b.solve_factored(&rhs)?;
        // C: centring (14d).
        let mean = y.iter().sum::<f64>() / nb as f64;
        *out = y.iter().map(|v| v - mean).collect();
    }
    let mut x_new = x.to_vec();
    // N: each boundary point to unit length (14e).
    for (b, &v) in problem.boundary.iter().enumerate() {
        let r = fb[0][b].hypot(fb[1][b]);
        x_new[2 * v] = fb[0][b] / r;
        x_new[2 * v + 1] = fb[1][b] / r;
    }
    // 14a with the new boundary and the same L.
    let ni = problem.n_interior();
    let fi = problem.interior_solve(solver_i, values, &x_new)?;
    for (i, &v) in problem.interior.iter().enumerate() {
        x_new[2 * v] = fi[i];
        x_new[2 * v + 1] = fi[ni + i];
    }
    Ok(x_new)
}
