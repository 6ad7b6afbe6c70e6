//! `aem-cg` and `aem-cg-safe`: the preconditioned nonlinear conjugate gradient method of
//! authalic energy minimization (AEM paper, Algorithm 1).
//!
//! Faithful variant: preconditioner `M = blockdiag(I_2 (x) [L_S(f0)]_II, [L_S(f0)]_BB)`
//! factored once (Eq. 20-21), preconditioned Fletcher-Reeves (Eq. 19), and the step of the
//! quadratic through `Phi(0)`, `Phi'(0)`, `Phi(alpha_prev)` (Eq. 18) with `alpha_0 = 2`. It
//! never checks the step, so the energy may increase; every such row has `ascent = 1`.
//!
//! Safe variant: the same direction and trial step, plus (a) a restart `p = -h` (with the
//! trial step reset to `alpha_0`) when `p` is not a descent direction or the fold guard cut
//! the previous step, (b) `alpha = alpha_prev` when the quadratic has no minimum,
//! (c) Armijo (22a) with halving, (d) a fold guard ([`FoldGuard`]; by default it rejects
//! steps that break the boundary ordering `theta_1 < ... < theta_nB < theta_1 + 2 pi` of
//! Eq. 10, which Algorithm 1 does not enforce), and (e) one restart along `-h` if backtracking fails. The columns
//! `restarted`, `quad_fallback`, `backtracks`, `fold_rejects` say which fired; `wolfe` says
//! whether the accepted step meets the curvature condition (22b) that the convergence proof
//! assumes (recorded for both variants, never enforced).

use crate::problem::{dot, norm};

use super::iterate::{finished, AuthalicIterate, Extras, AUTHALIC_COLUMNS};

use super::problem::{AuthalicOutcome, AuthalicProblem, AuthalicSettings, EvalBuffers, FoldGuard, Terms, EXACT};
use crate::linear::{LinearError, SpdSolver};
use crate::solver::executor::{execute, Method, ReadyMethod, Step};
use crate::solver::{Observer, StopReason};
use std::time::Instant;

/// The block-diagonal preconditioner, factored once.
struct Preconditioner {
    ni: usize,
    interior: SpdSolver,
    boundary: SpdSolver,
}

impl Preconditioner {
    fn new(problem: &AuthalicProblem, z0: &[f64]) -> Result<Preconditioner, LinearError> {
        let mut values = Vec::new();
        problem.laplacian(Some(&problem.positions_of(z0)), &mut values);
        let (bi, bb) = (&problem.block_i, &problem.block_b);
        let mut interior = problem.block_solver(bi)?;
        interior.factorize(&bi.gather(&values), &EXACT)?;
        let mut boundary = problem.block_solver(bb)?;
        boundary.factorize(&bb.gather(&values), &EXACT)?;
        Ok(Preconditioner { ni: problem.n_interior(), interior, boundary })
    }

    /// `h = M^{-1} g` by triangular solves with the stored factors (Eq. 21); the two interior
    /// coordinates `[g_I^1; g_I^2]` are the two columns of one solve.
    fn apply(&mut self, g: &[f64]) -> Result<Vec<f64>, LinearError> {
        let mut h = Vec::new();
        self.apply_into(g, &mut h)?;
        Ok(h)
    }

    /// [`Self::apply`] into `h`.
    fn apply_into(&mut self, g: &[f64], h: &mut Vec<f64>) -> Result<(), LinearError> {
        h.clear();
        h.extend_from_slice(g);
        let (interior, boundary) = h.split_at_mut(2 * self.ni);
        self.interior.solve_columns_in_place(interior)?;
        self.boundary.solve_columns_in_place(boundary)
    }
}

fn axpy(z: &[f64], a: f64, p: &[f64]) -> Vec<f64> {
    let mut out = Vec::new();
    axpy_into(z, a, p, &mut out);
    out
}

/// `out = z + a p`, elementwise in parallel (the same bits as in order).
fn axpy_into(z: &[f64], a: f64, p: &[f64], out: &mut Vec<f64>) {
    use rayon::prelude::*;
    out.resize(z.len(), 0.0);
    out.par_iter_mut().zip(z).zip(p).with_min_len(4096).for_each(|((o, x), d)| *o = x + a * d);
}

