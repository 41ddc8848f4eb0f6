//! A compact binary replay of an INS/GNSS run, written by the host and read by the firmware:
//! the run's starting point and model ([`NavSetup`]), then the IMU samples and GNSS fixes in
//! the order the host driver processes them. The loop that consumes it is
//! [`NavReplay`](super::run::NavReplay).
//!
//! # Format (version 9, all integers and floats little-endian)
//!
//! ```text
//! header     magic "IMUN" | version u16 = 8 | reserved u16 = 0 | record count u32      12 bytes
//! setup      58 f64, in this order:                                                   473 bytes
//!              t0 [s] | lat, lon [rad], h [m] | q_b^n w, x, y, z | v N, E, D [m/s]
//!              | gyro bias x, y, z [rad/s] (NaN: none) | lever arm x, y, z [m, body FRD]
//!              | sd_att N, E, D [rad] | sd_vel [m/s] | sd_pos [m] | obs_sd x 6
//!              | step [s] | gate (NaN: none) | max_imu_gap [s] | sd factors pos, vel
//!              | heading sd [rad] | scale-factor sd gyro, accel (NaN: none)
//!              | NHC sd [m/s] (NaN: none) | NHC lever x, y, z [m, body FRD]
//!              | ZUPT sd [m/s] (NaN: none) | ZUPT rate, specific-force, speed bounds
//!              | online identification: first decision [s] (NaN: none) | interval [s]
//!              | offset, smallest offset, bound [decades] | least gain [nats] | fixes
//!              | memory [s] (infinite: none) | exit z (0: none)
//!              | live start: window [s] (NaN: not live) | yaw [rad] (NaN: from the course)
//!              | yaw speed [m/s] | fix interval [s] | latency budget [s]
//!            then max_rejections u8 | components per axis u8 x 6 (gyro x, y, z, accel x, y, z)
//!            | setup flags u8 | live flags u8
//! components per component, axes in the order above: kind u8 | a, b, c f64             25 bytes
//!            (the model file's component encoding, `model::wire`: the kind table's code and
//!            quantities in file order, padded with zeros)
//! records    tag u8, then
//!              1 IMU:  t f64 | gyro f32 x 3 [rad/s] | accel f32 x 3 [m/s^2]           32 bytes
//!              2 GNSS: t f64 | lat, lon f64 [rad] | h f64 | vel f32 x 3 [m/s]
//!                      | sd_pos f32 x 3 [m] | sd_vel f32 x 3 [m/s] | flags u8 | yaw f64   77 bytes
//! trailer    CRC-32 (as zlib) of everything before it                                  4 bytes
//! ```
//!
//! Setup flags ([`setup_flags`]): the heading is known from the start (given, not taken from
//! the course). With the non-holonomic constraint (NHC) on, the loop applies it after every
//! filter step once the heading is known, from the start or from the first fix flagged
//! [`gnss_flags::HEADING`] ([`NavReplay::imu`](super::run::NavReplay::imu)), as the host does.
//!
//! With zero-velocity updates (ZUPT) on, the loop applies them after every filter step found
//! at rest ([`Zupt::after_step`](super::rest::Zupt::after_step)), as the host does.
//!
//! With the online identification on ([`OnlineConfig`], setup flags
//! [`setup_flags::ONLINE_PER_AXIS`], [`setup_flags::ONLINE_TAUS`],
//! [`setup_flags::ONLINE_CONSERVATIVE`], [`setup_flags::ONLINE_HOLD_FLAT_TAUS`],
//! [`setup_flags::ONLINE_GNSS_SD`] and [`setup_flags::ONLINE_FLAT_WAITS`]), the loop
//! runs the bank of shadow filters ([`crate::nav::online`]) and, after every filter step, takes its decision
//! ([`NavReplay::imu`](super::run::NavReplay::imu)), as the host does (`nav --adapt
//! --adapt-method bank`).
//!
//! Version 2 added the NHC (sd and lever arm) and the setup flags (the byte that was zero
//! padding in version 1); version 3 the ZUPT (sd and the rest detector's three bounds); version 4
//! the online identification (seven values and four flags); version 5 its memory
//! ([`OnlineConfig::memory`], an eighth value, infinite for none); version 6 its GNSS factors
//! ([`OnlineConfig::gnss_sd`], a fifth flag); version 7 the flat coordinates' wait
//! ([`OnlineConfig::flat_waits`], a sixth); version 8 the test for leaving the grid
//! ([`OnlineConfig::exit_z`], a ninth value); version 9 the live start ([`LiveConfig`], five
//! values and the live flags byte, [`live_flags`]: a firmware that starts the run itself, from
//! the raw stream, as [`LiveNav`](crate::nav::live::LiveNav) does). Older
//! replays are rejected ([`NavReplayError::BadVersion`]), not read with the new aiding off:
//! the replay is an intermediate file that `hal_sim::nav_qemu` writes afresh for every run, so there is nothing to migrate, and one layout keeps the
//! firmware's decoder to one panic-free path.
//!
//! GNSS flags ([`gnss_flags`]): withheld, set the heading to `yaw` (with the fix's velocity)
//! before fusing, fuse, fuse the velocity too. The host decides them (outage schedule, heading
//! from the course, the interval between fused fixes): they depend on the inputs only, never
//! on the filter, so the firmware replays exactly the decisions of the host run.
//!
//! Times and positions are `f64` (an `f32` latitude is 0.5 m coarse, an `f32` time cannot step
//! 10 ms at 1e6 s); sensor samples and fix velocities and deviations are `f32`, the values the
//! host's `f32` run rounds them to anyway, so both runs see the same inputs bit for bit.
//!
//! The [`Decoder`] is a byte-at-a-time state machine that returns an error (never panics) for
//! any input. Records are handed out as soon as they are complete, so the checksum is only
//! known at the end: a consumer must call [`Decoder::finish`].

