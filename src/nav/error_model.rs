//! The multi-axis strapdown error-state model: attitude, velocity and position errors plus the
//! noise components of each gyro and accelerometer axis, linearised about the navigation
//! solution (an [`ErrorModel`] with `Z = 6` observation axes: GNSS position and velocity).
//!
//! # Form: phi angle, computed minus true
//! The attitude error is the *phi angle* `phi` of the NED frame, with
//! `C_b^n(computed) = (I + [phi x]) C_b^n(true)` — the convention of
//! [`Strapdown::correct`](crate::strapdown::Strapdown::correct). The phi form is chosen over the
//! psi form because the mechanisation, its corrections and GNSS positions all live in the
//! computed NED frame; the psi form would need the position error folded into the attitude at
//! every correction. Errors are computed minus true: `dv = v^ - v`, `dp = p^ - p` in NED metres
//! (`dp_N = dL (R_N + h)`, `dp_E = dlambda (R_E + h) cos L`, `dp_D = -dh`).
//!
//! # Dynamics (Groves 2013 eq. 14.64-14.66 with `dp` in metres; Titterton & Weston §12.2)
//! With `w_in = w_ie + w_en`, and the rate errors `dw_ie = M_ie dp`, `dw_en = M_en_v dv + M_en_p dp`
//! (derivatives of [`earth_rate_ned`](earth::earth_rate_ned) and
//! [`transport_rate_ned`](earth::transport_rate_ned)):
//!
//! ```text
//! phi' = -[w_in x] phi - M_en_v dv - (M_ie + M_en_p) dp + C_b^n (b_g + w_g)
//! dv'  = -[f^n x] phi - [(2 w_ie + w_en) x] dv + [v x] (M_en_v dv + (2 M_ie + M_en_p) dp)
//!        + dg + C_b^n (b_a + w_a),          dg = (0, 0, 2 g dp_D / (R + h))
//! dp'  = dv                                  (terms of order |v| / R < 1e-5 /s neglected)
//! x_c' = A_c x_c + G_c xi_c                  (each component; b = sum_c C_c x_c per axis)
//! ```
//!
//! White components enter `Qc` through `C_b^n diag(N^2) C_b^n^T`; the others add states.
//! The model is linearised about a [`NavPoint`] held over the filter step, and discretised
//! exactly over the step ([`discretise_block`](crate::model::discretise::discretise_block)).
//!
//! # Observations (`Z = 6`)
//! The GNSS antenna sits at the lever arm `l` (body FRD, metres) from the IMU. Position rows
//! `z = p^_ant - p_gnss = dp - [(C l) x] phi`; velocity rows
//! `z = v^_ant - v_gnss = dv - [(C (w_ib x l)) x] phi` (the gyro-error term `C (b_g x l)` is
//! below a millimetre per second for arms under a metre and is neglected).
//!
//! State layout: `[phi 0..3, dv 3..6, dp 6..9, gyro x, y, z components, accel x, y, z
//! components, unused]`.

use super::imu_model::{ImuErrorModel, ImuSensor};
use crate::linalg::Arr;
use crate::model::discretise::discretise_block_into;
use crate::model::ins::pow2_near;
use crate::model::{ContinuousSystem, ErrorModel, ModelError, StateBlock};
use crate::strapdown::earth;
use crate::strapdown::skew;
use crate::Real;
use nalgebra::{Matrix2, Matrix3, Vector3};

/// Named state indices of the navigation errors.
pub mod nav_idx {
    /// Attitude error `phi` (NED, rad), three states.
    pub const ATT: usize = 0;
    /// Velocity error (NED, m/s), three states.
    pub const VEL: usize = 3;
    /// Position error (NED, m), three states.
    pub const POS: usize = 6;
    /// First sensor-component state.
    pub const SENSOR: usize = 9;
}

/// Observation axes: GNSS position N, E, D then velocity N, E, D.
pub const NAV_Z: usize = 6;

/// Names of the six sensor-axis blocks, in state order.
const AXIS_NAMES: [[&str; 3]; 2] = [
    ["gyro_x", "gyro_y", "gyro_z"],
    ["accel_x", "accel_y", "accel_z"],
];
const SENSORS: [ImuSensor; 2] = [ImuSensor::Gyro, ImuSensor::Accel];

