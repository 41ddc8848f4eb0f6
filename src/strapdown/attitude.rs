//! Attitude as a unit quaternion, body (FRD) to navigation (NED).
//!
//! A small own type rather than nalgebra's `UnitQuaternion`: every operation here is plain
//! arithmetic (no normalisation that may divide by zero behind the caller's back, no panic path),
//! and the conventions are fixed in one place:
//!
//! - Hamilton product, scalar first `q = (w, x, y, z)`;
//! - `q` is `q_b^n`: a body vector is resolved in NED as `v^n = q (0, v^b) q*`, i.e.
//!   `v^n = C_b^n v^b` with [`Quat::dcm`];
//! - Euler angles are the aerospace ZYX sequence: `C_b^n = R_z(yaw) R_y(pitch) R_x(roll)`
//!   (Groves eq. 2.22); roll right-wing-down positive, pitch nose-up positive, yaw east of north.
//!
//! ```
//! use imu_ident::strapdown::Quat;
//! let q = Quat::from_euler(0.1f64, -0.2, 2.0);
//! let (r, p, y) = q.euler();
//! assert!((r - 0.1).abs() < 1e-12 && (p + 0.2).abs() < 1e-12 && (y - 2.0).abs() < 1e-12);
//! ```

use crate::Real;
use nalgebra::{Matrix3, Vector3};

/// A quaternion `w + x i + y j + z k` (normally of unit norm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quat<T> {
    /// Scalar part.
    pub w: T,
    /// Vector part, i.
    pub x: T,
    /// Vector part, j.
    pub y: T,
    /// Vector part, k.
    pub z: T,
}

impl<T: Real> Quat<T> {
    /// The identity rotation.
    pub fn identity() -> Self {
        Self {
            w: T::one(),
            x: T::zero(),
            y: T::zero(),
            z: T::zero(),
        }
    }

    /// The same quaternion in another precision (components rounded to nearest).
    pub fn cast<U: Real>(&self) -> Quat<U> {
        Quat {
            w: U::lit(self.w.as_f64()),
            x: U::lit(self.x.as_f64()),
            y: U::lit(self.y.as_f64()),
            z: U::lit(self.z.as_f64()),
        }
    }

    /// The vector part.
    pub fn vector(&self) -> Vector3<T> {
        Vector3::new(self.x, self.y, self.z)
    }

    /// Conjugate (the inverse rotation for a unit quaternion).
    pub fn conj(&self) -> Self {
        Self {
            w: self.w,
            x: -self.x,
            y: -self.y,
            z: -self.z,
        }
    }

    /// Hamilton product `self * r`: the rotation `r` applied first, then `self`.
    pub fn mul(&self, r: &Self) -> Self {
        let (a, b) = (self, r);
        Self {
            w: a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
            x: a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
            y: a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
            z: a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
        }
    }

    /// Squared norm.
    pub fn norm2(&self) -> T {
        self.w * self.w + self.x * self.x + self.y * self.y + self.z * self.z
    }

    /// Renormalised to unit norm with the sign of `w` made non-negative (one representative per
    /// rotation). A zero or non-finite quaternion is returned unchanged (the caller's finiteness
    /// check then rejects it): never a division by zero.
    pub fn normalized(&self) -> Self {
        let n2 = self.norm2();
        if !(n2.is_finite() && n2 > T::zero()) {
            return *self;
        }
        let mut k = T::one() / n2.sqrt();
        if self.w < T::zero() {
            k = -k;
        }
        Self {
            w: self.w * k,
            x: self.x * k,
            y: self.y * k,
            z: self.z * k,
        }
    }

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.w.is_finite() && self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }

    /// The rotation by the rotation vector `r` (axis times angle), exactly:
    /// `q = (cos(|r|/2), sin(|r|/2) r / |r|)` (Groves eq. 2.40 with 5.75). Below
    /// `|r| = 1e-3` rad the Taylor series `cos(a/2) = 1 - a^2/8 + a^4/384`,
    /// `sin(a/2)/a = 1/2 - a^2/48 + a^4/3840` is used, whose truncation error (`a^6/46080`,
    /// 2e-23) is far below `f64` epsilon, and which avoids `0/0` at `r = 0`.
    pub fn from_rotvec(r: &Vector3<T>) -> Self {
        let a2 = r.norm_squared();
        let (c, s) = if a2 < T::lit(1e-6) {
            let a4 = a2 * a2;
            (
                T::one() - a2 / T::lit(8.0) + a4 / T::lit(384.0),
                T::lit(0.5) - a2 / T::lit(48.0) + a4 / T::lit(3840.0),
            )
        } else {
            let a = a2.sqrt();
            let h = a * T::lit(0.5);
            (h.cos(), h.sin() / a)
        };
        Self {
            w: c,
            x: s * r.x,
            y: s * r.y,
            z: s * r.z,
        }
    }

    /// The rotation vector of a unit quaternion (inverse of [`from_rotvec`](Self::from_rotvec)),
    /// angle in `[0, pi]`.
    pub fn rotvec(&self) -> Vector3<T> {
        let q = self.normalized();
        let v = q.vector();
        let s = v.norm();
        // angle = 2 atan2(|v|, w); the ratio angle/|v| tends to 2/w (= 2) at small angles.
        let k = if s < T::lit(1e-6) {
            T::lit(2.0) / q.w.max(T::lit(0.5))
        } else {
            T::lit(2.0) * s.atan2(q.w) / s
        };
        v * k
    }

    /// Direction cosine matrix `C_b^n` (Groves eq. 2.34).
    pub fn dcm(&self) -> Matrix3<T> {
        let (w, x, y, z) = (self.w, self.x, self.y, self.z);
        let two = T::lit(2.0);
        Matrix3::new(
            w * w + x * x - y * y - z * z,
            two * (x * y - w * z),
            two * (x * z + w * y),
            two * (x * y + w * z),
            w * w - x * x + y * y - z * z,
            two * (y * z - w * x),
            two * (x * z - w * y),
            two * (y * z + w * x),
            w * w - x * x - y * y + z * z,
        )
    }

    /// Resolves a body vector in NED: `C_b^n v`.
    pub fn rotate(&self, v: &Vector3<T>) -> Vector3<T> {
        self.dcm() * v
    }

    /// From ZYX Euler angles (roll, pitch, yaw) [rad]: `q = q_z(yaw) q_y(pitch) q_x(roll)`
    /// (Groves eq. 2.38).
    pub fn from_euler(roll: T, pitch: T, yaw: T) -> Self {
        let h = T::lit(0.5);
        let (sr, cr) = ((roll * h).sin(), (roll * h).cos());
        let (sp, cp) = ((pitch * h).sin(), (pitch * h).cos());
        let (sy, cy) = ((yaw * h).sin(), (yaw * h).cos());
        Self {
            w: cr * cp * cy + sr * sp * sy,
            x: sr * cp * cy - cr * sp * sy,
            y: cr * sp * cy + sr * cp * sy,
            z: cr * cp * sy - sr * sp * cy,
        }
    }

    /// ZYX Euler angles `(roll, pitch, yaw)` [rad] (Groves eq. 2.17): roll and yaw in
    /// `(-pi, pi]`, pitch in `[-pi/2, pi/2]` (the sine is clamped so rounding cannot give NaN).
    pub fn euler(&self) -> (T, T, T) {
        let c = self.dcm();
        let roll = c.m32.atan2(c.m33);
        let pitch = (-c.m31).max(-T::one()).min(T::one()).asin();
        let yaw = c.m21.atan2(c.m11);
        (roll, pitch, yaw)
    }
}

