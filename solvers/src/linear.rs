//! Sparse SPD solves with faer: the symbolic Cholesky analysis is done once per pattern and
//! the numeric factorization is recomputed into a reused buffer each iteration
//! (`../shared/notes/rust-stack.md` section 2).
//!
//! Conventions of the complex-view reference code (notes 1.8): a Tikhonov shift `tau` is
//! added to the diagonal, the matrix is scaled symmetrically by `S = diag(1/sqrt(a_ii))`
//! (Jacobi), and `tau` is added again to the scaled diagonal; the step is `d = S y` with
//! `(S A S + tau I) y = S b`.

use crate::assembly::Pattern;
pub use crate::linear_error::LinearError;
use crate::ordering::{metis_order_timed, Ordering};
use crate::supernodal::{Schedule, Workspace};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

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
/// strategies that retry, [`crate::hessian::SystemBlock::retries_failed_factorization`], and
/// the proxies' factorizations).
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
    pub error: LinearError,
    pub first: f64,
    pub last: f64,
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

/// One symbolic analysis: the pattern, its fill-reducing ordering and the symbolic Cholesky
/// factor. It depends on the pattern only, so every solver that factorizes matrices on the
/// same pattern (all Newton-type strategies on one mesh) can share it.
pub struct Analysis {
    symbolic_a: SymbolicSparseColMat<usize>,
    symbolic: SymbolicCholesky<usize>,
    /// The ordering asked for and the dof block it ordered by (the cache key's parts).
    requested: (Ordering, usize),
    /// The ordering used (`metis` falls back to AMD on tiny graphs).
    ordering: Ordering,
    /// The subtree-parallel numeric factorization's schedule (`supernodal`), when faer chose
    /// a supernodal factor; `None` for a simplicial one (small systems), which faer factorizes.
    schedule: Option<Schedule>,
    /// Wall time of the ordering plus the symbolic factorization, without any wait for
    /// another thread's METIS call.
    seconds: f64,
}

impl Analysis {
    fn new(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        ordering: Ordering,
        block: usize,
    ) -> Result<Analysis, LinearError> {
        let t0 = Instant::now();
        let (perm, waited) = match ordering {
            Ordering::Amd => (None, Duration::ZERO),
            Ordering::Metis => metis_order_timed(n, &col_ptr, &row_idx, block)?,
        };
        let symbolic_a = SymbolicSparseColMat::<usize>::new_checked(n, n, col_ptr, None, row_idx);
        let faer_ordering = match &perm {
            Some((fwd, inv)) => SymmetricOrdering::Custom(PermRef::new_checked(fwd, inv, n)),
            None => SymmetricOrdering::Amd,
        };
        let symbolic = factorize_symbolic_cholesky(
            symbolic_a.as_ref(),
            Side::Lower,
            faer_ordering,
            CholeskySymbolicParams::default(),
        )
        .map_err(|e| LinearError::Symbolic(format!("{e:?}")))?;
        let used = if perm.is_some() { Ordering::Metis } else { Ordering::Amd };
        let schedule = match symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(sn) => Some(
                Schedule::new(sn, symbolic.perm(), symbolic_a.col_ptr(), symbolic_a.row_idx())
                    .map_err(|e| LinearError::Symbolic(format!("the supernodal schedule: {e:?}")))?,
            ),
            SymbolicCholeskyRaw::Simplicial(_) => None,
        };
        let seconds = t0.elapsed().saturating_sub(waited).as_secs_f64();
        Ok(Analysis { symbolic_a, symbolic, requested: (ordering, block), ordering: used, schedule, seconds })
    }

    /// Wall time the analysis took when it was computed.
    pub fn seconds(&self) -> f64 {
        self.seconds
    }

    fn is_for(&self, n: usize, col_ptr: &[usize], row_idx: &[usize], ordering: Ordering, block: usize) -> bool {
        self.requested == (ordering, block)
            && self.symbolic_a.nrows() == n
            && self.symbolic_a.col_ptr() == col_ptr
            && self.symbolic_a.row_idx() == row_idx
    }
}

/// One cache entry: empty until an analysis succeeded. Its lock is held while the analysis
/// is computed, so a second request for the same pattern waits instead of repeating it.
type Slot = Arc<Mutex<Option<Arc<Analysis>>>>;