/// A callback `f(sensor, axis, first_state, component)`.
pub type ComponentVisitor<'a, T> =
    dyn FnMut(ImuSensor, usize, usize, &crate::model::Component<T>) + 'a;

/// `m[r][c] = v` when `v` is given and `(r, c)` is inside `m` (checked: see `physical`).
fn set<T: Copy, const N: usize>(m: &mut Arr<T, N>, r: usize, c: usize, v: Option<T>) {
    if let (Some(slot), Some(v)) = (m.get_mut(r).and_then(|row| row.get_mut(c)), v) {
        *slot = v;
    }
}

/// The navigation solution the error dynamics are linearised about.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NavPoint<T: Real> {
    /// Latitude [rad].
    pub lat: T,
    /// Ellipsoidal height [m].
    pub h: T,
    /// NED velocity [m/s].
    pub v: Vector3<T>,
    /// Attitude `C_b^n`.
    pub c_bn: Matrix3<T>,
    /// Specific force in NED, mean over the step [m/s^2].
    pub f_n: Vector3<T>,
    /// Body angular rate `w_ib^b` [rad/s] (for the velocity lever arm).
    pub w_b: Vector3<T>,
    /// Mean body angular rate over the step [rad/s] (drives the gyro scale-factor errors).
    pub mean_w_b: Vector3<T>,
    /// Mean body specific force over the step [m/s^2] (drives the accelerometer scale-factor
    /// errors).
    pub mean_f_b: Vector3<T>,
}

impl<T: Real> NavPoint<T> {
    /// Level, at rest, at latitude `lat` and height `h`.
    pub fn at_rest(lat: T, h: T) -> Self {
        Self {
            lat,
            h,
            v: Vector3::zeros(),
            c_bn: Matrix3::identity(),
            f_n: Vector3::new(T::zero(), T::zero(), -earth::normal_gravity(lat, h)),
            w_b: Vector3::zeros(),
            mean_w_b: Vector3::zeros(),
            mean_f_b: Vector3::new(T::zero(), T::zero(), -earth::normal_gravity(lat, h)),
        }
    }
}

/// Initial uncertainty of the navigation errors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NavInit<T: Real> {
    /// Attitude (roll, pitch, yaw as NED phi components N, E, D) [rad].
    pub sd_att: Vector3<T>,
    /// Velocity, each axis [m/s].
    pub sd_vel: T,
    /// Position, each axis [m].
    pub sd_pos: T,
}

/// The strapdown error-state model (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct StrapdownErrorModel<T: Real> {
    /// Sensor noise components per axis.
    pub imu: ImuErrorModel<T>,
    /// Initial uncertainty of the navigation errors.
    pub init: NavInit<T>,
    /// GNSS antenna from the IMU, body FRD [m].
    pub lever_arm: Vector3<T>,
    /// Default observation standard deviations (position N, E, D [m], velocity [m/s]), used
    /// where a fix gives none.
    pub obs_sd: [T; NAV_Z],
    /// The linearisation point.
    pub point: NavPoint<T>,
    /// Filter step [s].
    pub dt: T,
    /// Scale-factor errors of the gyros and the accelerometers as random constants with these
    /// standard deviations (dimensionless, e.g. `0.01` for 1 %), or none. They are sensor
    /// errors proportional to the input, `b = s w` (not noise components: the input drives
    /// them), and add six states after the noise components.
    pub scale_factor_sd: Option<[T; 2]>,
}

impl<T: Real> StrapdownErrorModel<T> {
    /// Number of active states: 9 navigation errors plus the components' states.
    pub fn states(&self) -> usize {
        self.scale_factor_start() + if self.scale_factor_sd.is_some() { 6 } else { 0 }
    }

    /// First scale-factor state (gyro x, y, z then accelerometer x, y, z).
    pub fn scale_factor_start(&self) -> usize {
        nav_idx::SENSOR + self.imu.states()
    }

    /// The scale-factor errors `(s_g, s_a)` of the physical state `x` (zero without them).
    pub fn scale_factors<const N: usize>(&self, x: &[T; N]) -> (Vector3<T>, Vector3<T>) {
        let mut s = [Vector3::zeros(), Vector3::zeros()];
        if self.scale_factor_sd.is_some() {
            let k = self.scale_factor_start();
            for (j, v) in x.iter().skip(k).take(6).enumerate() {
                if let Some(slot) = s.get_mut(j / 3).and_then(|s| s.get_mut(j % 3)) {
                    *slot = *v;
                }
            }
        }
        (s[0], s[1])
    }