/// What the step rule of one iteration produced.
struct Trial {
    alpha: f64,
    z: Vec<f64>,
    extras: Extras,
}

/// Run `aem-cg` (or `aem-cg-safe` when `safe`) from the variables `z0`.
pub fn aem_cg(
    problem: &AuthalicProblem,
    z0: Vec<f64>,
    settings: &AuthalicSettings,
    safe: bool,
    observer: &mut dyn Observer,
) -> AuthalicOutcome {
    let mut buf = EvalBuffers::default();
    let mut g = Vec::new();
    let terms = problem.terms_and_gradient_into(&z0, &mut buf, &mut g);
    let at = AuthalicIterate::new(problem, z0, terms, &g);
    let method = Preconditioner::new(problem, &at.z)
        .and_then(|mut precond| Ok((precond.apply(&g)?, precond)))
        .map(|(h, precond)| AemCg {
            settings,
            safe,
            precond,
            p: h.iter().map(|v| -v).collect(),
            hg: dot(&h, &g),
            h,
            g,
            alpha_prev: settings.alpha0,
            truncated: false,
            buf,
            trial: Vec::new(),
            z_next: Vec::new(),
            g_new: Vec::new(),
            h_new: Vec::new(),
        })
        .map_err(linear_failed);
    let start = ReadyMethod { method, columns: AUTHALIC_COLUMNS.to_vec(), analysis: None, charged: 0.0 };
    finished(execute(start, at, &settings.stop, observer))
}

fn linear_failed(e: LinearError) -> StopReason {
    StopReason::LinearSolveFailed(format!("preconditioner: {e}"))
}

/// AEM-CG's state between iterations: the gradient `g` at the iterate, its preconditioned
/// `h = M^-1 g`, the direction `p`, `h . g`, the last step length.
struct AemCg<'a> {
    settings: &'a AuthalicSettings,
    safe: bool,
    precond: Preconditioner,
    g: Vec<f64>,
    h: Vec<f64>,
    p: Vec<f64>,
    hg: f64,
    alpha_prev: f64,
    /// Set when the fold guard truncated the last step: conjugacy is lost, so restart.
    truncated: bool,
    // Vectors of the size of z kept between iterations (fresh ones are faulted in and zeroed
    // each time): the evaluations' buffers, the trial point, the next iterate, gradient and
    // preconditioned gradient.
    buf: EvalBuffers,
    trial: Vec<f64>,
    z_next: Vec<f64>,
    g_new: Vec<f64>,
    h_new: Vec<f64>,
}

impl<'a> Method for AemCg<'a> {
    type Iterate = AuthalicIterate<'a>;

