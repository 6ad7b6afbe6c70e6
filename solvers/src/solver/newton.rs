//! The Newton-type driver shared by every system-matrix strategy (complex-view paper,
//! Algorithm 1): evaluate, build the per-element blocks, assemble, factorize and solve,
//! injective step plus Armijo line search, repeat. "All methods share the same pipeline and
//! we only replace the system matrix" (Section 6).

use super::proxy::{ProxyError, ScalarProxy};
use super::truncated::{Forcing, Preconditioner, TruncatedSolve, CG_COLUMNS};
use super::{AnalysisReport, IterationRecord, Observer, Outcome, Settings, SolveError, StopReason, SystemView};
use crate::assembly::{pack_lower, Lower6, Pattern, SymmetricRows};
use crate::hessian::pn::TrustRegion;
use crate::hessian::SystemBlock;
use crate::line_search::{armijo, max_injective_step};
use crate::linear::{next_shift, LinearSettings, SpdSolver, MAX_REGULARIZATION_RETRIES};
use crate::problem::{EnergyScratch, Evaluation, MapProblem};
use crate::smoothness::{self, Matrix8};

use rayon::prelude::*;
use std::time::Instant;

/// Alias kept for readability at call sites.
pub type NewtonSettings = Settings;

/// How the driver solves each Newton system.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SystemSolve {
    /// Sparse Cholesky of the system, analysed once and factorized every iteration.
    #[default]
    Factorized,
    /// Truncated: preconditioned CG to an Eisenstat-Walker forcing term (`solver::truncated`),
    /// with the CG columns in the iteration CSVs.
    Truncated(Preconditioner),
}

/// The linear solver of a run: a factorization of the system, or the truncated steps with
/// their forcing terms.
enum Linear {
    Factorized(Box<SpdSolver>),
    Truncated(Box<TruncatedSolve>, Forcing),
}

/// Per-element system blocks of `strategy` at the evaluated iterate (parallel; each block
/// depends only on its element), and the smoothness term's edge blocks projected as
/// configured (Section 4.3).
pub fn project_blocks(
    problem: &MapProblem,
    ev: &Evaluation,
    strategy: &dyn SystemBlock,
    blocks: &mut Vec<Lower6>,
    edge_blocks: &mut Vec<Matrix8>,
) {
    let weight = problem.weight();
    blocks.resize(problem.n_faces(), [0.0; 21]);
    blocks.par_iter_mut().zip(ev.states.par_iter()).zip(problem.ops.par_iter()).for_each(|((b, s), op)| {
        *b = pack_lower(&(strategy.block(op, s) * weight));
    });
    if let Some(sm) = &problem.smoothness {
        edge_blocks.resize(sm.pairs.len(), Matrix8::zeros());
        edge_blocks.par_iter_mut().enumerate().for_each(|(k, b)| {
            let [i, j] = sm.pairs[k].faces;
            *b = smoothness::block(sm.coefficient(k), &ev.states[i], &ev.states[j], &sm.ops[k], sm.projection);
        });
    }
}

/// The lower-triangle values of the system matrix on `pattern`: the blocks, the strategy's
/// diagonal shift (SLIM's proximal term) and the handle penalty's diagonal.
pub fn scatter(
    problem: &MapProblem,
    pattern: &Pattern,
    strategy: &dyn SystemBlock,
    blocks: &[Lower6],
    edge_blocks: &[Matrix8],
    values: &mut Vec<f64>,
) {
    pattern.assemble_with_edges(blocks, edge_blocks, values);
    let shift = strategy.diagonal_shift();
    if shift != 0.0 {
        for &p in &pattern.diag {
            values[p] += shift;
        }
    }
    if let Some(pen) = &problem.penalty {
        for (dof, h) in pen.diagonal() {
            values[pattern.diag[dof]] += h;
        }
    }
}

/// [`newton_with`] factorizing every system.
pub fn newton(
    problem: &MapProblem,
    x0: Vec<f64>,
    strategy: &dyn SystemBlock,
    settings: &Settings,
    observer: &mut dyn Observer,
) -> Result<Outcome, SolveError> {
    newton_with(problem, x0, strategy, SystemSolve::Factorized, settings, observer)
}