/// Skew-symmetric matrix `[v x]` such that `[v x] u = v x u`.
pub fn skew<T: Real>(v: &Vector3<T>) -> Matrix3<T> {
    let z = T::zero();
    Matrix3::new(z, -v.z, v.y, v.z, z, -v.x, -v.y, v.x, z)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &Matrix3<f64>, b: &Matrix3<f64>, tol: f64) -> bool {
        (a - b).abs().max() < tol
    }

    #[test]
    fn euler_matches_elementary_rotations() {
        let (r, p, y): (f64, f64, f64) = (0.3, -0.4, 2.5);
        let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, r.cos(), -r.sin(), 0.0, r.sin(), r.cos());
        let ry = Matrix3::new(p.cos(), 0.0, p.sin(), 0.0, 1.0, 0.0, -p.sin(), 0.0, p.cos());
        let rz = Matrix3::new(y.cos(), -y.sin(), 0.0, y.sin(), y.cos(), 0.0, 0.0, 0.0, 1.0);
        let q = Quat::from_euler(r, p, y);
        assert!(close(&q.dcm(), &(rz * ry * rx), 1e-15));
        let (r2, p2, y2) = q.euler();
        assert!((r2 - r).abs() < 1e-14 && (p2 - p).abs() < 1e-14 && (y2 - y).abs() < 1e-14);
        // Product order: q_a * q_b has the DCM C_a C_b.
        let qa = Quat::from_euler(0.0f64, 0.0, 0.7);
        let qb = Quat::from_euler(0.2f64, 0.0, 0.0);
        assert!(close(&qa.mul(&qb).dcm(), &(qa.dcm() * qb.dcm()), 1e-15));
    }

    #[test]
    fn rotvec_round_trip_and_series_continuity() {
        let r = Vector3::new(0.3f64, -1.2, 0.8);
        let q = Quat::from_rotvec(&r);
        assert!((q.norm2() - 1.0).abs() < 1e-15);
        assert!((q.rotvec() - r).norm() < 1e-14);
        // Rotating the axis leaves it fixed.
        assert!((q.rotate(&r) - r).norm() < 1e-14);
        // Just below the series threshold |r| = 1e-3 the series agrees with the closed form.
        let u = Vector3::new(1.0f64, 2.0, -2.0) / 3.0;
        let r = u * (1e-3 * (1.0 - 1e-9));
        let a = r.norm();
        let q = Quat::from_rotvec(&r);
        assert!((q.w - (a / 2.0).cos()).abs() < 2e-16);
        assert!((q.vector() - r * ((a / 2.0).sin() / a)).norm() < 2e-19);
        assert_eq!(
            Quat::from_rotvec(&Vector3::<f64>::zeros()),
            Quat::identity()
        );
        assert!(Quat::<f64>::identity().rotvec().norm() == 0.0);
    }

    #[test]
    fn degenerate_inputs_do_not_panic() {
        let nan = Vector3::new(f64::NAN, 0.0, 0.0);
        assert!(!Quat::from_rotvec(&nan).is_finite());
        let zero = Quat {
            w: 0.0f32,
            x: 0.0,
            y: 0.0,
            z: 0.0,
        };
        assert_eq!(zero.normalized(), zero);
        let inf = Quat::from_euler(f32::INFINITY, 0.0, 0.0);
        let _ = inf.euler();
        let _ = inf.normalized().rotvec();
    }
}
