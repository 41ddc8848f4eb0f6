//! Zero-velocity updates at rest ([`Zupt`]): a detector that watches the IMU samples of one
//! filter step ([`RestDetector`]) and, after a step found at rest, the update
//! [`Navigator::zupt`]. Like the non-holonomic constraint ([`super::Nhc`]) it is a
//! pseudo-observation applied once per filter step by the caller's replay loop, with or without
//! GNSS: during an outage at a stop it is the only aiding.
//!
//! Why three tests and not one: the IMU alone cannot tell rest from a steady straight run (both
//! give no rotation and a specific force of magnitude g), so the detector also needs the
//! solution's speed to be low. Without that guard a car cruising through a GNSS outage on a
//! smooth road (every simulated straight) would be pinned to zero velocity. The IMU tests in
//! turn keep a slow but moving solution (a car creeping, or a solution whose velocity error is
//! about its speed) from being stopped:
//! - the rate magnitude `|w|` at most `gyro_max` on every sample of the step;
//! - the specific force, resolved in NED with the solution's attitude, within `accel_max` of
//!   `(0, 0, -g)` (normal gravity) on every sample. The vector, not the magnitude: a car
//!   braking at 1 m/s^2 changes the magnitude by only 0.05 m/s^2 (second order), the
//!   horizontal component by 1 m/s^2. A tilt error of 1 deg moves it by 0.17 m/s^2;
//! - the solution's speed at most `speed_max` at the step.
//!
//! ```
//! use imu_ident::nav::rest::{RestDetector, Zupt};
//! use nalgebra::Vector3;
//! let z = Zupt { sd: 0.02, gyro_max: 0.1, accel_max: 0.3, speed_max: 0.5 };
//! let mut d = RestDetector::new(9.806);
//! d.sample(&z, &Vector3::new(0.01, 0.0, -0.02), &Vector3::new(0.0, 0.1, -9.8));
//! assert!(d.take());
//! d.sample(&z, &Vector3::new(0.5, 0.0, 0.0), &Vector3::new(0.0, 0.0, -9.8));
//! assert!(!d.take()); // turning
//! d.sample(&z, &Vector3::new(0.0, 0.0, 0.0), &Vector3::new(-1.0, 0.0, -9.8));
//! assert!(!d.take()); // braking
//! assert!(!d.take()); // no sample since the last step
//! ```

use super::navigator::{NavError, NavObserver, Navigator};
use crate::filter::Fused;
use crate::model::ModelError;
use crate::strapdown::earth;
use crate::Real;
use nalgebra::Vector3;

/// The zero-velocity update and its rest detector's thresholds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Zupt<T> {
    /// Standard deviation of each velocity axis at rest [m/s].
    pub sd: T,
    /// Largest rate magnitude at rest, on any sample [rad/s].
    pub gyro_max: T,
    /// Largest departure of the specific force in NED from `(0, 0, -g)`, on any sample
    /// [m/s^2].
    pub accel_max: T,
    /// Largest solution speed at which the update applies [m/s] (module docs: why).
    pub speed_max: f64,
}

impl<T: Real> Zupt<T> {
    /// `self`, or an error unless every threshold is positive and finite (a zero or NaN
    /// threshold would silently never detect rest).
    pub fn checked(self) -> Result<Self, NavError> {
        let ok = |v: T| v.is_finite() && v > T::zero();
        if ok(self.sd)
            && ok(self.gyro_max)
            && ok(self.accel_max)
            && self.speed_max.is_finite()
            && self.speed_max > 0.0
        {
            Ok(self)
        } else {
            Err(NavError::Model(ModelError::BadSigma))
        }
    }

    /// The settings `z` (as a replay or the command line gives them) in `T`, checked.
    pub fn cast_checked(z: &Zupt<f64>) -> Result<Self, NavError> {
        Self {
            sd: T::lit(z.sd),
            gyro_max: T::lit(z.gyro_max),
            accel_max: T::lit(z.accel_max),
            speed_max: z.speed_max,
        }
        .checked()
    }

