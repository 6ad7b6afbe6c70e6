//! AQP, the Accelerated Quadratic Proxy (Kovalsky, Galun and Lipman, SIGGRAPH 2016): a
//! constant quadratic proxy of the energy, factored once, used as the preconditioner of a
//! Nesterov-type accelerated descent, with the authors' step memory and injectivity caps.
//!
//! - Proxy: `H = 2 sum_t a_t T_t^T T_t / sum_t a_t`, the Hessian of the Dirichlet energy
//!   `sum_t a_t |J_t|^2 / sum_t a_t` (`solver::proxy`, shared with `lbfgs-laplacian`), plus
//!   the soft handles' `2 lambda` for `deform` (the authors use hard constraints in a KKT
//!   system; a constant penalty keeps the proxy constant). For the free boundary (`param`)
//!   vertex 0 is pinned (identity rows; its components of every direction are 0) instead of
//!   the authors' constraint "sum of the boundary coordinates = 0": both only remove the
//!   translations, which change no energy.
//! - Momentum: `v = x - x_prev`, `eta = min(theta, 0.5 t_max(x, v))`, `y = x + eta v`, with
//!   `theta = (1 - sqrt(1/kappa)) / (1 + sqrt(1/kappa))` and `kappa = KAPPA` (the authors'
//!   examples: 1000, `theta = 0.9387`).
//! - Proxy step from `y`: `p = -H^-1 grad f(y)`, `t0 = min(t_mem, 0.5 t_max(y, p))` with the
//!   step memory `t_mem = min(1, 2^5.5 t_prev)` (first `t_prev = 2^-5.5`, so `t_mem = 1`),
//!   then Armijo backtracking against `f(y)` (`line_search::armijo` with `[line_search]`'s
//!   `armijo_c`, `shrink` and `min_step`, by default the authors' 0.2 and halving; its
//!   `max_step_fraction` is not used: AQP's caps are its own 0.5). `x_prev = x`,
//!   `x = y + t p`, `t_prev = t`.
//!
//! AQP is not monotone in `x` (Armijo holds against `f(y)`, not `f(x)`). Each row records the
//! energy, gradient norm and inertia at `x`, and the shared stop rules
//! (`StopSettings::reached`) are checked on them: the gradient rule on `|grad f(x)|`, the
//! energy-decrease rule on `f(x_k) - f(x_k+1)` of the last iteration in which `f(x)` did not
//! rise. An iteration in which `f(x)` rises is not a stall (its decrease is negative, below
//! any tolerance, and would stop the `deform` runs at the first rise); it leaves the rule's
//! last decrease unchanged (infinite before the first decrease). The rises stay visible in
//! the `energy` column.
//!
//! There is no restart and no monotonicity safeguard (the authors have none); a direction
//! that is not a descent direction or a line search that finds no step ends the run.

use super::proxy::{Proxy, ProxyError};
use super::{IterationRecord, Observer, Outcome, Settings, StopReason};
use crate::line_search::{armijo, max_injective_step};
use crate::problem::{norm, EnergyScratch, Evaluation, MapProblem};
use crate::solver::newton::SolveError;
use std::time::Instant;

/// The condition number the momentum is set for (the authors' examples).
pub const KAPPA: f64 = 1000.0;
/// Both steps, the momentum step along `v` and the proxy step along `p`, stop at this
/// fraction of the largest injective step.
pub const STEP_FRACTION: f64 = 0.5;
/// `log2` of the step memory's growth: `t_mem = min(1, 2^5.5 t_prev)`.
pub const STEP_MEMORY_LOG2: f64 = 5.5;

/// The extra CSV columns: `momentum` is the momentum step `eta` (0 when `v = 0`, i.e. in
/// iteration 1, where `y = x`); `energy_y` is `f(y)`, the Armijo reference; `t_init` is the
/// line search's first trial `min(t_mem, 0.5 t_max(y, p))`. NaN in row 0. `ls_evals` counts
/// the line search's energy evaluations only; every iteration with `momentum > 0` also
/// evaluates energy and gradient at `y` (and every iteration at the new `x`, for its row).
pub const AQP_COLUMNS: [&str; 3] = ["momentum", "energy_y", "t_init"];

