//! The INS/GNSS run loop over a [`replay`](super::replay): builds the [`Navigator`] from a
//! [`NavSetup`] and applies each IMU sample and GNSS fix exactly as the host driver
//! (`hal_sim::nav::run_with`) does, so that the firmware and the host run the same arithmetic
//! on the same inputs. The firmware only reads the bytes and times the calls.
//!
//! The non-holonomic constraint is the one decision that depends on the filter (the speed of
//! the solution), so it cannot be recorded in the replay like the GNSS flags: it is taken here,
//! by [`Nhc::after_step`], which the host driver calls too.

use super::navigator::{GnssFix, NavConfig, NavError, NavObserver, Navigator, NHC_Z};
use super::replay::{gnss_flags, GnssRecord, ImuRecord, NavSetup};
use super::rest::{RestDetector, Zupt};
use super::{NavInit, NavPoint, StrapdownErrorModel, NAV_Z};
use crate::filter::Fused;
use crate::model::ModelError;
use crate::strapdown::{Geodetic, Increment, Strapdown};
use crate::Real;
use nalgebra::Vector3;

impl NavSetup {
    /// The navigator this setup describes: the mechanisation at `pos`, `att`, `vel`, the error
    /// model with the noise model, initial uncertainty, lever arm and default observation
    /// deviations, the configuration, and the gyro bias seeded when given.
    pub fn navigator<T: Real, const N: usize>(&self) -> Result<Navigator<T, N>, NavError> {
        let ins = Strapdown::<T>::new(
            self.pos,
            Vector3::from(self.vel).map(T::lit),
            self.att.cast(),
        )?;
        let model = StrapdownErrorModel::<T> {
            imu: self.imu.cast(),
            init: NavInit {
                sd_att: self.init.sd_att.map(T::lit),
                sd_vel: T::lit(self.init.sd_vel),
                sd_pos: T::lit(self.init.sd_pos),
            },
            lever_arm: Vector3::from(self.lever_arm).map(T::lit),
            obs_sd: self.obs_sd.map(T::lit),
            point: NavPoint::at_rest(T::lit(self.pos.lat), T::lit(self.pos.h)),
            dt: T::lit(self.step),
            scale_factor_sd: self.scale_factor_sd.map(|v| v.map(T::lit)),
        };
        let cfg = NavConfig {
            step: T::lit(self.step),
            gate: self.gate.map(T::lit),
            max_imu_gap: T::lit(self.max_imu_gap),
            max_rejections: self.max_rejections,
        };
        let mut nav = Navigator::new(ins, self.t0, model, cfg)?;
        if let Some(b) = self.gyro_bias {
            nav.seed_gyro_bias(&Vector3::from(b).map(T::lit))?;
        }
        Ok(nav)
    }

    /// The non-holonomic constraint this setup describes (`None` without it). A standard
    /// deviation that is not finite and positive, or a lever arm that is not finite, is refused
    /// here ([`ModelError::BadSigma`], as [`Navigator::nhc`] would), so that a bad setup fails
    /// at the start rather than at the first filter step in motion.
    pub fn nhc<T: Real>(&self) -> Result<Option<Nhc<T>>, NavError> {
        let Some(sd) = self.nhc_sd else {
            return Ok(None);
        };
        if !(sd.is_finite() && sd > 0.0 && self.nhc_lever.iter().all(|v| v.is_finite())) {
            return Err(NavError::Model(ModelError::BadSigma));
        }
        Ok(Some(Nhc {
            sd: T::lit(sd),
            lever: Vector3::from(self.nhc_lever).map(T::lit),
        }))
    }
}

/// Speed [m/s] of the solution from which the non-holonomic constraint is applied: below it
/// the heading of the velocity is ill-defined and the car may be at rest, where a zero-velocity
/// update, not this constraint, is the right pseudo-observation.
pub const NHC_MIN_SPEED: f64 = 1.0;