use super::imu_model::ImuErrorModel;
pub use super::live::LiveConfig;
use super::online::OnlineConfig;
use super::rest::Zupt;
use super::NavInit;
use crate::crc::Crc32;
use crate::strapdown::{Geodetic, Quat};

/// First four bytes.
pub const MAGIC: [u8; 4] = *b"IMUN";
/// Format version (9: the live start; 8: the online identification's test for leaving the
/// grid; 7: its flat coordinates wait; 6: its GNSS factors; module docs).
pub const VERSION: u16 = 9;
/// Header length.
pub const HEADER_LEN: usize = 12;
/// Setup block length (58 `f64`, then `max_rejections`, six counts, the setup flags and the
/// live flags).
pub const SETUP_LEN: usize = SETUP_F64 * 8 + 9;
/// `f64` fields of the setup block.
const SETUP_F64: usize = 58;
/// One component.
pub const COMPONENT_LEN: usize = 25;
/// IMU record payload (after the tag).
pub const IMU_LEN: usize = 32;
/// GNSS record payload (after the tag).
pub const GNSS_LEN: usize = 77;
/// Trailer length.
pub const TRAILER_LEN: usize = 4;
/// Record tags.
pub const TAG_IMU: u8 = 1;
/// GNSS record tag.
pub const TAG_GNSS: u8 = 2;

/// Bits of the live flags byte ([`LiveConfig`]).
pub mod live_flags {
    /// The gyro bias is seeded from the levelling window
    /// ([`LiveConfig::static_gyro_bias`](super::LiveConfig::static_gyro_bias)).
    pub const STATIC_GYRO_BIAS: u8 = 1;
    /// The fixes' velocities are fused
    /// ([`LiveConfig::use_velocity`](super::LiveConfig::use_velocity)).
    pub const USE_VELOCITY: u8 = 2;
    /// Every defined bit.
    pub const ALL: u8 = STATIC_GYRO_BIAS | USE_VELOCITY;
}

