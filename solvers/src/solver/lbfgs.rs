//! L-BFGS on planar maps (Liu and Nocedal 1989; the quasi-Newton baseline of Smith and
//! Schaefer 2015 and of the SLIM and CM comparisons): the two-loop recursion over the last
//! `m` curvature pairs, the shared injective line search and the shared stop rules. Only the
//! energy and its gradient are needed.
//!
//! Two initial Hessians `H0`:
//! - [`InitialHessian::Scaled`]: `gamma I` with `gamma = s^T y / y^T y` of the newest pair
//!   (1 before the first), `m = 10` (the SLIM repository's baseline);
//! - [`InitialHessian::Laplacian`]: the solve with the constant proxy `A = Hessian of
//!   c sum_t a_t |J_t|^2 / sum_t a_t`, the energy's quadratic part (`c = 1/2` for SD, 1 for
//!   BARAP, `solver::proxy::dirichlet_coefficient`) plus the soft handles' `2 lambda`,
//!   factored once through our sparse Cholesky, `m = 5` (BCQN's
//!   code, `mlbfgs_solver.m`, blend `b = 0`); `solver::proxy` builds it, with vertex 0
//!   pinned for the free boundary (`param`).
//!
//! Safeguards: a pair with `s^T y <= CURVATURE_EPS |s| |y|` is not stored (it would make `H`
//! indefinite); a direction that is not a descent direction, or along which the line search
//! finds no step, is replaced by `-H0 g` with the history cleared (once per iteration).

use super::executor::{execute, Method, ReadyMethod, Step};
use super::map_iterate::MapIterate;
use super::observer::Observer;
use super::outcome::{AnalysisReport, Outcome};
use super::planar::PlanarSolver;
use super::proxy::{Proxy, ProxyError};
use super::settings::Settings;
use super::stop::StopReason;
use crate::line_search::{armijo, max_injective_step};
use crate::problem::{dot, norm, EnergyScratch, MapProblem};
use crate::solver::outcome::SolveError;
use std::collections::VecDeque;
use std::time::Instant;

/// History of the plain variant (the SLIM repository's L-BFGS baseline).
pub const SCALED_MEMORY: usize = 10;
/// History of the Laplacian-preconditioned variant (BCQN's code).
pub const LAPLACIAN_MEMORY: usize = 5;
/// A pair is stored only when `s^T y > CURVATURE_EPS |s| |y|` (the cosine of the angle
/// between step and gradient change): BFGS keeps `H` positive definite exactly when every
/// stored pair has `s^T y > 0`, and a nearly orthogonal pair is noise.
pub const CURVATURE_EPS: f64 = 1e-8;

/// The extra CSV columns of both variants: the pairs the direction was built from, whether
/// this step's pair was rejected by the curvature test (1/0), and whether the direction was
/// reset to `-H0 g` (1/0). NaN in row 0 (no direction yet).
pub const LBFGS_COLUMNS: [&str; 3] = [PAIRS, PAIR_SKIPPED, RESET];

const PAIRS: &str = "pairs";
const PAIR_SKIPPED: &str = "pair_skipped";
const RESET: &str = "reset";

/// The initial Hessian of the two-loop recursion.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InitialHessian {
    /// `gamma I`, `gamma = s^T y / y^T y` of the newest stored pair.
    Scaled,
    /// The solve with the constant Laplacian proxy.
    Laplacian,
}

/// One L-BFGS variant: its initial Hessian and history length.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Variant {
    /// The initial Hessian `H0`.
    pub h0: InitialHessian,
    /// Curvature pairs kept (`m`).
    pub memory: usize,
}

impl Variant {
    /// `lbfgs` (`laplacian = false`) or `lbfgs-laplacian`.
    pub fn new(laplacian: bool) -> Variant {
        if laplacian {
            Variant { h0: InitialHessian::Laplacian, memory: LAPLACIAN_MEMORY }
        } else {
            Variant { h0: InitialHessian::Scaled, memory: SCALED_MEMORY }
        }
    }
}

/// The last `m` curvature pairs `(s_i, y_i, 1 / s_i^T y_i)`, oldest first.
#[derive(Clone, Debug)]
pub struct History {
    m: usize,
    pairs: VecDeque<(Vec<f64>, Vec<f64>, f64)>,
    /// The two-loop's coefficients `alpha_i`, kept between calls.
    alpha: Vec<f64>,
}

impl History {
    /// An empty history that keeps at most `m` pairs.
    pub fn new(m: usize) -> History {
        History { m, pairs: VecDeque::with_capacity(m), alpha: Vec::with_capacity(m) }
    }

