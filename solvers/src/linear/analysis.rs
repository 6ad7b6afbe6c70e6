//! The symbolic analysis of a pattern (ordering and symbolic Cholesky), computed once and
//! shared by the runs on one mesh.

use super::error::LinearError;
use super::ordering::{metis_order_timed, Ordering};
use super::supernodal::{Schedule, ScheduleError};
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::SymbolicSparseColMat;
use faer::Side;
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// One symbolic analysis: the pattern, its fill-reducing ordering and the symbolic Cholesky
/// factor. It depends on the pattern only, so every solver that factorizes matrices on the
/// same pattern (all Newton-type strategies on one mesh) can share it.
pub struct Analysis {
    pub(super) symbolic_a: SymbolicSparseColMat<usize>,
    pub(super) symbolic: SymbolicCholesky<usize>,
    /// The ordering asked for and the dof block it ordered by (the cache key's parts).
    pub(super) requested: (Ordering, usize),
    /// The ordering used (`metis` falls back to AMD on tiny graphs).
    pub(super) ordering: Ordering,
    /// The subtree-parallel numeric factorization's schedule (`supernodal`), when faer chose
    /// a supernodal factor; `None` for a simplicial one (small systems), which faer factorizes.
    pub(super) schedule: Option<Schedule>,
    /// Wall time of the ordering plus the symbolic factorization, without any wait for
    /// another thread's METIS call.
    pub(super) seconds: f64,
}

impl Analysis {
    pub(super) fn new(
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
        let symbolic_of = |ordering| {
            factorize_symbolic_cholesky(symbolic_a.as_ref(), Side::Lower, ordering, CholeskySymbolicParams::default())
                .map_err(|e| LinearError::Symbolic(format!("{e:?}")))
        };
        let schedule_of = |symbolic: &SymbolicCholesky<usize>| match symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(sn) => {
                Schedule::new(sn, symbolic.perm(), symbolic_a.col_ptr(), symbolic_a.row_idx()).map(Some)
            }
            SymbolicCholeskyRaw::Simplicial(_) => Ok(None),
        };
        let mut symbolic = symbolic_of(faer_ordering)?;
        let schedule = match schedule_of(&symbolic) {
            Ok(s) => s,
            // faer's AMD order is not always a postorder of its elimination tree, which the
            // schedule needs (every subtree a contiguous run): postorder it, as CHOLMOD does,
            // and analyse again (the same fill). Only then: an order that works stays as it is.
            Err(ScheduleError::NotPostordered) if symbolic.perm().is_some() => {
                let fwd = symbolic.perm().map(|p| p.arrays().0.to_vec()).unwrap_or_default();
                let post = super::ordering::postorder(n, symbolic_a.col_ptr(), symbolic_a.row_idx(), &fwd);
                let inv = super::ordering::inverse(&post);
                symbolic = symbolic_of(SymmetricOrdering::Custom(PermRef::new_checked(&post, &inv, n)))?;
                schedule_of(&symbolic)
                    .map_err(|e| LinearError::Symbolic(format!("the supernodal schedule, postordered: {e:?}")))?
            }
            Err(e) => return Err(LinearError::Symbolic(format!("the supernodal schedule: {e:?}"))),
        };
        let used = if perm.is_some() { Ordering::Metis } else { Ordering::Amd };
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
    /// An empty cache.
    pub fn new() -> AnalysisCache {
        AnalysisCache::default()
    }

    /// Number of patterns with a stored analysis.
    pub fn len(&self) -> usize {
        let slots = self.slots.lock().unwrap_or_else(|e| e.into_inner());
        slots.iter().filter(|(_, s)| s.lock().unwrap_or_else(|e| e.into_inner()).is_some()).count()
    }

    /// Whether no pattern has a stored analysis.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The analysis of the pattern, computed by the first caller; `true` when it was
    /// reused (computed by another caller, possibly while this one waited).
    pub(super) fn get(
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
