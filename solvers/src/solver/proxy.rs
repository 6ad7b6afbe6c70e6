//! The constant quadratic proxy shared by the first-order drivers (`lbfgs-laplacian`'s
//! initial Hessian, `aqp`'s preconditioner): `A = Hessian of sum_t a_t |J_t|^2 / sum_t a_t`
//! (the cotan Laplacian, twice, on both coordinates; AQP's `2 sum_t a_t T_t^T T_t` in our
//! area normalization) plus the soft handles' `2 lambda`, factored once through our sparse
//! Cholesky.
//!
//! Without handles (`param`, free boundary) `A` has the translations in its kernel: vertex 0
//! is pinned (its rows and columns replaced by the identity, its components of `A^-1 q` set
//! to 0), so the directions never move it, which changes no energy (they are translation
//! invariant). With handles `A` is positive definite and nothing is pinned.

use super::{AnalysisReport, Settings, StopReason};
use crate::assembly::Pattern;
use crate::linear::{LinearError, LinearSettings, SpdSolver};
use crate::problem::MapProblem;
use crate::smoothness::Matrix8;
use crate::solver::newton::{next_shift, system_pattern, SolveError, MAX_REGULARIZATION_RETRIES};
use nalgebra::Matrix6;

/// The lower triangle of the proxy on `pattern` (the Newton pattern of `problem`): per face
/// `4 a_t / sum a M^T M` (`|J|_F^2 = 2 (|f_z|^2 + |f_zbar|^2) = 2 |M y|^2`), the handles'
/// `2 lambda`, and the dofs of `pinned` replaced by the identity.
pub fn laplacian_proxy(problem: &MapProblem, pattern: &Pattern, pinned: Option<usize>) -> Vec<f64> {
    let w = 4.0 * problem.weight();
    let blocks: Vec<Matrix6<f64>> = problem
        .ops
        .iter()
        .map(|op| {
            let m = op.m();
            m.transpose() * m * (w * op.area)
        })
        .collect();
    let edge_blocks = vec![Matrix8::zeros(); pattern.edge_scatter.len()];
    let mut values = Vec::new();
    pattern.assemble_with_edges(&blocks, &edge_blocks, &mut values);
    if let Some(pen) = &problem.penalty {
        for (dof, h) in pen.diagonal() {
            values[pattern.diag[dof]] += h;
        }
    }
    if let Some(v) = pinned {
        let pin = |i: usize| i / 2 == v;
        for c in 0..pattern.n {
            let range = pattern.col_ptr[c]..pattern.col_ptr[c + 1];
            for (value, &r) in values[range.clone()].iter_mut().zip(&pattern.row_idx[range]) {
                if pin(r) || pin(c) {
                    *value = if r == c { 1.0 } else { 0.0 };
                }
            }
        }
    }
    values
}

/// The factored proxy and its pinned vertex.
pub(crate) struct Proxy {
    solver: SpdSolver,
    /// The pinned vertex (`param`), `None` with handles.
    pub(crate) pinned: Option<usize>,
    /// The Tikhonov shift the factorization succeeded with.
    pub(crate) shift: f64,
    pub(crate) analysis: AnalysisReport,
    rhs: Vec<f64>,
    out: Vec<f64>,
}

/// Why the proxy could not be factored.
pub(crate) enum ProxyError {
    /// The linear solver could not be set up (a typed error of the run).
    Setup(SolveError),
    /// The factorization failed at every shift: the stop reason to record.
    Failed(StopReason),
}

impl Proxy {
    /// Factor the proxy of `problem` once, with the Newton driver's retries on failure;
    /// `Err` carries the stop reason of a factorization that failed at every shift.
    pub(crate) fn new(problem: &MapProblem, linear: &LinearSettings, settings: &Settings) -> Result<Proxy, ProxyError> {
        let pattern = system_pattern(problem);
        let mut solver = SpdSolver::shared(&pattern, linear.ordering, settings.analyses.as_deref())
            .map_err(|e| ProxyError::Setup(e.into()))?;
        let analysis = AnalysisReport {
            seconds: solver.analysis().seconds(),
            setup_seconds: solver.setup_seconds(),
            reused: solver.analysis_reused(),
        };
        let has_handles = problem.penalty.as_ref().is_some_and(|p| !p.handles.is_empty());
        let pinned = if has_handles { None } else { Some(0) };
        let values = laplacian_proxy(problem, &pattern, pinned);
        let mut lin = *linear;
        let mut result = solver.factorize(&values, &lin);
        for _ in 0..MAX_REGULARIZATION_RETRIES {
            if result.is_ok() {
                break;
            }
            lin.tikhonov = next_shift(lin.tikhonov);
            result = solver.factorize(&values, &lin);
        }
        if let Err(e) = result {
            return Err(ProxyError::Failed(StopReason::LinearSolveFailed(format!(
                "the Laplacian proxy: {e} (shifts {:e} to {:e})",
                linear.tikhonov, lin.tikhonov
            ))));
        }
        Ok(Proxy { solver, pinned, shift: lin.tikhonov, analysis, rhs: Vec::new(), out: Vec::new() })
    }

