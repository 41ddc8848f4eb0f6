//! How a run starts and what it does with each fix, from the inputs alone: the levelling
//! window ([`Alignment`]) and the per-fix decisions ([`FixPlanner`]). The host's batch start
//! (`hal_sim::nav::setup`), its replay writer and the live loop ([`super::live`]) all take
//! these, so a log gives the same start and the same decisions whichever way it enters.
//!
//! ```
//! use imu_ident::nav::start::{Alignment, FixPlanner};
//! use imu_ident::strapdown::Geodetic;
//! // 100 Hz at rest, level, for a 1-s window: the sample after the window ends it.
//! let mut al = Alignment::new(1.0);
//! let mut end = None;
//! for k in 0..200 {
//!     let t = 0.01 * f64::from(k);
//!     if al.sample(t, &[0.0; 3], &[0.0, 0.0, -9.8]) {
//!         end = Some(t);
//!         break;
//!     }
//! }
//! assert!((end.unwrap() - 1.01).abs() < 1e-9);
//! let ant = Geodetic { lat: 0.5, lon: 0.2, h: 10.0 };
//! let s = al.start(&ant, Some(0.3), false, &[0.0; 3]).unwrap();
//! assert!(s.gyro_bias.is_none() && (s.pos.h - 10.0).abs() < 1e-12);
//! // The heading from the course once the speed reaches 5 m/s; until then only fixes at rest.
//! let mut plan = FixPlanner::new(false, 5.0, 0.0);
//! assert!(!plan.plan(1.0, Some([2.0, 0.0, 0.0]), false).fuse);
//! let p = plan.plan(2.0, Some([0.0, 6.0, 0.0]), false);
//! assert!(p.fuse && (p.heading.unwrap() - core::f64::consts::FRAC_PI_2).abs() < 1e-12);
//! // The fix that placed the run is the start's position, not fused again.
//! let mut plan = FixPlanner::new(true, 5.0, 0.0);
//! plan.placed_at(3.0);
//! assert!(!plan.plan(3.0, Some([0.0; 3]), false).fuse && plan.plan(4.0, None, false).fuse);
//! ```

use super::run::move_by;
use crate::strapdown::Quat;
use crate::strapdown::{earth, heading_from_course, AlignError, Geodetic, Increment, Leveller};
use nalgebra::Vector3;

/// The levelling window at the start of a run: the samples of the first `window` seconds after
/// the first sample, at rest. Their mean specific force levels the IMU, their mean rate
/// estimates the gyro bias (Groves §5.6.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Alignment {
    window: f64,
    /// Time of the first sample (it only starts the clock).
    t0: Option<f64>,
    t_last: f64,
    lev: Leveller<f64>,
    sum_w: Vector3<f64>,
    n_w: u32,
}

/// The start state [`Alignment::start`] computes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartState {
    /// Attitude `q_b^n`.
    pub att: Quat<f64>,
    /// IMU position: the antenna's less the lever arm.
    pub pos: Geodetic,
    /// Gyro bias from the window's mean rate [rad/s] (when asked for and the window has
    /// samples).
    pub gyro_bias: Option<[f64; 3]>,
}

impl Alignment {
    /// A window of `window` seconds [s].
    pub fn new(window: f64) -> Self {
        Self {
            window,
            t0: None,
            t_last: f64::NAN,
            lev: Leveller::new(),
            sum_w: Vector3::zeros(),
            n_w: 0,
        }
    }

    /// Takes the sample at `t` [s] (mean rates `gyro` [rad/s] and specific force `accel`
    /// [m/s^2], body FRD, over the interval ending at `t`). Returns `true` when `t` is past the
    /// window (or not a number): that sample is not taken, and it is the run's start (its time
    /// is the run's `t0`; the run mechanises the samples after it).
    pub fn sample(&mut self, t: f64, gyro: &[f64; 3], accel: &[f64; 3]) -> bool {
        let Some(t0) = self.t0 else {
            self.t0 = Some(t);
            self.t_last = t;
            return false;
        };
        let inside = t <= t0 + self.window;
        if !inside {
            return true;
        }
        // Non-finite samples and intervals are skipped by the leveller, not by the rate sum
        // (the batch start has always summed every sample of the window).
        let dt = t - self.t_last;
        let w = Vector3::from(*gyro);
        self.lev
            .add(&Increment::from_rates(&w, &Vector3::from(*accel), dt), dt);
        self.sum_w += w;
        self.n_w = self.n_w.saturating_add(1);
        self.t_last = t;
        false
    }

