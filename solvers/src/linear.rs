//! Sparse SPD solves with faer: the symbolic Cholesky analysis is done once per pattern and
//! the numeric factorization is recomputed into a reused buffer each iteration
//! (`../shared/notes/rust-stack.md` section 2).
//!
//! Conventions of the complex-view reference code (notes 1.8): a Tikhonov shift `tau` is
//! added to the diagonal, the matrix is scaled symmetrically by `S = diag(1/sqrt(a_ii))`
//! (Jacobi), and `tau` is added again to the scaled diagonal; the step is `d = S y` with
//! `(S A S + tau I) y = S b`.

use crate::assembly::Pattern;
use crate::ordering::{metis_order, Ordering};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};

#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum LinearError {
    #[error("symbolic Cholesky analysis failed: {0}")]
    Symbolic(String),
    #[error("Cholesky factorization failed: matrix not positive definite (pivot {pivot})")]
    NotPositiveDefinite { pivot: usize },
    #[error("matrix diagonal entry {index} is {value} (not positive and finite)")]
    BadDiagonal { index: usize, value: f64 },
    #[error("solve requested before a successful factorization")]
    NotFactored,
}

/// Linear-system settings (`[linear]` in the config).
#[derive(Clone, Copy, Debug, PartialEq)]
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

pub struct SpdSolver {
    n: usize,
    symbolic_a: SymbolicSparseColMat<usize>,
    diag: Vec<usize>,
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    scaled: Vec<f64>,
    scale: Vec<f64>,
    mem: MemBuffer,
    factored: bool,
    ordering: Ordering,
}

impl SpdSolver {
    /// Analyse the Newton pattern once (two interleaved dofs per vertex) with `ordering`
    /// (supernodal when faer deems it worthwhile).
    pub fn new(pattern: &Pattern, ordering: Ordering) -> Result<SpdSolver, LinearError> {
        let (c, r, d) = (pattern.col_ptr.clone(), pattern.row_idx.clone(), pattern.diag.clone());
        Self::from_csc_ordered(pattern.n, c, r, d, ordering, 2)
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
        let perm = match ordering {
            Ordering::Amd => None,
            Ordering::Metis => metis_order(n, &col_ptr, &row_idx, block)?,
        };
        Self::analyse(n, col_ptr, row_idx, diag, perm)
    }

    /// Analyse a lower-triangular CSC pattern (sorted rows, every diagonal present; `diag`
    /// gives the value slot of each diagonal entry) with AMD.
    pub fn from_csc(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        diag: Vec<usize>,
    ) -> Result<SpdSolver, LinearError> {
        Self::analyse(n, col_ptr, row_idx, diag, None)
    }

    /// `perm = Some((fwd, inv))` orders by `fwd[new] = old`; `None` uses AMD.
    fn analyse(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        diag: Vec<usize>,
        perm: Option<(Vec<usize>, Vec<usize>)>,
    ) -> Result<SpdSolver, LinearError> {
        let symbolic_a = SymbolicSparseColMat::<usize>::new_checked(n, n, col_ptr, None, row_idx);
        let ordering = match &perm {
            Some((fwd, inv)) => SymmetricOrdering::Custom(PermRef::new_checked(fwd, inv, n)),
            None => SymmetricOrdering::Amd,
        };
        let symbolic =
            factorize_symbolic_cholesky(symbolic_a.as_ref(), Side::Lower, ordering, CholeskySymbolicParams::default())
                .map_err(|e| LinearError::Symbolic(format!("{e:?}")))?;
        let par = Par::Seq;
        let mem = MemBuffer::new(
            symbolic
                .factorize_numeric_llt_scratch::<f64>(par, Default::default())
                .or(symbolic.solve_in_place_scratch::<f64>(1, par)),
        );
        let l_values = vec![0.0; symbolic.len_val()];
        Ok(SpdSolver {
            n,
            symbolic_a,
            diag,
            symbolic,
            l_values,
            scaled: Vec::new(),
            scale: vec![1.0; n],
            mem,
            factored: false,
            ordering: if perm.is_some() { Ordering::Metis } else { Ordering::Amd },
        })
    }

    /// The ordering the analysis used (`metis` falls back to AMD on tiny graphs).
    pub fn ordering(&self) -> Ordering {
        self.ordering
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
    /// number of [`SpdSolver::solve_factored`] calls until the next factorization.
    pub fn factorize(&mut self, values: &[f64], settings: &LinearSettings) -> Result<(), LinearError> {
        self.factored = false;
        let (col_ptr, row_idx) = (self.symbolic_a.col_ptr(), self.symbolic_a.row_idx());
        regularize(col_ptr, row_idx, &self.diag, values, settings, &mut self.scaled, &mut self.scale)?;
        let a = SparseColMatRef::new(self.symbolic_a.as_ref(), &self.scaled);
        self.symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.l_values,
                a,
                Side::Lower,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut self.mem),
                Default::default(),
            )
            .map_err(|e| match e {
                faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index } => {
                    LinearError::NotPositiveDefinite { pivot: index }
                }
            })?;
        self.factored = true;
        Ok(())
    }

    /// Solve with the factor of the last successful [`SpdSolver::factorize`].
    pub fn solve_factored(&mut self, b: &[f64]) -> Result<Vec<f64>, LinearError> {
        let mut x = Vec::with_capacity(self.n);
        self.solve_factored_into(b, &mut x)?;
        Ok(x)
    }

    /// [`SpdSolver::solve_factored`] into `x`, reusing its allocation (the Newton loop's).
    pub fn solve_factored_into(&mut self, b: &[f64], x: &mut Vec<f64>) -> Result<(), LinearError> {
        if !self.factored {
            return Err(LinearError::NotFactored);
        }
        x.clear();
        x.extend(b.iter().zip(&self.scale).map(|(bi, si)| bi * si));
        let rhs = MatMut::from_column_major_slice_mut(x, self.n, 1);
        let llt = LltRef::new(&self.symbolic, &self.l_values);
        llt.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut self.mem));
        for (xi, si) in x.iter_mut().zip(&self.scale) {
            *xi *= si;
        }
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            return Err(LinearError::BadDiagonal { index: i, value: x[i] });
        }
        Ok(())
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

    #[test]
    fn metis_and_amd_orderings_solve_the_same_system_and_metis_fills_less() {
        let mesh = crate::generate::generate("bumpy_10k").unwrap();
        let pat = Pattern::new(&mesh.faces, mesh.n_vertices());
        let blocks: Vec<Matrix6<f64>> = (0..mesh.n_faces())
            .map(|t| {
                let b = Matrix6::from_fn(|i, j| ((i * 7 + j * 3 + t) % 11) as f64 * 0.1 - 0.5);
                b * b.transpose() + Matrix6::identity() * 1e-3
            })
            .collect();
        let mut vals = Vec::new();
        pat.assemble(&blocks, &mut vals);
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
}
