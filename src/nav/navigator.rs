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
//! - [`Navigator::gnss`]: a fix is fused at its own time `t_f <= t`: the solution's position
//!   and velocity are moved back by `t - t_f`, along the last sample's velocity change (over
//!   which the mechanised velocity is linear) and, for a late fix, the velocities kept at the
//!   sample boundaries of the last 0.94 s ([`history`]); the filter is first propagated
//!   over the part of the step already elapsed. The first fix after a step restarts the step
//!   clock at its time of validity, so fixes at the filter rate land on the steps, and faster
//!   fixes (4-Hz RTK) each propagate over part of a step while the steps keep their cadence,
//!   on a jittered IMU too (one propagation per fix). The six axes pass a
//!   vector chi-square gate, then are fused one by one ([`crate::filter::fuse`]); the estimated
//!   navigation errors are then removed from the mechanisation ([`Strapdown::correct`]) and
//!   zeroed in `x` ([`aiding`]).
//! - [`Navigator::zupt`] and [`Navigator::nhc`]: pseudo-observations of a vehicle at rest (zero
//!   velocity) and of a land vehicle that neither slides sideways nor leaves the road (zero
//!   body-frame lateral and vertical velocity), through the same gate, fusion and correction.
//!   Each keeps its own count of consecutive gated updates: were they to share the GNSS one,
//!   a pseudo-observation accepted every step would reset it and a GNSS fix after an outage
//!   could be gated for ever.

use super::error_model::{nav_idx, NavPoint, StrapdownErrorModel, NAV_Z};
use crate::filter::Kalman;
use crate::linalg::Arr;
use crate::model::{ErrorModel, ModelError};
use crate::strapdown::{Geodetic, Increment, Strapdown, StrapdownError};
use crate::Real;
use nalgebra::{Matrix3, Vector3};

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

/// The INS/GNSS navigator with at most `N` filter states, reporting its filter operations to
/// the observer `O` ([`NavObserver`]; none by default).
#[derive(Debug, Clone)]
pub struct Navigator<T: Real, const N: usize, O = ()> {
    ins: Strapdown<T>,
    model: StrapdownErrorModel<T>,
    scale: [T; N],
    p0: Arr<T, N>,
    kf: Kalman<T, N>,
    cfg: NavConfig<T>,
    t: f64,
    /// Time of the IMU sample before the last one (the start of the last sample).
    t_prev: f64,
    /// Time the filter was last propagated to (a step, or a fix between steps).
    t_kf: f64,
    /// Time the step clock last started: the last filter step, or the time of validity of the
    /// first fix after it (`gnss`).
    t_step: f64,
    /// A GNSS fix (fused or gated) has propagated the filter since the last filter step.
    fix_since_step: bool,
    sum_fn: Vector3<T>,
    sum_dt: T,
    sum_dtheta: Vector3<T>,
    sum_dv: Vector3<T>,
    w_b: Vector3<T>,
    /// Attitude `C_b^n` at the start of the last IMU sample.
    c_sample: Matrix3<T>,
    /// The NED acceleration over the last IMU sample (its velocity change over its
    /// interval), with which a fix inside the sample is compared with the solution
    /// interpolated to its time ([`Navigator::gnss`]).
    a_sample: Vector3<T>,
    /// The velocity every 20 ms over the last 0.94 s, for late fixes
    /// ([`history`]).
    history: VelocityHistory<T>,
    s_g: Vector3<T>,
    s_a: Vector3<T>,
    b_g: Vector3<T>,
    b_a: Vector3<T>,
    gaps: u32,
    rejected: u8,
    rejected_nhc: u8,
    rejected_zupt: u8,
    /// Factors on every GNSS fix's standard deviations, position and velocity, from the
    /// observer's decisions ([`NavObserver::gnss_sd_factor`]; ones until one).
    gnss_sd_factor: [T; 2],
    obs: O,
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
            t_prev: t,
            t_kf: t,
            t_step: t,
            fix_since_step: false,
            sum_fn: Vector3::zeros(),
            sum_dt: T::zero(),
            sum_dtheta: Vector3::zeros(),
            sum_dv: Vector3::zeros(),
            w_b: Vector3::zeros(),
            c_sample: Matrix3::identity(),
            a_sample: Vector3::zeros(),
            history: VelocityHistory::new(),
            s_g: Vector3::zeros(),
            s_a: Vector3::zeros(),
            b_g: Vector3::zeros(),
            b_a: Vector3::zeros(),
            gaps: 0,
            rejected: 0,
            rejected_nhc: 0,
            rejected_zupt: 0,
            gnss_sd_factor: [T::one(); 2],
            obs: (),
        })
    }

    /// The same navigator reporting its filter operations to `obs` from now on.
    pub fn with_observer<O: NavObserver<T, N>>(self, obs: O) -> Navigator<T, N, O> {
        Navigator {
            ins: self.ins,
            model: self.model,
            scale: self.scale,
            p0: self.p0,
            kf: self.kf,
            cfg: self.cfg,
            t: self.t,
            t_prev: self.t_prev,
            t_kf: self.t_kf,
            t_step: self.t_step,
            fix_since_step: self.fix_since_step,
            sum_fn: self.sum_fn,
            sum_dt: self.sum_dt,
            sum_dtheta: self.sum_dtheta,
            sum_dv: self.sum_dv,
            w_b: self.w_b,
            c_sample: self.c_sample,
            a_sample: self.a_sample,
            history: self.history,
            s_g: self.s_g,
            s_a: self.s_a,
            b_g: self.b_g,
            b_a: self.b_a,
            gaps: self.gaps,
            rejected: self.rejected,
            rejected_nhc: self.rejected_nhc,
            rejected_zupt: self.rejected_zupt,
            gnss_sd_factor: self.gnss_sd_factor,
            obs,
        }
    }
}

