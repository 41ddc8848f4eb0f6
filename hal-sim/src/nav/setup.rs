//! The start of a run and the per-fix decisions, shared by the host run ([`super::run_with`])
//! and the firmware replay writer (`hal_sim::nav_qemu`), so that both start from the same
//! [`NavSetup`] (built into a navigator by the core's `NavSetup::navigator`) and take the
//! same decisions on every fix. Both depend on the inputs and options only, never on the
//! filter, which is what lets the firmware replay them.

use super::NavArgs;
use crate::nav_io::outages::Outage;
use crate::nav_io::{self, GnssFix, ImuSample};
use anyhow::{bail, Context, Result};
use imu_ident::nav::{NavInit, NavSetup};
use imu_ident::strapdown::{earth, heading_from_course, Geodetic, Increment, Leveller, Quat};
use nalgebra::Vector3;

/// Default GNSS standard deviations (position N, E, D [m], velocity N, E, D [m/s]) where a fix
/// gives none.
pub const OBS_SD: [f64; 6] = [0.5, 0.5, 1.0, 0.1, 0.1, 0.2];
/// Standard deviation of a heading taken from the GNSS course [deg].
pub const HEADING_SD_DEG: f64 = 2.0;
/// Longest IMU interval taken as one step [s].
pub const MAX_IMU_GAP: f64 = 0.1;
/// Consecutive gated fixes before one is fused ungated.
pub const MAX_REJECTIONS: u8 = 3;

/// Where a run starts.
#[derive(Debug, Clone)]
pub struct Start {
    /// The navigator's starting point and settings.
    pub setup: NavSetup,
    /// Index of the IMU sample at `setup.t0`: the run mechanises `imu[k + 1..]`.
    pub k: usize,
    /// The outage schedule over the fixes.
    pub outages: Vec<Outage>,
}

/// Levels from the static window, estimates the gyro bias there, and places the navigator at
/// the GNSS fix nearest the end of the window (antenna minus the lever arm), at rest.
pub fn start(args: &NavArgs, imu: &[ImuSample], fixes: &[GnssFix]) -> Result<Start> {
    if imu.len() < 2 || fixes.is_empty() {
        bail!("nav: need at least two IMU samples and one GNSS fix");
    }
    let t_first_fix = fixes[0].t;
    let t_last_fix = fixes[fixes.len() - 1].t;
    let outages = args
        .outages
        .map(|o| o.schedule(t_first_fix, t_last_fix))
        .unwrap_or_default();
    // Levelling and static gyro bias.
    let t0 = imu[0].t;
    let mut lev = Leveller::<f64>::new();
    let mut sum_w = Vector3::zeros();
    let mut n_w = 0usize;
    let mut k = 1;
    while k < imu.len() && imu[k].t <= t0 + args.align {
        let dt = imu[k].t - imu[k - 1].t;
        let s = &imu[k];
        lev.add(
            &Increment::from_rates(&Vector3::from(s.gyro), &Vector3::from(s.accel), dt),
            dt,
        );
        sum_w += Vector3::from(s.gyro);
        n_w += 1;
        k += 1;
    }
    let (roll, pitch) = lev.level().map_err(|e| {
        anyhow::anyhow!(
            "{}: levelling over the first {} s: {e:?}",
            args.imu.display(),
            args.align
        )
    })?;
    let k = k.min(imu.len() - 1);
    let t_start = imu[k].t;
    let start_fix = fixes
        .iter()
        .min_by(|a, b| (a.t - t_start).abs().total_cmp(&(b.t - t_start).abs()))
        .copied()
        .context("no GNSS fix")?;
    let yaw0 = args.yaw_deg.map(f64::to_radians).unwrap_or(0.0);
    let q0 = Quat::from_euler(roll, pitch, yaw0);
    let lever = Vector3::from(args.lever_arm);
    let ant = Geodetic {
        lat: start_fix.lat_deg.to_radians(),
        lon: start_fix.lon_deg.to_radians(),
        h: start_fix.h,
    };
    let pos0 = super::move_by(&ant, &-(q0.dcm() * lever));
    let gyro_bias = (args.static_gyro_bias && n_w > 0).then(|| {
        // Mean rate at rest = bias + Earth rate; only the vertical part of the Earth rate is
        // known before the heading (the horizontal part, <= 7.3e-5 rad/s, stays in the bias).
        let c = q0.dcm();
        let w_ie_n = earth::earth_rate_ned(pos0.lat);
        let w_down_b = c.transpose() * Vector3::new(0.0, 0.0, w_ie_n.z);
        (sum_w / n_w as f64 - w_down_b).into()
    });
    let setup = NavSetup {
        t0: t_start,
        pos: pos0,
        att: q0,
        vel: [0.0; 3],
        gyro_bias,
        imu: args.model.clone(),
        init: NavInit {
            sd_att: args.init.sd_att,
            sd_vel: args.init.sd_vel,
            sd_pos: args.init.sd_pos,
        },
        lever_arm: args.lever_arm,
        obs_sd: OBS_SD,
        step: args.step,
        gate: args.gate,
        max_imu_gap: MAX_IMU_GAP,
        max_rejections: MAX_REJECTIONS,
        sd_factor: args.gnss_sd_factor,
        heading_sd: HEADING_SD_DEG.to_radians(),
        scale_factor_sd: args.scale_factor_sd,
        nhc_sd: args.nhc,
        nhc_lever: args.nhc_lever,
        zupt: args.zupt,
        online: args.online(),
        // The planner's start (`FixPlanner::new`): a given yaw.
        heading_known: args.yaw_deg.is_some(),
    };
    Ok(Start { setup, k, outages })
}