    /// After an IMU sample that ended a filter step: the update when the detector saw rest
    /// over the step and the solution is slower than `speed_max`; the detector restarts for
    /// the next step either way, with normal gravity at the solution's position (once per
    /// step: it changes by 3e-6 m/s^2 per metre of height). Returns the fusion result when
    /// applied.
    pub fn after_step<const N: usize, O: NavObserver<T, N>>(
        &self,
        nav: &mut Navigator<T, N, O>,
        detector: &mut RestDetector<T>,
    ) -> Result<Option<Fused<T, 3>>, NavError> {
        let still = detector.take();
        detector.g = RestDetector::gravity_at(nav);
        // The speed in f64 whatever T, as for the constraint (`Nhc::after_step`).
        let speed = nav.ins().velocity().map(|v| v.as_f64()).norm();
        if !(still && speed <= self.speed_max) {
            return Ok(None);
        }
        nav.zupt(self.sd).map(Some)
    }
}

/// Whether every IMU sample since the last step looked at rest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestDetector<T> {
    still: bool,
    samples: u32,
    /// Normal gravity at the solution [m/s^2], set at the start and after every step.
    g: T,
}

impl<T: Real> RestDetector<T> {
    /// A detector with normal gravity `g` [m/s^2].
    pub fn new(g: T) -> Self {
        Self {
            still: true,
            samples: 0,
            g,
        }
    }

    /// Normal gravity at the solution of `nav` [m/s^2].
    pub fn gravity_at<const N: usize, O: NavObserver<T, N>>(nav: &Navigator<T, N, O>) -> T {
        let p = nav.ins().position();
        earth::normal_gravity(T::lit(p.lat), T::lit(p.h))
    }

    /// One IMU sample: body rates `gyro` [rad/s] and the specific force resolved in NED `f_n`
    /// [m/s^2] (`C_b^n f_b` with the solution's attitude). A non-finite sample is not at rest.
    pub fn sample(&mut self, z: &Zupt<T>, gyro: &Vector3<T>, f_n: &Vector3<T>) {
        let at_rest = gyro.norm() <= z.gyro_max
            && (f_n + Vector3::new(T::zero(), T::zero(), self.g)).norm() <= z.accel_max;
        // `<=` is false for NaN, so a bad sample breaks the rest.
        self.still &= at_rest;
        self.samples = self.samples.saturating_add(1);
    }

    /// Whether the step that just ended was at rest (at least one sample, all at rest), and
    /// restart for the next step (gravity kept).
    pub fn take(&mut self) -> bool {
        let still = self.still && self.samples > 0;
        *self = Self::new(self.g);
        still
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const Z: Zupt<f64> = Zupt {
        sd: 0.02,
        gyro_max: 0.1,
        accel_max: 0.3,
        speed_max: 0.5,
    };
    const REST_F: Vector3<f64> = Vector3::new(0.0, 0.0, -9.8);

    #[test]
    fn thresholds_must_be_positive_and_finite() {
        assert!(Z.checked().is_ok());
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(Zupt { sd: bad, ..Z }.checked().is_err());
            assert!(Zupt { gyro_max: bad, ..Z }.checked().is_err());
            assert!(Zupt {
                accel_max: bad,
                ..Z
            }
            .checked()
            .is_err());
            assert!(Zupt {
                speed_max: bad,
                ..Z
            }
            .checked()
            .is_err());
        }
    }

    #[test]
    fn one_bad_sample_breaks_the_rest_of_its_step_only() {
        let mut d = RestDetector::new(9.8);
        for _ in 0..99 {
            d.sample(&Z, &Vector3::zeros(), &REST_F);
        }
        d.sample(&Z, &Vector3::new(f64::NAN, 0.0, 0.0), &REST_F);
        assert!(!d.take());
        d.sample(
            &Z,
            &Vector3::zeros(),
            &Vector3::new(0.0, 0.0, f64::INFINITY),
        );
        assert!(!d.take());
        d.sample(&Z, &Vector3::zeros(), &REST_F);
        assert!(d.take());
        // A NaN gravity (a broken solution) never detects rest.
        let mut d = RestDetector::new(f64::NAN);
        d.sample(&Z, &Vector3::zeros(), &REST_F);
        assert!(!d.take());
    }
}
