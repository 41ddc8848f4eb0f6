//! Initial alignment: levelling from the mean static specific force, heading given or taken
//! from the GNSS course once moving (Groves §5.6.2 and §5.6.3).
//!
//! At rest the accelerometers sense the reaction to gravity, `f^b = C_n^b (0, 0, -g)`, i.e. in
//! FRD `f = (g sin(pitch), -g sin(roll) cos(pitch), -g cos(roll) cos(pitch))`, hence
//! (Groves eq. 5.101) `roll = atan2(-f_y, -f_z)`, `pitch = atan2(f_x, sqrt(f_y^2 + f_z^2))`.
//! Averaging the velocity increments over a window removes the accelerometer white noise; an
//! accelerometer bias `b` leaves a tilt error of about `b / g` (the levelling limit).
//!
//! ```
//! use imu_ident::strapdown::{Leveller, Increment};
//! use nalgebra::Vector3;
//! let mut lev = Leveller::<f64>::new();
//! let f = Vector3::new(0.0, 0.0, -9.8); // level, at rest
//! for _ in 0..100 {
//!     lev.add(&Increment::from_rates(&Vector3::zeros(), &f, 0.01), 0.01);
//! }
//! let (roll, pitch) = lev.level().unwrap();
//! assert!(roll.abs() < 1e-12 && pitch.abs() < 1e-12);
//! ```

use super::attitude::Quat;
use super::mechanise::Increment;
use crate::Real;
use nalgebra::Vector3;

/// Why an alignment could not be computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AlignError {
    /// No sample (or zero total time) in the window.
    NoData,
    /// The mean specific force is not finite.
    NonFinite,
    /// The mean specific force is far from 1 g (between 0.5 g and 1.5 g is accepted): the
    /// vehicle was not at rest, or the accelerometer units are wrong.
    NotStatic,
    /// Too slow for the course to give the heading.
    TooSlow,
}

/// Accumulates static samples and levels from their mean specific force.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Leveller<T: Real> {
    sum_dv: Vector3<T>,
    time: T,
}

impl<T: Real> Default for Leveller<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> Leveller<T> {
    /// An empty window.
    pub fn new() -> Self {
        Self {
            sum_dv: Vector3::zeros(),
            time: T::zero(),
        }
    }

    /// Adds one sample of duration `dt` (non-finite samples and `dt` are skipped).
    pub fn add(&mut self, inc: &Increment<T>, dt: T) {
        if dt.is_finite() && dt > T::zero() && inc.dv.iter().all(|x| x.is_finite()) {
            self.sum_dv += inc.dv;
            self.time += dt;
        }
    }

    /// Total time accumulated [s].
    pub fn time(&self) -> T {
        self.time
    }

    /// Mean specific force over the window, body FRD [m/s^2].
    pub fn mean_specific_force(&self) -> Result<Vector3<T>, AlignError> {
        if self.time <= T::zero() {
            return Err(AlignError::NoData);
        }
        let f = self.sum_dv / self.time;
        if !f.iter().all(|x| x.is_finite()) {
            return Err(AlignError::NonFinite);
        }
        Ok(f)
    }

    /// `(roll, pitch)` [rad] from the mean specific force.
    pub fn level(&self) -> Result<(T, T), AlignError> {
        level_from_specific_force(&self.mean_specific_force()?)
    }

    /// The attitude from the levelling and a given `yaw` [rad].
    pub fn attitude(&self, yaw: T) -> Result<Quat<T>, AlignError> {
        let (roll, pitch) = self.level()?;
        Ok(Quat::from_euler(roll, pitch, yaw))
    }
}

/// `(roll, pitch)` from a static specific force in FRD (module docs, Groves eq. 5.101).
pub fn level_from_specific_force<T: Real>(f: &Vector3<T>) -> Result<(T, T), AlignError> {
    if !f.iter().all(|x| x.is_finite()) {
        return Err(AlignError::NonFinite);
    }
    let g = f.norm();
    let g0 = T::lit(crate::model::ins::G0);
    if g < T::lit(0.5) * g0 || g > T::lit(1.5) * g0 {
        return Err(AlignError::NotStatic);
    }
    let roll = (-f.y).atan2(-f.z);
    let pitch = f.x.atan2((f.y * f.y + f.z * f.z).sqrt());
    Ok((roll, pitch))
}

/// Heading [rad] from the GNSS course over ground `atan2(v_E, v_N)` when the horizontal speed
/// is at least `min_speed` [m/s] (valid when the vehicle moves along its x axis: no sideslip,
/// no reversing).
pub fn heading_from_course<T: Real>(v_ned: &Vector3<T>, min_speed: T) -> Result<T, AlignError> {
    if !v_ned.iter().all(|x| x.is_finite()) {
        return Err(AlignError::NonFinite);
    }
    let speed = (v_ned.x * v_ned.x + v_ned.y * v_ned.y).sqrt();
    if !(speed >= min_speed && speed > T::zero()) {
        return Err(AlignError::TooSlow);
    }
    Ok(v_ned.y.atan2(v_ned.x))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levelling_signs_from_the_rotated_gravity_reaction() {
        // f^b = C_n^b (0, 0, -g) for a grid of attitudes; levelling returns roll and pitch.
        for &(r, p) in &[
            (0.2f64, 0.1),
            (-0.5, 0.3),
            (1.0, -0.7),
            (-2.5, 0.4),
            (0.0, -1.2),
        ] {
            let q = Quat::from_euler(r, p, 1.3);
            let f = q.dcm().transpose() * Vector3::new(0.0, 0.0, -9.81);
            let (r2, p2) = level_from_specific_force(&f).unwrap();
            assert!(
                (r2 - r).abs() < 1e-12 && (p2 - p).abs() < 1e-12,
                "{r} {p}: {r2} {p2}"
            );
        }
        // Right wing down: +y axis points down, gravity reaction has f_y < 0.
        let f =
            Quat::from_euler(0.1f64, 0.0, 0.0).dcm().transpose() * Vector3::new(0.0, 0.0, -9.81);
        assert!(f.y < 0.0);
        // Nose up: the x axis points up, f_x > 0.
        let f =
            Quat::from_euler(0.0f64, 0.1, 0.0).dcm().transpose() * Vector3::new(0.0, 0.0, -9.81);
        assert!(f.x > 0.0);
    }

    #[test]
    fn refusals() {
        let lev = Leveller::<f32>::new();
        assert_eq!(lev.level(), Err(AlignError::NoData));
        let free_fall = Vector3::new(0.0f32, 0.0, -0.1);
        assert_eq!(
            level_from_specific_force(&free_fall),
            Err(AlignError::NotStatic)
        );
        let nan = Vector3::new(f32::NAN, 0.0, -9.8);
        assert_eq!(level_from_specific_force(&nan), Err(AlignError::NonFinite));
        let mut lev = Leveller::<f32>::new();
        lev.add(&Increment::from_rates(&Vector3::zeros(), &nan, 0.01), 0.01);
        assert_eq!(lev.level(), Err(AlignError::NoData));
        let v = Vector3::new(1.0f64, 1.0, 0.0);
        assert_eq!(heading_from_course(&v, 2.0), Err(AlignError::TooSlow));
        let yaw = heading_from_course(&(v * 3.0), 2.0).unwrap();
        assert!((yaw - core::f64::consts::FRAC_PI_4).abs() < 1e-15);
        let west = heading_from_course(&Vector3::new(0.0f64, -5.0, 0.0), 2.0).unwrap();
        assert!((west + core::f64::consts::FRAC_PI_2).abs() < 1e-15);
    }
}