    fn step(&mut self, at: &mut AuthalicIterate<'a>, _: usize, _: &mut dyn Observer) -> Result<Step, StopReason> {
        let AemCg { settings, safe, precond, g, h, p, hg, alpha_prev, truncated, buf, trial, z_next, g_new, h_new } =
            self;
        let problem = at.problem;
        let t_start = Instant::now();
        let phi0 = at.terms.energy;
        let step = if *safe {
            if *truncated {
                *alpha_prev = settings.alpha0;
            }
            safe_step(problem, settings, &at.z, &at.terms, p, h, *hg, g, *alpha_prev, *truncated, buf)
                .ok_or(StopReason::LineSearchFailed)?
        } else {
            // Eq. 18 with one evaluation at the previous step length.
            let dphi0 = dot(p, g);
            axpy_into(&at.z, *alpha_prev, p, trial);
            let phi_a = problem.terms_with(trial, buf).energy;
            let alpha = -*alpha_prev * *alpha_prev * dphi0 / (2.0 * (phi_a - phi0 - *alpha_prev * dphi0));
            if !alpha.is_finite() {
                return Err(StopReason::NonFinite(format!(
                    "quadratic step {alpha} (Phi(0) = {phi0}, Phi'(0) = {dphi0}, Phi({alpha_prev}) = {phi_a})"
                )));
            }
            axpy_into(&at.z, alpha, p, z_next);
            Trial { alpha, z: std::mem::take(z_next), extras: Extras { ls_evals: 1, ..Default::default() } }
        };
        let t_ls = t_start.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let t_new = problem.terms_and_gradient_into(&step.z, buf, g_new);
        let t_assemble = t0.elapsed().as_secs_f64();
        if !(t_new.energy.is_finite() && g_new.iter().all(|v| v.is_finite())) {
            return Err(StopReason::NonFinite(format!("energy {} after step {}", t_new.energy, step.alpha)));
        }
        let mut extras = step.extras;
        *truncated = extras.fold_rejects > 0;
        let dphi0 = dot(p, g);
        extras.ascent = t_new.energy > phi0;
        extras.wolfe = Some(dot(g_new, p).abs() <= settings.wolfe_c2 * dphi0.abs());
        // Preconditioned Fletcher-Reeves (Eq. 19b; Algorithm 1, lines 18-22).
        let t1 = Instant::now();
        precond.apply_into(g_new, h_new).map_err(linear_failed)?;
        let t_solve = t1.elapsed().as_secs_f64();
        let hg_new = dot(h_new, g_new);
        let beta = hg_new / *hg;
        p.iter_mut().zip(h_new.iter()).for_each(|(pk, hn)| *pk = -hn + beta * *pk);
        std::mem::swap(h, h_new);
        *hg = hg_new;
        std::mem::swap(g, g_new);
        // the old iterate's vector becomes the next step's
        *z_next = std::mem::replace(&mut at.z, step.z);
        *alpha_prev = step.alpha;
        let decrease = phi0 - t_new.energy;
        at.terms = t_new;
        at.grad_norm = norm(g);
        Ok(Step {
            step: step.alpha,
            decrease: Some(decrease),
            t_assemble,
            t_solve,
            t_linesearch: t_ls,
            ls_evals: extras.ls_evals,
            extra: extras.values(&at.terms),
            ..Step::default()
        })
    }
}

#[allow(clippy::too_many_arguments)]
fn safe_step(
    problem: &AuthalicProblem,
    settings: &AuthalicSettings,
    z: &[f64],
    terms: &Terms,
    p: &mut Vec<f64>,
    h: &[f64],
    hg: f64,
    g: &[f64],
    alpha_prev: f64,
    force_restart: bool,
    buf: &mut EvalBuffers,
) -> Option<Trial> {
    let mut extras = Extras::default();
    let mut dphi0 = dot(p, g);
    let restart = |p: &mut Vec<f64>| {
        *p = h.iter().map(|v| -v).collect();
        -hg
    };
    if force_restart || !(dphi0 < 0.0) {
        dphi0 = restart(p);
        extras.restarted = true;
    }
    loop {
        let phi0 = terms.energy;
        let trial = problem.terms_with(&axpy(z, alpha_prev, p), buf);
        extras.ls_evals += 1;
        let a2 = (trial.energy - phi0 - alpha_prev * dphi0) / (alpha_prev * alpha_prev);
        let mut alpha = -dphi0 / (2.0 * a2);
        if !(a2 > 0.0 && alpha.is_finite() && alpha > 0.0) {
            alpha = alpha_prev;
            extras.quad_fallback = true;
        }
        for _ in 0..=settings.max_backtracks {
            let zt = axpy(z, alpha, p);
            let t = if alpha == alpha_prev {
                trial
            } else {
                extras.ls_evals += 1;
                problem.terms_with(&zt, buf)
            };
            let armijo = t.energy.is_finite() && t.energy <= phi0 + settings.armijo_c * alpha * dphi0;
            let folds_ok = match settings.fold_guard {
                FoldGuard::None => true,
                FoldGuard::Boundary => problem.boundary_ordered(&zt),
                FoldGuard::All => t.folded <= terms.folded,
            };
            if armijo && folds_ok {
                return Some(Trial { alpha, z: zt, extras });
            }
            if !folds_ok {
                extras.fold_rejects += 1;
            }
            alpha *= 0.5;
            extras.backtracks += 1;
        }
        if extras.restarted {
            return None;
        }
        dphi0 = restart(p);
        extras.restarted = true;
    }
}