/// Analyses shared by the runs on one mesh (the symbolic factorization and ordering are
/// reused across solvers on the same pattern). The caller owns it (the
/// harness keeps one per loaded mesh and drops it with the mesh); a solver only looks up
/// or fills an entry, so results never depend on whether an entry was there. Entries are
/// keyed by a hash of the pattern, the ordering and the block size, and checked against all
/// of them on use. Only successful analyses are kept: after a failure the next run tries again.
#[derive(Default)]
pub struct AnalysisCache {
    slots: Mutex<Vec<(u64, Slot)>>,
}

impl std::fmt::Debug for AnalysisCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "AnalysisCache({} patterns)", self.len())
    }
}

/// Two caches are equal only when they are the same cache (settings compare by identity).
impl PartialEq for AnalysisCache {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self, other)
    }
}

impl AnalysisCache {
    pub fn new() -> AnalysisCache {
        AnalysisCache::default()
    }

    /// Number of patterns with a stored analysis.
    pub fn len(&self) -> usize {
        let slots = self.slots.lock().unwrap_or_else(|e| e.into_inner());
        slots.iter().filter(|(_, s)| s.lock().unwrap_or_else(|e| e.into_inner()).is_some()).count()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The analysis of the pattern, computed by the first caller; `true` when it was
    /// reused (computed by another caller, possibly while this one waited).
    fn get(
        &self,
        n: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        ordering: Ordering,
        block: usize,
    ) -> Result<(Arc<Analysis>, bool), LinearError> {
        let key = {
            let mut h = std::collections::hash_map::DefaultHasher::new();
            (n, col_ptr, row_idx, ordering, block).hash(&mut h);
            h.finish()
        };
        let slot = {
            let mut slots = self.slots.lock().unwrap_or_else(|e| e.into_inner());
            match slots.iter().find(|(k, _)| *k == key) {
                Some((_, s)) => s.clone(),
                None => {
                    let s = Slot::default();
                    slots.push((key, s.clone()));
                    s
                }
            }
        };
        let fresh = || Analysis::new(n, col_ptr.to_vec(), row_idx.to_vec(), ordering, block).map(Arc::new);
        let mut entry = slot.lock().unwrap_or_else(|e| e.into_inner());
        match entry.as_ref() {
            Some(a) if a.is_for(n, col_ptr, row_idx, ordering, block) => Ok((a.clone(), true)),
            // A hash collision (another pattern under the same key) gets a private analysis.
            Some(_) => Ok((fresh()?, false)),
            None => {
                let a = fresh()?;
                *entry = Some(a.clone());
                Ok((a, false))
            }
        }
    }
}

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
    solve_work: crate::triangular::SolveWork,
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
    pub fn new(pattern: &Pattern, ordering: Ordering) -> Result<SpdSolver, LinearError> {
        Self::shared(pattern, ordering, None)
    }