/// Bits of the setup flags byte.
pub mod setup_flags {
    /// The heading is known from the start ([`NavSetup::heading_known`](super::NavSetup)).
    pub const HEADING_KNOWN: u8 = 1;
    /// The online identification has one coordinate per axis ([`OnlineConfig::per_axis`]).
    ///
    /// [`OnlineConfig::per_axis`]: crate::nav::OnlineConfig::per_axis
    pub const ONLINE_PER_AXIS: u8 = 2;
    /// The online identification identifies the correlation times ([`OnlineConfig::taus`]).
    ///
    /// [`OnlineConfig::taus`]: crate::nav::OnlineConfig::taus
    pub const ONLINE_TAUS: u8 = 4;
    /// The online identification's running model is conservative
    /// ([`OnlineConfig::conservative`]).
    ///
    /// [`OnlineConfig::conservative`]: crate::nav::OnlineConfig::conservative
    pub const ONLINE_CONSERVATIVE: u8 = 8;
    /// The online identification holds the correlation times the data do not bound
    /// ([`OnlineConfig::hold_flat_taus`]).
    ///
    /// [`OnlineConfig::hold_flat_taus`]: crate::nav::OnlineConfig::hold_flat_taus
    pub const ONLINE_HOLD_FLAT_TAUS: u8 = 16;
    /// The online identification identifies factors on the GNSS fixes' standard deviations
    /// ([`OnlineConfig::gnss_sd`]).
    ///
    /// [`OnlineConfig::gnss_sd`]: crate::nav::OnlineConfig::gnss_sd
    pub const ONLINE_GNSS_SD: u8 = 32;
    /// The online identification holds a flat coordinate while a bounded one leaves the grid
    /// ([`OnlineConfig::flat_waits`]).
    ///
    /// [`OnlineConfig::flat_waits`]: crate::nav::OnlineConfig::flat_waits
    pub const ONLINE_FLAT_WAITS: u8 = 64;
    /// Every defined bit.
    pub const ALL: u8 = HEADING_KNOWN
        | ONLINE_PER_AXIS
        | ONLINE_TAUS
        | ONLINE_CONSERVATIVE
        | ONLINE_HOLD_FLAT_TAUS
        | ONLINE_GNSS_SD
        | ONLINE_FLAT_WAITS;
}

/// Bits of [`GnssRecord::flags`].
pub mod gnss_flags {
    /// Withheld by the outage schedule (recorded, not fused).
    pub const WITHHELD: u8 = 1;
    /// Set the heading to `yaw` (and the velocity to the fix's) before fusing.
    pub const HEADING: u8 = 2;
    /// Fuse the fix.
    pub const FUSE: u8 = 4;
    /// Fuse the velocity as well (else only the position).
    pub const VELOCITY: u8 = 8;
    /// Every defined bit.
    pub const ALL: u8 = WITHHELD | HEADING | FUSE | VELOCITY;
}

