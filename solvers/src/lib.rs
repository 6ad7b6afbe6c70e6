//! Numerics of mapbench: triangle meshes, the isometric energies of the complex-view
//! paper (Golla, Seidel, Chen 2018, Tables 1-2), per-element Hessians and their PSD
//! projections, sparse Newton-type solvers with an injective line search.
//!
//! Solvers are pure: no printing, no files, no global state. Each iteration is reported
//! to an [`solver::Observer`]; the harness turns observations into CSV rows.
//!
//! Conventions (docs/src/design/numerics.md): variables are interleaved, dof `2v` = u and `2v + 1` = v of
//! vertex `v`; meshes are scaled to total area 1 and energies are area-weighted means,
//! so the symmetric Dirichlet energy scores exactly 2 at an isometry.

// Every public item says in one line what it is (the book's reference builds on them).
#![warn(missing_docs)]
// `!(a > b)` is deliberate throughout: NaN must take the failure branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod assembly;
pub mod energy;
pub mod generate;
mod grouping;
pub mod hessian;
pub mod init;
pub mod laplacian;
pub mod line_search;
pub mod linear;
pub mod local;
pub mod mesh;
pub mod problem;
pub mod smoothness;
pub mod solver;
pub mod tasks;
#[cfg(test)]
mod test_support;
