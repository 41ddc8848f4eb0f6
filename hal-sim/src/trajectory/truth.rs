//! Truth along a [`Profile`] and the exact error-free IMU increments that go with it.
//!
//! The NED velocity, its derivative and the attitude are closed-form functions of time
//! ([`Profile::at`]). The IMU sees (Groves eq. 5.54 and 2.56, solved for the sensed quantities)
//!
//! ```text
//! omega_ib^b = omega_nb^b(roll, pitch, Euler rates) + C_n^b (omega_ie^n + omega_en^n)
//! f_ib^b     = C_n^b (dv^n/dt + (2 omega_ie^n + omega_en^n) x v^n - g^n)
//! ```
//!
//! with the Earth terms from the core (`imu_ident::strapdown::earth`, the same functions the
//! mechanisation calls). Position and the increments `int omega dt`, `int f dt` over each IMU
//! interval are integrated together by classical RK4 with [`SUBSTEPS`] steps per interval: the
//! increments are then Simpson-rule quadratures with error `h^5 max|x''''| / 2880` per substep
//! (about 1e-14 rad for the profiles here at 100 Hz), far below the mechanisation's own
//! truncation, so the simulator's outputs are exact for the purpose of testing it.

use super::profile::{Kinematics, Profile};
use anyhow::{bail, Result};
use imu_ident::strapdown::{earth, Geodetic, Increment, Quat};
use nalgebra::{SVector, Vector3};

/// RK4 steps per IMU interval.
pub const SUBSTEPS: usize = 2;

/// One truth sample at the end of an IMU interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthSample {
    /// Time [s].
    pub t: f64,
    /// Position.
    pub pos: Geodetic,
    /// NED velocity [m/s].
    pub vel: Vector3<f64>,
    /// Roll, pitch, yaw [rad] (yaw in `(-pi, pi]`).
    pub euler: [f64; 3],
    /// Exact increments over `(t - dt, t]` (zero for the first sample).
    pub inc: Increment<f64>,
}

/// NED velocity from the kinematics: `s (cos g cos psi, cos g sin psi, -sin g)`.
pub fn velocity(k: &Kinematics) -> Vector3<f64> {
    let (sg, cg) = k.gamma.sin_cos();
    let (sp, cp) = k.psi.sin_cos();
    Vector3::new(k.s * cg * cp, k.s * cg * sp, -k.s * sg)
}

/// Time derivative of [`velocity`].
pub fn acceleration(k: &Kinematics) -> Vector3<f64> {
    let (sg, cg) = k.gamma.sin_cos();
    let (sp, cp) = k.psi.sin_cos();
    let s = k.s;
    Vector3::new(
        k.sd * cg * cp - s * k.gammad * sg * cp - s * k.psid * cg * sp,
        k.sd * cg * sp - s * k.gammad * sg * sp + s * k.psid * cg * cp,
        -k.sd * sg - s * k.gammad * cg,
    )
}

/// Attitude `q_b^n` from the kinematics (roll, pitch = gamma, yaw = psi).
pub fn attitude(k: &Kinematics) -> Quat<f64> {
    Quat::from_euler(k.roll, k.gamma, k.psi)
}

/// `omega_ib^b` and `f_ib^b` at the kinematics `k`, latitude `lat`, height `h`.
pub fn imu_rates(k: &Kinematics, lat: f64, h: f64) -> (Vector3<f64>, Vector3<f64>) {
    let (sr, cr) = k.roll.sin_cos();
    let (st, ct) = k.gamma.sin_cos();
    // Body rate relative to NED from the ZYX Euler rates (Groves eq. 2.56 inverted).
    let w_nb = Vector3::new(
        k.rolld - k.psid * st,
        k.gammad * cr + k.psid * sr * ct,
        -k.gammad * sr + k.psid * cr * ct,
    );
    let c_nb = attitude(k).dcm().transpose();
    let v = velocity(k);
    let w_ie = earth::earth_rate_ned(lat);
    let w_en = earth::transport_rate_ned(&v, lat, h);
    let g = earth::gravity_ned(lat, h);
    let omega = w_nb + c_nb * (w_ie + w_en);
    let f = c_nb * (acceleration(k) + (w_ie * 2.0 + w_en).cross(&v) - g);
    (omega, f)
}

/// Truth samples at `1/dt` along a profile, from `start`; an iterator (a 2-h run at 100 Hz
/// would be 100 MB as a vector).
#[derive(Debug, Clone)]
pub struct TruthGen<'a> {
    profile: &'a Profile,
    dt: f64,
    k: usize,
    n: usize,
    /// `[lat, lon, h]` at the current sample.
    pos: [f64; 3],
}

type Y = SVector<f64, 9>;

impl<'a> TruthGen<'a> {
    /// Samples `t = 0, dt, 2 dt, ...` up to the profile's end.
    pub fn new(profile: &'a Profile, start: Geodetic, dt: f64) -> Result<Self> {
        if !(dt.is_finite() && dt > 0.0) {
            bail!("dt must be positive");
        }
        if start.lat.abs() > imu_ident::strapdown::MAX_LAT {
            bail!("start latitude too close to a pole");
        }
        Ok(Self {
            profile,
            dt,
            k: 0,
            n: (profile.duration() / dt + 1e-9).floor() as usize,
            pos: [start.lat, start.lon, start.h],
        })
    }

    fn deriv(&self, t: f64, y: &Y) -> Y {
        let k = self.profile.at(t);
        let (lat, h) = (y[0], y[2]);
        let r = earth::geodetic_rates(&velocity(&k), lat, h);
        let (w, f) = imu_rates(&k, lat, h);
        Y::from_column_slice(&[r.x, r.y, r.z, w.x, w.y, w.z, f.x, f.y, f.z])
    }

    fn sample(&self, t: f64, inc: Increment<f64>) -> TruthSample {
        let k = self.profile.at(t);
        let (roll, pitch, yaw) = attitude(&k).euler();
        TruthSample {
            t,
            pos: Geodetic {
                lat: self.pos[0],
                lon: self.pos[1],
                h: self.pos[2],
            },
            vel: velocity(&k),
            euler: [roll, pitch, yaw],
            inc,
        }
    }
}

impl Iterator for TruthGen<'_> {
    type Item = TruthSample;

    fn next(&mut self) -> Option<TruthSample> {
        if self.k > self.n {
            return None;
        }
        let t1 = self.k as f64 * self.dt;
        let zero = Increment {
            dtheta: Vector3::zeros(),
            dv: Vector3::zeros(),
        };
        if self.k == 0 {
            self.k = 1;
            return Some(self.sample(0.0, zero));
        }
        let t0 = (self.k - 1) as f64 * self.dt;
        let h = self.dt / SUBSTEPS as f64;
        let mut y = Y::zeros();
        y[0] = self.pos[0];
        y[1] = self.pos[1];
        y[2] = self.pos[2];
        for j in 0..SUBSTEPS {
            let t = t0 + j as f64 * h;
            let k1 = self.deriv(t, &y);
            let k2 = self.deriv(t + h / 2.0, &(y + k1 * (h / 2.0)));
            let k3 = self.deriv(t + h / 2.0, &(y + k2 * (h / 2.0)));
            let k4 = self.deriv(t + h, &(y + k3 * h));
            y += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
        }
        self.pos = [y[0], y[1], y[2]];
        self.k += 1;
        Some(self.sample(
            t1,
            Increment {
                dtheta: Vector3::new(y[3], y[4], y[5]),
                dv: Vector3::new(y[6], y[7], y[8]),
            },
        ))
    }
}
