//! The truncated Newton step of `kp-newton-cg` (the complex-view paper's future work, a
//! "matrix-free truncated Newton"): the projected Newton system `H d = -g` solved only as far
//! as the forcing term asks, by conjugate gradients preconditioned with a Laplacian of one
//! coordinate (`ScalarProxy`): weighted per face by the stiffness of its projected block
//! and refactored every iteration (the vertex graph's factorization, a quarter of the
//! system's at 1M), or, in `kp-newton-cg-laplacian`, the constant Dirichlet Laplacian
//! factored once ([`Preconditioner`]). Each CG iteration is one product with the assembled
//! system ([`SymmetricRows`]) and one pair of triangular solves with the preconditioner's
//! factor.
//!
//! The forcing term is Eisenstat and Walker's choice 2 ("Choosing the forcing terms in an
//! inexact Newton method", SIAM J. Sci. Comput. 17, 1996) with the safeguards of Kelley
//! ("Solving Nonlinear Equations with Newton's Method", SIAM 2003, Section 3.2.3):
//! `eta_k = gamma |g_k|^2 / |g_{k-1}|^2`, raised to `gamma eta_{k-1}^2` when that exceeds 0.1
//! (no sudden tightening), capped by `eta_max`, and at least `0.5 grad_tol / |g_k|` (no
//! oversolving on the last step); `gamma = 0.9`, `eta_0 = eta_max = 0.9`. Once `|g_k| <=
//! grad_tol` (the rule's event: a run that rule ends takes no such step) the last step is
//! the one to the gradient floor, `0.5 grad_floor / |g_k|`.

use super::newton_system::{Direction, SystemBuilder};
use super::observer::Metric;
use super::options::Options;
use super::outcome::{AnalysisReport, SolveError};
use super::proxy::{ProxyError, ScalarProxy};
use super::settings::Settings;
use super::stop::StopReason;
use crate::assembly::{Pattern, SymmetricRows};
use crate::linear::{LinearError, LinearSettings};
use crate::problem::{dot, Evaluation, MapProblem};
use std::time::Instant;

/// Eisenstat-Walker's `gamma` (choice 2 with exponent 2).
pub const GAMMA: f64 = 0.9;

/// The CG stops when `p^T H p <= CURVATURE_FLOOR r^T z`: the preconditioned Rayleigh quotient
/// `p^T H p / p^T A p` is below about 1e-12, a direction the projected Hessian (PSD) sees as
/// flat, along which the step would be unbounded.
pub const CURVATURE_FLOOR: f64 = 1e-12;

/// The extra columns of `kp-newton-cg`'s iteration CSVs: the CG iterations of the step, the
/// forcing term it was solved to, the relative residual `|P r| / |P g|` it reached, and
/// whether its CG stopped at `max_cg_iters` short of the forcing term (1/0; the harness
/// counts such rows as `cg_capped_iters`: a capped step is a safety net, not the method).
pub const CG_COLUMNS: [&str; 4] = [CG_ITERS, FORCING, CG_RESIDUAL, CG_CAPPED_COLUMN];

const CG_ITERS: &str = "cg_iters";
const FORCING: &str = "forcing";
const CG_RESIDUAL: &str = "cg_residual";

/// The column of [`CG_COLUMNS`] that marks a step whose CG hit [`NewtonCgOptions::max_cg_iters`].
pub const CG_CAPPED_COLUMN: &str = "cg_capped";

/// The preconditioner of the truncated steps: `kp-newton-cg`'s, `kp-newton-cg-laplacian`'s.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preconditioner {
    /// The constant Dirichlet Laplacian, factored once per run: the cheapest steps, but on
    /// the real meshes' distorted Tutte maps it is far from the system and CG needs tens of
    /// iterations per step (docs/src/results/kp-newton-cg.md).
    Laplacian,
    /// The Laplacian with each face weighted by its projected block's mean stiffness
    /// (`trace H_t / trace D_t`), refactored every Newton iteration on the same analysis: a
    /// factorization of the vertex graph per iteration, and one or two CG iterations.
    Stiffness,
}