    /// Number of stored pairs.
    pub fn len(&self) -> usize {
        self.pairs.len()
    }

    /// Whether no pair is stored.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// Drop every stored pair.
    pub fn clear(&mut self) {
        self.pairs.clear();
    }

    /// Store the pair `(s, y)` unless it fails the curvature test (then `false`); the oldest
    /// pair goes when `m` are stored.
    pub fn push(&mut self, s: Vec<f64>, y: Vec<f64>) -> bool {
        let sy = dot(&s, &y);
        if !(sy > CURVATURE_EPS * norm(&s) * norm(&y)) || self.m == 0 {
            return false;
        }
        if self.pairs.len() == self.m {
            self.pairs.pop_front();
        }
        self.pairs.push_back((s, y, 1.0 / sy));
        true
    }

    /// `s^T y / y^T y` of the newest pair, 1 without pairs.
    pub fn gamma(&self) -> f64 {
        self.pairs.back().map_or(1.0, |(s, y, _)| dot(s, y) / dot(y, y))
    }

    /// `d = -H g` by the two-loop recursion (Nocedal and Wright, Algorithm 7.4), with `h0`
    /// applying the initial Hessian in place.
    pub fn direction<E>(
        &mut self,
        g: &[f64],
        h0: impl FnOnce(&mut Vec<f64>) -> Result<(), E>,
        d: &mut Vec<f64>,
    ) -> Result<(), E> {
        d.clear();
        d.extend_from_slice(g);
        self.alpha.clear();
        for (s, y, rho) in self.pairs.iter().rev() {
            let a = rho * dot(s, d);
            d.iter_mut().zip(y).for_each(|(q, yi)| *q -= a * yi);
            self.alpha.push(a);
        }
        h0(d)?;
        for ((s, y, rho), a) in self.pairs.iter().zip(self.alpha.iter().rev()) {
            let b = rho * dot(y, d);
            d.iter_mut().zip(s).for_each(|(r, si)| *r += (a - b) * si);
        }
        d.iter_mut().for_each(|v| *v = -*v);
        Ok(())
    }
}

/// The initial Hessian as the driver applies it.
enum H0 {
    Scaled,
    Laplacian(Box<Proxy>),
}

impl H0 {
    /// `q <- H0 q`; `gamma` is the scaled variant's factor.
    fn apply(&mut self, gamma: f64, q: &mut Vec<f64>) -> Result<(), crate::linear::LinearError> {
        match self {
            H0::Scaled => {
                q.iter_mut().for_each(|v| *v *= gamma);
                Ok(())
            }
            H0::Laplacian(p) => p.apply(q),
        }
    }
}

/// L-BFGS from `x0` (orientation preserving) with `variant`, the shared line search
/// (`settings.line_search`) and stop rules (`settings.stop`).
pub fn lbfgs(
    problem: &MapProblem,
    x0: Vec<f64>,
    variant: Variant,
    settings: &Settings,
    observer: &mut dyn Observer,
) -> Result<Outcome, SolveError> {
    let t_setup = Instant::now();
    let (h0, analysis, shift) = match variant.h0 {
        InitialHessian::Scaled => (Ok(H0::Scaled), None, None),
        InitialHessian::Laplacian => match Proxy::new(problem, &settings.linear, settings) {
            Ok(p) => {
                let (a, s) = (p.analysis, p.shift);
                (Ok(H0::Laplacian(Box::new(p))), Some(a), Some(s))
            }
            Err(ProxyError::Setup(e)) => return Err(e),
            Err(ProxyError::Failed(reason)) => (Err(reason), None, None),
        },
    };
    // The numeric factorization is part of the method's cost: it goes into iteration 1.
    let charged =
        (t_setup.elapsed().as_secs_f64() - analysis.map_or(0.0, |a: AnalysisReport| a.setup_seconds)).max(0.0);
    let method = h0.map(|h0| Lbfgs {
        settings,
        h0,
        history: History::new(variant.memory),
        shift,
        d: Vec::new(),
        x_new: Vec::new(),
        g_old: Vec::new(),
        scratch: EnergyScratch::default(),
    });
    let start = ReadyMethod { method, columns: LBFGS_COLUMNS.to_vec(), analysis, charged };
    let at = MapIterate::new(problem, x0)?;
    Ok(execute(start, at, &settings.stop, observer).outcome)
}

impl PlanarSolver for Variant {
    fn solve(
        &self,
        problem: &MapProblem,
        x0: Vec<f64>,
        settings: &Settings,
        observer: &mut dyn Observer,
    ) -> Result<Outcome, SolveError> {
        lbfgs(problem, x0, *self, settings, observer)
    }
}

