//! Plain Newton: the unmodified element Hessians. The global matrix may be indefinite, so a
//! run can stop on a failed factorization or a non-descent direction; that is data. It does
//! not retry a failed factorization with a larger shift: shifted Newton is another method,
//! and the papers show plain Newton halting there (CM paper, Figure 2).

use super::element::{element_hessian, ElementState};
use super::system_block::SystemBlock;
use crate::local::LocalOp;
use nalgebra::Matrix6;

/// `newton`: the unmodified element Hessian, with no shift retries after a failed factorization.
#[derive(Clone, Copy, Debug, Default)]
pub struct Unprojected;

impl SystemBlock for Unprojected {
    fn block(&self, op: &LocalOp, s: &ElementState) -> Matrix6<f64> {
        element_hessian(op, s)
    }

    fn retries_failed_factorization(&self) -> bool {
        false
    }
}