    /// Calls `f(sensor, axis, first_state, component)` for each component with states, in state
    /// order.
    pub fn for_each_component(&self, f: &mut ComponentVisitor<'_, T>) {
        let mut k = nav_idx::SENSOR;
        for s in SENSORS {
            for (axis, comps) in self.imu.sensor(s).iter().enumerate() {
                for c in comps.iter() {
                    if c.states() > 0 {
                        f(s, axis, k, c);
                        k += c.states();
                    }
                }
            }
        }
    }

    /// Scales the covariance `p` (scaled states, of a filter running this model) for the
    /// model `new` of the same layout: where a component's magnitude
    /// ([`Component::magnitude`](crate::model::Component::magnitude): its stationary sigma, a
    /// random walk's one-hour growth) grows by `r`, its states' rows and columns grow by `r`.
    /// A prior that was too tight left a posterior too tight; with a correlation time of hours
    /// the new `Q` alone would take hours to loosen it. A magnitude that shrinks leaves the
    /// covariance as it is: the estimates made under the looser model are no better than it
    /// said.
    pub fn retune_covariance<const N: usize>(&self, new: &Self, p: &mut Arr<T, N>) {
        let mut old = [T::zero(); N];
        self.for_each_component(&mut |_, _, k, c| {
            for i in k..k + c.states() {
                if let Some(v) = old.get_mut(i) {
                    *v = c.magnitude();
                }
            }
        });
        let mut r = [T::one(); N];
        new.for_each_component(&mut |_, _, k, c| {
            for i in k..k + c.states() {
                if let (Some(v), Some(o)) = (r.get_mut(i), old.get(i)) {
                    let ratio = c.magnitude() / *o;
                    if ratio.is_finite() && ratio > T::one() {
                        *v = ratio;
                    }
                }
            }
        });
        for (row, ri) in p.iter_mut().zip(r.iter()) {
            for (v, rj) in row.iter_mut().zip(r.iter()) {
                *v = *v * *ri * *rj;
            }
        }
    }

    /// The sensor errors `(b_g, b_a)` (rad/s, m/s^2, body axes) of the physical state `x`: per
    /// axis the sum of its components' outputs `C_c x_c`.
    pub fn sensor_errors<const N: usize>(&self, x: &[T; N]) -> (Vector3<T>, Vector3<T>) {
        let mut b = [Vector3::zeros(), Vector3::zeros()];
        self.for_each_component(&mut |s, axis, k, c| {
            let blk = c.block();
            let si = usize::from(s == ImuSensor::Accel);
            // Checked access throughout (here and below): the firmware links only without
            // panic paths, and the visitor's indices are not provably in range.
            let Some(out) = b.get_mut(si).and_then(|v| v.get_mut(axis)) else {
                return;
            };
            for j in 0..blk.states {
                if let (Some(v), Some(cj)) = (x.get(k + j), blk.c.get(j)) {
                    *out += *cj * *v;
                }
            }
        });
        (b[0], b[1])
    }

