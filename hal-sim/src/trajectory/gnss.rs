//! GNSS position and velocity fixes from the truth: white noise of given standard deviations
//! in NED (position in metres, converted to latitude and longitude with the local radii),
//! fixes every `period` seconds, none inside the outage windows, at an antenna `lever_arm`
//! from the IMU (body frame): `p + C l` and `v + C (w x l)`, the navigator's own observation
//! (`imu_ident::nav::navigator`, aiding).

use super::truth::TruthSample;
use anyhow::{bail, Result};
use imu_ident::strapdown::{earth, move_by, Geodetic, Quat};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// How the fixes are made.
#[derive(Debug, Clone, PartialEq)]
pub struct GnssConfig {
    /// Time between fixes [s] (a multiple of the IMU interval).
    pub period: f64,
    /// Position noise standard deviations, north, east, down [m].
    pub sd_pos: [f64; 3],
    /// Velocity noise standard deviations, north, east, down [m/s].
    pub sd_vel: [f64; 3],
    /// Outage windows `[start, end)` [s]: no fix inside.
    pub outages: Vec<(f64, f64)>,
    /// The antenna from the IMU, body frame forward, right, down [m].
    pub lever_arm: [f64; 3],
}

impl Default for GnssConfig {
    /// 1 Hz, 1.5 m / 1.5 m / 3 m and 0.05 / 0.05 / 0.1 m/s, no outage, the antenna at the
    /// IMU.
    fn default() -> Self {
        Self {
            period: 1.0,
            sd_pos: [1.5, 1.5, 3.0],
            sd_vel: [0.05, 0.05, 0.1],
            outages: Vec::new(),
            lever_arm: [0.0; 3],
        }
    }
}

/// One fix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GnssFix {
    /// Time [s].
    pub t: f64,
    /// Measured position.
    pub pos: Geodetic,
    /// Measured NED velocity [m/s].
    pub vel: Vector3<f64>,
    /// Stated position standard deviations (N, E, D) [m].
    pub sd_pos: [f64; 3],
    /// Stated velocity standard deviations (N, E, D) [m/s].
    pub sd_vel: [f64; 3],
}

/// Makes fixes from truth samples.
#[derive(Debug, Clone)]
pub struct GnssSim {
    cfg: GnssConfig,
    rng: ChaCha8Rng,
    last: Option<i64>,
    /// Time of the truth sample before the one offered (its increments' interval).
    t_prev: Option<f64>,
}

impl GnssSim {
    /// A seeded generator.
    pub fn new(cfg: GnssConfig, seed: u64) -> Result<Self> {
        if !(cfg.period.is_finite() && cfg.period > 0.0) {
            bail!("GNSS period must be positive");
        }
        if !cfg
            .sd_pos
            .iter()
            .chain(cfg.sd_vel.iter())
            .all(|s| s.is_finite() && *s >= 0.0)
        {
            bail!("GNSS standard deviations must be finite and >= 0");
        }
        if !cfg.lever_arm.iter().all(|v| v.is_finite()) {
            bail!("GNSS lever arm must be finite");
        }
        Ok(Self {
            cfg,
            rng: ChaCha8Rng::seed_from_u64(seed),
            last: None,
            t_prev: None,
        })
    }

    /// The fix at this truth sample if one falls due (the first sample at or after each
    /// multiple of the period), else `None`. Offered every truth sample in time order: the
    /// body rate of the lever arm's velocity is the sample's angle increment over its
    /// interval.
    pub fn offer(&mut self, s: &TruthSample) -> Option<GnssFix> {
        let dt = self.t_prev.map_or(0.0, |t| s.t - t);
        self.t_prev = Some(s.t);
        let k = (s.t / self.cfg.period + 1e-9).floor() as i64;
        if self.last == Some(k) {
            return None;
        }
        self.last = Some(k);
        if self.cfg.outages.iter().any(|(a, b)| s.t >= *a && s.t < *b) {
            return None;
        }
        let mut n = || -> f64 { StandardNormal.sample(&mut self.rng) };
        let dp = Vector3::new(n(), n(), n()).component_mul(&Vector3::from(self.cfg.sd_pos));
        let dv = Vector3::new(n(), n(), n()).component_mul(&Vector3::from(self.cfg.sd_vel));
        let arm = Vector3::from(self.cfg.lever_arm);
        let c = Quat::from_euler(s.euler[0], s.euler[1], s.euler[2]).dcm();
        let w = if dt > 0.0 {
            s.inc.dtheta / dt
        } else {
            Vector3::zeros()
        };
        // At the IMU (no lever arm) `move_by` returns the position itself, bit for bit.
        let ant = move_by(&s.pos, &(c * arm));
        let rn = earth::radius_north(ant.lat) + ant.h;
        let re = (earth::radius_east(ant.lat) + ant.h) * ant.lat.cos();
        Some(GnssFix {
            t: s.t,
            pos: Geodetic {
                lat: ant.lat + dp.x / rn,
                lon: ant.lon + dp.y / re,
                h: ant.h - dp.z,
            },
            vel: s.vel + c * w.cross(&arm) + dv,
            sd_pos: self.cfg.sd_pos,
            sd_vel: self.cfg.sd_vel,
        })
    }
}
