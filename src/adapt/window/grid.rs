//! The global stage's grid (module documentation of [`super`]): the points of the lattice of
//! factors `10^{-1, 0, 1}` about the start model, at most [`GRID_DIMS`] coordinates at a time.
//! A child of [`super`]: it reads the search's state.
//!
//! ```
//! use imu_ident::adapt::window::grid_points;
//! assert_eq!(grid_points(4), (81, 0)); // `paper`: one grid over both sensors' components
//! assert_eq!(grid_points(5), (81, 0)); // with a beta: found by the polish and the scan
//! assert_eq!(grid_points(6), (81, 9)); // a second group of two
//! assert_eq!(grid_points(8), (81, 81)); // two per sensor (feature `params8`): 162, not 6561
//! ```

use super::{WindowSearch, MAXP};
use crate::adapt::guard::Bounds;
use crate::adapt::identifiable::IdentifiableModel;
use crate::Real;

/// Parameters one grid spans (the first ones in `theta` order: for `paper`, the accelerometer's
/// and the gyro's components). When at least two more follow (p >= 6: two components per
/// sensor, feature `params8`), a second grid spans the next `GRID_DIMS` of them, with the first
/// group at the first grid's best point ([`grid_points`]): two grids of `3^4` points, one after
/// the other, instead of one of `3^8`. A lone fifth parameter (an exponential-cosine's `beta`)
/// sits at the anchor's value and is found by the polish and the structure test's scan.
pub const GRID_DIMS: usize = 4;
/// Grid points per group (`3^GRID_DIMS`).
pub(super) const GRID: usize = 81;

/// Grid points of the first and of the second group for `p` parameters (`GRID_DIMS` docs):
/// `(81, 0)` for `paper` (p = 4) and with a `beta` (p = 5), `(81, 81)` at p = 8.
pub fn grid_points(p: usize) -> (usize, usize) {
    let first = 3usize.pow(p.min(GRID_DIMS) as u32).min(GRID);
    let rest = p.saturating_sub(GRID_DIMS);
    let second = if rest >= 2 {
        3usize.pow(rest.min(GRID_DIMS) as u32).min(GRID)
    } else {
        0
    };
    (first, second)
}

impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize, const W: usize>
    WindowSearch<T, M, N, Z, W>
{
    /// The `k`-th point of the grids for `p` parameters (`k` below the sum of [`grid_points`]).
    pub(super) fn grid_point(&self, k: usize, p: usize, bounds: &Bounds<T>) -> [T; MAXP] {
        // Every other search shifts the lattice by half a spacing in every parameter, so
        // that successive searches sample between each other's points (the anchor carries
        // the best point found so far from one search to the next).
        let shift = if self.searches % 2 == 1 {
            self.cfg.spacing * T::lit(0.5)
        } else {
            T::zero()
        };
        let (first, _) = grid_points(p);
        let (mut t, lo, hi, mut q) = if k < first {
            // The first group: the other coordinates at the anchor's values.
            let mut t = self.centre;
            for (v, a) in t.iter_mut().zip(self.anchor.iter()).take(p).skip(GRID_DIMS) {
                *v = *a;
            }
            (t, 0, p.min(GRID_DIMS), k)
        } else {
            // The second group (the next sensor's components) about the centre, the
            // first group's coordinates at the best point so far (the first grid's best,
            // or a point of this grid, which shares them).
            let mut t = self.top[0];
            for (v, c) in t.iter_mut().zip(self.centre.iter()).take(p).skip(GRID_DIMS) {
                *v = *c;
            }
            (t, GRID_DIMS, p.min(2 * GRID_DIMS), k - first)
        };
        for v in t.iter_mut().take(hi).skip(lo) {
            let level = (q % 3) as i32 - 1;
            q /= 3;
            *v += T::lit(f64::from(level)) * self.cfg.spacing - shift;
        }
        bounds.clamp(&t, p)
    }
}