/// What to do with one fix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixPlan {
    /// Withheld by the outage schedule.
    pub withheld: bool,
    /// Set the heading to this yaw [rad] (with the fix's velocity) first.
    pub heading: Option<f64>,
    /// Fuse the fix.
    pub fuse: bool,
}

/// The per-fix decisions of a run: the outage schedule, the heading from the GNSS course
/// (until it is known, only static fixes are fused) and the shortest interval between fused
/// fixes ([`NavArgs::fix_interval`]).
#[derive(Debug, Clone)]
pub struct FixPlanner {
    outages: Vec<Outage>,
    heading_known: bool,
    last_fused: f64,
    yaw_speed: f64,
    fix_interval: f64,
}

impl FixPlanner {
    /// The planner of a run with `args` and the outage schedule `outages`.
    pub fn new(args: &NavArgs, outages: Vec<Outage>) -> Self {
        Self {
            outages,
            heading_known: args.yaw_deg.is_some(),
            last_fused: f64::NEG_INFINITY,
            yaw_speed: args.yaw_speed,
            fix_interval: args.fix_interval,
        }
    }

    /// The heading is known (given, or set from the course).
    pub fn heading_known(&self) -> bool {
        self.heading_known
    }

    /// `t` [s] is inside a GNSS outage of the schedule.
    pub fn withheld_at(&self, t: f64) -> bool {
        nav_io::outages::withheld(&self.outages, t)
    }

    /// The decisions for the next fix `f`.
    pub fn plan(&mut self, f: &GnssFix) -> Result<FixPlan> {
        let withheld = nav_io::outages::withheld(&self.outages, f.t);
        let vel = f.vel_ned.map(Vector3::from);
        let speed = vel.map(|v| v.xy().norm()).unwrap_or(0.0);
        let mut heading = None;
        if !self.heading_known && !withheld {
            if let Some(v) = vel {
                if speed >= self.yaw_speed {
                    let yaw = heading_from_course(&v, self.yaw_speed)
                        .map_err(|e| anyhow::anyhow!("heading: {e:?}"))?;
                    heading = Some(yaw);
                    self.heading_known = true;
                }
            }
        }
        // 20 ms of slack: fixes logged at a nominal rate jitter by a few milliseconds.
        let due = f.t - self.last_fused >= self.fix_interval - 0.02;
        let fuse = !withheld && due && (self.heading_known || speed < 0.2 * self.yaw_speed);
        if fuse {
            self.last_fused = f.t;
        }
        Ok(FixPlan {
            withheld,
            heading,
            fuse,
        })
    }
}

/// The IMU samples with `args.imu_time_shift` added to their times (borrowed when zero); the
/// host run and the firmware replay both start from these.
pub fn shifted_imu<'a>(args: &NavArgs, imu: &'a [ImuSample]) -> std::borrow::Cow<'a, [ImuSample]> {
    if args.imu_time_shift == 0.0 {
        std::borrow::Cow::Borrowed(imu)
    } else {
        std::borrow::Cow::Owned(
            imu.iter()
                .map(|s| ImuSample {
                    t: s.t + args.imu_time_shift,
                    ..*s
                })
                .collect(),
        )
    }
}
