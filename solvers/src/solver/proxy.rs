//! The constant quadratic proxy shared by the first-order drivers (`lbfgs-laplacian`'s
//! initial Hessian, `aqp`'s preconditioner): `A = Hessian of c sum_t a_t |J_t|^2 / sum_t a_t`,
//! the energy's quadratic part, `c |J|^2` its Dirichlet part ([`dirichlet_coefficient`]: 1/2
//! for SD, half `|J|^2 + |J^-1|^2`; 1 for BARAP, `|J - R|^2 + ...`), plus the soft handles'
//! `2 lambda`, factored once through our sparse Cholesky. It is AQP's `H` of `f = 1/2 x^T H x
//! + g(x)` (the authors' `2 sum_t a_t T_t^T T_t` for their `|J|^2 + |J^-1|^2` and ARAP, both
//! `c = 1`): with our half SD the proxy is halved with the energy, so that `A^-1 grad` is the
//! same step as theirs (`2 c` times the cotan Laplacian on both coordinates).
//!
//! Without handles (`param`, free boundary) `A` has the translations in its kernel: vertex 0
//! is pinned (its rows and columns replaced by the identity, its components of `A^-1 q` set
//! to 0), so the directions never move it, which changes no energy (they are translation
//! invariant). With handles `A` is positive definite and nothing is pinned.
//!
//! `A` does not couple the two coordinates and is the same on both: `A = L (x) I_2` with `L`
//! the `n x n` proxy of one coordinate. `ScalarProxy` factors `L` alone (the vertex graph:
//! a quarter of the entries, about an eighth of the factorization's work) and solves for both
//! coordinates in one pass over its factor: `kp-newton-cg`'s preconditioner.

use super::outcome::AnalysisReport;
use super::settings::Settings;
use super::stop::StopReason;
use crate::assembly::{Lower6, Pattern};
use crate::laplacian::{LaplacianPattern, SubBlock};
use crate::linear::{with_shift_retries, MAX_REGULARIZATION_RETRIES};
use crate::linear::{LinearError, LinearSettings, SpdSolver};
use crate::problem::MapProblem;
use crate::smoothness::Matrix8;
use crate::solver::outcome::SolveError;
use nalgebra::Matrix6;
use rayon::prelude::*;

/// The coefficient `c` of the proxy's `c |J|^2`: the energy's Dirichlet part
/// ([`EnergyKind::dirichlet_part`](crate::energy::EnergyKind::dirichlet_part)), so that the
/// proxy is the Hessian of the energy's quadratic part. The energies without one (AQP refuses
/// them; `lbfgs-laplacian` and `kp-newton-cg`'s preconditioner run on them) keep `c = 1`, the
/// Dirichlet energy `|J|^2` itself, as before the proxy followed the energy.
pub fn dirichlet_coefficient(problem: &MapProblem) -> f64 {
    problem.energy.dirichlet_part().unwrap_or(1.0)
}

