//! The closed-loop INS/GNSS navigator: the strapdown mechanisation at the IMU rate, the
//! error-state Kalman filter of [`StrapdownErrorModel`] stepped at the filter rate (1 Hz by
//! default), GNSS position/velocity and zero-velocity updates, and the closed-loop correction.
//!
//! Time is passed in (seconds, `f64`, any epoch); the navigator never reads a clock.
//!
//! # The loop
//! - [`Navigator::imu`]: the increment is compensated by the current estimate of the sensor
//!   errors (`dtheta - b_g dt`, `dv - b_a dt`), mechanised, and its specific force accumulated
//!   in NED. When a filter step has elapsed the filter is propagated ([`Navigator::propagate`]):
//!   the model is linearised about the solution at the end of the step with the step's mean
//!   specific force, discretised exactly over the elapsed time, and `x, P` are predicted.
//! - The navigation-error part of `x` is zero after every correction and stays zero over a
//!   prediction: the mechanisation has already removed the estimated sensor errors, so the
//!   mean of `dphi, dv, dp` is only driven by the change of the estimated sensor errors within
//!   the step (`(1 - e^{-dt/tau}) b`, below 0.4 % of `b` for `tau >= 300 s` at 1 Hz), which is
//!   dropped. The sensor-error part of `x` is predicted as usual.
//! - [`Navigator::gnss`]: a fix is fused at its own time `t_f <= t` (the solution is moved back
//!   along its velocity by `t - t_f`, at most one IMU interval); the filter is first propagated
//!   over the part of the step already elapsed. The six axes pass a vector chi-square gate, then
//!   are fused one by one ([`fuse`]); the estimated navigation errors are then removed from the
//!   mechanisation ([`Strapdown::correct`]) and zeroed in `x`.
//! - [`Navigator::zupt`] and [`Navigator::nhc`]: pseudo-observations of a vehicle at rest (zero
//!   velocity) and of a land vehicle that neither slides sideways nor leaves the road (zero
//!   body-frame lateral and vertical velocity), through the same gate, fusion and correction.
//!   Each keeps its own count of consecutive gated updates: were they to share the GNSS one,
//!   a pseudo-observation accepted every step would reset it and a GNSS fix after an outage
//!   could be gated for ever.

use super::error_model::{nav_idx, NavPoint, StrapdownErrorModel, NAV_Z};
use crate::filter::{fuse, Fused, Kalman};
use crate::linalg::Arr;
use crate::model::discretise::discretise_block;
use crate::model::{ErrorModel, ModelError};
use crate::strapdown::{earth, Geodetic, Increment, Strapdown, StrapdownError};
use crate::Real;
use nalgebra::Vector3;

/// Axes of the non-holonomic constraint ([`Navigator::nhc`]): body y (right) and z (down).
pub const NHC_Z: usize = 2;

/// Chi-square quantiles at `1 - 1e-4` for 1 to 6 degrees of freedom (the default gate).
pub const CHI2_9999: [f64; 6] = [15.137, 18.421, 21.108, 23.513, 25.745, 27.856];

/// Navigator settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NavConfig<T: Real> {
    /// Filter step [s] (1 s: the design card's loop).
    pub step: T,
    /// Gate multiplier on [`CHI2_9999`] (`None`: no gate).
    pub gate: Option<T>,
    /// Longest IMU interval accepted as one step [s]; a longer gap restarts the
    /// coning/sculling history and is still integrated, but is reported.
    pub max_imu_gap: T,
    /// Consecutive gated fixes after which the next one is fused without the gate (a filter
    /// that drifted beyond its covariance, e.g. after an outage, would otherwise reject every
    /// later fix).
    pub max_rejections: u8,
}

impl<T: Real> Default for NavConfig<T> {
    fn default() -> Self {
        Self {
            step: T::one(),
            gate: Some(T::one()),
            max_imu_gap: T::lit(0.1),
            max_rejections: 3,
        }
    }
}

/// Why the navigator refused an input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NavError {
    /// The mechanisation refused the input.
    Strapdown(StrapdownError),
    /// The error model could not be built or discretised.
    Model(ModelError),
    /// A time was not finite, or went backwards.
    BadTime,
}

impl From<StrapdownError> for NavError {
    fn from(e: StrapdownError) -> Self {
        Self::Strapdown(e)
    }
}

impl From<ModelError> for NavError {
    fn from(e: ModelError) -> Self {
        Self::Model(e)
    }
}

