//! The Newton-type driver shared by every system-matrix strategy (complex-view paper,
//! Algorithm 1): evaluate, build the per-element blocks, assemble, factorize and solve,
//! injective step plus Armijo line search, repeat. "All methods share the same pipeline and
//! we only replace the system matrix" (Section 6).

use super::executor::{execute, Method, ReadyMethod, Step};
use super::map_iterate::MapIterate;
use super::newton_system::{Direction, SystemBuilder};
use super::observer::Metric;
use super::observer::Observer;
use super::outcome::{AnalysisReport, Outcome, SolveError};
use super::settings::Settings;
use super::stop::StopReason;
use super::truncated::{NewtonCgOptions, Preconditioner, Truncated, CG_COLUMNS};
use crate::hessian::SystemBlock;
use crate::line_search::{armijo, max_injective_step};
use crate::linear::{with_shift_retries, LinearSettings, SpdSolver, MAX_REGULARIZATION_RETRIES};
use crate::problem::{dot, norm, EnergyScratch, Evaluation, MapProblem};
use crate::smoothness::Projection;
use std::time::Instant;

/// Alias kept for readability at call sites.
pub type NewtonSettings = Settings;

/// How the driver solves each Newton system.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum SystemSolve {
    /// Sparse Cholesky of the system, analysed once and factorized every iteration.
    #[default]
    Factorized,
    /// Truncated: preconditioned CG to an Eisenstat-Walker forcing term (`solver::truncated`),
    /// with the CG columns in the iteration CSVs.
    Truncated(Preconditioner, NewtonCgOptions),
}

/// A Newton-type solver built for one energy: its system-matrix strategy and solve.
pub struct SolverSpec {
    /// The system-matrix strategy: how each element's block is built.
    pub block: Box<dyn SystemBlock>,
    /// Overrides how the smoothness term's 8x8 blocks are projected.
    pub smoothness_projection: Option<Projection>,
    /// How each Newton system is solved.
    pub solve: SystemSolve,
}

impl SolverSpec {
    /// `block`'s systems, factorized.
    pub fn factorized(block: impl SystemBlock + 'static) -> SolverSpec {
        SolverSpec { block: Box::new(block), smoothness_projection: None, solve: SystemSolve::Factorized }
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
    let builder = SystemBuilder::new(problem, strategy);
    let mut columns: Vec<&'static str> = strategy.counter_names().to_vec();
    match solve {
        SystemSolve::Factorized => {
            let s = SpdSolver::shared(&builder.pattern, settings.linear.ordering, settings.analyses.as_deref())?;
            let analysis = Some(AnalysisReport::of(&s));
            let retries = if strategy.retries_failed_factorization() { MAX_REGULARIZATION_RETRIES } else { 0 };
            let linear = Factorized { solver: Box::new(s), base: settings.linear, retries, rhs: Vec::new() };
            let method = Ok(NewtonStep::new(builder, linear, settings));
            run(ReadyMethod { method, columns, analysis, charged: 0.0 }, problem, x0, settings, observer)
        }
        SystemSolve::Truncated(preconditioner, options) => {
            columns.extend(CG_COLUMNS);
            let (linear, analysis, charged) =
                Truncated::new(problem, &builder.pattern, preconditioner, options, settings)?;
            let method = linear.map(|linear| NewtonStep::new(builder, linear, settings));
            run(ReadyMethod { method, columns, analysis, charged }, problem, x0, settings, observer)
        }
    }
}

/// `start`'s method from `x0` under `settings`' stop rules.
fn run<'a, M: Method<Iterate = MapIterate<'a>>>(
    start: ReadyMethod<M>,
    problem: &'a MapProblem,
    x0: Vec<f64>,
    settings: &Settings,
    observer: &mut dyn Observer,
) -> Result<Outcome, SolveError> {
    let at = MapIterate::new(problem, x0)?;
    Ok(execute(start, at, &settings.stop, observer).outcome)
}

/// A sparse Cholesky of every system, analysed once, with the strategy's shift retries.
struct Factorized {
    solver: Box<SpdSolver>,
    base: LinearSettings,
    retries: usize,
    rhs: Vec<f64>,
}

impl Direction for Factorized {
    fn direction(
        &mut self,
        system: &SystemBuilder,
        ev: &Evaluation,
        _grad_norm: f64,
        iter: usize,
        d: &mut Vec<f64>,
    ) -> Result<(f64, Vec<Metric>), StopReason> {
        let Factorized { solver, base, retries, rhs } = self;
        rhs.clear();
        rhs.extend(ev.grad.iter().map(|g| -g));
        let shift = with_shift_retries(base, *retries, |lin| {
            solver.factorize(&system.values, lin).and_then(|_| solver.solve_factored_into(rhs, d))
        })
        .map_err(|failed| StopReason::LinearSolveFailed(format!("the system at iterate {iter}: {failed}")))?;
        Ok((shift, Vec::new()))
    }
}

/// A Newton-type method: the system of `builder`, solved by `linear`, then the injective
/// step and Armijo's line search (Algorithm 1).
pub(crate) struct NewtonStep<'a, L> {
    builder: SystemBuilder<'a>,
    linear: L,
    settings: &'a Settings,
    d: Vec<f64>,
    x_new: Vec<f64>,
    scratch: EnergyScratch,
}