/// The L-BFGS method's state between iterations.
struct Lbfgs<'a> {
    settings: &'a Settings,
    h0: H0,
    history: History,
    /// The proxy's shift (the Laplacian variant's rows).
    shift: Option<f64>,
    d: Vec<f64>,
    x_new: Vec<f64>,
    g_old: Vec<f64>,
    scratch: EnergyScratch,
}

impl<'a> Method for Lbfgs<'a> {
    type Iterate = MapIterate<'a>;

    fn step(&mut self, at: &mut MapIterate<'a>, iter: usize, _: &mut dyn Observer) -> Result<Step, StopReason> {
        let Lbfgs { settings, h0, history, shift, d, x_new, g_old, scratch } = self;
        let problem = at.problem;
        let (mut t_solve, mut t_ls, mut ls_evals) = (0.0, 0.0, 0);
        let pairs = history.len();
        let mut reset = false;
        let accepted = loop {
            let t0 = Instant::now();
            let gamma = history.gamma();
            let solved = history.direction(&at.ev.grad, |q| h0.apply(gamma, q), d);
            t_solve += t0.elapsed().as_secs_f64();
            if let Err(e) = solved {
                return Err(StopReason::LinearSolveFailed(format!("the Laplacian proxy at iterate {iter}: {e}")));
            }
            let t0 = Instant::now();
            let g_dot_d = dot(&at.ev.grad, d);
            let found = if g_dot_d < 0.0 {
                let t_max = max_injective_step(problem, &at.x, d);
                let t_init = (settings.line_search.max_step_fraction * t_max).min(1.0);
                let (acc, evals) =
                    armijo(problem, &at.x, d, at.ev.energy, g_dot_d, t_init, &settings.line_search, x_new, scratch);
                ls_evals += evals;
                acc
            } else {
                None
            };
            t_ls += t0.elapsed().as_secs_f64();
            match found {
                Some(acc) => break acc,
                // The pairs made a bad direction: start over from -H0 g.
                None if !history.is_empty() => {
                    history.clear();
                    reset = true;
                }
                None if g_dot_d < 0.0 => return Err(StopReason::after_line_search(g_dot_d, at.ev.energy)),
                None => return Err(StopReason::NotDescent),
            }
        };
        std::mem::swap(&mut at.x, x_new);
        let decrease = at.ev.energy - accepted.energy;
        g_old.clone_from(&at.ev.grad);
        let (t_eval, t_record) = at.evaluate_moved()?;
        let s: Vec<f64> = at.x.iter().zip(x_new.iter()).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = at.ev.grad.iter().zip(g_old.iter()).map(|(a, b)| a - b).collect();
        let skipped = !history.push(s, y);
        Ok(Step {
            step: accepted.t,
            decrease: Some(decrease),
            t_assemble: t_eval,
            t_solve,
            t_linesearch: t_ls,
            t_record,
            shift: *shift,
            ls_evals,
            extra: vec![
                (PAIRS, if reset { 0 } else { pairs } as f64),
                (PAIR_SKIPPED, f64::from(u8::from(skipped))),
                (RESET, f64::from(u8::from(reset))),
            ],
            ..Step::default()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::{EnergyKind, Sd};
    use crate::solver::observer::Recorder;
    use crate::solver::stop::StopSettings;
    use nalgebra::{DMatrix, DVector};

    /// A dense SPD matrix with a spread of eigenvalues (deterministic).
    fn spd(n: usize, seed: u64) -> DMatrix<f64> {
        let mut s = seed;
        let b = DMatrix::from_fn(n, n, |_, _| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        });
        &b * b.transpose() + DMatrix::from_diagonal(&DVector::from_fn(n, |i, _| 0.1 + i as f64))
    }

    /// Dense BFGS inverse update `H+ = (I - rho s y^T) H (I - rho y s^T) + rho s s^T`.
    fn bfgs_update(h: &DMatrix<f64>, s: &DVector<f64>, y: &DVector<f64>) -> DMatrix<f64> {
        let rho = 1.0 / s.dot(y);
        let i = DMatrix::identity(s.len(), s.len());
        let a = &i - s * y.transpose() * rho;
        &a * h * a.transpose() + s * s.transpose() * rho
    }

    /// On `f = x^T Q x / 2 - b^T x` with inexact line searches, the two-loop recursion gives
    /// dense BFGS's directions to round-off while it holds every pair (the first `m` steps),
    /// for a fixed `H0` (the Laplacian variant) and for `gamma I` rebuilt from the newest
    /// pair (the scaled variant); once pairs are dropped it does not.
    #[test]
    fn two_loop_matches_dense_bfgs_for_the_first_m_steps() {
        let n = 12;
        let q = spd(n, 3);
        let b = DVector::from_fn(n, |i, _| (i as f64 * 0.7).sin());
        let h0_fixed = spd(n, 11).try_inverse().unwrap();
        for fixed in [true, false] {
            let m = 4;
            let mut hist = History::new(m);
            let mut x = DVector::zeros(n);
            let (mut pairs, mut differed) = (Vec::new(), false);
            for k in 0..8 {
                let g = &q * &x - &b;
                let mut d = Vec::new();
                let gamma = hist.gamma();
                hist.direction(
                    g.as_slice(),
                    |v: &mut Vec<f64>| -> Result<(), ()> {
                        let w = if fixed {
                            &h0_fixed * DVector::from_column_slice(v)
                        } else {
                            DVector::from_column_slice(v) * gamma
                        };
                        v.copy_from_slice(w.as_slice());
                        Ok(())
                    },
                    &mut d,
                )
                .unwrap();
                let d = DVector::from_vec(d);
                // dense BFGS over every pair so far
                let mut h = if fixed { h0_fixed.clone() } else { DMatrix::identity(n, n) * gamma };
                for (s, y) in &pairs {
                    h = bfgs_update(&h, s, y);
                }
                let dense = -(&h * &g);
                let rel = (&d - &dense).norm() / dense.norm();
                if k <= m {
                    assert!(rel < 1e-10, "fixed {fixed}, step {k}: {rel}");
                } else {
                    differed |= rel > 1e-6;
                }
                assert!(g.dot(&d) < 0.0, "descent at step {k}");
                // inexact (0.7 of the exact step): with exact steps on a quadratic dropped pairs
                // would not matter (the directions are conjugate), and the test would not see them
                let t = 0.7 * -g.dot(&d) / d.dot(&(&q * &d));
                let s = &d * t;
                x += &s;
                let y = &q * &s;
                assert!(hist.push(s.as_slice().to_vec(), y.as_slice().to_vec()));
                pairs.push((s, y));
                assert_eq!(hist.len(), (k + 1).min(m));
            }
            assert!(differed, "fixed {fixed}: dropping pairs should change the directions");
        }
    }

    #[test]
    fn pairs_without_curvature_are_skipped() {
        let mut h = History::new(2);
        assert!(!h.push(vec![1.0, 0.0], vec![-1.0, 0.0]), "negative curvature");
        assert!(!h.push(vec![1.0, 0.0], vec![0.0, 1.0]), "orthogonal");
        assert!(h.is_empty() && h.gamma() == 1.0);
        assert!(h.push(vec![1.0, 0.0], vec![2.0, 0.0]));
        assert_eq!(h.gamma(), 0.5);
    }

    /// Both variants descend without flips to KP's minimum on a generated mesh (the shared
    /// meshes: `harness/tests`).
    #[test]
    fn both_variants_reach_kp_on_a_generated_mesh() {
        use crate::tasks::param::{solve_param, ParamSettings};
        let mesh = crate::generate::generate("bumpy_1k").unwrap();
        let mut settings = ParamSettings::for_energy(&EnergyKind::Sd(Sd));
        settings.solver.stop = StopSettings::rules_only(1e-5, 0.0, 5000);
        let kp = solve_param(&mesh, EnergyKind::Sd(Sd), "kp-newton", &settings, &mut Recorder::default()).unwrap();
        for (solver, max_iters) in [("lbfgs", 1000), ("lbfgs-laplacian", 200)] {
            let mut rec = Recorder::default();
            let out = solve_param(&mesh, EnergyKind::Sd(Sd), solver, &settings, &mut rec).unwrap();
            assert_eq!(out.stop_reason, StopReason::GradientTolerance, "{solver}");
            assert!(out.iterations < max_iters, "{solver}: {}", out.iterations);
            assert!(rec.rows.windows(2).all(|w| w[1].energy <= w[0].energy), "{solver}");
            assert!(rec.rows.iter().all(|r| r.flips == 0), "{solver}");
            assert!(rec.rows[1..].iter().all(|r| r.ls_evals >= 1), "{solver}");
            let rel = (out.final_energy - kp.final_energy).abs() / kp.final_energy;
            assert!(rel < 1e-6, "{solver}: {} vs KP {}", out.final_energy, kp.final_energy);
            let cols: Vec<_> = rec.rows[1].extra.iter().map(|e| e.0).collect();
            assert_eq!(cols, LBFGS_COLUMNS);
            assert_eq!(rec.rows[0].shift, None);
        }
    }
}
