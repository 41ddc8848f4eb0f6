//! White sensor noise given as a density (angle / velocity random walk of IEEE Std 952).
//!
//! The density `N` is in sensor units per sqrt(Hz) (rad/s/sqrt(Hz) = rad/sqrt(s) for a gyro,
//! m/s^2/sqrt(Hz) for an accelerometer), so it does not depend on the sampling rate. It has no
//! state of its own: it enters as white noise of intensity `N^2` on the INS state the sensor
//! drives (the velocity error for an accelerometer, the tilt for a gyro). Sampled at rate `1/dt`
//! its discrete standard deviation would be `N / sqrt(dt)`.
//!
//! ```
//! use imu_ident::model::WhiteNoise;
//! let w = WhiteNoise::new(1e-4f64).unwrap();
//! assert!((w.qc() - 1e-8).abs() < 1e-22);
//! assert!((w.sampled_sigma(0.01) - 1e-3).abs() < 1e-15);
//! ```

use crate::model::ModelError;
use crate::Real;

/// White noise of density `density` [units/sqrt(Hz)].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WhiteNoise<T> {
    /// Noise density [units/sqrt(Hz)].
    pub density: T,
}

impl<T: Real> WhiteNoise<T> {
    /// Checks `density > 0`, finite.
    pub fn new(density: T) -> Result<Self, ModelError> {
        if !(density.is_finite() && density > T::zero()) {
            return Err(ModelError::BadDensity);
        }
        Ok(Self { density })
    }

    /// Continuous intensity `N^2` on the integrating INS state.
    pub fn qc(&self) -> T {
        self.density * self.density
    }

    /// Standard deviation of the noise averaged over a sample interval `dt`: `N / sqrt(dt)`.
    pub fn sampled_sigma(&self, dt: T) -> T {
        self.density / dt.sqrt()
    }
}