    /// Physical `A` and `Qc` over the active states, written into `a` and `qc` (zero elsewhere):
    /// what a prediction needs, at every 1-Hz step and for every shadow of the bank
    /// ([`Self::initial_covariance`] is built apart). Into the caller's arrays, not returned:
    /// the firmware's deepest stack runs through here.
    fn physical_into<const N: usize>(
        &self,
        a: &mut Arr<T, N>,
        qc: &mut Arr<T, N>,
    ) -> Result<(), ModelError> {
        let n = self.states();
        if n > N {
            return Err(ModelError::TooManyStates);
        }
        self.imu.validate()?;
        let p = &self.point;
        let (lat, h) = (p.lat, p.h);
        // The latitude's functions evaluated once (the same values as the free functions).
        let at = earth::Latitude::new(lat);
        let rn = at.radius_north() + h;
        let re = at.radius_east() + h;
        let (sl, cl) = (at.sin(), at.cos());
        let tl = sl / cl;
        let w = T::lit(earth::OMEGA_IE);
        let w_ie = at.earth_rate_ned();
        let w_en = at.transport_rate_ned(&p.v, h);
        let w_in = w_ie + w_en;
        let (vn, ve) = (p.v.x, p.v.y);
        let z = T::zero();
        // d w_ie / d dp (only dL = dp_N / R_N enters).
        let m_ie = Matrix3::new(-w * sl / rn, z, z, z, z, z, -w * cl / rn, z, z);
        // d w_en / d dv and d dp (dh = -dp_D).
        let m_en_v = Matrix3::new(z, T::one() / re, z, -T::one() / rn, z, z, z, -tl / re, z);
        let m_en_p = Matrix3::new(
            z,
            z,
            ve / (re * re),
            z,
            z,
            -vn / (rn * rn),
            -ve / (re * cl * cl * rn),
            z,
            -ve * tl / (re * re),
        );
        let g = at.normal_gravity(h);
        let r_mean = (rn * re).sqrt();

        let f_pp = -skew(&w_in);
        let f_pv = -m_en_v;
        let f_pr = -(m_ie + m_en_p);
        let f_vp = -skew(&p.f_n);
        let f_vv = -skew(&(w_ie * T::lit(2.0) + w_en)) + skew(&p.v) * m_en_v;
        let mut f_vr = skew(&p.v) * (m_ie * T::lit(2.0) + m_en_p);
        f_vr[(2, 2)] += T::lit(2.0) * g / r_mean;

        for row in a.iter_mut().chain(qc.iter_mut()) {
            row.fill(T::zero());
        }
        let put = |m: &mut Arr<T, N>, r0: usize, c0: usize, b: &Matrix3<T>| {
            for i in 0..3 {
                for j in 0..3 {
                    m[r0 + i][c0 + j] = b[(i, j)];
                }
            }
        };
        use nav_idx::{ATT, POS, VEL};
        put(a, ATT, ATT, &f_pp);
        put(a, ATT, VEL, &f_pv);
        put(a, ATT, POS, &f_pr);
        put(a, VEL, ATT, &f_vp);
        put(a, VEL, VEL, &f_vv);
        put(a, VEL, POS, &f_vr);
        put(a, POS, VEL, &Matrix3::identity());

        // White noise: C diag(N^2) C^T on phi (gyro) and dv (accel).
        let c = p.c_bn;
        for (si, s) in SENSORS.iter().enumerate() {
            let mut d = Matrix3::zeros();
            for (axis, comps) in self.imu.sensor(*s).iter().enumerate() {
                d[(axis, axis)] = comps.iter().fold(T::zero(), |acc, c| acc + c.white_qc());
            }
            let q = c * d * c.transpose();
            put(
                qc,
                if si == 0 { ATT } else { VEL },
                if si == 0 { ATT } else { VEL },
                &q,
            );
        }
        // Component blocks and their coupling through C_b^n.
        self.for_each_component(&mut |s, axis, k, comp| {
            let blk = comp.block();
            let row0 = if s == ImuSensor::Gyro { ATT } else { VEL };
            let at = |m: &Matrix2<T>, i: usize, j: usize| m.get((i, j)).copied();
            for i in 0..blk.states {
                for j in 0..blk.states {
                    set(a, k + i, k + j, at(&blk.a, i, j));
                    set(qc, k + i, k + j, at(&blk.qc, i, j));
                }
                for r in 0..3 {
                    let v = c.get((r, axis)).zip(blk.c.get(i)).map(|(x, y)| *x * *y);
                    set(a, row0 + r, k + i, v);
                }
            }
        });
        // Scale factors: phi' += C diag(w_b) s_g, dv' += C diag(f_b) s_a (Groves eq. 14.64
        // with the scale-factor terms of eq. 4.18).
        if self.scale_factor_sd.is_some() {
            let k = self.scale_factor_start();
            for j in 0..3 {
                for r in 0..3 {
                    let cw = c.get((r, j)).zip(p.mean_w_b.get(j)).map(|(x, y)| *x * *y);
                    let cf = c.get((r, j)).zip(p.mean_f_b.get(j)).map(|(x, y)| *x * *y);
                    set(a, ATT + r, k + j, cw);
                    set(a, VEL + r, k + 3 + j, cf);
                }
            }
        }
        Ok(())
    }