/// The non-holonomic constraint of a run ([`Navigator::nhc`]), applied by the host driver and
/// the replay loop alike through [`after_step`](Self::after_step).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nhc<T: Real> {
    /// Standard deviation of the body lateral and vertical velocity [m/s].
    pub sd: T,
    /// The point the constraint holds at, from the IMU, body FRD [m].
    pub lever: Vector3<T>,
}

impl<T: Real> Nhc<T> {
    /// The constraint after an IMU sample that ended a filter step (the caller checks that
    /// one did: once per step, with or without GNSS, since during an outage it is the only
    /// aiding). Not applied before the heading is known (`heading_known`: it would pull the
    /// velocity onto a wrong body axis), nor while the solution is slower than
    /// [`NHC_MIN_SPEED`]. Returns the fusion result when applied.
    pub fn after_step<const N: usize, O: NavObserver<T, N>>(
        &self,
        nav: &mut Navigator<T, N, O>,
        heading_known: bool,
    ) -> Result<Option<Fused<T, NHC_Z>>, NavError> {
        // The speed in f64 whatever T (as the host driver has always computed it), so the
        // threshold is compared at the same precision in f32 and f64 runs.
        let speed = nav.ins().velocity().map(|v| v.as_f64()).norm();
        if !(heading_known && speed > NHC_MIN_SPEED) {
            return Ok(None);
        }
        nav.nhc(self.sd, &self.lever).map(Some)
    }
}

/// What one IMU sample did ([`NavReplay::imu`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuStep<T> {
    /// The sample ended a filter step (the filter was propagated).
    pub stepped: bool,
    /// The non-holonomic constraint's update after the step, when it was applied.
    pub nhc: Option<Fused<T, NHC_Z>>,
    /// The zero-velocity update after the step, when it was applied.
    pub zupt: Option<Fused<T, 3>>,
    /// The online identification moved the running filter's noise model after the step.
    pub retuned: bool,
}

/// The solution at a GNSS epoch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Epoch<T> {
    /// Epoch time [s].
    pub t: f64,
    /// IMU position moved back to the epoch ([`Navigator::solution_at`]).
    ///
    /// [`Navigator::solution_at`]: super::Navigator::solution_at
    pub pos: Geodetic,
    /// NED velocity [m/s] at the epoch.
    pub vel: [T; 3],
    /// Standard deviations of the position error N, E, D [m].
    pub sd_pos: [T; 3],
    /// The record's [`gnss_flags`], with [`EPOCH_GATED`] when the gate rejected the fix.
    pub flags: u8,
}

/// Flag of [`Epoch::flags`]: the fix was offered to the filter and gated.
pub const EPOCH_GATED: u8 = 0x80;

/// `p` moved by the NED offset `d` (the geodetic step of the strapdown layer, here where the
/// epochs and the start use it).
pub use crate::strapdown::move_by;

/// The rates of the record `r` in `T`: `(gyro [rad/s], specific force [m/s^2])`.
pub fn record_rates<T: Real>(r: &ImuRecord) -> (Vector3<T>, Vector3<T>) {
    let v = |a: [f32; 3]| Vector3::from(a).map(|v| T::lit(f64::from(v)));
    (v(r.gyro), v(r.accel))
}

/// A run over replay records, its navigator reporting to the observer `O` (the online
/// identification's bank, [`with_observer`](NavReplay::with_observer); none by default).
#[derive(Debug, Clone)]
pub struct NavReplay<T: Real, const N: usize, O = ()> {
    nav: Navigator<T, N, O>,
    /// Time of the last IMU sample [s].
    t: f64,
    sd_factor: [T; 2],
    heading_sd: T,
    nhc: Option<Nhc<T>>,
    zupt: Option<Zupt<T>>,
    rest: RestDetector<T>,
    /// Given at the start, or set from a fix flagged [`gnss_flags::HEADING`] since.
    heading_known: bool,
}

