//! Fixed-size linear algebra without panic paths: the bottom layer of the core.
//!
//! Everything above (noise models, error models, the Kalman kernel, identification) uses these
//! kernels on row-major `[[T; N]; N]` arrays ([`Arr`]) with a run-time active size `n <= N`, or
//! nalgebra's fixed-size matrices through [`At`] (checked element access). Nothing here knows
//! about navigation.
//!
//! ```
//! use imu_ident::linalg::{cholesky, chol_solve, mul, Arr};
//! let a: Arr<f64, 2> = [[4.0, 2.0], [2.0, 3.0]];
//! let l = cholesky(&a, 2).unwrap();
//! let x = chol_solve(&l, &[2.0, 1.0], 2);
//! assert!((4.0 * x[0] + 2.0 * x[1] - 2.0).abs() < 1e-12);
//! let i2: Arr<f64, 2> = [[1.0, 0.0], [0.0, 1.0]];
//! assert_eq!(mul(&a, &i2, 2), a);
//! ```

pub mod cholesky;
pub mod dense;

pub use cholesky::{chol_solve, cholesky, inverse_diagonal, is_positive_definite};
pub use dense::{
    axpy, dot, from_mat, from_vec, head, head_mut, mul, mul_into, mul_pattern_into, mul_t_sym,
    mul_t_sym_into, row_pattern, to_mat, to_vec, transpose, transpose_into, zeros, Arr,
};

use crate::Real;
use nalgebra::SMatrix;

/// Element access without a panic path, for loops whose indices stay below the active size
/// (which the optimiser does not always prove, leaving nalgebra's bounds check and its panic in
/// the firmware; see RELIABILITY.md, "Panic-free firmware, proved at link time"). Outside the
/// matrix a read gives zero and a write does nothing: never the case for these callers.
pub trait At<T> {
    /// `self[(i, j)]`, zero outside.
    fn at(&self, i: usize, j: usize) -> T;
    /// `self[(i, j)] = v`, nothing outside.
    fn set_at(&mut self, i: usize, j: usize, v: T);
    /// `self[k]` (column-major linear index: the `k`-th entry of a vector), zero outside.
    fn el(&self, k: usize) -> T;
    /// `self[k] = v`, nothing outside.
    fn set_el(&mut self, k: usize, v: T);
}

impl<T: Real, const R: usize, const C: usize> At<T> for SMatrix<T, R, C> {
    #[inline(always)]
    fn at(&self, i: usize, j: usize) -> T {
        self.get((i, j)).copied().unwrap_or_else(T::zero)
    }
    #[inline(always)]
    fn set_at(&mut self, i: usize, j: usize, v: T) {
        if let Some(e) = self.get_mut((i, j)) {
            *e = v;
        }
    }
    #[inline(always)]
    fn el(&self, k: usize) -> T {
        self.get(k).copied().unwrap_or_else(T::zero)
    }
    #[inline(always)]
    fn set_el(&mut self, k: usize, v: T) {
        if let Some(e) = self.get_mut(k) {
            *e = v;
        }
    }
}