/// One GNSS fix. Non-finite velocity or standard deviations mean missing (the model's defaults
/// are then used for the standard deviations).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GnssFix<T: Real> {
    /// Time of validity [s], same time scale as the IMU samples.
    pub t: f64,
    /// Antenna position.
    pub pos: Geodetic,
    /// Antenna NED velocity [m/s] (NaN: not given).
    pub vel: Vector3<T>,
    /// Position standard deviations N, E, D [m].
    pub sd_pos: Vector3<T>,
    /// Velocity standard deviations N, E, D [m/s].
    pub sd_vel: Vector3<T>,
}

/// The INS/GNSS navigator with at most `N` filter states.
#[derive(Debug, Clone)]
pub struct Navigator<T: Real, const N: usize> {
    ins: Strapdown<T>,
    model: StrapdownErrorModel<T>,
    scale: [T; N],
    p0: Arr<T, N>,
    kf: Kalman<T, N>,
    cfg: NavConfig<T>,
    t: f64,
    /// Time the filter was last propagated to (a step, or a fix between steps).
    t_kf: f64,
    /// Time the step clock last started: the last filter step, or the first fix after it.
    t_step: f64,
    /// A GNSS fix has been fused since the last filter step.
    fix_since_step: bool,
    sum_fn: Vector3<T>,
    sum_dt: T,
    sum_dtheta: Vector3<T>,
    sum_dv: Vector3<T>,
    w_b: Vector3<T>,
    s_g: Vector3<T>,
    s_a: Vector3<T>,
    b_g: Vector3<T>,
    b_a: Vector3<T>,
    gaps: u32,
    rejected: u8,
    rejected_nhc: u8,
    rejected_zupt: u8,
}

impl<T: Real, const N: usize> Navigator<T, N> {
    /// Starts at time `t` from the aligned mechanisation `ins`, with the error model `model`
    /// (its `point` is replaced by the solution of `ins`).
    pub fn new(
        ins: Strapdown<T>,
        t: f64,
        mut model: StrapdownErrorModel<T>,
        cfg: NavConfig<T>,
    ) -> Result<Self, NavError> {
        if !(t.is_finite() && cfg.step.is_finite() && cfg.step > T::zero()) {
            return Err(NavError::BadTime);
        }
        let (lat, h) = ins.lat_h();
        model.point = NavPoint::at_rest(lat, h);
        model.point.v = ins.velocity();
        model.point.c_bn = ins.dcm();
        model.dt = cfg.step;
        let scale = <StrapdownErrorModel<T> as ErrorModel<T, N, NAV_Z>>::scaling(&model)?;
        let sys = <StrapdownErrorModel<T> as ErrorModel<T, N, NAV_Z>>::system(&model, &scale)?;
        let kf = Kalman::new(&sys.P0, sys.n);
        Ok(Self {
            ins,
            model,
            scale,
            p0: sys.P0,
            kf,
            cfg,
            t,
            t_kf: t,
            t_step: t,
            fix_since_step: false,
            sum_fn: Vector3::zeros(),
            sum_dt: T::zero(),
            sum_dtheta: Vector3::zeros(),
            sum_dv: Vector3::zeros(),
            w_b: Vector3::zeros(),
            s_g: Vector3::zeros(),
            s_a: Vector3::zeros(),
            b_g: Vector3::zeros(),
            b_a: Vector3::zeros(),
            gaps: 0,
            rejected: 0,
            rejected_nhc: 0,
            rejected_zupt: 0,
        })
    }

    /// The mechanisation (solution at [`time`](Self::time)).
    pub fn ins(&self) -> &Strapdown<T> {
        &self.ins
    }

    /// The error model (linearised at the last filter step).
    pub fn model(&self) -> &StrapdownErrorModel<T> {
        &self.model
    }

    /// The Kalman filter, in scaled states.
    pub fn kalman(&self) -> &Kalman<T, N> {
        &self.kf
    }

    /// Time of the solution [s].
    pub fn time(&self) -> f64 {
        self.t
    }

    /// IMU gaps longer than the configured limit so far.
    pub fn gaps(&self) -> u32 {
        self.gaps
    }

    /// Estimated sensor errors `(b_g, b_a)` now being removed from the IMU (rad/s, m/s^2).
    pub fn sensor_errors(&self) -> (Vector3<T>, Vector3<T>) {
        (self.b_g, self.b_a)
    }

    /// Estimated scale-factor errors `(s_g, s_a)` now being removed (zero without them).
    pub fn scale_factors(&self) -> (Vector3<T>, Vector3<T>) {
        (self.s_g, self.s_a)
    }