/// Where and how a run starts: everything the navigator is built from
/// ([`NavSetup::navigator`], in [`super::run`]).
#[derive(Debug, Clone, PartialEq)]
pub struct NavSetup {
    /// Start time [s] (the last IMU sample before the first record).
    pub t0: f64,
    /// IMU position.
    pub pos: Geodetic,
    /// Attitude `q_b^n`.
    pub att: Quat<f64>,
    /// NED velocity [m/s].
    pub vel: [f64; 3],
    /// Initial gyro bias estimate [rad/s].
    pub gyro_bias: Option<[f64; 3]>,
    /// Noise model.
    pub imu: ImuErrorModel<f64>,
    /// Initial uncertainty.
    pub init: NavInit<f64>,
    /// GNSS antenna from the IMU, body FRD [m].
    pub lever_arm: [f64; 3],
    /// Default observation standard deviations.
    pub obs_sd: [f64; 6],
    /// Filter step [s].
    pub step: f64,
    /// Gate multiplier (`None`: no gate).
    pub gate: Option<f64>,
    /// Longest IMU interval taken as one step [s].
    pub max_imu_gap: f64,
    /// Consecutive gated fixes before one is fused ungated.
    pub max_rejections: u8,
    /// Factors on the fixes' position and velocity standard deviations.
    pub sd_factor: [f64; 2],
    /// Standard deviation of a heading set from the course [rad].
    pub heading_sd: f64,
    /// Gyro and accelerometer scale-factor standard deviations (none: no scale-factor states).
    pub scale_factor_sd: Option<[f64; 2]>,
    /// Non-holonomic constraint: standard deviation [m/s] of the body lateral and vertical
    /// velocity at [`nhc_lever`](Self::nhc_lever) (none: not applied). When and how it is
    /// applied: [`NavReplay::imu`](super::run::NavReplay::imu).
    pub nhc_sd: Option<f64>,
    /// The point the constraint holds at, from the IMU, body FRD [m] (kept without the
    /// constraint too, so that every setup round-trips).
    pub nhc_lever: [f64; 3],
    /// Zero-velocity updates after every filter step at rest (none: not applied).
    pub zupt: Option<Zupt<f64>>,
    /// Online identification of the noise model by the bank of shadow filters (none: the
    /// model is fixed).
    pub online: Option<OnlineConfig>,
    /// The heading is known from the start (given), not first set by a fix flagged
    /// [`gnss_flags::HEADING`]: the constraint waits for a known heading.
    pub heading_known: bool,
    /// A live replay ([`crate::nav::live`]): the records are the raw stream from the first
    /// sample (fixes unflagged), and the start (`t0`, `pos`, `att`, `vel`, `gyro_bias`,
    /// `heading_known`) is the live loop's, with these rules.
    pub live: Option<LiveConfig>,
}

/// Default GNSS standard deviations (position N, E, D [m], velocity N, E, D [m/s]) where a fix
/// gives none (`hal-sim nav`'s).
pub const DEFAULT_OBS_SD: [f64; 6] = [0.5, 0.5, 1.0, 0.1, 0.1, 0.2];
/// Standard deviation of a heading taken from the GNSS course [deg].
pub const DEFAULT_HEADING_SD_DEG: f64 = 2.0;
/// Longest IMU interval taken as one step [s].
pub const DEFAULT_MAX_IMU_GAP: f64 = 0.1;
/// Consecutive gated fixes before one is fused ungated.
pub const DEFAULT_MAX_REJECTIONS: u8 = 3;

impl NavSetup {
    /// A run with the noise model `imu` and the initial uncertainty `init`, at rest at the
    /// origin with a level attitude (the start a live run or the host's alignment fills in),
    /// with the defaults of `hal-sim nav` for the rest: a 1-s step, no gate, no aiding but
    /// the fixes, the default deviations ([`DEFAULT_OBS_SD`]).
    pub fn new(imu: ImuErrorModel<f64>, init: NavInit<f64>) -> Self {
        Self {
            t0: 0.0,
            pos: Geodetic::default(),
            att: Quat::identity(),
            vel: [0.0; 3],
            gyro_bias: None,
            imu,
            init,
            lever_arm: [0.0; 3],
            obs_sd: DEFAULT_OBS_SD,
            step: 1.0,
            gate: None,
            max_imu_gap: DEFAULT_MAX_IMU_GAP,
            max_rejections: DEFAULT_MAX_REJECTIONS,
            sd_factor: [1.0; 2],
            heading_sd: DEFAULT_HEADING_SD_DEG.to_radians(),
            scale_factor_sd: None,
            nhc_sd: None,
            nhc_lever: [0.0; 3],
            zupt: None,
            online: None,
            heading_known: false,
            live: None,
        }
    }
}

/// One IMU sample (mean rates over the interval ending at `t`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuRecord {
    /// End of the interval [s].
    pub t: f64,
    /// Angular rate, body FRD [rad/s].
    pub gyro: [f32; 3],
    /// Specific force, body FRD [m/s^2].
    pub accel: [f32; 3],
}