/// `[solver.kp-newton-cg]`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NewtonCgOptions {
    /// The largest forcing term (and the first): the step's relative residual target.
    pub eta_max: f64,
    /// CG iterations per Newton step at most; the step is then what CG reached.
    pub max_cg_iters: usize,
}

impl CgReport {
    /// The step is what CG reached at the iteration cap, not the forcing term's solve.
    pub fn capped(&self) -> bool {
        self.stop == CgStop::MaxIterations
    }
}

impl Default for NewtonCgOptions {
    fn default() -> Self {
        NewtonCgOptions { eta_max: 0.9, max_cg_iters: 500 }
    }
}

impl Options for NewtonCgOptions {
    fn check(&self) -> Result<(), String> {
        if !(self.eta_max > 0.0 && self.eta_max < 1.0) {
            return Err(format!("eta_max = {}: it must be in (0, 1) (default 0.9)", self.eta_max));
        }
        if self.max_cg_iters == 0 {
            return Err("max_cg_iters = 0: it must be at least 1 (default 500)".to_string());
        }
        Ok(())
    }
}

/// Eisenstat-Walker's choice 2 with Kelley's safeguards (module doc).
#[derive(Clone, Copy, Debug)]
pub struct Forcing {
    eta_max: f64,
    /// The gradient norm target of the run (the last step need not solve below it).
    grad_tol: f64,
    /// The tightest gradient norm the run stops at (the target once `grad_tol` has held).
    grad_floor: f64,
    /// The previous forcing term and gradient norm (`None` before the first step).
    last: Option<(f64, f64)>,
}

impl Forcing {
    /// The forcing terms of a run: at most `eta_max`, at least `0.5 grad_tol / |g|` while
    /// `|g| > grad_tol`, `0.5 grad_floor / |g|` after.
    pub fn new(eta_max: f64, grad_tol: f64, grad_floor: f64) -> Forcing {
        Forcing { eta_max, grad_tol, grad_floor, last: None }
    }

    /// The forcing term of the step at gradient norm `g_norm`.
    pub fn next(&mut self, g_norm: f64) -> f64 {
        let eta = match self.last {
            None => self.eta_max,
            Some((eta_prev, g_prev)) => {
                let ratio = g_norm / g_prev;
                let mut eta = GAMMA * ratio * ratio;
                let floor = GAMMA * eta_prev * eta_prev;
                if floor > 0.1 {
                    eta = eta.max(floor);
                }
                eta.min(self.eta_max)
            }
        };
        let aim = if g_norm > self.grad_tol { self.grad_tol } else { self.grad_floor };
        let eta = eta.max(0.5 * aim / g_norm).min(self.eta_max);
        self.last = Some((eta, g_norm));
        eta
    }
}

/// Why the CG of one step stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CgStop {
    /// `|P r| <= eta |P g|`.
    Converged,
    /// A direction of (numerically) zero curvature.
    Flat,
    /// [`NewtonCgOptions::max_cg_iters`] iterations.
    MaxIterations,
}

/// What one truncated step did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CgReport {
    /// CG iterations taken.
    pub iterations: usize,
    /// `|P r| / |P g|` at the returned direction.
    pub residual: f64,
    /// Why CG stopped.
    pub stop: CgStop,
}

/// The preconditioner and the buffers of the truncated steps of one run.
pub(crate) struct TruncatedSolve {
    pub(crate) proxy: ScalarProxy,
    rows: SymmetricRows,
    options: NewtonCgOptions,
    r: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
}

/// `v`'s entries of vertex `pinned` set to zero (`P v`).
fn unpin(pinned: Option<usize>, v: &mut [f64]) {
    if let Some(p) = pinned {
        v[2 * p..2 * p + 2].fill(0.0);
    }
}

impl TruncatedSolve {
    pub(crate) fn new(proxy: ScalarProxy, rows: SymmetricRows, options: NewtonCgOptions) -> TruncatedSolve {
        TruncatedSolve { proxy, rows, options, r: Vec::new(), z: Vec::new(), p: Vec::new(), q: Vec::new() }
    }