/// The lower triangle of the proxy on `pattern` (the Newton pattern of `problem`): per face
/// `4 c a_t / sum a M^T M` (`|J|_F^2 = 2 (|f_z|^2 + |f_zbar|^2) = 2 |M y|^2`), the handles'
/// `2 lambda`, and the dofs of `pinned` replaced by the identity.
pub fn laplacian_proxy(problem: &MapProblem, pattern: &Pattern, pinned: Option<usize>) -> Vec<f64> {
    let w = 4.0 * dirichlet_coefficient(problem) * problem.weight();
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
        let pattern = problem.system_pattern();
        let mut solver = SpdSolver::shared(&pattern, linear.ordering, settings.analyses.as_deref())
            .map_err(|e| ProxyError::Setup(e.into()))?;
        let analysis = AnalysisReport::of(&solver);
        let pinned = pinned_vertex(problem);
        let values = laplacian_proxy(problem, &pattern, pinned);
        let shift = factorize_with_retries(&mut solver, &values, linear)?;
        Ok(Proxy { solver, pinned, shift, analysis, rhs: Vec::new(), out: Vec::new() })
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

/// Vertex 0 without handles (the translations are the proxy's kernel), none with them.
fn pinned_vertex(problem: &MapProblem) -> Option<usize> {
    let has_handles = problem.penalty.as_ref().is_some_and(|p| !p.handles.is_empty());
    if has_handles {
        None
    } else {
        Some(0)
    }
}

/// Factorize `values` with the Newton driver's retries at larger shifts; the shift that
/// succeeded, or the stop reason when none did.
fn factorize_with_retries(solver: &mut SpdSolver, values: &[f64], linear: &LinearSettings) -> Result<f64, ProxyError> {
    with_shift_retries(linear, MAX_REGULARIZATION_RETRIES, |lin| solver.factorize(values, lin))
        .map_err(|failed| ProxyError::Failed(StopReason::LinearSolveFailed(format!("the Laplacian proxy: {failed}"))))
}

/// The Dirichlet proxy's edge weights `-L_t[i][j]` of one coordinate, per face and edge
/// (opposite each corner): `-8 c a_t / sum a (d_i . d_j)`, `d` the Wirtinger row of each
/// corner (`M^T M = 2 (d_i . d_j) (x) I_2`). The rows of `L_t` sum to zero (a constant has no
/// derivative), so the assembled diagonal is the negated row sum.
fn dirichlet_weights(problem: &MapProblem, weights: &mut Vec<[f64; 3]>) {
    let w = 8.0 * dirichlet_coefficient(problem) * problem.weight();
    weights.clear();
    weights.par_extend(problem.ops.par_iter().map(|op| {
        std::array::from_fn(|k| {
            let (i, j) = ((k + 1) % 3, (k + 2) % 3);
            -w * op.area * (op.d_re[i] * op.d_re[j] + op.d_im[i] * op.d_im[j])
        })
    }));
}

/// Weights no lower than this fraction of the mean stiffness (a face whose projected block
/// is zero would otherwise leave its vertices without a diagonal).
pub const STIFFNESS_FLOOR: f64 = 1e-8;

/// The stiffness-weighted edge weights: each face's Dirichlet weights scaled by `s_t =
/// trace(H_t) / trace(D_t)`, its system block's mean stiffness against the Dirichlet block
/// `D_t = 4 c a_t / sum a M^T M` (`trace D_t = 16 c a_t / sum a sum |d_i|^2`), so that
/// `s_t D_t` has `H_t`'s trace: the isotropic part of each element's projected Hessian (the
/// same whatever `c`).
/// `scale` is scratch (the `s_t`), kept by the caller so that no iteration allocates.
fn stiffness_weights(problem: &MapProblem, blocks: &[Lower6], weights: &mut Vec<[f64; 3]>, scale: &mut Vec<f64>) {
    let diag = [0, 2, 5, 9, 14, 20]; // LOWER's (a, a) entries
    let c = dirichlet_coefficient(problem);
    scale.clear();
    scale.par_extend(problem.ops.par_iter().zip(blocks.par_iter()).map(|(op, b)| {
        let d2: f64 = (0..3).map(|i| op.d_re[i] * op.d_re[i] + op.d_im[i] * op.d_im[i]).sum();
        let trace_d = 16.0 * c * problem.weight() * op.area * d2;
        diag.iter().map(|&k| b[k]).sum::<f64>() / trace_d
    }));
    let mean = scale.iter().sum::<f64>() / scale.len().max(1) as f64;
    let floor = STIFFNESS_FLOOR * mean;
    dirichlet_weights(problem, weights);
    weights.par_iter_mut().zip(scale.par_iter()).for_each(|(w, &s)| {
        let s = if s > floor { s } else { floor };
        w.iter_mut().for_each(|x| *x *= s);
    });
}

/// The lower CSC values of `L` from edge `weights` into `values`: assembled on `pattern`
/// (into the scratch `full`), gathered into `block`, the handles' `2 lambda` on the
/// diagonal, `pinned`'s row and column the identity's.
fn scalar_values(
    problem: &MapProblem,
    pattern: &LaplacianPattern,
    block: &SubBlock,
    weights: &[[f64; 3]],
    pinned: Option<usize>,
    full: &mut Vec<f64>,
    values: &mut Vec<f64>,
) {
    pattern.assemble(weights, full);
    block.gather_into(full, values);
    if let Some(pen) = &problem.penalty {
        // the same 2 lambda on both coordinates of a handle's vertex: count the first
        for (dof, h) in pen.diagonal().filter(|(dof, _)| dof % 2 == 0) {
            values[block.diag[dof / 2]] += h;
        }
    }
    if let Some(v) = pinned {
        for c in 0..block.n {
            let range = block.col_ptr[c]..block.col_ptr[c + 1];
            for (value, &r) in values[range.clone()].iter_mut().zip(&block.row_idx[range]) {
                if r == v || c == v {
                    *value = if r == c { 1.0 } else { 0.0 };
                }
            }
        }
    }
}

/// The vertex graph's Laplacian pattern and its lower CSC block over every vertex.
fn scalar_pattern(problem: &MapProblem) -> (LaplacianPattern, SubBlock) {
    let n = problem.n_vertices;
    let pattern = LaplacianPattern::new(&problem.faces, n);
    let all: Vec<usize> = (0..n).collect();
    let block = SubBlock::new(&pattern, &all, &all);
    (pattern, block)
}

/// The proxy of one coordinate, `L`, as a lower CSC block of the vertex graph and its values
/// (the Dirichlet weights of `dirichlet_weights`, the handles, the pin).
pub fn scalar_laplacian_proxy(problem: &MapProblem, pinned: Option<usize>) -> (SubBlock, Vec<f64>) {
    let (pattern, block) = scalar_pattern(problem);
    let mut weights = Vec::new();
    dirichlet_weights(problem, &mut weights);
    let mut values = Vec::new();
    scalar_values(problem, &pattern, &block, &weights, pinned, &mut Vec::new(), &mut values);
    (block, values)
}

/// The factored proxy of one coordinate (module doc): `z = P A^-1 P r` for interleaved `r`.
/// Built with the constant Dirichlet weights; [`ScalarProxy::reweight`] refactors it with
/// the stiffness weights of a system's blocks (same pattern, same analysis).
pub(crate) struct ScalarProxy {
    solver: SpdSolver,
    pinned: Option<usize>,
    /// The Tikhonov shift the last factorization succeeded with.
    pub(crate) shift: f64,
    pub(crate) analysis: AnalysisReport,
    /// Both coordinates, one column each.
    columns: Vec<f64>,
    pattern: LaplacianPattern,
    block: SubBlock,
    /// Scratch kept across reweightings (no iteration allocates): edge weights, per-face
    /// stiffness scales, the assembled matrix, its lower block's values.
    weights: Vec<[f64; 3]>,
    scale: Vec<f64>,
    full: Vec<f64>,
    values: Vec<f64>,
}

impl ScalarProxy {
    /// Analyse (with the run's ordering, sharing the analysis through `settings.analyses`)
    /// and factor the constant `L`.
    pub(crate) fn new(problem: &MapProblem, settings: &Settings) -> Result<ScalarProxy, ProxyError> {
        let mut proxy = Self::analysed(problem, settings)?;
        dirichlet_weights(problem, &mut proxy.weights);
        proxy.assemble(problem);
        proxy.shift = factorize_with_retries(&mut proxy.solver, &proxy.values, &settings.linear)?;
        Ok(proxy)
    }

    /// Analysed but not factored: [`ScalarProxy::reweight`] factors it (a proxy reweighted
    /// every iteration has no use for the constant factor).
    pub(crate) fn analysed(problem: &MapProblem, settings: &Settings) -> Result<ScalarProxy, ProxyError> {
        let pinned = pinned_vertex(problem);
        let (pattern, block) = scalar_pattern(problem);
        let (n, ordering) = (block.n, settings.linear.ordering);
        let (col_ptr, row_idx, diag) = (&block.col_ptr, &block.row_idx, block.diag.clone());
        let solver = match settings.analyses.as_deref() {
            Some(cache) => SpdSolver::from_csc_cached(n, col_ptr, row_idx, diag, ordering, 1, cache),
            None => SpdSolver::from_csc_ordered(n, col_ptr.clone(), row_idx.clone(), diag, ordering, 1),
        }
        .map_err(|e| ProxyError::Setup(e.into()))?;
        let analysis = AnalysisReport::of(&solver);
        let shift = settings.linear.tikhonov;
        let (columns, weights, scale, full, values) = (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        Ok(ScalarProxy { solver, pinned, shift, analysis, columns, pattern, block, weights, scale, full, values })
    }

    /// `values` from the current `weights`.
    fn assemble(&mut self, problem: &MapProblem) {
        let (pattern, block, weights) = (&self.pattern, &self.block, &self.weights);
        scalar_values(problem, pattern, block, weights, self.pinned, &mut self.full, &mut self.values);
    }

    /// Refactor `L` with the stiffness weights of `blocks` (one per face, as the Newton driver
    /// projects them); the failure's stop reason when no shift factorizes it.
    pub(crate) fn reweight(
        &mut self,
        problem: &MapProblem,
        blocks: &[Lower6],
        linear: &LinearSettings,
    ) -> Result<(), StopReason> {
        stiffness_weights(problem, blocks, &mut self.weights, &mut self.scale);
        self.assemble(problem);
        match factorize_with_retries(&mut self.solver, &self.values, linear) {
            Ok(shift) => {
                self.shift = shift;
                Ok(())
            }
            Err(ProxyError::Failed(reason)) => Err(reason),
            Err(ProxyError::Setup(e)) => Err(StopReason::LinearSolveFailed(e.to_string())),
        }
    }

    /// `z <- P A^-1 P r`, `P` zeroing the pinned vertex's dofs; `r` and `z` interleaved.
    pub(crate) fn apply(&mut self, r: &[f64], z: &mut [f64]) -> Result<(), LinearError> {
        let n = r.len() / 2;
        self.columns.resize(2 * n, 0.0);
        let (u, v) = self.columns.split_at_mut(n);
        for (i, p) in r.chunks_exact(2).enumerate() {
            (u[i], v[i]) = (p[0], p[1]);
        }
        if let Some(p) = self.pinned {
            (u[p], v[p]) = (0.0, 0.0);
        }
        self.solver.solve_columns_in_place(&mut self.columns)?;
        let (u, v) = self.columns.split_at(n);
        for (i, q) in z.chunks_exact_mut(2).enumerate() {
            (q[0], q[1]) = (u[i], v[i]);
        }
        if let Some(p) = self.pinned {
            z[2 * p..2 * p + 2].fill(0.0);
        }
        Ok(())
    }

    /// The vertex whose dofs the proxy fixes (none with handles).
    pub(crate) fn pinned(&self) -> Option<usize> {
        self.pinned
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::{Barap, EnergyKind, Sd};
    use crate::problem::{dot, norm, Evaluation, Penalty};

    /// `c sum_t a_t |J_t|^2 / sum a` at `x`, plus the handle penalty when the problem has one.
    fn dirichlet(pb: &MapProblem, x: &[f64]) -> f64 {
        let c = dirichlet_coefficient(pb);
        let d = (0..pb.n_faces())
            .map(|t| {
                let w = pb.ops[t].wirtinger(pb.target(x, t));
                c * pb.ops[t].area * 2.0 * (w.x() + w.y())
            })
            .sum::<f64>()
            / pb.total_area;
        d + pb.penalty.as_ref().map_or(0.0, |p| p.value(x))
    }

    /// The 2n matrix `two` (lower triangle on `pattern`) is `L (x) I_2` for the scalar
    /// matrix `one` (lower triangle on `block`), entry by entry within `tol` relative.
    fn assert_kronecker_i2(pattern: &Pattern, two: &[f64], block: &SubBlock, one: &[f64], tol: f64) {
        let scalar = |r: usize, c: usize| {
            let range = block.col_ptr[c]..block.col_ptr[c + 1];
            block.row_idx[range.clone()].binary_search(&r).map_or(0.0, |k| one[range.start + k])
        };
        for c in 0..pattern.n {
            let range = pattern.col_ptr[c]..pattern.col_ptr[c + 1];
            for (&r, &value) in pattern.row_idx[range.clone()].iter().zip(&two[range]) {
                let want = if r % 2 == c % 2 { scalar(r / 2, c / 2) } else { 0.0 };
                assert!((value - want).abs() < tol * (1.0 + want.abs()), "({r}, {c}): {value} vs {want}");
            }
        }
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
        let mut pb = MapProblem::new(&mesh, EnergyKind::Sd(Sd)).unwrap();
        let pattern = pb.system_pattern();
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

    /// `grad Q(x)` of the part `Q` of the problem's energy homogeneous of degree 2 in the map,
    /// from the energy's own gradient (its densities, area weights and penalty), not from any
    /// formula of the proxy: `E(s x) = s^2 Q(x) + s P(x) + R + s^-2 B(x)` for SD (`B` the
    /// `|J^-1|^2` barrier) and BARAP at `k = 0` (`P = -4 sum a sqrt(x) / sum a`), the penalty
    /// adding to `Q`, `P` and `R`. So `g(s) = grad E(s x) / s = grad Q + s^-1 grad P + s^-4
    /// grad B`, and Richardson's `2 g(2s) - g(s) = grad Q - 7/8 s^-4 grad B`: at `s = 1e3` the
    /// barrier's trace is 1e-12 of its gradient.
    fn quadratic_part_gradient(pb: &MapProblem, x: &[f64]) -> Vec<f64> {
        let g = |s: f64| {
            let xs: Vec<f64> = x.iter().map(|v| v * s).collect();
            let mut ev = Evaluation::default();
            pb.evaluate(&xs, &mut ev).unwrap();
            ev.grad.iter().map(|g| g / s).collect::<Vec<f64>>()
        };
        let (s, twice) = (1e3, g(2e3));
        g(s).iter().zip(&twice).map(|(a, b)| 2.0 * b - a).collect()
    }

    /// The audit's claim and its fix: the proxy applied to `v` is the Hessian of the
    /// energy's quadratic part applied to `v`, by central differences of that part's gradient
    /// along `v` at the Tutte map of `bumpy_1k`: for SD `1/2 |J|^2` (half the proxy the
    /// Dirichlet energy `|J|^2` gives, which was the proxy before), with and without handles;
    /// for BARAP at `k = 0` the ARAP part's `|J|^2`. `Q` is quadratic, so the central difference
    /// has no truncation error: what is left is the barrier's 1e-12 (above) and round-off,
    /// about 1e-16 of the gradient over `h = 1e-4`, well inside 1e-8 of `|A v|`. At BARAP's
    /// default `k` the barrier's `k |J|` adds `k` times the image's signed area to `Q`, whose
    /// Hessian lives on the boundary: the proxy, which leaves it out, then matches on the
    /// interior vertices only.
    #[test]
    fn the_proxy_is_the_hessian_of_the_energy_s_quadratic_part() {
        use crate::init::{tutte, TutteBoundary};
        let mesh = crate::generate::generate("bumpy_1k").unwrap().normalized();
        let x = tutte(&mesh, TutteBoundary::Uniform).unwrap();
        let boundary: std::collections::BTreeSet<usize> =
            crate::mesh::topology::boundary_loops(&mesh.faces, mesh.n_vertices()).concat().into_iter().collect();
        let handles = Penalty { lambda: 1e3, handles: vec![(3, [0.1, 0.2]), (40, [-0.3, 0.0])] };
        let h = 1e-4;
        let cases = [
            (EnergyKind::Sd(Sd), None, 0.5),
            (EnergyKind::Sd(Sd), Some(handles), 0.5),
            (EnergyKind::Barap(Barap { k: 0.0 }), None, 1.0),
            (EnergyKind::Barap(Barap { k: 0.1 }), None, 1.0),
        ];
        for (energy, penalty, c) in cases {
            let mut pb = MapProblem::new(&mesh, energy).unwrap();
            pb.penalty = penalty;
            assert_eq!(dirichlet_coefficient(&pb), c);
            let pattern = pb.system_pattern();
            let a = laplacian_proxy(&pb, &pattern, None);
            let n = pb.n_dofs();
            for k in [37, 11] {
                let v = wave(n, k);
                let at = |sign: f64| -> Vec<f64> {
                    let xs: Vec<f64> = x.iter().zip(&v).map(|(a, b)| a + sign * h * b).collect();
                    quadratic_part_gradient(&pb, &xs)
                };
                let (plus, minus) = (at(1.0), at(-1.0));
                let fd: Vec<f64> = plus.iter().zip(&minus).map(|(p, m)| (p - m) / (2.0 * h)).collect();
                let av = pattern.sym_mul(&a, &v);
                let label = format!("{} k {k} handles {}", energy.name(), pb.penalty.is_some());
                let interior = |i: &usize| !boundary.contains(&(i / 2));
                let err = |keep: &dyn Fn(&usize) -> bool| {
                    let diff: Vec<f64> = (0..n).filter(keep).map(|i| fd[i] - av[i]).collect();
                    norm(&diff) / norm(&av)
                };
                if energy == (EnergyKind::Barap(Barap { k: 0.1 })) {
                    assert!(err(&interior) < 1e-8, "{label}: interior {:e}", err(&interior));
                    assert!(err(&|_| true) > 1e-4, "{label}: the barrier's area term is missing: {:e}", err(&|_| true));
                } else {
                    assert!(err(&|_| true) < 1e-8, "{label}: {:e}", err(&|_| true));
                }
                if energy == EnergyKind::Sd(Sd) && pb.penalty.is_none() {
                    // the proxy of the Dirichlet energy |J|^2 (BARAP's) is twice SD's Hessian
                    let barap = MapProblem::new(&mesh, EnergyKind::Barap(Barap { k: 0.1 })).unwrap();
                    let twice = pattern.sym_mul(&laplacian_proxy(&barap, &pattern, None), &v);
                    let rel = norm(&twice.iter().zip(&fd).map(|(t, f)| t - 2.0 * f).collect::<Vec<_>>()) / norm(&twice);
                    assert!(rel < 1e-8, "{label}: {rel:e}");
                }
            }
        }
    }

    /// Blocks that are multiples `c_t D_t` of the Dirichlet blocks are isotropic: the
    /// stiffness weights then reproduce them exactly, `L_w (x) I_2` is their assembly (and
    /// with every `c_t = 1` it is the constant proxy). A zero block is floored.
    #[test]
    fn the_stiffness_weights_reproduce_isotropic_blocks() {
        let mesh = crate::generate::generate("bumpy_1k").unwrap().normalized();
        let pb = MapProblem::new(&mesh, EnergyKind::Sd(Sd)).unwrap();
        let pattern = pb.system_pattern();
        let dirichlet = |t: usize| {
            let op = &pb.ops[t];
            let m = op.m();
            m.transpose() * m * (4.0 * dirichlet_coefficient(&pb) * pb.weight() * op.area)
        };
        let (lap, block) = scalar_pattern(&pb);
        for c in [|_: usize| 1.0, |t: usize| 0.5 + (t % 7) as f64] {
            let blocks: Vec<Lower6> =
                (0..pb.n_faces()).map(|t| crate::assembly::pack_lower(&(dirichlet(t) * c(t)))).collect();
            let mut two = Vec::new();
            pattern.assemble(&blocks, &mut two);
            let mut weights = Vec::new();
            stiffness_weights(&pb, &blocks, &mut weights, &mut Vec::new());
            let mut one = Vec::new();
            scalar_values(&pb, &lap, &block, &weights, None, &mut Vec::new(), &mut one);
            assert_kronecker_i2(&pattern, &two, &block, &one, 1e-9);
        }
        let mut blocks: Vec<Lower6> = (0..pb.n_faces()).map(|t| crate::assembly::pack_lower(&dirichlet(t))).collect();
        blocks[5] = [0.0; 21];
        let (mut floored, mut constant) = (Vec::new(), Vec::new());
        stiffness_weights(&pb, &blocks, &mut floored, &mut Vec::new());
        dirichlet_weights(&pb, &mut constant);
        let mean = 1.0 - 1.0 / pb.n_faces() as f64;
        for k in 0..3 {
            assert!((floored[5][k] - STIFFNESS_FLOOR * mean * constant[5][k]).abs() < 1e-12 * constant[5][k].abs());
            assert!((floored[6][k] - constant[6][k]).abs() < 1e-12 * constant[6][k].abs());
        }
    }

    /// The proxy of one coordinate is the two-coordinate proxy's `L` in `L (x) I_2`, with
    /// the handles and the pin; its solve for both coordinates at once is the two-coordinate
    /// proxy's solve.
    #[test]
    fn the_scalar_proxy_is_the_proxy_of_each_coordinate() {
        let mesh = crate::generate::generate("bumpy_1k").unwrap().normalized();
        let mut pb = MapProblem::new(&mesh, EnergyKind::Sd(Sd)).unwrap();
        let pattern = pb.system_pattern();
        for penalty in [None, Some(Penalty { lambda: 1e3, handles: vec![(3, [0.1, 0.2]), (40, [-0.3, 0.0])] })] {
            pb.penalty = penalty;
            let pinned = pinned_vertex(&pb);
            assert_eq!(pinned.is_none(), pb.penalty.is_some());
            let two = laplacian_proxy(&pb, &pattern, pinned);
            let (block, one) = scalar_laplacian_proxy(&pb, pinned);
            assert_kronecker_i2(&pattern, &two, &block, &one, 1e-12);
            let settings = Settings::default();
            let mut full = Proxy::new(&pb, &settings.linear, &settings).ok().unwrap();
            let mut half = ScalarProxy::new(&pb, &settings).ok().unwrap();
            let q = wave(pb.n_dofs(), 37);
            let mut want = q.clone();
            full.apply(&mut want).unwrap();
            let mut got = vec![f64::NAN; q.len()];
            half.apply(&q, &mut got).unwrap();
            let err = norm(&want.iter().zip(&got).map(|(a, b)| a - b).collect::<Vec<_>>());
            assert!(err < 1e-9 * norm(&want), "{err}");
            assert_eq!(pinned.map(|v| [got[2 * v], got[2 * v + 1]]).unwrap_or_default(), [0.0, 0.0]);
        }
    }
}