    /// `q <- P A^-1 P q`, `P` zeroing the pinned dofs.
    pub(crate) fn apply(&mut self, q: &mut Vec<f64>) -> Result<(), LinearError> {
        self.rhs.clone_from(q);
        if let Some(v) = self.pinned {
            self.rhs[2 * v..2 * v + 2].fill(0.0);
        }
        self.solver.solve_factored_into(&self.rhs, &mut self.out)?;
        if let Some(v) = self.pinned {
            self.out[2 * v..2 * v + 2].fill(0.0);
        }
        q.clone_from(&self.out);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::EnergyKind;
    use crate::problem::{norm, Penalty};

    fn dot(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| x * y).sum()
    }

    /// `sum_t a_t |J_t|^2 / sum a` at `x`, plus the handle penalty when the problem has one.
    fn dirichlet(pb: &MapProblem, x: &[f64]) -> f64 {
        let d = (0..pb.n_faces())
            .map(|t| {
                let w = pb.ops[t].wirtinger(pb.target(x, t));
                pb.ops[t].area * 2.0 * (w.x() + w.y())
            })
            .sum::<f64>()
            / pb.total_area;
        d + pb.penalty.as_ref().map_or(0.0, |p| p.value(x))
    }

    fn wave(n: usize, k: usize) -> Vec<f64> {
        (0..n).map(|i| ((i * k % 101) as f64 / 101.0 * 6.0).sin()).collect()
    }

    /// The proxy is the Hessian of the Dirichlet energy (plus the penalty for deform): its
    /// bilinear form equals the central difference of the energy's directional derivative,
    /// `(D(x + y) - D(x - y)) / 2 = y^T A x` (exact for a quadratic), for several pairs; the
    /// translations are in its kernel, and pinned, vertex 0's dofs are the identity's.
    #[test]
    fn the_proxy_is_the_hessian_of_the_dirichlet_energy_and_pins_vertex_0() {
        let mesh = crate::generate::generate("bumpy_1k").unwrap().normalized();
        let mut pb = MapProblem::new(&mesh, EnergyKind::Sd).unwrap();
        let pattern = system_pattern(&pb);
        let n = pb.n_dofs();
        for penalty in [None, Some(Penalty { lambda: 1e3, handles: vec![(3, [0.1, 0.2]), (40, [-0.3, 0.0])] })] {
            pb.penalty = penalty;
            let a = laplacian_proxy(&pb, &pattern, None);
            for (kx, ky) in [(37, 53), (11, 89), (7, 7)] {
                let (x, y) = (wave(n, kx), wave(n, ky));
                let plus: Vec<f64> = x.iter().zip(&y).map(|(a, b)| a + b).collect();
                let minus: Vec<f64> = x.iter().zip(&y).map(|(a, b)| a - b).collect();
                let fd = (dirichlet(&pb, &plus) - dirichlet(&pb, &minus)) / 2.0;
                let form = dot(&y, &pattern.sym_mul(&a, &x));
                // the penalty's linear part cancels in the central difference only for its
                // quadratic term: D(x+y) - D(x-y) = 2 y^T (A x - 2 lambda S^T c), so add it back
                let lin = pb.penalty.as_ref().map_or(0.0, |p| {
                    p.handles.iter().map(|&(v, c)| 2.0 * p.lambda * (c[0] * y[2 * v] + c[1] * y[2 * v + 1])).sum()
                });
                assert!((fd + lin - form).abs() < 1e-9 * form.abs().max(1.0), "{kx} {ky}: {fd} vs {form}");
            }
        }
        pb.penalty = None;
        let a = laplacian_proxy(&pb, &pattern, None);
        let ones: Vec<f64> = (0..n).map(|i| (i % 2) as f64).collect();
        assert!(norm(&pattern.sym_mul(&a, &ones)) < 1e-9);
        let p = laplacian_proxy(&pb, &pattern, Some(0));
        let e0: Vec<f64> = (0..n).map(|i| f64::from(u8::from(i == 1))).collect();
        assert_eq!(pattern.sym_mul(&p, &e0), e0);
    }
}