    /// `d` with `|P (H d + g)| <= eta |P g|` by preconditioned CG from `d = 0`, `H` the
    /// symmetric matrix whose lower triangle `values` is on the rows' pattern. The pinned
    /// vertex's dofs of `d` stay 0 (CG on the system with that vertex fixed, which a
    /// translation-invariant energy loses nothing by). Every CG iterate is a descent direction
    /// (`H` PSD); when the first direction is already flat, `d` is the preconditioned
    /// gradient step `-P A^-1 P g`.
    pub(crate) fn solve(
        &mut self,
        values: &[f64],
        g: &[f64],
        eta: f64,
        d: &mut Vec<f64>,
    ) -> Result<CgReport, LinearError> {
        let n = g.len();
        let (r, z, p, q) = (&mut self.r, &mut self.z, &mut self.p, &mut self.q);
        d.clear();
        d.resize(n, 0.0);
        // The residual lives on the free dofs: `r = P (-g - H d)` throughout (a pinned entry
        // would only meet the preconditioner's zeros in `r . z`).
        let pinned = self.proxy.pinned();
        r.clear();
        r.extend(g.iter().map(|x| -x));
        unpin(pinned, r);
        z.resize(n, 0.0);
        q.resize(n, 0.0);
        let g_norm = dot(r, r).sqrt();
        let target = eta * g_norm;
        self.proxy.apply(r, z)?;
        p.clone_from(z);
        let mut rz = dot(r, z);
        let mut residual = g_norm;
        let mut iterations = 0;
        let mut flat_start = false;
        let stop = loop {
            if residual <= target || !(rz > 0.0) {
                break CgStop::Converged;
            }
            if iterations >= self.options.max_cg_iters {
                break CgStop::MaxIterations;
            }
            self.rows.mul(values, p, q);
            let pq = dot(p, q);
            if !(pq > CURVATURE_FLOOR * rz) {
                if iterations == 0 {
                    d.clone_from(p);
                    flat_start = true;
                }
                break CgStop::Flat;
            }
            let alpha = rz / pq;
            d.iter_mut().zip(p.iter()).for_each(|(di, pi)| *di += alpha * pi);
            r.iter_mut().zip(q.iter()).for_each(|(ri, qi)| *ri -= alpha * qi);
            unpin(pinned, r);
            iterations += 1;
            residual = dot(r, r).sqrt();
            if residual <= target {
                break CgStop::Converged;
            }
            self.proxy.apply(r, z)?;
            let rz_new = dot(r, z);
            let beta = rz_new / rz;
            rz = rz_new;
            p.iter_mut().zip(z.iter()).for_each(|(pi, zi)| *pi = zi + beta * *pi);
        };
        // The preconditioned gradient step's residual is not computed (NaN).
        let residual = if flat_start {
            f64::NAN
        } else if g_norm > 0.0 {
            residual / g_norm
        } else {
            0.0
        };
        Ok(CgReport { iterations, residual, stop })
    }
}

/// The truncated steps of a run: CG on the system with the preconditioner, to the forcing
/// terms ([`CG_COLUMNS`] for each row).
pub(crate) struct Truncated<'a> {
    problem: &'a MapProblem,
    steps: TruncatedSolve,
    forcing: Forcing,
    preconditioner: Preconditioner,
    linear: LinearSettings,
}

/// A truncated method ready, or why it cannot start; the analysis; the setup charged to
/// iteration 1.
type TruncatedStart<'a> = (Result<Truncated<'a>, StopReason>, Option<AnalysisReport>, f64);

impl<'a> Truncated<'a> {
    /// The preconditioner built and factored on `problem`: that is part of the method's cost
    /// (charged to iteration 1, as AQP's proxy); its analysis, like the factorized variant's,
    /// is the run's `analysis_s`.
    pub(crate) fn new(
        problem: &'a MapProblem,
        pattern: &Pattern,
        preconditioner: Preconditioner,
        options: NewtonCgOptions,
        settings: &Settings,
    ) -> Result<TruncatedStart<'a>, SolveError> {
        let t_setup = Instant::now();
        let proxy = match preconditioner {
            Preconditioner::Laplacian => ScalarProxy::new(problem, settings),
            Preconditioner::Stiffness => ScalarProxy::analysed(problem, settings),
        };
        match proxy {
            Ok(proxy) => {
                let analysis = proxy.analysis;
                let charged = (t_setup.elapsed().as_secs_f64() - analysis.setup_seconds).max(0.0);
                let steps = TruncatedSolve::new(proxy, SymmetricRows::new(pattern), options);
                let forcing = Forcing::new(options.eta_max, settings.stop.grad_tol, settings.stop.grad_floor);
                let truncated = Truncated { problem, steps, forcing, preconditioner, linear: settings.linear };
                Ok((Ok(truncated), Some(analysis), charged))
            }
            Err(ProxyError::Setup(e)) => Err(e),
            Err(ProxyError::Failed(reason)) => Ok((Err(reason), Some(AnalysisReport::default()), 0.0)),
        }
    }
}