    /// [`ErrorModel::dynamics`] into the caller's `a`, `qc`: `A'`, `Qc'` in the states scaled
    /// by `scale`; returns the number of active states.
    #[allow(non_snake_case)]
    pub fn dynamics_into<const N: usize>(
        &self,
        scale: &[T; N],
        A: &mut Arr<T, N>,
        Qc: &mut Arr<T, N>,
    ) -> Result<usize, ModelError> {
        self.physical_into(A, Qc)?;
        let n = self.states();
        // Zipped rather than indexed (no bounds checks left for the no-panic link check).
        for ((ra, rq), si) in A.iter_mut().zip(Qc.iter_mut()).zip(scale.iter()).take(n) {
            for ((a, q), sj) in ra.iter_mut().zip(rq.iter_mut()).zip(scale.iter()).take(n) {
                *a = *a * *sj / *si;
                *q /= *si * *sj;
            }
        }
        let finite = A.iter().chain(Qc.iter()).flatten().all(|v| v.is_finite());
        if !finite {
            return Err(ModelError::NonFinite);
        }
        Ok(n)
    }

    /// `(Phi, Qd)` of [`Self::dynamics_into`] over the step `dt`, into the caller's arrays
    /// ([`discretise_block_into`]): the filter step of the navigator and of each shadow of the
    /// bank, with `A'`, `Qc'` in this frame only.
    #[allow(non_snake_case)]
    pub fn discrete_into<const N: usize>(
        &self,
        scale: &[T; N],
        Phi: &mut Arr<T, N>,
        Qd: &mut Arr<T, N>,
    ) -> Result<(), ModelError> {
        let mut A = [[T::zero(); N]; N];
        let mut Qc = [[T::zero(); N]; N];
        let n = self.dynamics_into(scale, &mut A, &mut Qc)?;
        discretise_block_into(&A, &Qc, self.dt, n, Phi, Qd)
    }

    /// Physical `P0` over the active states: the navigation errors' initial deviations, each
    /// component's stationary covariance and the scale factors' deviations.
    fn initial_covariance<const N: usize>(&self) -> Arr<T, N> {
        use nav_idx::{ATT, POS, VEL};
        let mut p0 = [[T::zero(); N]; N];
        self.for_each_component(&mut |_, _, k, comp| {
            let blk = comp.block();
            let at = |m: &Matrix2<T>, i: usize, j: usize| m.get((i, j)).copied();
            for i in 0..blk.states {
                for j in 0..blk.states {
                    set(&mut p0, k + i, k + j, at(&blk.p0, i, j));
                }
            }
        });
        if let Some(sd) = self.scale_factor_sd {
            let k = self.scale_factor_start();
            for j in 0..3 {
                set(&mut p0, k + j, k + j, Some(sd[0] * sd[0]));
                set(&mut p0, k + 3 + j, k + 3 + j, Some(sd[1] * sd[1]));
            }
        }
        let ini = &self.init;
        for i in 0..3 {
            p0[ATT + i][ATT + i] = ini.sd_att[i] * ini.sd_att[i];
            p0[VEL + i][VEL + i] = ini.sd_vel * ini.sd_vel;
            p0[POS + i][POS + i] = ini.sd_pos * ini.sd_pos;
        }
        p0
    }

    /// The observation rows `H` in the states scaled by `scale` and the default variances
    /// `R` (module docs, "Observations"): all a fusion needs, without building `A` and `Qc`.
    pub fn observation<const N: usize>(&self, scale: &[T; N]) -> ([[T; N]; NAV_Z], [T; NAV_Z]) {
        use nav_idx::{ATT, POS, VEL};
        let (p, c) = (&self.point, &self.point.c_bn);
        // Observation rows with the lever arm.
        let mut hm = [[T::zero(); N]; NAV_Z];
        let l_n = c * self.lever_arm;
        let lv_n = c * p.w_b.cross(&self.lever_arm);
        let (sp, sv) = (-skew(&l_n), -skew(&lv_n));
        for i in 0..3 {
            hm[i][POS + i] = T::one();
            hm[3 + i][VEL + i] = T::one();
            for j in 0..3 {
                hm[i][ATT + j] = sp[(i, j)];
                hm[3 + i][ATT + j] = sv[(i, j)];
            }
        }
        for row in hm.iter_mut() {
            for (h, s) in row.iter_mut().zip(scale.iter()) {
                *h *= *s;
            }
        }
        let mut r = [T::zero(); NAV_Z];
        for (r, sd) in r.iter_mut().zip(self.obs_sd.iter()) {
            *r = *sd * *sd;
        }
        (hm, r)
    }
}

