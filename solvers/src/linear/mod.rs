//! Sparse SPD solves with faer: the symbolic Cholesky analysis is done once per pattern and
//! the numeric factorization is recomputed into a reused buffer each iteration
//! (docs/src/design/linear-algebra.md).
//!
//! Conventions of the complex-view reference code (`meshNewton`): a Tikhonov shift `tau` is
//! added to the diagonal, the matrix is scaled symmetrically by `S = diag(1/sqrt(a_ii))`
//! (Jacobi), and `tau` is added again to the scaled diagonal; the step is `d = S y` with
//! `(S A S + tau I) y = S b`.
//!
//! The wing's parts: the orderings (`ordering.rs`), the subtree-parallel supernodal factor
//! (`supernodal.rs`), its triangular solves (`triangular.rs`) and their errors (`error.rs`).

mod analysis;
mod error;
pub mod ordering;
pub mod supernodal;
pub mod triangular;

pub use analysis::{Analysis, AnalysisCache};
pub use error::LinearError;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{LltRef, SymbolicCholesky, SymbolicCholeskyRaw};
use faer::sparse::SparseColMatRef;
use faer::{Conj, MatMut, Par, Side};
use ordering::Ordering;
use std::sync::Arc;
use std::time::Instant;
use supernodal::Workspace;

/// A lower-triangular CSC sparsity pattern, rows sorted within each column and every diagonal
/// entry present: what [`SpdSolver::new`] analyses (the assembled Newton pattern, a layer up,
/// is one).
pub trait LowerPattern {
    /// The matrix dimension.
    fn dim(&self) -> usize;
    /// Start of each column in [`LowerPattern::row_indices`] (length `dim + 1`).
    fn col_ptr(&self) -> &[usize];
    /// Row of each stored entry, sorted within each column (rows `>=` the column).
    fn row_indices(&self) -> &[usize];
    /// Value slot of each diagonal entry.
    fn diagonal_slots(&self) -> &[usize];
}

/// Linear-system settings (`[linear]` in the config).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LinearSettings {
    /// Tikhonov shift, added before and after Jacobi scaling.
    pub tikhonov: f64,
    /// Symmetric Jacobi scaling (complex-view paper Section 6.1: without it Cholesky often
    /// fails on cut meshes).
    pub jacobi: bool,
    /// Fill-reducing ordering of the Newton system (the Tutte and authalic Laplacians, solved
    /// a few times per run, always use AMD).
    pub ordering: Ordering,
}

impl Default for LinearSettings {
    fn default() -> Self {
        LinearSettings { tikhonov: 1e-10, jacobi: true, ordering: Ordering::default() }
    }
}

/// How many times the Tikhonov shift is increased after a failed factorization (by the
/// Newton systems' strategies that retry and by the proxies' factorizations, layers up).
pub const MAX_REGULARIZATION_RETRIES: usize = 3;

/// The shift of the retry after a failed factorization with shift `tau`: x1000, at least
/// 1e-8 (from the default 1e-10: 1e-7, 1e-4, 0.1).
pub fn next_shift(tau: f64) -> f64 {
    (tau * 1e3).max(1e-8)
}

/// `attempt` (a factorization, or a factorization and a solve) at the base shift of `base`
/// and, while it fails, at up to `retries` larger ones ([`next_shift`]): the shift that
/// succeeded, or the last failure with the shifts tried.
pub fn with_shift_retries(
    base: &LinearSettings,
    retries: usize,
    mut attempt: impl FnMut(&LinearSettings) -> Result<(), LinearError>,
) -> Result<f64, ShiftsFailed> {
    let mut lin = *base;
    let mut result = attempt(&lin);
    for _ in 0..retries {
        if result.is_ok() {
            break;
        }
        lin.tikhonov = next_shift(lin.tikhonov);
        result = attempt(&lin);
    }
    result.map(|()| lin.tikhonov).map_err(|error| ShiftsFailed {
        error,
        first: base.tikhonov,
        last: lin.tikhonov,
        retried: retries > 0,
    })
}

/// A factorization that failed at every shift [`with_shift_retries`] tried.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{error} ({})", if *.retried { format!("shifts {:e} to {:e}", .first, .last) } else { format!("shift {:e}, no retry", .first) })]
pub struct ShiftsFailed {
    /// The failure at the last shift tried.
    pub error: LinearError,
    /// The base shift, tried first.
    pub first: f64,
    /// The last (largest) shift tried.
    pub last: f64,
    /// Whether retries were allowed (`retries > 0`).
    pub retried: bool,
}