/// `theta = (1 - sqrt(1/kappa)) / (1 + sqrt(1/kappa))`.
pub fn theta(kappa: f64) -> f64 {
    let r = (1.0 / kappa).sqrt();
    (1.0 - r) / (1.0 + r)
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// AQP from `x0` (orientation preserving) with the shared stop rules (`settings.stop`).
pub fn aqp(
    problem: &MapProblem,
    x0: Vec<f64>,
    settings: &Settings,
    observer: &mut dyn Observer,
) -> Result<Outcome, SolveError> {
    let t_setup = Instant::now();
    let proxy = match Proxy::new(problem, &settings.linear, settings) {
        Ok(p) => Ok(p),
        Err(ProxyError::Setup(e)) => return Err(e),
        Err(ProxyError::Failed(reason)) => Err(reason),
    };
    let analysis = proxy.as_ref().ok().map(|p| p.analysis);
    let shift = proxy.as_ref().ok().map(|p| p.shift);
    // The numeric factorization is part of the method's cost: it goes into iteration 1.
    let mut t_factor = (t_setup.elapsed().as_secs_f64() - analysis.map_or(0.0, |a| a.setup_seconds)).max(0.0);

    let mut x = x0;
    let mut ev = Evaluation::default();
    problem.evaluate(&x, &mut ev)?;
    let init_energy = ev.energy;
    let mut record = IterationRecord {
        iter: 0,
        energy: ev.energy,
        grad_norm: norm(&ev.grad),
        neg_eig: ev.neg_eig,
        indefinite_elems: ev.indefinite_elems,
        flips: problem.flips(&x),
        extra: AQP_COLUMNS.iter().map(|&n| (n, f64::NAN)).collect(),
        ..Default::default()
    };
    let mut halt = observer.observe(&record).stop_reason();
    let outcome = |iterations, stop_reason, record: &IterationRecord, x| Outcome {
        iterations,
        stop_reason,
        init_energy,
        final_energy: record.energy,
        grad_norm: record.grad_norm,
        flips: record.flips,
        x,
        analysis,
    };
    let mut proxy = match proxy {
        Ok(p) => p,
        Err(reason) => return Ok(outcome(0, halt.unwrap_or(reason), &record, x)),
    };

    let theta = theta(KAPPA);
    let memory = STEP_MEMORY_LOG2.exp2();
    let mut t_prev = 1.0 / memory;
    let mut x_prev = x.clone();
    let (mut v, mut y, mut p, mut x_new) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut ev_y = Evaluation::default();
    let mut scratch = EnergyScratch::default();
    let mut last_decrease = f64::INFINITY;
    let mut t_cum = 0.0;
    let mut iter = 0usize;
    let stop = loop {
        if let Some(reason) = halt.take() {
            break reason;
        }
        if let Some(reason) = settings.stop.reached(record.grad_norm, last_decrease, iter) {
            break reason;
        }
        let t_start = Instant::now();
        let (mut t_eval, mut t_solve, mut t_ls) = (0.0, 0.0, 0.0);

        // 1. momentum: y = x + eta v, injective by the 0.5 t_max cap
        let t0 = Instant::now();
        v.clear();
        v.extend(x.iter().zip(&x_prev).map(|(a, b)| a - b));
        let eta = if norm(&v) > 0.0 { theta.min(STEP_FRACTION * max_injective_step(problem, &x, &v)) } else { 0.0 };
        t_ls += t0.elapsed().as_secs_f64();
        let moved = eta > 0.0;
        if moved {
            let t0 = Instant::now();
            y.clear();
            y.extend(x.iter().zip(&v).map(|(a, b)| a + eta * b));
            let evaluated = problem.evaluate(&y, &mut ev_y);
            t_eval += t0.elapsed().as_secs_f64();
            if let Err(e) = evaluated {
                break StopReason::NonFinite(format!("at the momentum point of iterate {iter}: {e}"));
            }
        }
        let (y_at, at_y) = if moved { (&y, &ev_y) } else { (&x, &ev) };

        // 2. the proxy direction at y
        let t0 = Instant::now();
        p.clone_from(&at_y.grad);
        let solved = proxy.apply(&mut p);
        p.iter_mut().for_each(|q| *q = -*q);
        t_solve += t0.elapsed().as_secs_f64();
        if let Err(e) = solved {
            break StopReason::LinearSolveFailed(format!("the Laplacian proxy at iterate {iter}: {e}"));
        }
        let g_dot_p = dot(&at_y.grad, &p);
        if !(g_dot_p < 0.0) {
            break StopReason::NotDescent;
        }

        // 3. the step from y: step memory, 0.5 t_max cap, Armijo against f(y)
        let t0 = Instant::now();
        let t_mem = (t_prev * memory).min(1.0);
        let t_init = t_mem.min(STEP_FRACTION * max_injective_step(problem, y_at, &p));
        let (accepted, ls_evals) =
            armijo(problem, y_at, &p, at_y.energy, g_dot_p, t_init, &settings.line_search, &mut x_new, &mut scratch);
        t_ls += t0.elapsed().as_secs_f64();
        let Some(accepted) = accepted else {
            break StopReason::LineSearchFailed;
        };
        let energy_y = at_y.energy;

        // 4. x_prev = x, x = y + t p
        std::mem::swap(&mut x_prev, &mut x);
        std::mem::swap(&mut x, &mut x_new);
        t_prev = accepted.t;
        let e_old = ev.energy;
        let t0 = Instant::now();
        if let Err(e) = problem.evaluate(&x, &mut ev) {
            break StopReason::NonFinite(e.to_string());
        }
        t_eval += t0.elapsed().as_secs_f64();
        // A rise of f(x) is not a stall: the decrease rule sees the iterations without one.
        let decrease = e_old - ev.energy;
        if !(decrease < 0.0) {
            last_decrease = decrease;
        }
        let flips = problem.flips(&x);
        let t_iter = t_start.elapsed().as_secs_f64() + t_factor;
        t_solve += std::mem::take(&mut t_factor);
        t_cum += t_iter;
        iter += 1;
        record = IterationRecord {
            iter,
            energy: ev.energy,
            grad_norm: norm(&ev.grad),
            step: accepted.t,
            neg_eig: ev.neg_eig,
            indefinite_elems: ev.indefinite_elems,
            flips,
            t_assemble_s: t_eval,
            t_project_s: 0.0,
            t_solve_s: t_solve,
            t_linesearch_s: t_ls,
            t_iter_s: t_iter,
            t_cum_s: t_cum,
            shift,
            ls_evals,
            extra: AQP_COLUMNS.iter().copied().zip([eta, energy_y, t_init]).collect(),
        };
        halt = observer.observe(&record).stop_reason();
    };
    Ok(outcome(iter, stop, &record, x))
}

