//! The errors of the sparse solves, in a module of their own: both `linear` and the
//! orderings it calls report them.

/// Why a sparse analysis, factorization or solve failed.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum LinearError {
    /// The ordering or the symbolic analysis failed, with the reason.
    #[error("symbolic Cholesky analysis failed: {0}")]
    Symbolic(String),
    /// The numeric factorization met a non-positive pivot.
    #[error("Cholesky factorization failed: matrix not positive definite (pivot {pivot})")]
    NotPositiveDefinite {
        /// Column of the pivot in the factor's (permuted) order.
        pivot: usize,
    },
    /// A shifted diagonal entry is not positive and finite, so Jacobi scaling cannot use it.
    #[error("matrix diagonal entry {index} is {value} (not positive and finite)")]
    BadDiagonal {
        /// Row of the entry.
        index: usize,
        /// The shifted entry.
        value: f64,
    },
    /// A solve was asked for before a successful factorization.
    #[error("solve requested before a successful factorization")]
    NotFactored,
    /// The right-hand sides' length is not a positive multiple of the matrix's rows.
    #[error("right-hand sides of {len} values do not make whole columns of {rows} rows")]
    RhsLength {
        /// Rows of the matrix.
        rows: usize,
        /// Values given.
        len: usize,
    },
}
