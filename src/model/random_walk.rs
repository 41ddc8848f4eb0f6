//! Random walk (rate random walk of IEEE Std 952): `x' = w`, `E[w(t) w(s)] = q delta(t - s)`.
//!
//! Not stationary: its variance grows as `sigma0^2 + q t`, so there is no ACF in the stationary
//! sense; [`RandomWalk::covariance`] gives `E[x(t) x(s)]` from the start instead.
//!
//! ```
//! use imu_ident::model::RandomWalk;
//! let rw = RandomWalk::new(1e-8f64, 0.0).unwrap();
//! assert_eq!(rw.discretise(2.0), (1.0, 2e-8));
//! ```

use crate::model::ModelError;
use crate::Real;

/// A random-walk sensor error with driving density `q` [units^2 / s] and initial standard
/// deviation `sigma0` (the uncertainty of its value at start).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RandomWalk<T> {
    /// Driving white-noise density [units^2/s].
    pub q: T,
    /// Standard deviation of the initial value.
    pub sigma0: T,
}

impl<T: Real> RandomWalk<T> {
    /// Checks `q > 0` and `sigma0 >= 0`, finite.
    pub fn new(q: T, sigma0: T) -> Result<Self, ModelError> {
        if !(q.is_finite() && q > T::zero()) {
            return Err(ModelError::BadDensity);
        }
        if !(sigma0.is_finite() && sigma0 >= T::zero()) {
            return Err(ModelError::BadSigma);
        }
        Ok(Self { q, sigma0 })
    }

    /// Exact discretisation: `Phi = 1`, `Qd = q dt`.
    pub fn discretise(&self, dt: T) -> (T, T) {
        (T::one(), self.q * dt)
    }

    /// `E[x(t) x(s)] = sigma0^2 + q min(t, s)` for `t, s >= 0`.
    pub fn covariance(&self, t: T, s: T) -> T {
        self.sigma0 * self.sigma0 + self.q * t.min(s).max(T::zero())
    }
}