impl Direction for Truncated<'_> {
    fn direction(
        &mut self,
        system: &SystemBuilder,
        ev: &Evaluation,
        grad_norm: f64,
        iter: usize,
        d: &mut Vec<f64>,
    ) -> Result<(f64, Vec<Metric>), StopReason> {
        if self.preconditioner == Preconditioner::Stiffness {
            self.steps.proxy.reweight(self.problem, &system.blocks, &self.linear)?;
        }
        let eta = self.forcing.next(grad_norm);
        let cg = self
            .steps
            .solve(&system.values, &ev.grad, eta, d)
            .map_err(|e| StopReason::LinearSolveFailed(format!("the preconditioner at iterate {iter}: {e}")))?;
        // the system itself is not shifted; the preconditioner's factorization was
        let columns = vec![
            (CG_ITERS, cg.iterations as f64),
            (FORCING, eta),
            (CG_RESIDUAL, cg.residual),
            (CG_CAPPED_COLUMN, f64::from(u8::from(cg.capped()))),
        ];
        Ok((self.steps.proxy.shift, columns))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::{EnergyKind, Sarap, Sd};
    use crate::generate::{generate, generated_handles};
    use crate::hessian::kp::Kp;
    use crate::init::{tutte, TutteBoundary};
    use crate::linear::{LinearSettings, SpdSolver};
    use crate::mesh::Mesh;
    use crate::problem::{Evaluation, MapProblem};
    use crate::solver::newton_system::{project_blocks, scatter};
    use crate::solver::observer::{IterationRecord, Recorder};
    use crate::solver::outcome::Outcome;
    use crate::solver::settings::Settings;
    use crate::solver::stop::{StopReason, StopSettings};
    use crate::tasks::deform::{solve_deform, DeformSettings};
    use crate::tasks::param::{solve_param, ParamSettings};
    use crate::test_support::shared_mesh;

    /// Choice 2 by hand: the first term is `eta_max`; then `0.9 (g_k / g_{k-1})^2`, raised to
    /// `0.9 eta_{k-1}^2` while that is above 0.1, capped by `eta_max`, and never below
    /// `0.5 grad_tol / g_k`.
    #[test]
    fn the_forcing_terms_follow_eisenstat_walker_choice_2_with_kelley_s_safeguards() {
        let mut f = Forcing::new(0.9, 1e-6, 0.0);
        assert_eq!(f.next(1.0), 0.9);
        // 0.9 * 0.25 = 0.225 < floor 0.9 * 0.81 = 0.729 (> 0.1): the floor
        assert!((f.next(0.5) - 0.729).abs() < 1e-15);
        // ratio 1: 0.9, capped at 0.9
        assert!((f.next(0.5) - 0.9).abs() < 1e-15);
        let mut f = Forcing::new(0.9, 1e-6, 0.0);
        f.next(1.0);
        f.next(0.5);
        f.next(0.05); // 0.9 * 0.01 = 0.009, floor 0.9 * 0.729^2 = 0.478
        assert!((f.next(0.05) - 0.9f64.min(0.9)).abs() < 1e-15);
        // a fast fall once the floor is below 0.1: eta = 0.9 (g_k / g_{k-1})^2
        let mut f = Forcing::new(0.3, 1e-12, 0.0);
        assert_eq!(f.next(1.0), 0.3); // floor 0.081 < 0.1 from here on
        assert!((f.next(0.1) - 0.009).abs() < 1e-15);
        assert!((f.next(0.01) - 0.009).abs() < 1e-15);
        // near the run's target the step need not solve below it: 0.5 * 1e-3 / 2e-3
        let mut f = Forcing::new(0.3, 1e-3, 1e-10);
        f.next(1.0);
        assert!((f.next(2e-3) - 0.25).abs() < 1e-15);
        // past the rule (its event) the floor is the gradient floor's: 0.9 (0.5e-3 / 2e-3)^2
        assert!((f.next(0.5e-3) - 0.9 * 0.0625).abs() < 1e-15);
        let mut f = Forcing::new(0.3, 1e-3, 1e-10);
        f.next(1.0);
        assert!((f.next(1e-9) - 0.05).abs() < 1e-15, "0.5 * 1e-10 / 1e-9");
    }

    /// KP's system at the Tutte map of `mesh` (param SD): the problem, the pattern and the
    /// values, and the gradient.
    fn system(mesh: &Mesh) -> (MapProblem, crate::assembly::Pattern, Vec<f64>, Vec<f64>) {
        let mesh = mesh.normalized();
        let problem = MapProblem::new(&mesh, EnergyKind::Sd(Sd)).unwrap();
        let x = tutte(&mesh, TutteBoundary::Uniform).unwrap();
        let mut ev = Evaluation::default();
        problem.evaluate(&x, &mut ev).unwrap();
        let pattern = problem.system_pattern();
        let (mut blocks, mut edges, mut values) = (Vec::new(), Vec::new(), Vec::new());
        project_blocks(&problem, &ev, &Kp, &mut blocks, &mut edges);
        scatter(&problem, &pattern, &Kp, &blocks, &edges, &mut values);
        (problem, pattern, values, ev.grad)
    }

    fn steps(problem: &MapProblem, pattern: &crate::assembly::Pattern, max_cg_iters: usize) -> TruncatedSolve {
        let proxy = ScalarProxy::new(problem, &Settings::default()).ok().unwrap();
        TruncatedSolve::new(proxy, SymmetricRows::new(pattern), NewtonCgOptions { eta_max: 0.9, max_cg_iters })
    }

    /// The step meets its forcing term (`|P r| <= eta |P g|`, checked with an independent
    /// product), keeps the pinned vertex in place, descends, and with a tight term is the
    /// factorized Newton step up to the translation it leaves out.
    #[test]
    fn the_truncated_step_meets_its_forcing_term_and_tends_to_the_newton_step() {
        let (problem, pattern, values, g) = system(&generate("bumpy_1k").unwrap());
        let mut tn = steps(&problem, &pattern, 1000);
        let mut d = Vec::new();
        let free = |v: &[f64]| v[2..].iter().map(|x| x * x).sum::<f64>().sqrt();
        let mut last_iters = 0;
        for eta in [0.5, 1e-2, 1e-4, 1e-9] {
            let rep = tn.solve(&values, &g, eta, &mut d).unwrap();
            let hd = pattern.sym_mul(&values, &d);
            let r: Vec<f64> = hd.iter().zip(&g).map(|(a, b)| a + b).collect();
            assert_eq!(rep.stop, CgStop::Converged, "{eta}");
            assert!(free(&r) <= eta * free(&g) * (1.0 + 1e-9), "{eta}: {} vs {}", free(&r), free(&g));
            assert!((rep.residual - free(&r) / free(&g)).abs() < 1e-6 * rep.residual.max(1e-12), "{eta}");
            assert_eq!(d[..2], [0.0, 0.0]);
            assert!(d.iter().zip(&g).map(|(a, b)| a * b).sum::<f64>() < 0.0);
            assert!(rep.iterations >= last_iters && rep.iterations > 0);
            last_iters = rep.iterations;
        }
        // the factorized step, moved so that vertex 0 stays: the same to the solve's accuracy
        let mut direct = SpdSolver::new(&pattern, crate::linear::ordering::Ordering::Amd).unwrap();
        let minus_g: Vec<f64> = g.iter().map(|x| -x).collect();
        let mut dd = direct.solve(&values, &minus_g, &LinearSettings::default()).unwrap();
        let (tu, tv) = (dd[0], dd[1]);
        dd.chunks_exact_mut(2).for_each(|p| (p[0], p[1]) = (p[0] - tu, p[1] - tv));
        let diff: f64 = d.iter().zip(&dd).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
        assert!(diff < 1e-6 * free(&dd), "{diff} vs {}", free(&dd));
        // an iteration cap returns what CG reached, still a descent direction
        let mut capped = steps(&problem, &pattern, 2);
        let rep = capped.solve(&values, &g, 1e-10, &mut d).unwrap();
        assert_eq!((rep.stop, rep.iterations, rep.capped()), (CgStop::MaxIterations, 2, true));
        assert!(rep.residual > 1e-10 && d.iter().zip(&g).map(|(a, b)| a * b).sum::<f64>() < 0.0);
    }

    /// A system that is flat along the first direction: the step is the preconditioned
    /// gradient step, and the residual is not claimed.
    #[test]
    fn a_flat_first_direction_returns_the_preconditioned_gradient() {
        let (problem, pattern, values, g) = system(&generate("bumpy_1k").unwrap());
        let mut tn = steps(&problem, &pattern, 100);
        let zero = vec![0.0; values.len()];
        let mut d = Vec::new();
        let rep = tn.solve(&zero, &g, 1e-3, &mut d).unwrap();
        assert_eq!((rep.stop, rep.iterations), (CgStop::Flat, 0));
        assert!(rep.residual.is_nan());
        let mut z = vec![0.0; g.len()];
        let minus_g: Vec<f64> = g.iter().map(|x| -x).collect();
        tn.proxy.apply(&minus_g, &mut z).unwrap();
        assert_eq!(d, z);
    }

    fn value(r: &IterationRecord, column: &str) -> f64 {
        r.extra_value(column).unwrap()
    }

    /// Converged without a flip to KP's energy within `rel`; every row's forcing term in
    /// `(0, 0.9]`, its CG iterations at least 1, its residual below the forcing term.
    fn assert_reaches(label: &str, out: &Outcome, rows: &[IterationRecord], kp: &Outcome, rel: f64) {
        assert!(out.stop_reason.is_converged(), "{label}: {:?} after {}", out.stop_reason, out.iterations);
        assert!(rows.iter().all(|r| r.flips == 0), "{label}");
        let cols: Vec<_> = rows[0].extra.iter().map(|e| e.0).collect();
        assert_eq!(cols, CG_COLUMNS, "{label}");
        assert!(rows[0].extra.iter().all(|e| e.1.is_nan()), "{label}");
        for r in &rows[1..] {
            let (iters, eta, res) = (value(r, "cg_iters"), value(r, "forcing"), value(r, "cg_residual"));
            assert!(eta > 0.0 && eta <= 0.9 && iters >= 1.0 && res <= eta, "{label} {}: {iters} {eta} {res}", r.iter);
            assert_eq!(value(r, CG_CAPPED_COLUMN), 0.0, "{label} {}", r.iter);
        }
        let gap = (out.final_energy - kp.final_energy).abs() / kp.final_energy;
        eprintln!("{label}: kp-newton-cg {} iterations, kp {}, rel {gap:.1e}", out.iterations, kp.iterations);
        assert!(gap < rel, "{label}: {} vs KP {} ({gap:e})", out.final_energy, kp.final_energy);
    }

    /// `param` SD to `|grad| <= 1e-5`: the minimum of `kp-newton` within 1e-6 relative, on a
    /// generated mesh and two shared ones.
    #[test]
    fn reaches_kp_s_minimum_in_param() {
        let meshes = [Some(generate("bumpy_1k").unwrap()), shared_mesh("cow"), shared_mesh("bunnyhead")];
        for mesh in meshes.iter().flatten() {
            let mut settings = ParamSettings::for_energy(&EnergyKind::Sd(Sd));
            settings.solver.stop = StopSettings::rules_only(1e-5, 0.0, 1000);
            let kp = solve_param(mesh, EnergyKind::Sd(Sd), "kp-newton", &settings, &mut Recorder::default()).unwrap();
            for solver in ["kp-newton-cg", "kp-newton-cg-laplacian"] {
                let mut rec = Recorder::default();
                let out = solve_param(mesh, EnergyKind::Sd(Sd), solver, &settings, &mut rec).unwrap();
                let label = format!("{} {solver}", mesh.source);
                assert_eq!(out.stop_reason, StopReason::GradientTolerance, "{label}");
                assert_reaches(&label, &out, &rec.rows, &kp, 1e-6);
            }
        }
    }

    /// `deform` on the bent bar (handles: nothing pinned), SD and NH, to `|grad| <= 1e-6`
    /// (the default energy-decrease rule stops the two at different distances from the
    /// minimum: NH's energy there is 4e-4; below 1e-8 the line search runs out of digits of
    /// SD's energy, about 2, before the gradient gets there).
    #[test]
    fn reaches_kp_s_minimum_in_deform() {
        let mesh = generate("planar_bar_2k").unwrap();
        let handles = generated_handles("planar_bar_2k").unwrap();
        let mut settings = DeformSettings::default();
        settings.solver.stop = StopSettings::rules_only(1e-6, 0.0, 500);
        for energy in [EnergyKind::Sd(Sd), EnergyKind::default_for("nh").unwrap()] {
            let solve = |solver: &str, rec: &mut Recorder| {
                solve_deform(&mesh, &handles, None, energy, solver, &settings, rec).unwrap()
            };
            let kp = solve("kp-newton", &mut Recorder::default());
            let mut rec = Recorder::default();
            let out = solve("kp-newton-cg", &mut rec);
            assert_eq!(out.stop_reason, StopReason::GradientTolerance);
            assert_reaches(&format!("planar_bar_2k {energy:?}"), &out, &rec.rows, &kp, 1e-6);
        }
    }

    /// With `max_cg_iters = 1` on the sack in SARAP (where the default cap of 500 was hit in
    /// 210 of 331 steps) some rows are marked `cg_capped = 1`: exactly those whose
    /// CG stopped at the cap with its residual above the forcing term.
    #[test]
    fn a_step_at_the_cg_cap_is_marked() {
        let mesh = generate("sack_1k").unwrap();
        let mut settings = ParamSettings::for_energy(&EnergyKind::Sarap(Sarap));
        settings.solver.stop.max_iters = 30;
        settings.solver.options = "max_cg_iters = 1".parse().unwrap();
        let mut rec = Recorder::default();
        solve_param(&mesh, EnergyKind::Sarap(Sarap), "kp-newton-cg", &settings, &mut rec).unwrap();
        let rows = rec.rows;
        assert!(rows[0].extra_value(CG_CAPPED_COLUMN).unwrap().is_nan());
        let capped: Vec<bool> = rows[1..].iter().map(|r| value(r, CG_CAPPED_COLUMN) == 1.0).collect();
        for (r, &c) in rows[1..].iter().zip(&capped) {
            assert!(value(r, CG_CAPPED_COLUMN) == 0.0 || c, "{}", r.iter);
            assert_eq!(c, value(r, "cg_iters") == 1.0 && value(r, "cg_residual") > value(r, "forcing"), "{}", r.iter);
        }
        assert!(capped.iter().any(|&c| c), "{capped:?}");
    }

    /// The same bits on 1 and 3 threads (the proxy's factor and solves are, the products sum
    /// each row in a fixed order, the dots are sequential).
    #[test]
    fn the_iterates_do_not_depend_on_the_thread_count() {
        let mesh = generate("bumpy_10k").unwrap();
        let settings = ParamSettings::for_energy(&EnergyKind::Sd(Sd));
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let mut rec = Recorder::default();
                let out = solve_param(&mesh, EnergyKind::Sd(Sd), "kp-newton-cg", &settings, &mut rec).unwrap();
                // bits: row 0's columns are NaN
                let rows: Vec<_> = rec.rows[1..].iter().map(|r| (r.energy, value(r, "cg_iters").to_bits())).collect();
                (out.x, rows)
            })
        };
        let one = run(1);
        assert!(one.1.len() > 3 && one.1.iter().any(|r| f64::from_bits(r.1) > 1.0));
        assert_eq!(one, run(3));
    }
}