/// The matrix the factorization sees (module doc): `scaled = S (A + tau I) S + tau I` with
/// `S = diag(1/sqrt(a_ii + tau))` when `settings.jacobi`, else `A + tau I` and `S = I`.
/// `A` is a lower-triangle CSC with diagonal slots `diag`.
pub fn regularize(
    col_ptr: &[usize],
    row_idx: &[usize],
    diag: &[usize],
    values: &[f64],
    settings: &LinearSettings,
    scaled: &mut Vec<f64>,
    scale: &mut Vec<f64>,
) -> Result<(), LinearError> {
    let tau = settings.tikhonov;
    let n = diag.len();
    scaled.clear();
    scaled.extend_from_slice(values);
    scale.clear();
    scale.resize(n, 1.0);
    for &p in diag {
        scaled[p] += tau;
    }
    if settings.jacobi {
        for (i, &p) in diag.iter().enumerate() {
            let d = scaled[p];
            if !(d > 0.0 && d.is_finite()) {
                return Err(LinearError::BadDiagonal { index: i, value: d });
            }
            scale[i] = 1.0 / d.sqrt();
        }
        for c in 0..n {
            let sc = scale[c];
            let range = col_ptr[c]..col_ptr[c + 1];
            for (v, &r) in scaled[range.clone()].iter_mut().zip(&row_idx[range]) {
                *v *= sc * scale[r];
            }
        }
        for &p in diag {
            scaled[p] += tau;
        }
    }
    Ok(())
}

/// Sparse Cholesky solves on one pattern: its symbolic analysis and the last numeric factor.
pub struct SpdSolver {
    n: usize,
    analysis: Arc<Analysis>,
    /// The analysis came from an [`AnalysisCache`] entry computed by another solver.
    reused: bool,
    /// Time spent obtaining the analysis: computing it, or waiting for another solver that was.
    setup_seconds: f64,
    diag: Vec<usize>,
    l_values: Vec<f64>,
    scaled: Vec<f64>,
    scale: Vec<f64>,
    mem: MemBuffer,
    /// The parallelism `mem` was sized for, and the right-hand-side columns.
    mem_par: Par,
    mem_cols: usize,
    /// Per-thread scratch of the subtree-parallel factorization.
    workspace: Workspace,
    /// Factorize with faer's own (supernode after supernode) kernel even when a schedule
    /// exists: `time-system --kernel faer`, to measure one against the other.
    faer_kernel: bool,
    /// Scratch of `triangular::solve_in_place` (right-hand sides, the tasks' buffers).
    solve_work: triangular::SolveWork,
    factored: bool,
}

/// faer's parallelism for the calling thread: the threads of the rayon pool it runs in (a
/// run's `threads_per_run`), sequential in a pool of one. Used by faer's kernels here (the
/// simplicial factorization, `--kernel faer`, the solves); the supernodal factorization
/// schedules its own threads (`supernodal`).
pub fn current_par() -> Par {
    match rayon::current_num_threads() {
        0 | 1 => Par::Seq,
        n => Par::rayon(n),
    }
}

fn scratch(symbolic: &SymbolicCholesky<usize>, par: Par) -> MemBuffer {
    MemBuffer::new(
        symbolic
            .factorize_numeric_llt_scratch::<f64>(par, Default::default())
            .or(symbolic.solve_in_place_scratch::<f64>(1, par)),
    )
}

impl SpdSolver {
    /// Analyse the Newton pattern once (two interleaved dofs per vertex) with `ordering`
    /// (supernodal when faer deems it worthwhile).
    pub fn new(pattern: &impl LowerPattern, ordering: Ordering) -> Result<SpdSolver, LinearError> {
        Self::shared(pattern, ordering, None)
    }

    /// [`SpdSolver::new`], taking the analysis from `cache` when another solver on the same
    /// pattern already computed it (and leaving it there for the next one).
    pub fn shared(
        pattern: &impl LowerPattern,
        ordering: Ordering,
        cache: Option<&AnalysisCache>,
    ) -> Result<SpdSolver, LinearError> {
        let t0 = Instant::now();
        let (analysis, reused) = match cache {
            Some(c) => c.get(pattern.dim(), pattern.col_ptr(), pattern.row_indices(), ordering, 2)?,
            None => {
                let (c, r) = (pattern.col_ptr().to_vec(), pattern.row_indices().to_vec());
                (Arc::new(Analysis::new(pattern.dim(), c, r, ordering, 2)?), false)
            }
        };
        Ok(Self::with_analysis(analysis, pattern.diagonal_slots().to_vec(), reused, t0.elapsed().as_secs_f64()))
    }