/// One GNSS fix and what to do with it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GnssRecord {
    /// Time of validity [s].
    pub t: f64,
    /// Antenna position.
    pub pos: Geodetic,
    /// NED velocity [m/s] (NaN: none).
    pub vel: [f32; 3],
    /// Position standard deviations N, E, D [m] (NaN: the model's default).
    pub sd_pos: [f32; 3],
    /// Velocity standard deviations [m/s] (NaN: the model's default).
    pub sd_vel: [f32; 3],
    /// [`gnss_flags`].
    pub flags: u8,
    /// Heading to set [rad] (with [`gnss_flags::HEADING`]).
    pub yaw: f64,
}

/// A record of the log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Record {
    /// An IMU sample.
    Imu(ImuRecord),
    /// A GNSS fix.
    Gnss(GnssRecord),
}

/// What [`Decoder::push`] completed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// The setup is complete: read it with [`Decoder::setup`].
    Setup,
    /// A record.
    Record(Record),
}

/// Why a replay could not be written or read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NavReplayError {
    /// More records than a `u32` count, or more components on an axis than fit.
    TooLarge,
    /// Not a navigation replay (magic).
    BadMagic,
    /// Another version than [`VERSION`] (the one found).
    BadVersion(u16),
    /// A reserved field, a component kind or count, a tag or a flag is not valid.
    BadField,
    /// The data ended early.
    Truncated,
    /// The checksum does not match.
    BadChecksum,
    /// Bytes follow the checksum.
    TrailingData,
}

impl core::fmt::Display for NavReplayError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if let Self::BadVersion(v) = self {
            return write!(
                f,
                "navigation replay version {v} is not supported (this build reads version \
                 {VERSION} only: write the replay again with the same build of hal-sim)"
            );
        }
        f.write_str(match self {
            Self::TooLarge => "too many records or components",
            Self::BadMagic => "not a navigation replay (bad magic)",
            Self::BadVersion(_) => "unsupported navigation replay version",
            Self::BadField => "invalid field in the navigation replay",
            Self::Truncated => "navigation replay is truncated",
            Self::BadChecksum => "navigation replay checksum mismatch",
            Self::TrailingData => "bytes after the end of the navigation replay",
        })
    }
}

impl core::error::Error for NavReplayError {}

/// The axes of a model in file order.
fn axes(m: &ImuErrorModel<f64>) -> [&super::AxisModel<f64>; 6] {
    let [g0, g1, g2] = &m.gyro;
    let [a0, a1, a2] = &m.accel;
    [g0, g1, g2, a0, a1, a2]
}