/// The Newton driver with `strategy`'s system matrix, solved as `solve` says.
pub fn newton_with(
    problem: &MapProblem,
    x0: Vec<f64>,
    strategy: &dyn SystemBlock,
    solve: SystemSolve,
    settings: &Settings,
    observer: &mut dyn Observer,
) -> Result<Outcome, SolveError> {
    let pattern = problem.system_pattern();
    let t_setup = Instant::now();
    let mut edge_blocks: Vec<Matrix8> = vec![Matrix8::zeros(); pattern.edge_scatter.len()];
    // The constant preconditioner is built and factored once: that is part of the method's
    // cost and goes into iteration 1 (as AQP's proxy); the reweighted one is factored in
    // every iteration. Its analysis, like the factorized variant's, is the run's `analysis_s`.
    let mut t_factor = 0.0;
    let (linear, analysis) = match solve {
        SystemSolve::Factorized => {
            let s = SpdSolver::shared(&pattern, settings.linear.ordering, settings.analyses.as_deref())?;
            let analysis = AnalysisReport::of(&s);
            (Ok(Linear::Factorized(Box::new(s))), analysis)
        }
        SystemSolve::Truncated(preconditioner) => {
            let proxy = match preconditioner {
                Preconditioner::Laplacian => ScalarProxy::new(problem, settings),
                Preconditioner::Stiffness => ScalarProxy::analysed(problem, settings),
            };
            match proxy {
                Ok(proxy) => {
                    let analysis = proxy.analysis;
                    t_factor = (t_setup.elapsed().as_secs_f64() - analysis.setup_seconds).max(0.0);
                    let options = settings.options.newton_cg;
                    let steps = TruncatedSolve::new(proxy, SymmetricRows::new(&pattern), options);
                    let forcing = Forcing::new(options.eta_max, settings.stop.grad_tol);
                    (Ok(Linear::Truncated(Box::new(steps), forcing)), analysis)
                }
                Err(ProxyError::Setup(e)) => return Err(e),
                Err(ProxyError::Failed(reason)) => (Err(reason), AnalysisReport::default()),
            }
        }
    };
    let mut names: Vec<&'static str> = strategy.counter_names().to_vec();
    if matches!(solve, SystemSolve::Truncated(_)) {
        names.extend(CG_COLUMNS);
    }
    let mut x = x0;
    let mut ev = Evaluation::default();
    problem.evaluate(&x, &mut ev)?;
    let init_energy = ev.energy;
    // No system has been built at row 0: the strategy's counters are not defined yet.
    let mut record = IterationRecord::initial(problem, &x, &ev, &names);
    let mut halt = observer.observe(&record).stop_reason();
    let mut linear = match linear {
        Ok(l) => l,
        Err(reason) => return Ok(Outcome::at(x, &record, init_energy, halt.unwrap_or(reason), Some(analysis))),
    };

    let mut blocks: Vec<Lower6> = vec![[0.0; 21]; problem.n_faces()];
    let mut values = Vec::new();
    let mut x_new = Vec::with_capacity(x.len());
    // Per-iteration buffers, allocated once: the right-hand side, the Newton direction and
    // the line search's energy sums.
    let (mut rhs, mut d) = (Vec::with_capacity(x.len()), Vec::with_capacity(x.len()));
    let mut scratch = EnergyScratch::default();
    let mut last_decrease = f64::INFINITY;
    // An adaptive filter's state: the filter of the next system and the last step's model fit.
    let trust_region = strategy.trust_region();
    let mut filter = TrustRegion::FIRST;
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

        let adaptive = trust_region.map(|tr| tr.system(filter));
        let system: &dyn SystemBlock = match &adaptive {
            Some(a) => a,
            None => strategy,
        };
        project_blocks(problem, &ev, system, &mut blocks, &mut edge_blocks);
        let mut counters = system.counters(&ev.states);
        let mut t_project = t_start.elapsed().as_secs_f64();

        let t0 = Instant::now();
        scatter(problem, &pattern, system, &blocks, &edge_blocks, &mut values);
        let t_scatter = t0.elapsed().as_secs_f64();

        observer.system(&SystemView {
            iter,
            col_ptr: &pattern.col_ptr,
            row_idx: &pattern.row_idx,
            diag: &pattern.diag,
            values: &values,
            grad: &ev.grad,
            linear: &settings.linear,
        });
        let t0 = Instant::now();
        let mut cg_columns = Vec::new();
        let shift = match &mut linear {
            Linear::Factorized(linear) => {
                rhs.clear();
                rhs.extend(ev.grad.iter().map(|g| -g));
                let mut lin = LinearSettings { ..settings.linear };
                let mut solved = linear.factorize(&values, &lin).and_then(|_| linear.solve_factored_into(&rhs, &mut d));
                let retries = if strategy.retries_failed_factorization() { MAX_REGULARIZATION_RETRIES } else { 0 };
                for _ in 0..retries {
                    if solved.is_ok() {
                        break;
                    }
                    lin.tikhonov = next_shift(lin.tikhonov);
                    solved = linear.factorize(&values, &lin).and_then(|_| linear.solve_factored_into(&rhs, &mut d));
                }
                if let Err(e) = solved {
                    let tried = if retries == 0 {
                        format!("shift {:e}, no retry", settings.linear.tikhonov)
                    } else {
                        format!("shifts {:e} to {:e}", settings.linear.tikhonov, lin.tikhonov)
                    };
                    break StopReason::LinearSolveFailed(format!("the system at iterate {iter}: {e} ({tried})"));
                }
                lin.tikhonov
            }
            Linear::Truncated(steps, forcing) => {
                if solve == SystemSolve::Truncated(Preconditioner::Stiffness) {
                    if let Err(reason) = steps.proxy.reweight(problem, &blocks, &settings.linear) {
                        break reason;
                    }
                }
                let eta = forcing.next(record.grad_norm);
                match steps.solve(&values, &ev.grad, eta, &mut d) {
                    Ok(cg) => {
                        cg_columns.extend([cg.iterations as f64, eta, cg.residual, f64::from(u8::from(cg.capped()))])
                    }
                    Err(e) => {
                        break StopReason::LinearSolveFailed(format!("the preconditioner at iterate {iter}: {e}"))
                    }
                }
                // the system itself is not shifted; the preconditioner's factorization was
                steps.proxy.shift
            }
        };
        let t_charged = std::mem::take(&mut t_factor);
        let t_solve = t0.elapsed().as_secs_f64() + t_charged;

        let t0 = Instant::now();
        let g_dot_d: f64 = ev.grad.iter().zip(&d).map(|(g, d)| g * d).sum();
        if !(g_dot_d < 0.0) {
            break StopReason::NotDescent;
        }
        let t_max = max_injective_step(problem, &x, &d);
        let t_init = (settings.line_search.max_step_fraction * t_max).min(1.0);
        let (accepted, ls_evals) =
            armijo(problem, &x, &d, ev.energy, g_dot_d, t_init, &settings.line_search, &mut x_new, &mut scratch);
        let t_ls = t0.elapsed().as_secs_f64();
        let Some(acc) = accepted else {
            break StopReason::LineSearchFailed;
        };
        std::mem::swap(&mut x, &mut x_new);
        last_decrease = ev.energy - acc.energy;
        if let Some(tr) = &trust_region {
            // The model fit of the step actually taken, s = t d, with the unfiltered Hessian
            // at the old iterate (`ev` still holds it).
            let t0 = Instant::now();
            let predicted = -(acc.t * g_dot_d + 0.5 * acc.t * acc.t * problem.hessian_form(&ev, &d));
            let fit = TrustRegion::fit(last_decrease, predicted, ev.energy);
            counters = vec![filter.code(), fit];
            filter = tr.next(fit);
            t_project += t0.elapsed().as_secs_f64();
        }

        let t0 = Instant::now();
        // The next system needs the states, energy and gradient; the inertia is counted for
        // the row (the projections find their negative eigenvalues themselves).
        if let Err(e) = problem.evaluate_without_inertia(&x, &mut ev) {
            // The line search only accepts finite energies, so this is a derivative overflow.
            break StopReason::NonFinite(e.to_string());
        }
        let t_eval = t0.elapsed().as_secs_f64();
        let t_iter = t_start.elapsed().as_secs_f64() + t_charged;
        // Record-only work (IterationRecord::t_record_s): the inertia counts and the flips.
        let t0 = Instant::now();
        problem.count_inertia(&mut ev);
        let flips = problem.flips(&x);
        let t_record = t0.elapsed().as_secs_f64();
        t_cum += t_iter;
        iter += 1;
        record = IterationRecord {
            t_assemble_s: t_eval + t_scatter,
            t_project_s: t_project,
            t_solve_s: t_solve,
            t_linesearch_s: t_ls,
            t_iter_s: t_iter,
            t_cum_s: t_cum,
            t_record_s: t_record,
            shift: Some(shift),
            ls_evals,
            extra: names.iter().copied().zip(counters.into_iter().chain(cg_columns)).collect(),
            ..IterationRecord::of(iter, &ev, flips, acc.t)
        };
        halt = observer.observe(&record).stop_reason();
    };
    Ok(Outcome::at(x, &record, init_energy, stop, Some(analysis)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::EnergyKind;
    use crate::hessian::kp::Kp;
    use crate::local::LocalOp;
    use crate::mesh::Mesh;
    use crate::solver::{Recorder, StopSettings};
    use nalgebra::Matrix6;

    /// A 4-triangle fan mapped with a stretch, so SD has work to do.
    fn problem() -> (MapProblem, Vec<f64>) {
        let p = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]];
        let f = vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]];
        let mesh = Mesh::new("fan", p.clone(), f);
        let x = p.iter().flat_map(|q| [2.0 * q[0], 0.7 * q[1]]).collect();
        (MapProblem::new(&mesh, EnergyKind::Sd).unwrap(), x)
    }

    fn settings() -> Settings {
        Settings {
            stop: StopSettings { grad_tol: 1e-9, energy_decrease_tol: 0.0, max_iters: 100 },
            ..Settings::default()
        }
    }

    /// A broken strategy: negative definite blocks make every factorization fail.
    struct NegativeDefinite;
    impl SystemBlock for NegativeDefinite {
        fn block(&self, op: &LocalOp, _s: &crate::hessian::ElementState) -> Matrix6<f64> {
            -Matrix6::identity() * op.area
        }
    }

    #[test]
    fn converges_on_a_fan_to_the_isometry() {
        let (pb, x) = problem();
        let mut rec = Recorder::default();
        let out = newton(&pb, x, &Kp, &settings(), &mut rec).unwrap();
        assert_eq!(out.stop_reason, StopReason::GradientTolerance);
        assert!((out.final_energy - 2.0).abs() < 1e-12);
        // rows: 0 = initial state, then one per accepted step; energies non-increasing
        assert_eq!(rec.rows.len(), out.iterations + 1);
        assert!(rec.rows.windows(2).all(|w| w[1].energy <= w[0].energy && w[1].iter == w[0].iter + 1));
        assert!(rec.rows[1..].iter().all(|r| r.step > 0.0 && r.t_iter_s >= r.t_solve_s));
    }

    #[test]
    fn failed_factorization_stops_with_a_reason_and_keeps_the_iterate() {
        let (pb, x) = problem();
        let mut rec = Recorder::default();
        let out = newton(&pb, x.clone(), &NegativeDefinite, &settings(), &mut rec).unwrap();
        assert_eq!(out.stop_reason.as_str(), "linear_solve_failed");
        assert!(out.stop_reason.detail().is_some());
        assert_eq!(out.iterations, 0);
        assert_eq!(out.x, x);
        assert_eq!(rec.rows.len(), 1);
    }

    /// KP's blocks minus `delta` times their diagonal. The assembled matrix is `K - delta
    /// diag(K)`, so after Jacobi scaling it is `S K S - delta/(1 - delta) I`: KP's (PSD, with
    /// the translations in its kernel) pushed below zero by about `delta`. A shift of 0.1 on
    /// the scaled diagonal makes it definite again, the smaller ones do not.
    struct Dented {
        delta: f64,
        retry: bool,
    }
    impl SystemBlock for Dented {
        fn block(&self, op: &LocalOp, s: &crate::hessian::ElementState) -> Matrix6<f64> {
            let b = Kp.block(op, s);
            b - Matrix6::from_diagonal(&b.diagonal()) * self.delta
        }
        fn retries_failed_factorization(&self) -> bool {
            self.retry
        }
    }

    #[test]
    fn each_row_records_the_shift_of_its_system() {
        let (pb, x) = problem();
        let base = settings().linear.tikhonov;
        let mut rec = Recorder::default();
        let out = newton(&pb, x.clone(), &Kp, &settings(), &mut rec).unwrap();
        assert!(out.iterations > 2);
        // row 0 has no system; KP's systems factorize at the base shift
        assert_eq!(rec.rows[0].shift, None);
        assert!(rec.rows[1..].iter().all(|r| r.shift == Some(base)), "{:?}", rec.rows);

        // a system that fails until the third retry: each row records that retry's shift
        let third = next_shift(next_shift(next_shift(base)));
        assert!((third - 0.1).abs() < 1e-12, "{third}");
        let mut rec = Recorder::default();
        let out = newton(&pb, x.clone(), &Dented { delta: 0.01, retry: true }, &settings(), &mut rec).unwrap();
        assert!(out.iterations >= 1, "{:?}", out.stop_reason);
        assert_eq!(rec.rows[0].shift, None);
        assert!(rec.rows[1..].iter().all(|r| r.shift == Some(third)), "{:?}", rec.rows);

        // beyond the last retry: the run stops, saying which shifts it tried
        let mut rec = Recorder::default();
        let out = newton(&pb, x, &Dented { delta: 0.5, retry: true }, &settings(), &mut rec).unwrap();
        let detail = out.stop_reason.detail().unwrap().to_string();
        assert_eq!((out.stop_reason.as_str(), out.iterations, rec.rows.len()), ("linear_solve_failed", 0, 1));
        assert!(
            detail.starts_with("the system at iterate 0: ")
                && detail.ends_with(&format!("(shifts 1e-10 to {third:e})")),
            "{detail}"
        );
    }

    #[test]
    fn a_strategy_without_retry_stops_at_its_first_failed_factorization() {
        let (pb, x) = problem();
        let mut rec = Recorder::default();
        let out = newton(&pb, x.clone(), &Dented { delta: 0.01, retry: false }, &settings(), &mut rec).unwrap();
        assert_eq!(out.stop_reason.as_str(), "linear_solve_failed");
        assert_eq!(out.stop_reason.detail().map(|d| d.ends_with("(shift 1e-10, no retry)")), Some(true));
        assert_eq!((out.iterations, rec.rows.len()), (0, 1));
        assert_eq!(out.x, x);
        // unprojected Newton is such a strategy
        assert!(!crate::hessian::none::Unprojected.retries_failed_factorization());
        assert!(Kp.retries_failed_factorization());
    }

    #[test]
    fn strategy_counters_follow_the_design_columns() {
        let (pb, x) = problem();
        let mut rec = Recorder::default();
        newton(&pb, x, &crate::hessian::slim::Slim, &settings(), &mut rec).unwrap();
        assert!(rec.rows.len() > 2);
        // row 0: no system yet; then SD's weights, which are never clamped
        assert_eq!(rec.rows[0].extra.len(), 1);
        assert!(rec.rows[0].extra[0].0 == "clamped" && rec.rows[0].extra[0].1.is_nan());
        assert!(rec.rows[1..].iter().all(|r| r.extra == [("clamped", 0.0)]), "{:?}", rec.rows);
    }

    #[test]
    fn observer_can_interrupt() {
        let (pb, x) = problem();
        let out = newton(&pb, x, &Kp, &settings(), &mut crate::solver::StopAt(1)).unwrap();
        assert_eq!(out.stop_reason, StopReason::Interrupted);
        assert_eq!(out.iterations, 1);
    }

    #[test]
    fn a_passed_deadline_stops_with_timeout() {
        let (pb, x) = problem();
        for k in [0, 1] {
            let out = newton(&pb, x.clone(), &Kp, &settings(), &mut crate::solver::TimeoutAt(k)).unwrap();
            assert_eq!(out.stop_reason, StopReason::Timeout, "at {k}");
            assert_eq!(out.iterations, k);
        }
    }

    #[test]
    fn max_iterations_and_inverted_start() {
        let (pb, x) = problem();
        let mut s = settings();
        s.stop.max_iters = 1;
        let out = newton(&pb, x.clone(), &Kp, &s, &mut Recorder::default()).unwrap();
        assert_eq!(out.stop_reason, StopReason::MaxIterations);
        assert_eq!(out.iterations, 1);
        // an inverted initial map is an error naming the element
        let mut bad = x;
        bad[2] = -5.0; // vertex 1 across vertex 0
        let err = newton(&pb, bad, &Kp, &s, &mut Recorder::default()).unwrap_err();
        assert!(err.to_string().contains("element"), "{err}");
    }
}
