//! Plain Newton: the unmodified element Hessians. The global matrix may be indefinite, so a
//! run can stop on a failed factorization or a non-descent direction; that is data.

use super::{element_hessian, ElementState, SystemBlock};
use crate::local::LocalOp;
use nalgebra::Matrix6;

#[derive(Clone, Copy, Debug, Default)]
pub struct Unprojected;

impl SystemBlock for Unprojected {
    fn block(&self, op: &LocalOp, s: &ElementState) -> Matrix6<f64> {
        element_hessian(op, s)
    }
}
