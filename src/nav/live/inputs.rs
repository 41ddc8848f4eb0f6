//! What a live run takes and says: its rules ([`LiveConfig`]), the fixes as they arrive
//! ([`LiveFix`]), the events of each call ([`LiveEvent`], [`DropReason`]), the bounds on its
//! inputs' times, and the replay record a fix becomes ([`record_of`]).

use super::super::replay::{gnss_flags, GnssRecord, ImuRecord, NavSetup};
use super::super::run::{Epoch, ImuStep};
use super::super::start::FixPlan;
use super::super::NAV_Z;
use crate::filter::Fused;
use crate::strapdown::{AlignError, Geodetic};
use crate::Real;

/// Fixes waiting for the IMU sample that passes them.
pub const PENDING: usize = 8;

/// A sample further ahead of the previous one than this [s] is suspect: refused, and taken
/// only when the next sample follows it within this (a real gap: the sensor restarted).
/// One corrupted time stamp then costs one sample, not the run (every later sample would be
/// "backwards").
pub const MAX_IMU_JUMP: f64 = 1.0;

/// A fix further ahead of the newest sample than this [s] is dropped
/// ([`DropReason::Ahead`]): a corrupted time would otherwise head the queue for ever.
pub const MAX_FIX_LEAD: f64 = 2.0;

/// How a live run starts and decides its fixes (the host's `nav` options of the same names;
/// carried by a live replay, [`NavSetup::live`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiveConfig {
    /// The levelling window after the first sample, at rest [s] (`--align`).
    pub align: f64,
    /// The heading, when given [rad] (`--yaw`); else from the GNSS course.
    pub yaw: Option<f64>,
    /// Seed the gyro bias with the window's mean rate (not `--no-static-gyro-bias`).
    pub static_gyro_bias: bool,
    /// Speed at which the course gives the heading [m/s] (`--yaw-speed`).
    pub yaw_speed: f64,
    /// Shortest interval between fused fixes [s] (`--fix-interval`).
    pub fix_interval: f64,
    /// Fuse the fixes' velocities (`--use-velocity`).
    pub use_velocity: bool,
    /// The receiver's latency budget [s]: the IMU samples are mechanised this long after they
    /// arrive, so that a fix that comes up to this late is still taken after the first
    /// sample at or past its time, as the host takes it (module docs). The solution is then
    /// this much behind the newest sample.
    pub latency: f64,
}

impl LiveConfig {
    /// The host's defaults (`hal-sim nav`) with the window `align` [s].
    pub fn new(align: f64) -> Self {
        Self {
            align,
            yaw: None,
            static_gyro_bias: true,
            yaw_speed: 2.0,
            fix_interval: 0.0,
            use_velocity: true,
            latency: 0.0,
        }
    }
}

/// A GNSS fix as it arrives (the host's GNSS CSV row, angles in radians).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiveFix {
    /// Time of validity [s], the IMU's time scale.
    pub t: f64,
    /// Antenna position.
    pub pos: Geodetic,
    /// NED velocity [m/s].
    pub vel: Option<[f64; 3]>,
    /// Position standard deviations N, E, D [m] (none: the setup's defaults).
    pub sd_pos: Option<[f64; 3]>,
    /// Velocity standard deviations [m/s] (none: the setup's defaults).
    pub sd_vel: Option<[f64; 3]>,
}

impl LiveFix {
    /// The fix of a replay record (its flags and yaw are not read: the live run decides
    /// them); a vector with a component that is not finite is none.
    pub fn from_record(r: &GnssRecord) -> Self {
        let v = |a: [f32; 3]| a.iter().all(|x| x.is_finite()).then(|| a.map(f64::from));
        Self {
            t: r.t,
            pos: r.pos,
            vel: v(r.vel),
            sd_pos: v(r.sd_pos),
            sd_vel: v(r.sd_vel),
        }
    }
}

/// Why a fix was not taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DropReason {
    /// Its time is not after the previous fix's (or not a number).
    NotIncreasing,
    /// It is before the run's start.
    BeforeStart,
    /// Its time is not finite, or more than [`MAX_FIX_LEAD`] ahead of the newest sample.
    Ahead,
    /// The queue of fixes waiting for the IMU is full.
    QueueFull,
}

/// What a call did, in order ([`LiveNav::imu`], [`LiveNav::gnss`]).
#[derive(Debug)]
pub enum LiveEvent<'a, T: Real> {
    /// The run started from this setup (the alignment's start state in the configured one).
    Started(&'a NavSetup),
    /// The levelling failed (not at rest, or no sample): it starts again from the next sample.
    Realigning(AlignError),
    /// No fix came before the start's buffer filled: the levelling starts again.
    NoFix,
    /// A fix at this time was dropped.
    FixDropped(f64, DropReason),
    /// An IMU sample of the run (the record the replay would hold) and what it did.
    Imu(&'a ImuRecord, &'a ImuStep<T>),
    /// A fix of the run: its record (the decisions in its flags), the fusion when it was
    /// fused, and the solution at its time.
    Fix {
        /// The fix as the replay would hold it.
        record: &'a GnssRecord,
        /// The fusion, when fused.
        fused: Option<&'a Fused<T, NAV_Z>>,
        /// The solution at the fix's time.
        epoch: &'a Epoch<T>,
    },
}

/// The replay record of the fix `f` with the decisions `plan`.
pub fn record_of(f: &LiveFix, plan: &FixPlan, use_velocity: bool) -> GnssRecord {
    let f32x3 = |v: [f64; 3]| v.map(|x| x as f32);
    let nan3 = [f32::NAN; 3];
    // A heading needs the velocity it comes from.
    let heading = plan.heading.filter(|_| f.vel.is_some());
    let mut flags = 0;
    for (on, bit) in [
        (plan.withheld, gnss_flags::WITHHELD),
        (heading.is_some(), gnss_flags::HEADING),
        (plan.fuse, gnss_flags::FUSE),
        (use_velocity, gnss_flags::VELOCITY),
    ] {
        if on {
            flags |= bit;
        }
    }
    GnssRecord {
        t: f.t,
        pos: f.pos,
        vel: f.vel.map_or(nan3, f32x3),
        sd_pos: f.sd_pos.map_or(nan3, f32x3),
        sd_vel: f.sd_vel.map_or(nan3, f32x3),
        flags,
        yaw: heading.unwrap_or(0.0),
    }
}