    /// [`SpdSolver::from_csc`] with a choice of ordering; METIS orders the graph whose nodes
    /// are groups of `block` consecutive dofs.
    pub fn from_csc_ordered(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        diag: Vec<usize>,
        ordering: Ordering,
        block: usize,
    ) -> Result<SpdSolver, LinearError> {
        let t0 = Instant::now();
        let analysis = Arc::new(Analysis::new(n, col_ptr, row_idx, ordering, block)?);
        Ok(Self::with_analysis(analysis, diag, false, t0.elapsed().as_secs_f64()))
    }

    /// [`SpdSolver::from_csc_ordered`], taking the analysis from `cache` when an earlier
    /// solver on the same pattern computed it (an authalic run's `L_II`: the initial map's
    /// and the preconditioner's).
    pub fn from_csc_cached(
        n: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        diag: Vec<usize>,
        ordering: Ordering,
        block: usize,
        cache: &AnalysisCache,
    ) -> Result<SpdSolver, LinearError> {
        let t0 = Instant::now();
        let (analysis, reused) = cache.get(n, col_ptr, row_idx, ordering, block)?;
        Ok(Self::with_analysis(analysis, diag, reused, t0.elapsed().as_secs_f64()))
    }

    /// Analyse a lower-triangular CSC pattern (sorted rows, every diagonal present; `diag`
    /// gives the value slot of each diagonal entry) with AMD.
    pub fn from_csc(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        diag: Vec<usize>,
    ) -> Result<SpdSolver, LinearError> {
        Self::from_csc_ordered(n, col_ptr, row_idx, diag, Ordering::Amd, 1)
    }

    fn with_analysis(analysis: Arc<Analysis>, diag: Vec<usize>, reused: bool, setup_seconds: f64) -> SpdSolver {
        let mem_par = current_par();
        let mem = scratch(&analysis.symbolic, mem_par);
        let l_values = vec![0.0; analysis.symbolic.len_val()];
        let n = analysis.symbolic_a.nrows();
        SpdSolver {
            n,
            analysis,
            reused,
            setup_seconds,
            diag,
            l_values,
            scaled: Vec::new(),
            scale: vec![1.0; n],
            mem,
            mem_par,
            mem_cols: 1,
            workspace: Workspace::default(),
            faer_kernel: false,
            solve_work: Default::default(),
            factored: false,
        }
    }

    /// The shared analysis (ordering, symbolic factor) this solver factorizes with.
    pub fn analysis(&self) -> &Arc<Analysis> {
        &self.analysis
    }

    /// Whether the analysis was reused from a cache entry another solver computed.
    pub fn analysis_reused(&self) -> bool {
        self.reused
    }

    /// Wall time this solver spent obtaining its analysis (computing it, or waiting for it).
    pub fn setup_seconds(&self) -> f64 {
        self.setup_seconds
    }

    /// The ordering the analysis used (`metis` falls back to AMD on tiny graphs).
    pub fn ordering(&self) -> Ordering {
        self.analysis.ordering
    }

    /// Factorize with faer's sequential-over-supernodes kernel (`true`) instead of the
    /// subtree-parallel one of `supernodal` (the default); for benchmarks.
    pub fn set_faer_kernel(&mut self, faer: bool) {
        self.faer_kernel = faer;
    }

    /// Number of stored entries of the Cholesky factor (with supernodal padding).
    pub fn factor_len(&self) -> usize {
        self.l_values.len()
    }

    /// Solve `A x = b` for the SPD matrix with lower-triangle `values` on the analysed
    /// pattern, with the regularization and scaling of `settings`.
    pub fn solve(&mut self, values: &[f64], b: &[f64], settings: &LinearSettings) -> Result<Vec<f64>, LinearError> {
        self.factorize(values, settings)?;
        self.solve_factored(b)
    }

