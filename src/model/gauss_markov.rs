//! First-order Gauss-Markov process (METHOD.md §2, paper eq. 7-9).
//!
//! `x' = -alpha x + sigma sqrt(2 alpha) xi`, with `alpha = 1/tau` and unit white `xi`; its
//! autocorrelation is `K(t) = sigma^2 exp(-alpha |t|)`.
//!
//! ```
//! use imu_ident::model::GaussMarkov;
//! let gm = GaussMarkov::new(1e-3f64, 100.0).unwrap();
//! let (phi, qd) = gm.discretise(1.0);
//! assert!((phi - (-0.01f64).exp()).abs() < 1e-15);
//! // Qd keeps the stationary variance: phi^2 sigma^2 + qd = sigma^2.
//! assert!((phi * phi * 1e-6 + qd - 1e-6).abs() < 1e-18);
//! assert!((gm.acf(100.0) - 1e-6 * (-1.0f64).exp()).abs() < 1e-18);
//! ```

use crate::model::ModelError;
use crate::Real;

/// A first-order Gauss-Markov sensor error: standard deviation `sigma`, correlation time `tau`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaussMarkov<T> {
    /// Stationary standard deviation, in the sensor's units.
    pub sigma: T,
    /// Correlation time [s]; `alpha = 1/tau`.
    pub tau: T,
}

impl<T: Real> GaussMarkov<T> {
    /// Checks the parameters: both finite and strictly positive.
    pub fn new(sigma: T, tau: T) -> Result<Self, ModelError> {
        if !(sigma.is_finite() && sigma > T::zero()) {
            return Err(ModelError::BadSigma);
        }
        if !(tau.is_finite() && tau > T::zero()) {
            return Err(ModelError::BadTau);
        }
        Ok(Self { sigma, tau })
    }

    /// `alpha = 1 / tau` [1/s].
    pub fn alpha(&self) -> T {
        T::one() / self.tau
    }

    /// Continuous white-noise intensity of the driving term, `2 alpha sigma^2` (eq. 8).
    pub fn qc(&self) -> T {
        T::lit(2.0) * self.alpha() * self.sigma * self.sigma
    }

    /// Exact discretisation: `Phi = exp(-alpha dt)`, `Qd = sigma^2 (1 - exp(-2 alpha dt))`.
    pub fn discretise(&self, dt: T) -> (T, T) {
        let phi = (-self.alpha() * dt).exp();
        (phi, self.sigma * self.sigma * (T::one() - phi * phi))
    }

    /// Analytic autocorrelation `K(t) = sigma^2 exp(-alpha |t|)`.
    pub fn acf(&self, t: T) -> T {
        self.sigma * self.sigma * (-self.alpha() * t.abs()).exp()
    }
}