impl<T: Real, const N: usize> NavReplay<T, N> {
    /// Starts the run `setup` describes.
    pub fn new(setup: &NavSetup) -> Result<Self, NavError> {
        // The constraint first: a fallible step after the navigator's construction would hold
        // the navigator (about 6 KB in f32) in one more stack temporary on the firmware.
        let nhc = setup.nhc()?;
        let zupt = setup.zupt.as_ref().map(Zupt::cast_checked).transpose()?;
        let nav = setup.navigator()?;
        let rest = RestDetector::new(RestDetector::gravity_at(&nav));
        Ok(Self {
            nav,
            t: setup.t0,
            sd_factor: setup.sd_factor.map(T::lit),
            heading_sd: T::lit(setup.heading_sd),
            nhc,
            zupt,
            rest,
            heading_known: setup.heading_known,
        })
    }

    /// The same run with its navigator reporting to `obs` from now on (for the bank of
    /// [`crate::nav::online`], started on [`navigator`](Self::navigator) with the setup's
    /// [`NavSetup::online`]).
    pub fn with_observer<O: NavObserver<T, N>>(self, obs: O) -> NavReplay<T, N, O> {
        NavReplay {
            nav: self.nav.with_observer(obs),
            t: self.t,
            sd_factor: self.sd_factor,
            heading_sd: self.heading_sd,
            nhc: self.nhc,
            zupt: self.zupt,
            rest: self.rest,
            heading_known: self.heading_known,
        }
    }
}

impl<T: Real, const N: usize, O: NavObserver<T, N>> NavReplay<T, N, O> {
    /// The navigator.
    pub fn navigator(&self) -> &Navigator<T, N, O> {
        &self.nav
    }

    /// The navigator, to change (the host's window replays retune its model and open its
    /// gate; the bank is started on it).
    pub fn navigator_mut(&mut self) -> &mut Navigator<T, N, O> {
        &mut self.nav
    }

    /// Time of the last IMU sample [s].
    pub fn time(&self) -> f64 {
        self.t
    }

    /// The heading is known (given at the start, or set from the course by a fix since).
    pub fn heading_known(&self) -> bool {
        self.heading_known
    }

    /// One IMU sample (mean rates over `(previous t, r.t]`), then, when it ended a filter
    /// step, the non-holonomic constraint if the setup has one ([`Nhc::after_step`]) and the
    /// zero-velocity update if the setup has one and the step was at rest
    /// ([`Zupt::after_step`]): the host driver's order, before the fixes this sample reaches.
    pub fn imu(&mut self, r: &ImuRecord) -> Result<ImuStep<T>, NavError> {
        let (gyro, accel) = record_rates(r);
        self.sample(r.t, gyro, accel)
    }

    /// [`imu`](Self::imu) for a sample at `t` [s] of mean rates `gyro` [rad/s] and specific
    /// force `accel` [m/s^2] over `(previous t, t]`, in `T` (the host's driver, whose samples
    /// are f64, calls this: one driver for the host and the firmware).
    pub fn sample(
        &mut self,
        t: f64,
        gyro: Vector3<T>,
        accel: Vector3<T>,
    ) -> Result<ImuStep<T>, NavError> {
        let dt = t - self.t;
        if dt.is_nan() || dt <= 0.0 {
            return Err(NavError::BadTime);
        }
        let inc = Increment::from_rates(&gyro, &accel, T::lit(dt));
        let stepped = self.nav.imu(t, &inc)?;
        if let Some(z) = &self.zupt {
            // The raw sample resolved with the attitude before it (`rest` module docs; the
            // host driver's order), before the step's update below.
            let f_n = self.nav.sample_attitude() * accel;
            self.rest.sample(z, &gyro, &f_n);
        }
        self.t = t;
        let nhc = match (&self.nhc, stepped) {
            (Some(c), true) => c.after_step(&mut self.nav, self.heading_known)?,
            _ => None,
        };
        let zupt = match (&self.zupt, stepped) {
            (Some(z), true) => z.after_step(&mut self.nav, &mut self.rest)?,
            _ => None,
        };
        // The online identification's decision after the step's aiding (the host driver's
        // order), before the fixes this sample reaches.
        let retuned = stepped && self.nav.take_observer_model(t)?;
        Ok(ImuStep {
            stepped,
            nhc,
            zupt,
            retuned,
        })
    }