    /// Samples taken into the window.
    pub fn samples(&self) -> u32 {
        self.n_w
    }

    /// The start at the antenna position `ant`: levelled from the window's mean specific
    /// force, with the yaw `yaw` [rad] (0 when not given), the IMU `lever_arm` [m, body FRD]
    /// from the antenna, and, with `static_gyro_bias`, the window's mean rate less the vertical
    /// Earth rate as the gyro bias (only the vertical part of the Earth rate is known before
    /// the heading; the horizontal part, at most 7.3e-5 rad/s, stays in the bias).
    pub fn start(
        &self,
        ant: &Geodetic,
        yaw: Option<f64>,
        static_gyro_bias: bool,
        lever_arm: &[f64; 3],
    ) -> Result<StartState, AlignError> {
        let (roll, pitch) = self.lev.level()?;
        let att = Quat::from_euler(roll, pitch, yaw.unwrap_or(0.0));
        let c = att.dcm();
        let pos = move_by(ant, &-(c * Vector3::from(*lever_arm)));
        let gyro_bias = (static_gyro_bias && self.n_w > 0).then(|| {
            let w_ie_n = earth::earth_rate_ned(pos.lat);
            let w_down_b = c.transpose() * Vector3::new(0.0, 0.0, w_ie_n.z);
            (self.sum_w / f64::from(self.n_w) - w_down_b).into()
        });
        Ok(StartState {
            att,
            pos,
            gyro_bias,
        })
    }
}

/// What to do with one fix ([`FixPlanner::plan`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixPlan {
    /// Withheld (an outage of the host's schedule; the planner only passes it on).
    pub withheld: bool,
    /// Set the heading to this yaw [rad] (with the fix's velocity) first.
    pub heading: Option<f64>,
    /// Fuse the fix.
    pub fuse: bool,
}

/// The per-fix decisions of a run: the heading from the GNSS course (until it is known, only
/// fixes at rest are fused) and the shortest interval between fused fixes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixPlanner {
    heading_known: bool,
    last_fused: f64,
    yaw_speed: f64,
    fix_interval: f64,
}

impl FixPlanner {
    /// A planner whose heading is known from the start or not, taking the heading from the
    /// course at `yaw_speed` [m/s] and fusing fixes at least `fix_interval` [s] apart.
    pub fn new(heading_known: bool, yaw_speed: f64, fix_interval: f64) -> Self {
        Self {
            heading_known,
            last_fused: f64::NEG_INFINITY,
            yaw_speed,
            fix_interval,
        }
    }

    /// The run was placed at the fix of time `t` [s]: its position is the start's, so that fix
    /// counts as the last fused one, and is not fused again when the run comes to it (a start
    /// placed at a fix after the levelling window's end; one before the end is not the run's).
    /// Fusing it again would take its error twice, as if independent
    /// of the start's, which is that same error; and whether it came to be fused hung on which
    /// side of the window's end a sample fell (nanoseconds on a hub's counted stamps moved the
    /// first minute by 0.6 sigma; BENCHMARKS.md "The fix that places the run").
    pub fn placed_at(&mut self, t: f64) {
        self.last_fused = t;
    }

    /// The heading is known (given, or set from the course).
    pub fn heading_known(&self) -> bool {
        self.heading_known
    }

    /// The decisions for the next fix, at `t` [s] with the NED velocity `vel` [m/s] if it has
    /// one, `withheld` or not.
    pub fn plan(&mut self, t: f64, vel: Option<[f64; 3]>, withheld: bool) -> FixPlan {
        let vel = vel.map(Vector3::from);
        let speed = vel.map(|v| v.xy().norm()).unwrap_or(0.0);
        let mut heading = None;
        if !self.heading_known && !withheld {
            if let Some(v) = vel.filter(|_| speed >= self.yaw_speed) {
                // A horizontal speed at or over `yaw_speed` is finite; a vertical velocity
                // that is not leaves the heading unknown.
                if let Ok(yaw) = heading_from_course(&v, self.yaw_speed) {
                    heading = Some(yaw);
                    self.heading_known = true;
                }
            }
        }
        // 20 ms of slack: fixes logged at a nominal rate jitter by a few milliseconds.
        // A fix not after the last fused one (the fix that placed the run) is not fused again.
        let due = t > self.last_fused && t - self.last_fused >= self.fix_interval - 0.02;
        let fuse = !withheld && due && (self.heading_known || speed < 0.2 * self.yaw_speed);
        if fuse {
            self.last_fused = t;
        }
        FixPlan {
            withheld,
            heading,
            fuse,
        }
    }
}
