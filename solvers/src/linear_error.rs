//! The errors of the sparse solves, in a module of their own: both `linear` and the
//! orderings it calls report them.

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
    #[error("right-hand sides of {len} values do not make whole columns of {rows} rows")]
    RhsLength { rows: usize, len: usize },
}