    /// Physical state estimate `S x`.
    pub fn state_si(&self) -> [T; N] {
        let mut x = self.kf.x;
        for (v, s) in x.iter_mut().zip(self.scale.iter()) {
            *v *= *s;
        }
        x
    }

    /// Physical standard deviation of each state.
    pub fn sigma_si(&self) -> [T; N] {
        let mut out = [T::zero(); N];
        for (i, (o, s)) in out.iter_mut().zip(self.scale.iter()).enumerate() {
            let p = self.kf.P.get(i).and_then(|r| r.get(i)).copied();
            *o = p.unwrap_or_else(T::zero).max(T::zero()).sqrt() * *s;
        }
        out
    }

    /// Replaces the gate multiplier on [`CHI2_9999`] (`None`: no gate). The online
    /// identification's window replays run ungated: a gate makes the innovation likelihood
    /// discontinuous in the noise parameters, and a model that rejects more fixes would be
    /// scored on fewer.
    pub fn set_gate(&mut self, gate: Option<T>) {
        self.cfg.gate = gate;
    }

    /// Replaces the sensor noise model (same layout: same kinds on the same axes), keeping
    /// `x` and `P`.
    pub fn set_imu_model(&mut self, imu: super::ImuErrorModel<T>) -> Result<(), NavError> {
        let mut m = self.model.clone();
        m.imu = imu;
        if !<StrapdownErrorModel<T> as ErrorModel<T, N, NAV_Z>>::same_layout(&self.model, &m) {
            return Err(NavError::Model(ModelError::TooManyStates));
        }
        <StrapdownErrorModel<T> as ErrorModel<T, N, NAV_Z>>::system(&m, &self.scale)?;
        self.model = m;
        Ok(())
    }

    /// [`set_imu_model`](Self::set_imu_model) for a model identified online: the states are
    /// kept, and where a component's magnitude ([`Component::magnitude`]: its stationary
    /// sigma, a random walk's one-hour growth) grows by `r`, the covariance of its states
    /// grows by `r^2` (rows and columns by `r`). A prior that was too tight left a posterior
    /// too tight; with a correlation time of hours the new `Q` alone would take hours to
    /// loosen it, and the filter would stay overconfident meanwhile. A magnitude that shrinks
    /// leaves the covariance as it is: the estimates made under the looser model are no better
    /// than it said.
    ///
    /// [`Component::magnitude`]: crate::model::Component::magnitude
    pub fn retune_imu_model(&mut self, imu: super::ImuErrorModel<T>) -> Result<(), NavError> {
        let mut old = [T::zero(); N];
        self.model.for_each_component(&mut |_, _, k, c| {
            for i in k..k + c.states() {
                if let Some(v) = old.get_mut(i) {
                    *v = c.magnitude();
                }
            }
        });
        self.set_imu_model(imu)?;
        let mut r = [T::one(); N];
        self.model.for_each_component(&mut |_, _, k, c| {
            for i in k..k + c.states() {
                if let (Some(v), Some(o)) = (r.get_mut(i), old.get(i)) {
                    let ratio = c.magnitude() / *o;
                    if ratio.is_finite() && ratio > T::one() {
                        *v = ratio;
                    }
                }
            }
        });
        for (row, ri) in self.kf.P.iter_mut().zip(r.iter()) {
            for (p, rj) in row.iter_mut().zip(r.iter()) {
                *p = *p * *ri * *rj;
            }
        }
        Ok(())
    }

