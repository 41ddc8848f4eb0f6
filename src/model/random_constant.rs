//! Random constant (turn-on bias): `x' = 0`, `x(0) ~ N(0, sigma^2)`; `K(t) = sigma^2`.
//!
//! ```
//! use imu_ident::model::RandomConstant;
//! let rc = RandomConstant::new(2e-3f64).unwrap();
//! assert_eq!(rc.discretise(1.0), (1.0, 0.0));
//! assert_eq!(rc.acf(1e6), 4e-6);
//! ```

use crate::model::ModelError;
use crate::Real;

/// A random-constant sensor error of standard deviation `sigma`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RandomConstant<T> {
    /// Standard deviation of the constant.
    pub sigma: T,
}

impl<T: Real> RandomConstant<T> {
    /// Checks `sigma > 0`, finite.
    pub fn new(sigma: T) -> Result<Self, ModelError> {
        if !(sigma.is_finite() && sigma > T::zero()) {
            return Err(ModelError::BadSigma);
        }
        Ok(Self { sigma })
    }

    /// Exact discretisation: `Phi = 1`, `Qd = 0`.
    pub fn discretise(&self, _dt: T) -> (T, T) {
        (T::one(), T::zero())
    }

    /// `K(t) = sigma^2` for every lag.
    pub fn acf(&self, _t: T) -> T {
        self.sigma * self.sigma
    }
}
