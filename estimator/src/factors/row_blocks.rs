//! A helper of the factors' analytic Jacobians: a 3-row Jacobian assembled from 3 × 3 blocks.

use nalgebra::{Matrix3, SMatrix};

/// A 3 × C Jacobian that is zero but for 3 × 3 blocks at the given first columns.
pub(super) fn blocks<const C: usize>(parts: &[(usize, Matrix3<f64>)]) -> SMatrix<f64, 3, C> {
    let mut m = SMatrix::<f64, 3, C>::zeros();
    for (col, part) in parts {
        m.fixed_view_mut::<3, 3>(0, *col).copy_from(part);
    }
    m
}