    /// One GNSS fix: the heading is set and the fix fused as its flags say. Returns the fusion
    /// result when it was fused.
    pub fn gnss(&mut self, r: &GnssRecord) -> Result<Option<Fused<T, NAV_Z>>, NavError> {
        let v3 = |a: &[f32; 3]| Vector3::from(*a).map(|v| T::lit(f64::from(v)));
        if r.flags & gnss_flags::HEADING != 0 {
            self.set_heading(T::lit(r.yaw), v3(&r.vel))?;
        }
        if r.flags & gnss_flags::FUSE == 0 {
            return Ok(None);
        }
        let vel = if r.flags & gnss_flags::VELOCITY != 0 {
            v3(&r.vel)
        } else {
            Vector3::repeat(T::lit(f64::NAN))
        };
        let fix = GnssFix {
            t: r.t,
            pos: r.pos,
            vel,
            sd_pos: v3(&r.sd_pos),
            sd_vel: v3(&r.sd_vel),
        };
        self.fuse(&fix).map(Some)
    }

    /// The heading from the GNSS course: yaw `yaw` [rad] and the fix's NED velocity `vel`
    /// [m/s], with the setup's heading deviation ([`Navigator::set_heading`]); the heading is
    /// known from now on (the non-holonomic constraint may apply).
    pub fn set_heading(&mut self, yaw: T, vel: Vector3<T>) -> Result<(), NavError> {
        self.nav.set_heading(yaw, self.heading_sd, Some(vel))?;
        self.heading_known = true;
        Ok(())
    }

    /// Sets the factors on the fixes' standard deviations (the host's online identification
    /// of the GNSS noise); a factor that is not finite and positive leaves both unchanged and
    /// returns [`ModelError::BadSigma`](crate::model::ModelError::BadSigma).
    pub fn set_sd_factor(&mut self, f: [T; 2]) -> Result<(), NavError> {
        if f.iter().all(|x| x.is_finite() && *x > T::zero()) {
            self.sd_factor = f;
            Ok(())
        } else {
            Err(NavError::Model(crate::model::ModelError::BadSigma))
        }
    }

    /// Fuses `fix`, its standard deviations multiplied by the setup's factors
    /// ([`NavSetup::sd_factor`]).
    pub fn fuse(&mut self, fix: &GnssFix<T>) -> Result<Fused<T, NAV_Z>, NavError> {
        let [fp, fv] = self.sd_factor;
        let fix = GnssFix {
            sd_pos: fix.sd_pos * fp,
            sd_vel: fix.sd_vel * fv,
            ..*fix
        };
        self.nav.gnss(&fix)
    }

    /// The solution at the epoch `r` (after [`gnss`](Self::gnss) for it), moved back from the
    /// last IMU time ([`Navigator::solution_at`]); `fused` is what [`gnss`](Self::gnss)
    /// returned.
    pub fn epoch(&self, r: &GnssRecord, fused: Option<&Fused<T, NAV_Z>>) -> Epoch<T> {
        let (pos, v) = self.nav.solution_at(r.t);
        let sd = self.nav.sigma_si();
        let p = super::nav_idx::POS;
        let sd_pos = [p, p + 1, p + 2].map(|i| sd.get(i).copied().unwrap_or_else(T::zero));
        let gated = fused.is_some_and(|f| f.gated);
        Epoch {
            t: r.t,
            pos,
            vel: [v.x, v.y, v.z],
            sd_pos,
            flags: r.flags | if gated { EPOCH_GATED } else { 0 },
        }
    }
}
