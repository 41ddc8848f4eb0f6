//! The INS/GNSS run loop over a [`replay`](super::replay): builds the [`Navigator`] from a
//! [`NavSetup`] and applies each IMU sample and GNSS fix exactly as the host driver
//! (`hal_sim::nav::run_with`) does, so that the firmware and the host run the same arithmetic
//! on the same inputs. The firmware only reads the bytes and times the calls.

use super::navigator::{GnssFix, NavConfig, NavError, Navigator};
use super::replay::{gnss_flags, GnssRecord, ImuRecord, NavSetup};
use super::{NavInit, NavPoint, StrapdownErrorModel, NAV_Z};
use crate::filter::Fused;
use crate::strapdown::{earth, Geodetic, Increment, Strapdown};
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
}

/// The solution at a GNSS epoch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Epoch<T> {
    /// Epoch time [s].
    pub t: f64,
    /// IMU position moved back along the velocity to the epoch.
    pub pos: Geodetic,
    /// NED velocity [m/s].
    pub vel: [T; 3],
    /// Standard deviations of the position error N, E, D [m].
    pub sd_pos: [T; 3],
    /// The record's [`gnss_flags`], with [`EPOCH_GATED`] when the gate rejected the fix.
    pub flags: u8,
}

/// Flag of [`Epoch::flags`]: the fix was offered to the filter and gated.
pub const EPOCH_GATED: u8 = 0x80;

/// `p` moved by the NED offset `d` [m] (first order; offsets of metres): the epoch solution
/// moved back to the fix time, on the host (`hal_sim::nav::move_by`) and the firmware alike.
pub fn move_by(p: &Geodetic, d: &Vector3<f64>) -> Geodetic {
    let rn = earth::radius_north(p.lat) + p.h;
    let re = earth::radius_east(p.lat) + p.h;
    Geodetic {
        lat: p.lat + d.x / rn,
        lon: p.lon + d.y / (re * libm::cos(p.lat)),
        h: p.h - d.z,
    }
}

/// A run over replay records.
#[derive(Debug, Clone)]
pub struct NavReplay<T: Real, const N: usize> {
    nav: Navigator<T, N>,
    /// Time of the last IMU sample [s].
    t: f64,
    sd_factor: [T; 2],
    heading_sd: T,
}

impl<T: Real, const N: usize> NavReplay<T, N> {
    /// Starts the run `setup` describes.
    pub fn new(setup: &NavSetup) -> Result<Self, NavError> {
        Ok(Self {
            nav: setup.navigator()?,
            t: setup.t0,
            sd_factor: setup.sd_factor.map(T::lit),
            heading_sd: T::lit(setup.heading_sd),
        })
    }

    /// The navigator.
    pub fn navigator(&self) -> &Navigator<T, N> {
        &self.nav
    }

    /// Time of the last IMU sample [s].
    pub fn time(&self) -> f64 {
        self.t
    }

    /// One IMU sample (mean rates over `(previous t, r.t]`). Returns true when a filter step
    /// was taken.
    pub fn imu(&mut self, r: &ImuRecord) -> Result<bool, NavError> {
        let dt = r.t - self.t;
        if dt.is_nan() || dt <= 0.0 {
            return Err(NavError::BadTime);
        }
        let inc = Increment::from_rates(
            &Vector3::from(r.gyro).map(|v| T::lit(f64::from(v))),
            &Vector3::from(r.accel).map(|v| T::lit(f64::from(v))),
            T::lit(dt),
        );
        let stepped = self.nav.imu(r.t, &inc)?;
        self.t = r.t;
        Ok(stepped)
    }

    /// One GNSS fix: the heading is set and the fix fused as its flags say. Returns the fusion
    /// result when it was fused.
    pub fn gnss(&mut self, r: &GnssRecord) -> Result<Option<Fused<T, NAV_Z>>, NavError> {
        let v3 = |a: &[f32; 3]| Vector3::from(*a).map(|v| T::lit(f64::from(v)));
        if r.flags & gnss_flags::HEADING != 0 {
            self.nav
                .set_heading(T::lit(r.yaw), self.heading_sd, Some(v3(&r.vel)))?;
        }
        if r.flags & gnss_flags::FUSE == 0 {
            return Ok(None);
        }
        let vel = if r.flags & gnss_flags::VELOCITY != 0 {
            v3(&r.vel)
        } else {
            Vector3::repeat(T::lit(f64::NAN))
        };
        let [fp, fv] = self.sd_factor;
        let fix = GnssFix {
            t: r.t,
            pos: r.pos,
            vel,
            sd_pos: v3(&r.sd_pos) * fp,
            sd_vel: v3(&r.sd_vel) * fv,
        };
        self.nav.gnss(&fix).map(Some)
    }

    /// The solution at the epoch `r` (after [`gnss`](Self::gnss) for it), moved back from the
    /// last IMU time; `fused` is what [`gnss`](Self::gnss) returned.
    pub fn epoch(&self, r: &GnssRecord, fused: Option<&Fused<T, NAV_Z>>) -> Epoch<T> {
        let ins = self.nav.ins();
        let v = ins.velocity();
        let v64 = v.map(|x| x.as_f64());
        let pos = move_by(&ins.position(), &(-v64 * (self.t - r.t)));
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