    /// Heading alignment (for example from the GNSS course once moving): replaces the yaw,
    /// keeping roll and pitch, optionally the velocity (NED, m/s), and restarts the heading
    /// error `phi_D` with standard deviation `sd` [rad], uncorrelated with the other states.
    pub fn set_heading(&mut self, yaw: T, sd: T, vel: Option<Vector3<T>>) -> Result<(), NavError> {
        let (roll, pitch, _) = self.ins.attitude().euler();
        self.ins
            .set_attitude(crate::strapdown::Quat::from_euler(roll, pitch, yaw))?;
        if let Some(v) = vel {
            self.ins.set_velocity(v)?;
        }
        let k = nav_idx::ATT + 2;
        let s = self.scale.get(k).copied().unwrap_or_else(T::one);
        for (i, row) in self.kf.P.iter_mut().enumerate() {
            if let Some(v) = row.get_mut(k) {
                *v = if i == k {
                    (sd / s) * (sd / s)
                } else {
                    T::zero()
                };
            }
        }
        if let Some(row) = self.kf.P.get_mut(k) {
            for (j, v) in row.iter_mut().enumerate() {
                if j != k {
                    *v = T::zero();
                }
            }
        }
        if vel.is_some() {
            // The velocity error of the new velocity is not correlated with the rest either.
            for i in nav_idx::VEL..nav_idx::VEL + 3 {
                let sv = self.scale.get(i).copied().unwrap_or_else(T::one);
                let keep = self
                    .kf
                    .P
                    .get(i)
                    .and_then(|r| r.get(i))
                    .copied()
                    .unwrap_or_else(T::zero);
                for (r, row) in self.kf.P.iter_mut().enumerate() {
                    if let Some(v) = row.get_mut(i) {
                        *v = if r == i {
                            keep.max(T::lit(0.01) / (sv * sv))
                        } else {
                            T::zero()
                        };
                    }
                }
                if let Some(row) = self.kf.P.get_mut(i) {
                    for (j, v) in row.iter_mut().enumerate() {
                        if j != i {
                            *v = T::zero();
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// Seeds the estimate of the gyro errors (for example the mean rate at rest less the
    /// Earth rate): on each axis, the first Gauss-Markov, random-walk or random-constant
    /// component takes `b_g` [rad/s]; axes without one are left alone.
    pub fn seed_gyro_bias(&mut self, b_g: &Vector3<T>) -> Result<(), NavError> {
        if !b_g.iter().all(|v| v.is_finite()) {
            return Err(NavError::Strapdown(StrapdownError::NonFiniteInput));
        }
        let mut done = [false; 3];
        let scale = self.scale;
        let x = &mut self.kf.x;
        self.model.for_each_component(&mut |s, axis, k, c| {
            use crate::model::ComponentKind as K;
            let bias_like = matches!(c.kind(), K::GaussMarkov | K::RandomWalk | K::RandomConstant);
            if s != super::ImuSensor::Gyro || !bias_like {
                return;
            }
            // Checked access: the visitor's axis is not provably below 3 (no-panic firmware).
            let Some(d) = done.get_mut(axis).filter(|d| !**d) else {
                return;
            };
            if let (Some(v), Some(sc), Some(b)) = (x.get_mut(k), scale.get(k), b_g.get(axis)) {
                *v = *b / *sc;
                *d = true;
            }
        });
        self.refresh_compensation();
        Ok(())
    }

    /// One IMU sample ending at time `t`. Returns true when a filter step was taken.
    pub fn imu(&mut self, t: f64, inc: &Increment<T>) -> Result<bool, NavError> {
        let dt64 = t - self.t;
        if !(dt64.is_finite() && dt64 > 0.0) {
            return Err(NavError::BadTime);
        }
        let dt = T::lit(dt64);
        if dt > self.cfg.max_imu_gap {
            self.gaps = self.gaps.saturating_add(1);
            self.ins.restart_increments();
        }
        // Measured = (1 + s) true + b: true ~ measured - b - s measured (first order in s).
        let comp = Increment {
            dtheta: inc.dtheta - self.b_g * dt - self.s_g.component_mul(&inc.dtheta),
            dv: inc.dv - self.b_a * dt - self.s_a.component_mul(&inc.dv),
        };
        let c = self.ins.dcm();
        self.ins.step(&comp, dt)?;
        self.t = t;
        self.sum_fn += c * comp.dv;
        self.sum_dt += dt;
        self.sum_dtheta += comp.dtheta;
        self.sum_dv += comp.dv;
        self.w_b = comp.dtheta / dt;
        // The step clock runs from the last step (or the first fix after it, `gnss`), not
        // from the last propagation: the fixes between steps propagate over the part elapsed
        // without moving the next step, so the steps (and the constraint after each,
        // `run::Nhc`) stay at the filter rate however often fixes arrive.
        if self.t - self.t_step >= self.cfg.step.as_f64() - 1e-6 {
            self.propagate()?;
            self.t_step = self.t;
            self.fix_since_step = false;
            return Ok(true);
        }
        Ok(false)
    }

    /// Propagates the filter from its last time to the solution's time.
    #[allow(non_snake_case)]
    pub fn propagate(&mut self) -> Result<(), NavError> {
        let dt64 = self.t - self.t_kf;
        if dt64 <= 0.0 {
            return Ok(());
        }
        self.linearise();
        if self.sum_dt > T::zero() {
            self.model.point.f_n = self.sum_fn / self.sum_dt;
            self.model.point.mean_w_b = self.sum_dtheta / self.sum_dt;
            self.model.point.mean_f_b = self.sum_dv / self.sum_dt;
        }
        self.model.dt = T::lit(dt64);
        let sys =
            <StrapdownErrorModel<T> as ErrorModel<T, N, NAV_Z>>::system(&self.model, &self.scale)?;
        let (Phi, Qd) = discretise_block(&sys.A, &sys.Qc, self.model.dt, sys.n)?;
        self.kf.predict(&Phi, &Qd);
        for v in self.kf.x.iter_mut().take(nav_idx::SENSOR) {
            *v = T::zero();
        }
        if !self.kf.diagonal_healthy() {
            self.kf.repair(&self.p0);
        }
        self.t_kf = self.t;
        self.sum_fn = Vector3::zeros();
        self.sum_dt = T::zero();
        self.sum_dtheta = Vector3::zeros();
        self.sum_dv = Vector3::zeros();
        self.refresh_compensation();
        Ok(())
    }

    /// Fuses a GNSS fix (its time must not be after the solution's). Returns the per-axis
    /// fusion result (position N, E, D, velocity N, E, D).
    pub fn gnss(&mut self, fix: &GnssFix<T>) -> Result<Fused<T, NAV_Z>, NavError> {
        let lag = self.t - fix.t;
        if !(lag.is_finite() && lag >= -1e-6) {
            return Err(NavError::BadTime);
        }
        self.propagate()?;
        // The first fix after a step restarts the step clock: fixes at the filter rate then
        // land on the steps and propagate nothing (one propagation per step, not two);
        // faster fixes propagate over the part of the step elapsed, one step in k per fix.
        if !self.fix_since_step {
            self.t_step = self.t;
            self.fix_since_step = true;
        }
        self.linearise();
        // Only H and R: A and Qc were built by the propagation just done.
        let (h, r0) = self.model.observation(&self.scale);
        let c = self.ins.dcm();
        let v = self.ins.velocity();
        // Antenna position at the fix time, minus the fix, in NED metres (f64: the difference
        // of two latitudes must not be rounded to f32 first).
        let p = self.ins.position();
        let lever_n = c * self.model.lever_arm;
        let (rn, re) = (
            earth::radius_north(p.lat) + p.h,
            earth::radius_east(p.lat) + p.h,
        );
        let back = |i: usize| v[i].as_f64() * lag;
        let d = [
            (p.lat - fix.pos.lat) * rn + lever_n.x.as_f64() - back(0),
            (p.lon - fix.pos.lon) * re * libm::cos(p.lat) + lever_n.y.as_f64() - back(1),
            -(p.h - fix.pos.h) + lever_n.z.as_f64() - back(2),
        ];
        let v_ant = v + c * self.w_b.cross(&self.model.lever_arm);
        let mut z = [T::zero(); NAV_Z];
        let mut r = r0;
        for i in 0..3 {
            z[i] = T::lit(d[i]);
            z[3 + i] = v_ant[i] - fix.vel[i];
            let (sp, sv) = (fix.sd_pos[i], fix.sd_vel[i]);
            if sp.is_finite() && sp > T::zero() {
                r[i] = sp * sp;
            }
            if sv.is_finite() && sv > T::zero() {
                r[3 + i] = sv * sv;
            }
        }
        let fused = self.fuse_gated(&z, &h, &r);
        self.close_loop()?;
        Ok(fused)
    }

    /// Zero-velocity update with standard deviation `sd` [m/s] on each axis, with its own count
    /// of consecutive rejections (like [`nhc`](Self::nhc): updates accepted every step at rest
    /// must not reset the count that lets GNSS back in after an outage).
    pub fn zupt(&mut self, sd: T) -> Result<Fused<T, 3>, NavError> {
        self.propagate()?;
        let v = self.ins.velocity();
        let mut h = [[T::zero(); N]; 3];
        for (i, row) in h.iter_mut().enumerate() {
            if let (Some(x), Some(s)) = (
                row.get_mut(nav_idx::VEL + i),
                self.scale.get(nav_idx::VEL + i),
            ) {
                *x = *s;
            }
        }
        let z = [v.x, v.y, v.z];
        let r = [sd * sd; 3];
        let mut rejected = self.rejected_zupt;
        let fused = self.fuse_counted(&z, &h, &r, &mut rejected);
        self.rejected_zupt = rejected;
        self.close_loop()?;
        Ok(fused)
    }

    /// The non-holonomic constraint of a land vehicle: the body-frame lateral (y) and vertical
    /// (z) velocity of the point at `lever` [m, body FRD] from the IMU are zero, each with
    /// standard deviation `sd` [m/s] (how far the vehicle departs from it: side slip, bounce,
    /// mounting misalignment). Fused like a GNSS fix (vector gate, sequential scalar updates,
    /// closed-loop correction), with its own count of consecutive rejections (module docs).
    /// Only meaningful while the vehicle moves and the heading is known; the caller decides
    /// (the host driver and the firmware's replay loop through [`super::run::Nhc::after_step`]).
    pub fn nhc(&mut self, sd: T, lever: &Vector3<T>) -> Result<Fused<T, NHC_Z>, NavError> {
        if !(sd.is_finite() && sd > T::zero() && lever.iter().all(|v| v.is_finite())) {
            return Err(NavError::Model(ModelError::BadSigma));
        }
        self.propagate()?;
        let (z, h) = self.nhc_observation(lever);
        let r = [sd * sd; NHC_Z];
        let mut rejected = self.rejected_nhc;
        let fused = self.fuse_counted(&z, &h, &r, &mut rejected);
        self.rejected_nhc = rejected;
        self.close_loop()?;
        Ok(fused)
    }

    /// The predicted measurement `z` (body y and z velocity of the point at `lever` from the
    /// IMU, computed minus the constraint's zero) and its rows `H` in the scaled states, at the
    /// current solution, with the step's mean body rate [`NavPoint::mean_w_b`].
    ///
    /// Measurement (Groves 2013 eq. 16.60 with the lever arm): `v_b = C^T v + w x l`, `C =
    /// C_b^n`, `v` the NED velocity of the IMU, `w` the body rate, `l = lever`.
    ///
    /// Derivation in this module's phi-angle convention (computed minus true, [`error_model`]
    /// docs): `C^ = (I + [phi x]) C`, so `C^T^ = C^T (I + [phi x])^T = C^T (I - [phi x])`, and
    /// `v^ = v + dv`. To first order
    ///
    /// ```text
    /// v_b^ = C^T (I - [phi x]) (v + dv) + w x l
    ///      = v_b + C^T dv - C^T (phi x v)
    ///      = v_b + C^T dv + C^T [v x] phi          (-(phi x v) = v x phi)
    /// H    = [ C^T [v x] | C^T | 0 ]  rows y, z
    /// ```
    ///
    /// The rate error term `(b_g^ - b_g) x l` is neglected, as in the GNSS velocity rows
    /// ([`error_model`] docs): below a millimetre per second for `|l| < 1 m`. The mean rate of
    /// the step rather than the last sample's: the last sample carries the vibration of a
    /// roof-mounted IMU (0.65 m times a few 0.01 rad/s of noise), the mean only a half-step lag.
    ///
    /// [`error_model`]: super::error_model
    pub fn nhc_observation(&self, lever: &Vector3<T>) -> ([T; NHC_Z], [[T; N]; NHC_Z]) {
        let c = self.ins.dcm();
        let v = self.ins.velocity();
        let ct = c.transpose();
        let v_b = ct * v + self.model.point.mean_w_b.cross(lever);
        let h_att = ct * crate::strapdown::skew(&v);
        let mut h = [[T::zero(); N]; NHC_Z];
        let mut z = [T::zero(); NHC_Z];
        for (k, (row, zk)) in h.iter_mut().zip(z.iter_mut()).enumerate() {
            // Body axis 1 (y, right) then 2 (z, down).
            let b = k + 1;
            *zk = v_b.get(b).copied().unwrap_or_else(T::zero);
            for j in 0..3 {
                let pairs = [
                    (nav_idx::ATT + j, h_att.get((b, j))),
                    (nav_idx::VEL + j, ct.get((b, j))),
                ];
                for (col, val) in pairs {
                    if let (Some(x), Some(v), Some(s)) =
                        (row.get_mut(col), val, self.scale.get(col))
                    {
                        *x = *v * *s;
                    }
                }
            }
        }
        (z, h)
    }

    /// [`fuse`] with the configured gate, skipped after `max_rejections` consecutive
    /// rejections (the GNSS count).
    #[allow(non_snake_case)]
    fn fuse_gated<const Z: usize>(
        &mut self,
        z: &[T; Z],
        H: &[[T; N]; Z],
        r: &[T; Z],
    ) -> Fused<T, Z> {
        let mut rejected = self.rejected;
        let fused = self.fuse_counted(z, H, r, &mut rejected);
        self.rejected = rejected;
        fused
    }

    /// [`fuse`] with the configured gate, skipped after `max_rejections` consecutive
    /// rejections counted in `rejected`.
    #[allow(non_snake_case)]
    fn fuse_counted<const Z: usize>(
        &mut self,
        z: &[T; Z],
        H: &[[T; N]; Z],
        r: &[T; Z],
        rejected: &mut u8,
    ) -> Fused<T, Z> {
        let gate = if *rejected >= self.cfg.max_rejections {
            None
        } else {
            self.cfg.gate
        };
        let fused = match gate {
            Some(k) => fuse(
                &mut self.kf,
                z,
                H,
                r,
                Some(&move |m: usize| T::lit(CHI2_9999[m.clamp(1, 6) - 1]) * k),
            ),
            None => fuse(&mut self.kf, z, H, r, None),
        };
        *rejected = if fused.gated {
            rejected.saturating_add(1)
        } else {
            0
        };
        fused
    }

    /// The linearisation point from the current solution (specific force kept).
    fn linearise(&mut self) {
        let (lat, h) = self.ins.lat_h();
        let pt = &mut self.model.point;
        pt.lat = lat;
        pt.h = h;
        pt.v = self.ins.velocity();
        pt.c_bn = self.ins.dcm();
        pt.w_b = self.w_b;
    }

    /// Removes the estimated navigation errors from the mechanisation and zeroes them in `x`.
    fn close_loop(&mut self) -> Result<(), NavError> {
        let x = self.state_si();
        let v3 = |k: usize| Vector3::new(x[k], x[k + 1], x[k + 2]);
        let (phi, dv, dp) = (v3(nav_idx::ATT), v3(nav_idx::VEL), v3(nav_idx::POS));
        self.ins.correct(&phi, &dv, &dp)?;
        for v in self.kf.x.iter_mut().take(nav_idx::SENSOR) {
            *v = T::zero();
        }
        if !self.kf.diagonal_healthy() {
            self.kf.repair(&self.p0);
        }
        self.refresh_compensation();
        Ok(())
    }

    fn refresh_compensation(&mut self) {
        let x = self.state_si();
        let (bg, ba) = self.model.sensor_errors(&x);
        let (sg, sa) = self.model.scale_factors(&x);
        if bg
            .iter()
            .chain(ba.iter())
            .chain(sg.iter())
            .chain(sa.iter())
            .all(|v| v.is_finite())
        {
            self.b_g = bg;
            self.b_a = ba;
            self.s_g = sg;
            self.s_a = sa;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nav::{ImuErrorModel, NavInit};
    use crate::strapdown::{Geodetic, Quat};

    /// A navigator with no sensor states at `att`, `v`, with the step's mean rate `w`.
    fn navigator(att: Quat<f64>, v: Vector3<f64>, w: Vector3<f64>) -> Navigator<f64, 9> {
        let pos = Geodetic {
            lat: 0.6,
            lon: 2.0,
            h: 100.0,
        };
        let ins = Strapdown::new(pos, v, att).unwrap_or_else(|e| panic!("{e:?}"));
        let model = StrapdownErrorModel {
            imu: ImuErrorModel::default(),
            init: NavInit {
                sd_att: Vector3::repeat(0.01),
                sd_vel: 0.1,
                sd_pos: 1.0,
            },
            lever_arm: Vector3::zeros(),
            obs_sd: [1.0; NAV_Z],
            point: NavPoint::at_rest(0.6, 100.0),
            dt: 1.0,
            scale_factor_sd: None,
        };
        let mut nav = Navigator::new(ins, 0.0, model, NavConfig::default())
            .unwrap_or_else(|e| panic!("{e:?}"));
        nav.model.point.mean_w_b = w;
        nav
    }

    /// The rows of `nhc_observation` against the predicted measurement of a perturbed state:
    /// the computed state is the true one with the errors `phi`, `dv` put in through
    /// `Strapdown::correct` (which removes them, so `-phi`, `-dv` put them in), the filter's
    /// own definition of the error state. `z(computed) - z(true)` must equal `H x` to first
    /// order: with errors of 1e-4 rad and 1e-3 m/s, the second-order residual is below
    /// `|phi| |dv| + |phi|^2 |v|` ~ 1e-6 m/s, a sign error would leave ~1e-3 m/s.
    #[test]
    fn nhc_rows_match_a_perturbed_state_to_first_order() {
        let l = Vector3::new(0.3, -0.2, 0.65);
        let w = Vector3::new(0.05, -0.03, 0.4);
        let cases = [
            (
                Quat::from_euler(0.1, -0.05, 0.7),
                Vector3::new(8.0, 5.0, -0.3),
            ),
            (
                Quat::from_euler(-0.3, 0.2, -2.5),
                Vector3::new(-12.0, 3.0, 0.5),
            ),
            (
                Quat::from_euler(0.0, 0.0, 1.2),
                Vector3::new(2.0, -9.0, 0.0),
            ),
        ];
        let errs = [
            (Vector3::new(1e-4, 0.0, 0.0), Vector3::zeros()),
            (Vector3::new(0.0, 1e-4, 0.0), Vector3::zeros()),
            (Vector3::new(0.0, 0.0, 1e-4), Vector3::zeros()),
            (Vector3::zeros(), Vector3::new(1e-3, 0.0, 0.0)),
            (Vector3::zeros(), Vector3::new(0.0, 1e-3, 0.0)),
            (Vector3::zeros(), Vector3::new(0.0, 0.0, 1e-3)),
            (
                Vector3::new(-7e-5, 5e-5, 1e-4),
                Vector3::new(4e-4, -8e-4, 6e-4),
            ),
        ];
        for (att, v) in cases {
            let truth = navigator(att, v, w);
            let (z0, h) = truth.nhc_observation(&l);
            for (phi, dv) in errs {
                let mut computed = truth.clone();
                computed
                    .ins
                    .correct(&-phi, &-dv, &Vector3::zeros())
                    .unwrap_or_else(|e| panic!("{e:?}"));
                let (z1, _) = computed.nhc_observation(&l);
                // H in scaled states: x_scaled = x / scale.
                let mut x = [0.0; 9];
                for i in 0..3 {
                    x[nav_idx::ATT + i] = phi[i] / truth.scale[nav_idx::ATT + i];
                    x[nav_idx::VEL + i] = dv[i] / truth.scale[nav_idx::VEL + i];
                }
                for k in 0..NHC_Z {
                    let hx: f64 = h[k].iter().zip(x.iter()).map(|(a, b)| a * b).sum();
                    let dz = z1[k] - z0[k];
                    assert!(
                        (dz - hx).abs() < 2e-6 && (hx.abs() > 1e-5 || dz.abs() < 1e-5),
                        "axis {k}, phi {phi:?}, dv {dv:?}: z difference {dz:e}, H x {hx:e}"
                    );
                }
            }
        }
    }

    /// With the vehicle moving along its body x axis and no lever arm the constraint holds
    /// (`z = 0`); a vehicle moving sideways is gated, counted apart from the GNSS fixes.
    #[test]
    fn nhc_zero_for_forward_motion_and_gated_counter_is_separate() {
        let yaw = 0.9f64;
        let v = Vector3::new(yaw.cos(), yaw.sin(), 0.0) * 10.0;
        let mut nav = navigator(Quat::from_euler(0.0, 0.0, yaw), v, Vector3::zeros());
        let (z, _) = nav.nhc_observation(&Vector3::zeros());
        assert!(z.iter().all(|v| v.abs() < 1e-9), "{z:?}");
        let fused = nav
            .nhc(0.1, &Vector3::zeros())
            .unwrap_or_else(|e| panic!("{e:?}"));
        assert_eq!(fused.dof, NHC_Z);
        assert!(!fused.gated);
        assert!(nav.nhc(-1.0, &Vector3::zeros()).is_err());
        assert!(nav.nhc(f64::NAN, &Vector3::zeros()).is_err());
        // A grossly violated constraint is gated and counted apart from the GNSS count.
        nav.ins
            .set_velocity(Vector3::new(-v.y, v.x, 0.0))
            .unwrap_or_else(|e| panic!("{e:?}"));
        let f = nav
            .nhc(0.01, &Vector3::zeros())
            .unwrap_or_else(|e| panic!("{e:?}"));
        assert!(f.gated);
        assert_eq!((nav.rejected_nhc, nav.rejected), (1, 0));
    }

    /// A zero-velocity update while the solution moves fast is gated and counted apart from
    /// the GNSS and constraint counts; one at rest is accepted and resets its own count only.
    #[test]
    fn zupt_gated_counter_is_separate() {
        let v = Vector3::new(10.0, 0.0, 0.0);
        let mut nav = navigator(Quat::from_euler(0.0, 0.0, 0.0), v, Vector3::zeros());
        nav.rejected = 2;
        let f = nav.zupt(0.01).unwrap_or_else(|e| panic!("{e:?}"));
        assert!(f.gated);
        assert_eq!(
            (nav.rejected_zupt, nav.rejected, nav.rejected_nhc),
            (1, 2, 0)
        );
        nav.ins
            .set_velocity(Vector3::new(0.001, 0.0, 0.0))
            .unwrap_or_else(|e| panic!("{e:?}"));
        let f = nav.zupt(0.01).unwrap_or_else(|e| panic!("{e:?}"));
        assert!(!f.gated);
        assert_eq!((nav.rejected_zupt, nav.rejected), (0, 2));
    }
}