impl<T: Real, const N: usize, O: NavObserver<T, N>> Navigator<T, N, O> {
    /// The observer.
    pub fn observer(&self) -> &O {
        &self.obs
    }

    /// The observer, mutable (an online identification deciding between steps).
    pub fn observer_mut(&mut self) -> &mut O {
        &mut self.obs
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

    /// The attitude `C_b^n` at the start of the last IMU sample (the one that resolved its
    /// specific force): a raw sample's specific force in NED is `sample_attitude() * f_b`,
    /// without computing the direction cosines again (the rest detector, `rest`).
    pub fn sample_attitude(&self) -> &Matrix3<T> {
        &self.c_sample
    }

    /// Time of the solution [s].
    pub fn time(&self) -> f64 {
        self.t
    }

    /// IMU gaps longer than the configured limit so far.
    pub fn gaps(&self) -> u32 {
        self.gaps
    }

    /// The longest IMU interval mechanised with the previous sample's increments [s]
    /// ([`NavConfig::max_imu_gap`]).
    pub fn max_imu_gap(&self) -> T {
        self.cfg.max_imu_gap
    }

    /// Estimated sensor errors `(b_g, b_a)` now being removed from the IMU (rad/s, m/s^2).
    pub fn sensor_errors(&self) -> (Vector3<T>, Vector3<T>) {
        (self.b_g, self.b_a)
    }

    /// Estimated scale-factor errors `(s_g, s_a)` now being removed (zero without them).
    pub fn scale_factors(&self) -> (Vector3<T>, Vector3<T>) {
        (self.s_g, self.s_a)
    }

    /// Physical state estimate `S x` ([`Kalman::state_si`]).
    pub fn state_si(&self) -> [T; N] {
        self.kf.state_si(&self.scale)
    }

    /// Physical standard deviation of each state, `sqrt(P_ii) S_i` ([`Kalman::sigma_si`]).
    pub fn sigma_si(&self) -> [T; N] {
        self.kf.sigma_si(&self.scale)
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
        let old = self.model.clone();
        self.set_imu_model(imu)?;
        old.retune_covariance(&self.model, &mut self.kf.P);
        Ok(())
    }

    /// Asks the observer for its decision at time `t` [s] ([`NavObserver::decide`]: the
    /// replay loops call this after every filter step and its aiding) and takes the model it
    /// decided, if any ([`retune_imu_model`](Self::retune_imu_model)). Returns whether the
    /// model changed.
    pub fn take_observer_model(&mut self, t: f64) -> Result<bool, NavError> {
        let Some(m) = self.obs.decide(t) else {
            return Ok(false);
        };
        // Factors that are not finite and positive are not taken (the observer's own check
        // makes them so; a NaN must not reach R).
        if let Some(f) = self
            .obs
            .gnss_sd_factor()
            .filter(|f| f.iter().all(|v| *v > 0.0 && v.is_finite()))
        {
            self.gnss_sd_factor = f.map(T::lit);
        }
        self.retune_imu_model(m).map(|()| true)
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
            self.history.clear();
        }
        restart_heading(&mut self.kf, &self.scale, sd, vel.is_some());
        self.obs.heading_restarted(&self.scale, sd, vel.is_some());
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
        self.obs.sensors_seeded(&self.kf.x);
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
        let comp = compensate(inc, dt, &(self.b_g, self.b_a), &(self.s_g, self.s_a));
        let c = self.ins.dcm();
        self.c_sample = c;
        let v0 = self.ins.velocity();
        self.history.push(self.t, v0);
        self.ins.step(&comp, dt)?;
        self.a_sample = (self.ins.velocity() - v0) / dt;
        self.t_prev = self.t;
        self.t = t;
        self.sum_fn += c * comp.dv;
        self.sum_dt += dt;
        self.sum_dtheta += comp.dtheta;
        self.sum_dv += comp.dv;
        self.w_b = comp.dtheta / dt;
        // The step clock runs from the last step (or the first fix after it, at its time of
        // validity, `gnss`), not from the last propagation: the fixes between steps propagate
        // over the part elapsed without moving the next step, so the steps (and the
        // constraint after each, `run::Nhc`) stay at the filter rate however often fixes
        // arrive.
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
        let mut Phi = [[T::zero(); N]; N];
        let mut Qd = [[T::zero(); N]; N];
        self.model.discrete_into(&self.scale, &mut Phi, &mut Qd)?;
        self.obs
            .propagated(&self.model, &self.scale, &self.kf.x, &self.p0);
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
        let v_before = self.ins.velocity();
        self.ins.correct(&phi, &dv, &dp)?;
        self.history.shift(&(self.ins.velocity() - v_before));
        self.obs.corrected(&self.kf.x, &self.p0);
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

/// The increment `inc` over `dt` [s] with the estimated sensor errors removed: biases
/// `(b_g, b_a)` and scale factors `(s_g, s_a)` ([`Navigator::sensor_errors`],
/// [`Navigator::scale_factors`]). Measured = (1 + s) true + b dt, so true ~ measured - b dt -
/// s measured (first order in s). The navigator's samples and the output predictor's
/// ([`super::predictor`]) go through this one function, so both mechanise the same numbers.
pub fn compensate<T: Real>(
    inc: &Increment<T>,
    dt: T,
    bias: &(Vector3<T>, Vector3<T>),
    scale: &(Vector3<T>, Vector3<T>),
) -> Increment<T> {
    Increment {
        dtheta: inc.dtheta - bias.0 * dt - scale.0.component_mul(&inc.dtheta),
        dv: inc.dv - bias.1 * dt - scale.1.component_mul(&inc.dv),
    }
}

/// The covariance of a heading restarted with standard deviation `sd` [rad] (and, with `vel`,
/// of a velocity replaced by a measured one): `phi_D` (and the velocity errors) uncorrelated
/// with the other states, their estimates zero ([`Navigator::set_heading`]; also applied to
/// an observer's shadow filters, whose estimates of the old heading's error no longer apply).
pub fn restart_heading<T: Real, const N: usize>(
    kf: &mut Kalman<T, N>,
    scale: &[T; N],
    sd: T,
    vel: bool,
) {
    let k = nav_idx::ATT + 2;
    let s = scale.get(k).copied().unwrap_or_else(T::one);
    for (i, row) in kf.P.iter_mut().enumerate() {
        if let Some(v) = row.get_mut(k) {
            *v = if i == k {
                (sd / s) * (sd / s)
            } else {
                T::zero()
            };
        }
    }
    if let Some(row) = kf.P.get_mut(k) {
        for (j, v) in row.iter_mut().enumerate() {
            if j != k {
                *v = T::zero();
            }
        }
    }
    if vel {
        // The velocity error of the new velocity is not correlated with the rest either.
        for i in nav_idx::VEL..nav_idx::VEL + 3 {
            let sv = scale.get(i).copied().unwrap_or_else(T::one);
            let keep =
                kf.P.get(i)
                    .and_then(|r| r.get(i))
                    .copied()
                    .unwrap_or_else(T::zero);
            for (r, row) in kf.P.iter_mut().enumerate() {
                if let Some(v) = row.get_mut(i) {
                    *v = if r == i {
                        keep.max(T::lit(0.01) / (sv * sv))
                    } else {
                        T::zero()
                    };
                }
            }
            if let Some(row) = kf.P.get_mut(i) {
                for (j, v) in row.iter_mut().enumerate() {
                    if j != i {
                        *v = T::zero();
                    }
                }
            }
        }
    }
    if let Some(x) = kf.x.get_mut(nav_idx::ATT + 2) {
        *x = T::zero();
    }
    if vel {
        for x in kf.x.iter_mut().skip(nav_idx::VEL).take(3) {
            *x = T::zero();
        }
    }
}

mod aiding;
pub mod history;
mod observer;
pub mod spread;
use history::VelocityHistory;
pub use observer::{NavObserver, ObservationKind};
pub use spread::NavSd;
#[cfg(test)]
pub(crate) mod tests;
