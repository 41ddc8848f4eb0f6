//! The start of a run and the per-fix decisions, shared by the host run ([`super::run_with`])
//! and the firmware replay writer (`hal_sim::nav_qemu`), so that both start from the same
//! [`NavSetup`] (built into a navigator by the core's `NavSetup::navigator`) and take the
//! same decisions on every fix. Both depend on the inputs and options only, never on the
//! filter, which is what lets the firmware replay them.

use super::NavArgs;
use crate::nav_io::outages::Outage;
use crate::nav_io::{self, GnssFix, ImuSample};
use anyhow::{bail, Context, Result};
use imu_ident::nav::live::LiveConfig;
pub use imu_ident::nav::start::FixPlan;
use imu_ident::nav::start::{Alignment, FixPlanner as CorePlanner};
use imu_ident::nav::{NavInit, NavSetup};
use imu_ident::strapdown::Geodetic;

pub use imu_ident::nav::replay::{
    DEFAULT_HEADING_SD_DEG as HEADING_SD_DEG, DEFAULT_MAX_IMU_GAP as MAX_IMU_GAP,
    DEFAULT_MAX_REJECTIONS as MAX_REJECTIONS, DEFAULT_OBS_SD as OBS_SD,
};

/// Where a run starts.
#[derive(Debug, Clone)]
pub struct Start {
    /// The navigator's starting point and settings.
    pub setup: NavSetup,
    /// Index of the IMU sample at `setup.t0`: the run mechanises `imu[k + 1..]`.
    pub k: usize,
    /// The outage schedule over the fixes.
    pub outages: Vec<Outage>,
    /// Time of the fix that placed the run [s]; not fused again ([`FixPlanner::new`]).
    pub t_placing: f64,
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
    // Levelling and static gyro bias: the core's window, which the live loop runs too. The
    // run starts at the first sample past the window (the last one when none is).
    let mut alignment = Alignment::new(args.align);
    let k = imu
        .iter()
        .position(|s| alignment.sample(s.t, &s.gyro, &s.accel))
        .unwrap_or(imu.len() - 1);
    let t_start = imu[k].t;
    let start_fix = fixes
        .iter()
        .min_by(|a, b| (a.t - t_start).abs().total_cmp(&(b.t - t_start).abs()))
        .copied()
        .context("no GNSS fix")?;
    let ant = Geodetic {
        lat: start_fix.lat_deg.to_radians(),
        lon: start_fix.lon_deg.to_radians(),
        h: start_fix.h,
    };
    let yaw0 = args.yaw_deg.map(f64::to_radians);
    let st = alignment
        .start(&ant, yaw0, args.static_gyro_bias, &args.lever_arm)
        .map_err(|e| {
            anyhow::anyhow!(
                "{}: levelling over the first {} s: {e:?}",
                args.imu.display(),
                args.align
            )
        })?;
    let setup = NavSetup {
        t0: t_start,
        pos: st.pos,
        att: st.att,
        gyro_bias: st.gyro_bias,
        ..settings(args)
    };
    Ok(Start {
        setup,
        k,
        outages,
        t_placing: start_fix.t,
    })
}

/// The run's settings from `args`, at rest at the origin with a level attitude: what the
/// start fills in ([`start`], [`LiveNav`](imu_ident::nav::live::LiveNav)) is left at that.
pub fn settings(args: &NavArgs) -> NavSetup {
    NavSetup {
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
        ..NavSetup::new(
            args.model.clone(),
            NavInit {
                sd_att: args.init.sd_att,
                sd_vel: args.init.sd_vel,
                sd_pos: args.init.sd_pos,
            },
        )
    }
}

/// The live loop's rules for a run with `args` (its outage schedule aside: a live run
/// withholds nothing); the settings are [`settings`].
pub fn live_config(args: &NavArgs) -> LiveConfig {
    LiveConfig {
        align: args.align,
        yaw: args.yaw_deg.map(f64::to_radians),
        static_gyro_bias: args.static_gyro_bias,
        yaw_speed: args.yaw_speed,
        fix_interval: args.fix_interval,
        use_velocity: args.use_velocity,
        latency: args.latency,
    }
}

/// The per-fix decisions of a run: the outage schedule over the core's planner
/// ([`imu_ident::nav::start::FixPlanner`]: the heading from the GNSS course, until it is known
/// only static fixes fused, and the shortest interval between fused fixes,
/// [`NavArgs::fix_interval`]).
#[derive(Debug, Clone)]
pub struct FixPlanner {
    outages: Vec<Outage>,
    core: CorePlanner,
}

impl FixPlanner {
    /// The planner of a run with `args` from `start`: its outage schedule, and the fix that
    /// placed it, not fused again (the live loop's rule, `CorePlanner::placed_at`).
    pub fn new(args: &NavArgs, start: &Start) -> Self {
        let mut core = CorePlanner::new(args.yaw_deg.is_some(), args.yaw_speed, args.fix_interval);
        core.placed_at(start.t_placing);
        Self {
            outages: start.outages.clone(),
            core,
        }
    }

    /// The heading is known (given, or set from the course).
    pub fn heading_known(&self) -> bool {
        self.core.heading_known()
    }

    /// `t` [s] is inside a GNSS outage of the schedule.
    pub fn withheld_at(&self, t: f64) -> bool {
        nav_io::outages::withheld(&self.outages, t)
    }

    /// The decisions for the next fix `f`.
    pub fn plan(&mut self, f: &GnssFix) -> FixPlan {
        let withheld = self.withheld_at(f.t);
        self.core.plan(f.t, f.vel_ned, withheld)
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