/// Writes `setup` and `records` to `sink` (called with consecutive pieces of the file).
pub fn encode(
    setup: &NavSetup,
    records: &[Record],
    mut sink: impl FnMut(&[u8]),
) -> Result<(), NavReplayError> {
    let count = u32::try_from(records.len()).map_err(|_| NavReplayError::TooLarge)?;
    let mut crc = Crc32::new();
    let mut put = |b: &[u8]| {
        crc.update(b);
        sink(b);
    };
    put(&MAGIC);
    put(&VERSION.to_le_bytes());
    put(&0u16.to_le_bytes());
    put(&count.to_le_bytes());
    let s = setup;
    let nan3 = [f64::NAN; 3];
    let q = s.att;
    let nan2 = [f64::NAN; 2];
    let zupt = s.zupt.map_or([f64::NAN; 4], |z| {
        [z.sd, z.gyro_max, z.accel_max, z.speed_max]
    });
    let online = s.online.map_or([f64::NAN; 9], |o| {
        [
            o.first,
            o.every,
            o.offset,
            o.min_offset,
            o.bound,
            o.min_gain,
            f64::from(o.min_fixes),
            o.memory,
            o.exit_z,
        ]
    });
    let live = s.live.map_or([f64::NAN; 5], |l| {
        [
            l.align,
            l.yaw.unwrap_or(f64::NAN),
            l.yaw_speed,
            l.fix_interval,
            l.latency,
        ]
    });
    let parts: [&[f64]; 17] = [
        &[s.t0, s.pos.lat, s.pos.lon, s.pos.h],
        &[q.w, q.x, q.y, q.z],
        &s.vel,
        s.gyro_bias.as_ref().unwrap_or(&nan3),
        &s.lever_arm,
        &[s.init.sd_att.x, s.init.sd_att.y, s.init.sd_att.z],
        &[s.init.sd_vel, s.init.sd_pos],
        &s.obs_sd,
        &[s.step, s.gate.unwrap_or(f64::NAN), s.max_imu_gap],
        &s.sd_factor,
        &[s.heading_sd],
        s.scale_factor_sd.as_ref().unwrap_or(&nan2),
        &[s.nhc_sd.unwrap_or(f64::NAN)],
        &s.nhc_lever,
        &zupt,
        &online,
        &live,
    ];
    for v in parts.iter().flat_map(|p| p.iter()) {
        put(&v.to_le_bytes());
    }
    let mut counts = [0u8; 6];
    for (c, a) in counts.iter_mut().zip(axes(&s.imu)) {
        *c = u8::try_from(a.len()).map_err(|_| NavReplayError::TooLarge)?;
    }
    put(&[s.max_rejections]);
    put(&counts);
    let flag = |on: bool, bit: u8| if on { bit } else { 0 };
    put(&[flag(s.heading_known, setup_flags::HEADING_KNOWN)
        | flag(
            s.online.is_some_and(|o| o.per_axis),
            setup_flags::ONLINE_PER_AXIS,
        )
        | flag(s.online.is_some_and(|o| o.taus), setup_flags::ONLINE_TAUS)
        | flag(
            s.online.is_some_and(|o| o.conservative),
            setup_flags::ONLINE_CONSERVATIVE,
        )
        | flag(
            s.online.is_some_and(|o| o.hold_flat_taus),
            setup_flags::ONLINE_HOLD_FLAT_TAUS,
        )
        | flag(
            s.online.is_some_and(|o| o.gnss_sd),
            setup_flags::ONLINE_GNSS_SD,
        )
        | flag(
            s.online.is_some_and(|o| o.flat_waits),
            setup_flags::ONLINE_FLAT_WAITS,
        )]);
    put(&[flag(
        s.live.is_some_and(|l| l.static_gyro_bias),
        live_flags::STATIC_GYRO_BIAS,
    ) | flag(
        s.live.is_some_and(|l| l.use_velocity),
        live_flags::USE_VELOCITY,
    )]);
    for c in axes(&s.imu).into_iter().flat_map(|a| a.iter()) {
        let kind = c.kind();
        put(&[kind.code()]);
        let mut v = [0.0f64; 3];
        for (o, q) in v.iter_mut().zip(kind.quantities()) {
            *o = c.get(*q).unwrap_or(0.0);
        }
        for x in v {
            put(&x.to_le_bytes());
        }
    }
    let f32s = |put: &mut dyn FnMut(&[u8]), v: &[f32; 3]| {
        for x in v {
            put(&x.to_le_bytes());
        }
    };
    for r in records {
        match r {
            Record::Imu(r) => {
                put(&[TAG_IMU]);
                put(&r.t.to_le_bytes());
                f32s(&mut put, &r.gyro);
                f32s(&mut put, &r.accel);
            }
            Record::Gnss(r) => {
                put(&[TAG_GNSS]);
                for v in [r.t, r.pos.lat, r.pos.lon, r.pos.h] {
                    put(&v.to_le_bytes());
                }
                f32s(&mut put, &r.vel);
                f32s(&mut put, &r.sd_pos);
                f32s(&mut put, &r.sd_vel);
                put(&[r.flags]);
                put(&r.yaw.to_le_bytes());
            }
        }
    }
    let value = crc.value();
    sink(&value.to_le_bytes());
    Ok(())
}

/// The streaming decoder (its own file to keep this one short).
#[path = "replay_decoder.rs"]
mod decoder;
pub use decoder::Decoder;

#[cfg(test)]
#[path = "replay_tests.rs"]
mod tests;