impl<T: Real, const N: usize> ErrorModel<T, N, NAV_Z> for StrapdownErrorModel<T> {
    fn dt(&self) -> T {
        self.dt
    }

    fn scaling(&self) -> Result<[T; N], ModelError> {
        if self.states() > N {
            return Err(ModelError::TooManyStates);
        }
        let mut s = [T::one(); N];
        let ini = &self.init;
        let att = ini.sd_att.x.max(ini.sd_att.y).max(ini.sd_att.z);
        for i in 0..3 {
            s[nav_idx::ATT + i] = pow2_near(att);
            s[nav_idx::VEL + i] = pow2_near(ini.sd_vel);
            s[nav_idx::POS + i] = pow2_near(ini.sd_pos);
        }
        self.for_each_component(&mut |_, _, k, c| {
            let blk = c.block();
            for j in 0..blk.states {
                if let (Some(v), Some(p)) = (s.get_mut(k + j), blk.p0.get((j, j))) {
                    *v = pow2_near(p.sqrt().max(c.magnitude()));
                }
            }
        });
        if let Some(sd) = self.scale_factor_sd {
            let k = self.scale_factor_start();
            for j in 0..6 {
                if let Some(v) = s.get_mut(k + j) {
                    *v = pow2_near(sd[j / 3]);
                }
            }
        }
        if s.iter().all(|v| v.is_finite() && *v > T::zero()) {
            Ok(s)
        } else {
            Err(ModelError::BadSigma)
        }
    }

    #[allow(non_snake_case)]
    fn system(&self, scale: &[T; N]) -> Result<ContinuousSystem<T, N, NAV_Z>, ModelError> {
        let (A, Qc, n) = self.dynamics(scale)?;
        let mut P0 = self.initial_covariance::<N>();
        for (rp, si) in P0.iter_mut().zip(scale.iter()).take(n) {
            for (p, sj) in rp.iter_mut().zip(scale.iter()).take(n) {
                *p /= *si * *sj;
            }
        }
        let (H, R) = self.observation(scale);
        Ok(ContinuousSystem { A, Qc, P0, H, R, n })
    }

    #[allow(non_snake_case)]
    fn dynamics(&self, scale: &[T; N]) -> Result<(Arr<T, N>, Arr<T, N>, usize), ModelError> {
        let mut A = [[T::zero(); N]; N];
        let mut Qc = [[T::zero(); N]; N];
        let n = self.dynamics_into(scale, &mut A, &mut Qc)?;
        Ok((A, Qc, n))
    }

    fn blocks(&self, f: &mut dyn FnMut(StateBlock)) {
        for (name, start) in [
            ("att", nav_idx::ATT),
            ("vel", nav_idx::VEL),
            ("pos", nav_idx::POS),
        ] {
            f(StateBlock {
                name,
                component: None,
                start: start as u8,
                width: 3,
            });
        }
        self.for_each_component(&mut |s, axis, k, c| {
            let si = usize::from(s == ImuSensor::Accel);
            f(StateBlock {
                name: AXIS_NAMES[si][axis],
                component: Some(c.kind()),
                start: k as u8,
                width: c.states() as u8,
            })
        });
        if self.scale_factor_sd.is_some() {
            let k = self.scale_factor_start();
            for (i, name) in ["gyro_sf", "accel_sf"].into_iter().enumerate() {
                f(StateBlock {
                    name,
                    component: Some(crate::model::ComponentKind::RandomConstant),
                    start: (k + 3 * i) as u8,
                    width: 3,
                });
            }
        }
    }

    fn same_layout(&self, other: &Self) -> bool {
        let kinds = |m: &Self| {
            let mut v: heapless::Vec<(u8, u8), 48> = heapless::Vec::new();
            m.for_each_component(&mut |s, axis, _, c| {
                let _ = v.push(((s as u8) * 8 + axis as u8, c.kind().code()));
            });
            v
        };
        kinds(self) == kinds(other)
            && self.scale_factor_sd.is_some() == other.scale_factor_sd.is_some()
    }
}