    /// [`SpdSolver::new`], taking the analysis from `cache` when another solver on the same
    /// pattern already computed it (and leaving it there for the next one).
    pub fn shared(
        pattern: &Pattern,
        ordering: Ordering,
        cache: Option<&AnalysisCache>,
    ) -> Result<SpdSolver, LinearError> {
        let t0 = Instant::now();
        let (analysis, reused) = match cache {
            Some(c) => c.get(pattern.n, &pattern.col_ptr, &pattern.row_idx, ordering, 2)?,
            None => {
                let (c, r) = (pattern.col_ptr.clone(), pattern.row_idx.clone());
                (Arc::new(Analysis::new(pattern.n, c, r, ordering, 2)?), false)
            }
        };
        Ok(Self::with_analysis(analysis, pattern.diag.clone(), reused, t0.elapsed().as_secs_f64()))
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
                crate::supernodal::factorize(sn, schedule, &mut self.workspace, &self.scaled, &mut self.l_values)
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
                crate::triangular::solve_in_place(sn, perm, sched, &self.l_values, x, &mut self.solve_work);
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
mod tests {
    use super::*;
    use nalgebra::Matrix6;

    #[test]
    fn solves_laplacian_like_system() {
        // A 2x2 grid of 8 triangles: blocks = cotan-like PSD blocks + identity shift makes SPD.
        let faces = vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];
        let pat = Pattern::new(&faces, 5);
        let blocks: Vec<Matrix6<f64>> = (0..faces.len())
            .map(|t| {
                let b = Matrix6::from_fn(|i, j| (((i + 1) * (j + 2) + t) % 5) as f64 * 0.1);
                b * b.transpose() + Matrix6::identity()
            })
            .collect();
        let mut vals = Vec::new();
        pat.assemble(&blocks, &mut vals);
        let x_true: Vec<f64> = (0..10).map(|i| (i as f64).cos()).collect();
        let b = pat.sym_mul(&vals, &x_true);
        let mut solver = SpdSolver::new(&pat, Ordering::Amd).unwrap();
        for jacobi in [false, true] {
            let x = solver.solve(&vals, &b, &LinearSettings { tikhonov: 0.0, jacobi, ..Default::default() }).unwrap();
            for i in 0..10 {
                assert!((x[i] - x_true[i]).abs() < 1e-10, "{jacobi} {i}");
            }
        }
        // refactorization with new values reuses the analysis
        let vals2: Vec<f64> = vals.iter().map(|v| 2.0 * v).collect();
        let x = solver.solve(&vals2, &b, &LinearSettings::default()).unwrap();
        assert!((x[3] - 0.5 * x_true[3]).abs() < 1e-8);
    }

    /// A generated mesh, its Newton pattern and SPD values on it (PSD element blocks plus
    /// `shift` times the identity).
    fn spd_system(name: &str, shift: f64) -> (crate::mesh::Mesh, Pattern, Vec<f64>) {
        let mesh = crate::generate::generate(name).unwrap();
        let pat = Pattern::new(&mesh.faces, mesh.n_vertices());
        let blocks: Vec<Matrix6<f64>> = (0..mesh.n_faces())
            .map(|t| {
                let b = Matrix6::from_fn(|i, j| ((i * 7 + j * 3 + t) % 11) as f64 * 0.1 - 0.5);
                b * b.transpose() + Matrix6::identity() * shift
            })
            .collect();
        let mut vals = Vec::new();
        pat.assemble(&blocks, &mut vals);
        (mesh, pat, vals)
    }

    #[test]
    fn metis_and_amd_orderings_solve_the_same_system_and_metis_fills_less() {
        let (_, pat, vals) = spd_system("bumpy_10k", 1e-3);
        let x_true: Vec<f64> = (0..pat.n).map(|i| (i as f64 * 0.01).sin()).collect();
        let b = pat.sym_mul(&vals, &x_true);
        let settings = LinearSettings { tikhonov: 0.0, jacobi: true, ..Default::default() };
        let mut metis = SpdSolver::new(&pat, Ordering::Metis).unwrap();
        let mut amd = SpdSolver::new(&pat, Ordering::Amd).unwrap();
        assert_eq!((metis.ordering(), amd.ordering()), (Ordering::Metis, Ordering::Amd));
        let (xm, xa) = (metis.solve(&vals, &b, &settings).unwrap(), amd.solve(&vals, &b, &settings).unwrap());
        let err = |x: &[f64]| x.iter().zip(&x_true).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(err(&xm) < 1e-8 && err(&xa) < 1e-8, "{} {}", err(&xm), err(&xa));
        // nested dissection: less fill than AMD on a 10k-vertex mesh (rust-stack.md: ~20% at 71k)
        assert!(metis.factor_len() < amd.factor_len(), "{} vs {}", metis.factor_len(), amd.factor_len());
    }

    /// Several right-hand sides solved in one pass give each column's own solution; a length
    /// that is not whole columns is a typed error.
    #[test]
    fn columns_are_solved_together() {
        let (_, pat, vals) = spd_system("bumpy_5k", 1e-3);
        let settings = LinearSettings { tikhonov: 1e-10, jacobi: true, ..Default::default() };
        let mut solver = SpdSolver::new(&pat, Ordering::Metis).unwrap();
        solver.factorize(&vals, &settings).unwrap();
        let cols: Vec<Vec<f64>> =
            (0..3).map(|k| (0..pat.n).map(|i| ((i * (k + 2)) as f64 * 0.013).sin()).collect()).collect();
        let mut together: Vec<f64> = cols.concat();
        solver.solve_columns_in_place(&mut together).unwrap();
        for (k, b) in cols.iter().enumerate() {
            let alone = solver.solve_factored(b).unwrap();
            let got = &together[k * pat.n..][..pat.n];
            let scale = alone.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let err = alone.iter().zip(got).fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
            assert!(err <= 1e-12 * scale, "column {k}: {err:e} of {scale:e}");
            // and it solves the system: A x = b
            let ax = pat.sym_mul(&vals, got);
            let res = ax.iter().zip(b).fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
            assert!(res <= 1e-8, "column {k}: residual {res:e}");
        }
        let mut ragged = vec![1.0; pat.n + 1];
        let e = solver.solve_columns_in_place(&mut ragged).unwrap_err();
        assert_eq!(e, LinearError::RhsLength { rows: pat.n, len: pat.n + 1 });
    }

    #[test]
    fn indefinite_matrix_is_a_typed_error() {
        let faces = vec![[0, 1, 2]];
        let pat = Pattern::new(&faces, 3);
        let blocks = vec![-Matrix6::<f64>::identity()];
        let mut vals = Vec::new();
        pat.assemble(&blocks, &mut vals);
        let mut solver = SpdSolver::new(&pat, Ordering::Amd).unwrap();
        let b = vec![1.0; 6];
        let err = solver
            .solve(&vals, &b, &LinearSettings { tikhonov: 0.0, jacobi: false, ..Default::default() })
            .unwrap_err();
        assert!(matches!(err, LinearError::NotPositiveDefinite { .. }));
        let err = solver.solve(&vals, &b, &LinearSettings::default()).unwrap_err();
        assert!(matches!(err, LinearError::BadDiagonal { .. }));
    }

    #[test]
    fn a_cache_shares_one_analysis_per_pattern_and_ordering_and_solves_the_same() {
        let (mesh, pat, vals) = spd_system("bumpy_1k", 1e-2);
        let b: Vec<f64> = (0..pat.n).map(|i| (i as f64 * 0.3).cos()).collect();
        let settings = LinearSettings::default();

        let cache = AnalysisCache::new();
        let mut first = SpdSolver::shared(&pat, Ordering::Metis, Some(&cache)).unwrap();
        let mut second = SpdSolver::shared(&pat, Ordering::Metis, Some(&cache)).unwrap();
        assert!(!first.analysis_reused() && second.analysis_reused());
        assert!(Arc::ptr_eq(first.analysis(), second.analysis()));
        assert!(first.analysis().seconds() > 0.0);
        assert_eq!(cache.len(), 1);
        // another ordering or another pattern is another entry
        let amd = SpdSolver::shared(&pat, Ordering::Amd, Some(&cache)).unwrap();
        assert!(!amd.analysis_reused() && amd.ordering() == Ordering::Amd);
        let half = Pattern::new(&mesh.faces[..mesh.n_faces() / 2], mesh.n_vertices());
        assert!(!SpdSolver::shared(&half, Ordering::Metis, Some(&cache)).unwrap().analysis_reused());
        assert_eq!(cache.len(), 3);
        // a failed analysis (a block size that does not divide the dofs) is reported to each
        // caller and never stored
        for _ in 0..2 {
            let err = cache.get(pat.n, &pat.col_ptr, &pat.row_idx, Ordering::Metis, pat.n + 1).err();
            assert!(matches!(err, Some(LinearError::Symbolic(_))), "{err:?}");
        }
        assert_eq!(cache.len(), 3);
        // bit-identical solutions from the shared and a private analysis
        let mut private = SpdSolver::new(&pat, Ordering::Metis).unwrap();
        let x = private.solve(&vals, &b, &settings).unwrap();
        assert_eq!(first.solve(&vals, &b, &settings).unwrap(), x);
        assert_eq!(second.solve(&vals, &b, &settings).unwrap(), x);
    }

    #[test]
    fn concurrent_requests_for_one_pattern_analyse_it_once() {
        let mesh = crate::generate::generate("bumpy_1k").unwrap();
        let pat = Pattern::new(&mesh.faces, mesh.n_vertices());
        let cache = AnalysisCache::new();
        let reused: Vec<bool> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..4)
                .map(|_| s.spawn(|| SpdSolver::shared(&pat, Ordering::Metis, Some(&cache)).unwrap().analysis_reused()))
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        assert_eq!(reused.iter().filter(|r| !**r).count(), 1, "{reused:?}");
        assert_eq!(cache.len(), 1);
    }
}
