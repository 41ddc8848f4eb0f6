//! The INS error filter: an [`InsModel`] discretised exactly and run by the [`Kalman`] kernel
//! in scaled states, with estimates reported back in SI units.
//!
//! ```
//! use imu_ident::filter::InsFilter;
//! use imu_ident::model::InsModel;
//! let mut f = InsFilter::new(InsModel::<f32>::paper()).unwrap();
//! for _ in 0..100 {
//!     f.step(0.0);
//! }
//! let e = f.estimates();
//! assert!(e.sigma_dv < 0.03 && e.sigma_delta > 0.0);
//! ```

use crate::filter::error_state::ErrorStateFilter;
use crate::filter::kalman::{Innovation, Kalman};
use crate::linalg::{to_vec, Arr};
use crate::model::{
    idx, ContinuousSystem, InsModel, ModelError, Scaling, StateMat, StateRow, StateVec, NX,
};
use crate::Real;

/// Estimates and their standard deviations, in SI units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Estimates<T> {
    /// Velocity error [m/s].
    pub dv: T,
    /// Tilt error [rad].
    pub delta: T,
    /// Total accelerometer error [m/s^2] (sum of its component states).
    pub da: T,
    /// Total gyro drift [rad/s] (sum of its component states).
    pub dw: T,
    /// `sqrt(P)` of each of the above.
    pub sigma_dv: T,
    /// Standard deviation of the tilt error [rad].
    pub sigma_delta: T,
    /// Standard deviation of the accelerometer error [m/s^2].
    pub sigma_da: T,
    /// Standard deviation of the gyro drift [rad/s].
    pub sigma_dw: T,
}

impl<T: Real> Estimates<T> {
    /// SI estimates from a filter in scaled states, the scaling `s`, and the rows that sum each
    /// sensor's components (in physical units). Works on the kernel's arrays over the active
    /// block (no conversion to nalgebra on the 1 Hz path).
    pub fn from_kalman(
        kf: &Kalman<T, NX>,
        s: &Scaling<T>,
        accel_row: &StateRow<T>,
        gyro_row: &StateRow<T>,
    ) -> Self {
        let n = kf.active();
        // (row x, sqrt(row P row^T)) over the active block.
        let comb = |row: &StateRow<T>| {
            let (mut mean, mut var) = (T::zero(), T::zero());
            for ((ri, xi), pi) in row.iter().zip(kf.x.iter()).zip(kf.P.iter()).take(n) {
                mean += *ri * *xi;
                let mut a = T::zero();
                for (rj, pij) in row.iter().zip(pi.iter()).take(n) {
                    a += *rj * *pij;
                }
                var += *ri * a;
            }
            (mean, var.max(T::zero()).sqrt())
        };
        let (da, sigma_da) = comb(accel_row);
        let (dw, sigma_dw) = comb(gyro_row);
        let x = |i: usize| kf.x.get(i).copied().unwrap_or_else(T::zero);
        let sd = |i: usize| {
            let p = kf.P.get(i).and_then(|r| r.get(i)).copied();
            p.unwrap_or_else(T::zero).max(T::zero()).sqrt()
        };
        let (dv, dl) = (idx::DV, idx::DELTA);
        Estimates {
            dv: x(dv) * s[dv],
            delta: x(dl) * s[dl],
            da,
            dw,
            sigma_dv: sd(dv) * s[dv],
            sigma_delta: sd(dl) * s[dl],
            sigma_da,
            sigma_dw,
        }
    }
}

/// A Kalman filter of the one-channel INS errors with its sensor-noise model: the generic
/// [`ErrorStateFilter`] of [`InsModel`] (the one fixed-model filter), with the one-channel
/// scalar interface, its gate and its SI estimates.
#[derive(Debug, Clone)]
pub struct InsFilter<T: Real> {
    inner: ErrorStateFilter<T, InsModel<T>, NX, 1>,
    accel_row: StateRow<T>,
    gyro_row: StateRow<T>,
    gate: Option<T>,
}

impl<T: Real> InsFilter<T> {
    /// Builds the filter: validates the model, chooses the state scaling, discretises, and
    /// starts from a zero estimate with the model's initial covariance.
    pub fn new(model: InsModel<T>) -> Result<Self, ModelError> {
        let inner = ErrorStateFilter::new(model)?;
        let (accel_row, gyro_row) = inner.model().output_rows(inner.scale())?;
        Ok(Self {
            inner,
            accel_row,
            gyro_row,
            gate: None,
        })
    }

    /// Replaces the model's parameters, keeping the estimate, covariance and scaling. The new
    /// model must have the same state layout (same kinds in the same order); otherwise
    /// [`ModelError::TooManyStates`] is returned and nothing changes.
    pub fn set_model(&mut self, model: InsModel<T>) -> Result<(), ModelError> {
        let (accel, gyro) = model.output_rows(self.inner.scale())?;
        self.inner.set_model(model)?;
        self.accel_row = accel;
        self.gyro_row = gyro;
        Ok(())
    }

    /// Sets the chi-square outlier gate on the NIS (`None`: no gating).
    pub fn set_gate(&mut self, gate: Option<T>) {
        self.gate = gate;
    }

    /// The model in use.
    pub fn model(&self) -> &InsModel<T> {
        self.inner.model()
    }

    /// The state scaling `S` (physical = `S` x scaled).
    pub fn scale(&self) -> &[T; NX] {
        self.inner.scale()
    }

    /// The underlying Kalman filter, in scaled states.
    pub fn kalman(&self) -> &Kalman<T, NX> {
        self.inner.kalman()
    }

    /// The continuous system, in scaled states.
    pub fn system(&self) -> &ContinuousSystem<T, NX, 1> {
        self.inner.system()
    }

    /// The discrete system `(Phi, Qd)` over the active states, in scaled states.
    pub fn discrete(&self) -> (&Arr<T, NX>, &Arr<T, NX>) {
        self.inner.discrete()
    }

    /// Propagates one step `dt`.
    pub fn predict(&mut self) {
        self.inner.predict();
    }

    /// Uses one velocity observation `z` [m/s] (NaN: missing).
    pub fn update(&mut self, z: T) -> Innovation<T> {
        let f = match self.gate {
            Some(g) => self.inner.update(&[z], Some(&move |_| g)),
            None => self.inner.update(&[z], None),
        };
        let [axis] = f.axes;
        Innovation {
            innovation: f.innovation[0],
            variance: f.variance[0],
            nis: f.nis,
            status: axis.into(),
        }
    }

    /// One filter cycle: predict to the observation time, then update.
    pub fn step(&mut self, z: T) -> Innovation<T> {
        self.predict();
        self.update(z)
    }

    /// Repairs `P` if it lost positive definiteness (reset to the initial covariance).
    /// Returns true if a repair was made.
    pub fn repair(&mut self) -> bool {
        self.inner.repair()
    }

    /// Current estimates in SI units.
    pub fn estimates(&self) -> Estimates<T> {
        let scale = to_vec(self.inner.scale());
        Estimates::from_kalman(self.kalman(), &scale, &self.accel_row, &self.gyro_row)
    }

    /// Physical covariance `S P S`.
    pub fn covariance_si(&self) -> StateMat<T> {
        let s = StateMat::from_diagonal(&to_vec(self.inner.scale()));
        s * self.kalman().covariance() * s
    }

    /// Physical state estimate `S x`.
    pub fn state_si(&self) -> StateVec<T> {
        to_vec(&self.inner.state_si())
    }
}