    /// Numeric factorization of `values` (scaled and shifted per `settings`), kept for any
    /// number of [`SpdSolver::solve_factored`] calls until the next factorization. Runs on
    /// the threads of the calling rayon pool ([`current_par`]).
    pub fn factorize(&mut self, values: &[f64], settings: &LinearSettings) -> Result<(), LinearError> {
        self.factored = false;
        let par = self.par();
        let symbolic_a = &self.analysis.symbolic_a;
        let (col_ptr, row_idx) = (symbolic_a.col_ptr(), symbolic_a.row_idx());
        regularize(col_ptr, row_idx, &self.diag, values, settings, &mut self.scaled, &mut self.scale)?;
        let not_pd = |e| match e {
            faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index } => {
                LinearError::NotPositiveDefinite { pivot: index }
            }
        };
        match (&self.analysis.schedule, self.analysis.symbolic.raw()) {
            (Some(schedule), SymbolicCholeskyRaw::Supernodal(sn)) if !self.faer_kernel => {
                supernodal::factorize(sn, schedule, &mut self.workspace, &self.scaled, &mut self.l_values)
                    .map_err(not_pd)?;
            }
            _ => {
                let a = SparseColMatRef::new(symbolic_a.as_ref(), &self.scaled);
                self.analysis
                    .symbolic
                    .factorize_numeric_llt::<f64>(
                        &mut self.l_values,
                        a,
                        Side::Lower,
                        LltRegularization::default(),
                        par,
                        MemStack::new(&mut self.mem),
                        Default::default(),
                    )
                    .map_err(not_pd)?;
            }
        }
        self.factored = true;
        Ok(())
    }

    /// [`current_par`], with the scratch memory resized when it changed since the last call.
    fn par(&mut self) -> Par {
        let par = current_par();
        if par != self.mem_par {
            self.mem = scratch(&self.analysis.symbolic, par);
            (self.mem_par, self.mem_cols) = (par, 1);
        }
        par
    }

    /// Solve with the factor of the last successful [`SpdSolver::factorize`].
    pub fn solve_factored(&mut self, b: &[f64]) -> Result<Vec<f64>, LinearError> {
        let mut x = Vec::with_capacity(self.n);
        self.solve_factored_into(b, &mut x)?;
        Ok(x)
    }

    /// [`SpdSolver::solve_factored`] into `x`, reusing its allocation (the Newton loop's).
    pub fn solve_factored_into(&mut self, b: &[f64], x: &mut Vec<f64>) -> Result<(), LinearError> {
        x.clear();
        x.extend_from_slice(b);
        self.solve_columns_in_place(x)
    }

    /// Solve for every column of `x` at once (column-major, `n` rows each, as many columns as
    /// `x` holds), in place: one pass over the factor for all of them, which is what a
    /// triangular solve's time is made of (the AEM preconditioner's two interior coordinates).
    /// A supernodal factor is solved by `triangular` (on the calling pool's threads when it is
    /// large, the same bits for any pool), a simplicial one by faer.
    pub fn solve_columns_in_place(&mut self, x: &mut [f64]) -> Result<(), LinearError> {
        if !self.factored {
            return Err(LinearError::NotFactored);
        }
        let n = self.n;
        if n == 0 || !x.len().is_multiple_of(n) {
            return Err(LinearError::RhsLength { rows: n, len: x.len() });
        }
        let k = x.len() / n;
        for col in x.chunks_exact_mut(n) {
            col.iter_mut().zip(&self.scale).for_each(|(xi, si)| *xi *= si);
        }
        match (&self.analysis.schedule, self.analysis.symbolic.raw()) {
            // A supernodal factor: our solve (the module's doc says why), unless faer's
            // kernels are asked for.
            (Some(_), SymbolicCholeskyRaw::Supernodal(sn)) if !self.faer_kernel => {
                let perm = self.analysis.symbolic.perm();
                let sched = self.analysis.schedule.as_ref();
                triangular::solve_in_place(sn, perm, sched, &self.l_values, x, &mut self.solve_work);
            }
            _ => self.faer_solve(x, k),
        }
        for col in x.chunks_exact_mut(n) {
            col.iter_mut().zip(&self.scale).for_each(|(xi, si)| *xi *= si);
        }
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            return Err(LinearError::BadDiagonal { index: i % n, value: x[i] });
        }
        Ok(())
    }

    /// faer's triangular solves for the `k` columns of `x` (scaled), on the calling pool's
    /// threads: a simplicial factor (small systems), or `time-system --kernel faer`.
    fn faer_solve(&mut self, x: &mut [f64], k: usize) {
        let n = self.n;
        let par = self.par();
        if k > self.mem_cols {
            let req = self.analysis.symbolic.solve_in_place_scratch::<f64>(k, par);
            self.mem = MemBuffer::new(
                req.or(self.analysis.symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default())),
            );
            self.mem_cols = k;
        }
        let rhs = MatMut::from_column_major_slice_mut(x, n, k);
        let llt = LltRef::new(&self.analysis.symbolic, &self.l_values);
        llt.solve_in_place_with_conj(Conj::No, rhs, par, MemStack::new(&mut self.mem));
    }
}

#[cfg(test)]
mod tests;