impl<'a, L: Direction> NewtonStep<'a, L> {
    pub(crate) fn new(builder: SystemBuilder<'a>, linear: L, settings: &'a Settings) -> NewtonStep<'a, L> {
        NewtonStep { builder, linear, settings, d: Vec::new(), x_new: Vec::new(), scratch: EnergyScratch::default() }
    }
}

impl<'a, L: Direction> Method for NewtonStep<'a, L> {
    type Iterate = MapIterate<'a>;

    fn step(&mut self, at: &mut MapIterate<'a>, iter: usize, observer: &mut dyn Observer) -> Result<Step, StopReason> {
        let NewtonStep { builder, linear, settings, d, x_new, scratch } = self;
        let problem = at.problem;
        let (counters, mut t_project, t_scatter) = builder.build(&at.ev);
        observer.system(&builder.view(iter, &at.ev.grad, &settings.linear));

        let t0 = Instant::now();
        let grad_norm = norm(&at.ev.grad);
        let (shift, solve_columns) = linear.direction(builder, &at.ev, grad_norm, iter, d)?;
        let t_solve = t0.elapsed().as_secs_f64();

        let t0 = Instant::now();
        let g_dot_d = dot(&at.ev.grad, d);
        if !(g_dot_d < 0.0) {
            return Err(StopReason::NotDescent);
        }
        let t_max = max_injective_step(problem, &at.x, d);
        let t_init = (settings.line_search.max_step_fraction * t_max).min(1.0);
        let (accepted, ls_evals) =
            armijo(problem, &at.x, d, at.ev.energy, g_dot_d, t_init, &settings.line_search, x_new, scratch);
        let t_ls = t0.elapsed().as_secs_f64();
        let acc = accepted.ok_or_else(|| StopReason::after_line_search(g_dot_d, at.ev.energy))?;
        std::mem::swap(&mut at.x, x_new);
        let decrease = at.ev.energy - acc.energy;
        // The model fit of the step actually taken, with the unfiltered Hessian at the old
        // iterate (`at.ev` still holds it).
        let t0 = Instant::now();
        let fitted = builder.fit(&at.ev, d, acc.t, g_dot_d, decrease);
        t_project += t0.elapsed().as_secs_f64();
        let (t_eval, t_record) = at.evaluate_moved()?;
        Ok(Step {
            step: acc.t,
            decrease: Some(decrease),
            t_assemble: t_eval + t_scatter,
            t_project,
            t_solve,
            t_linesearch: t_ls,
            t_record,
            t_reused: 0.0,
            shift: Some(shift),
            ls_evals,
            extra: fitted.unwrap_or(counters).into_iter().chain(solve_columns).collect(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::{EnergyKind, Sd};
    use crate::hessian::kp::Kp;
    use crate::linear::next_shift;
    use crate::local::LocalOp;
    use crate::mesh::Mesh;
    use crate::solver::observer::Recorder;
    use crate::solver::stop::StopSettings;
    use nalgebra::Matrix6;

    /// A 4-triangle fan mapped with a stretch, so SD has work to do.
    fn problem() -> (MapProblem, Vec<f64>) {
        let p = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]];
        let f = vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]];
        let mesh = Mesh::new("fan", p.clone(), f);
        let x = p.iter().flat_map(|q| [2.0 * q[0], 0.7 * q[1]]).collect();
        (MapProblem::new(&mesh, EnergyKind::Sd(Sd)).unwrap(), x)
    }

    fn settings() -> Settings {
        Settings { stop: StopSettings::rules_only(1e-9, 0.0, 100), ..Settings::default() }
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
        let out = newton(&pb, x, &Kp, &settings(), &mut crate::solver::observer::StopAt(1)).unwrap();
        assert_eq!(out.stop_reason, StopReason::Interrupted);
        assert_eq!(out.iterations, 1);
    }

    #[test]
    fn a_passed_deadline_stops_with_timeout() {
        let (pb, x) = problem();
        for k in [0, 1] {
            let out = newton(&pb, x.clone(), &Kp, &settings(), &mut crate::solver::observer::TimeoutAt(k)).unwrap();
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
