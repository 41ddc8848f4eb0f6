//! A compact binary replay of an INS/GNSS run, written by the host and read by the firmware:
//! the run's starting point and model ([`NavSetup`]), then the IMU samples and GNSS fixes in
//! the order the host driver processes them. The loop that consumes it is
//! [`NavReplay`](super::run::NavReplay).
//!
//! # Format (version 1, all integers and floats little-endian)
//!
//! ```text
//! header     magic "IMUN" | version u16 = 1 | reserved u16 = 0 | record count u32      12 bytes
//! setup      34 f64, in this order:                                                   280 bytes
//!              t0 [s] | lat, lon [rad], h [m] | q_b^n w, x, y, z | v N, E, D [m/s]
//!              | gyro bias x, y, z [rad/s] (NaN: none) | lever arm x, y, z [m, body FRD]
//!              | sd_att N, E, D [rad] | sd_vel [m/s] | sd_pos [m] | obs_sd x 6
//!              | step [s] | gate (NaN: none) | max_imu_gap [s] | sd factors pos, vel
//!              | heading sd [rad]
//!            then max_rejections u8 | components per axis u8 x 6 (gyro x, y, z, accel x, y, z)
//!            | 0 u8
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
//! GNSS flags ([`gnss_flags`]): withheld, set the heading to `yaw` (with the fix's velocity)
//! before fusing, fuse, fuse the velocity too. The host decides them (outage schedule, heading
//! from the course, one fix per step): they depend on the inputs only, never on the filter, so
//! the firmware replays exactly the decisions of the host run.
//!
//! Times and positions are `f64` (an `f32` latitude is 0.5 m coarse, an `f32` time cannot step
//! 10 ms at 1e6 s); sensor samples and fix velocities and deviations are `f32`, the values the
//! host's `f32` run rounds them to anyway, so both runs see the same inputs bit for bit.
//!
//! The [`Decoder`] is a byte-at-a-time state machine that returns an error (never panics) for
//! any input. Records are handed out as soon as they are complete, so the checksum is only
//! known at the end: a consumer must call [`Decoder::finish`].

use super::imu_model::{ImuErrorModel, MAX_AXIS_COMPONENTS};
use super::NavInit;
use crate::crc::Crc32;
use crate::model::ComponentKind;
use crate::strapdown::{Geodetic, Quat};
use nalgebra::Vector3;

/// First four bytes.
pub const MAGIC: [u8; 4] = *b"IMUN";
/// Format version.
pub const VERSION: u16 = 1;
/// Header length.
pub const HEADER_LEN: usize = 12;
/// Setup block length (34 `f64` and 8 bytes of counts).
pub const SETUP_LEN: usize = 36 * 8 + 8;
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
    /// Unknown version.
    BadVersion,
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
        f.write_str(match self {
            Self::TooLarge => "too many records or components",
            Self::BadMagic => "not a navigation replay (bad magic)",
            Self::BadVersion => "unsupported navigation replay version",
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
    let parts: [&[f64]; 12] = [
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
    put(&[0]);
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

/// Where the decoder is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    Header,
    Setup,
    Component,
    Tag,
    Imu,
    Gnss,
    Trailer,
    Done,
    Failed(NavReplayError),
}

/// Streaming decoder: feed it bytes with [`push`](Self::push), then call
/// [`finish`](Self::finish). After the first error every call returns that error.
#[derive(Debug, Clone)]
pub struct Decoder {
    stage: Stage,
    buf: [u8; SETUP_LEN],
    fill: usize,
    crc: Crc32,
    count: u32,
    seen: u32,
    /// Components still to read, per axis (file order).
    left: [u8; 6],
    setup: NavSetup,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

/// Little-endian reader over a filled buffer (out-of-range reads give zeros: the stage
/// lengths make them impossible, and this keeps every path panic-free).
struct Le<'a>(&'a [u8], usize);

impl Le<'_> {
    fn take<const K: usize>(&mut self) -> [u8; K] {
        let mut out = [0u8; K];
        if let Some(s) = self.0.get(self.1..self.1 + K) {
            out.copy_from_slice(s);
        }
        self.1 += K;
        out
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
    fn f32x3(&mut self) -> [f32; 3] {
        [(); 3].map(|()| f32::from_le_bytes(self.take()))
    }
    fn u8(&mut self) -> u8 {
        let [b] = self.take();
        b
    }
}

impl Decoder {
    /// A decoder waiting for the header.
    pub fn new() -> Self {
        Self {
            stage: Stage::Header,
            buf: [0; SETUP_LEN],
            fill: 0,
            crc: Crc32::new(),
            count: 0,
            seen: 0,
            left: [0; 6],
            setup: NavSetup {
                t0: 0.0,
                pos: Geodetic::default(),
                att: Quat::identity(),
                vel: [0.0; 3],
                gyro_bias: None,
                imu: ImuErrorModel::default(),
                init: NavInit {
                    sd_att: Vector3::zeros(),
                    sd_vel: 0.0,
                    sd_pos: 0.0,
                },
                lever_arm: [0.0; 3],
                obs_sd: [0.0; 6],
                step: 1.0,
                gate: None,
                max_imu_gap: 0.0,
                max_rejections: 0,
                sd_factor: [1.0; 2],
                heading_sd: 0.0,
                scale_factor_sd: None,
            },
        }
    }

    /// The setup, once [`Event::Setup`] has been returned.
    pub fn setup(&self) -> Option<&NavSetup> {
        match self.stage {
            Stage::Tag | Stage::Imu | Stage::Gnss | Stage::Trailer | Stage::Done => {
                Some(&self.setup)
            }
            _ => None,
        }
    }

    /// Records handed out so far.
    pub fn records_seen(&self) -> u32 {
        self.seen
    }

    /// Consumes one byte; returns what it completed.
    pub fn push(&mut self, byte: u8) -> Result<Option<Event>, NavReplayError> {
        let need = match self.stage {
            Stage::Failed(e) => return Err(e),
            Stage::Done => return self.fail(NavReplayError::TrailingData),
            Stage::Header => HEADER_LEN,
            Stage::Setup => SETUP_LEN,
            Stage::Component => COMPONENT_LEN,
            Stage::Tag => 1,
            Stage::Imu => IMU_LEN,
            Stage::Gnss => GNSS_LEN,
            Stage::Trailer => TRAILER_LEN,
        };
        if let Some(slot) = self.buf.get_mut(self.fill) {
            *slot = byte;
        }
        self.fill += 1;
        if self.fill < need {
            return Ok(None);
        }
        let filled = self.fill;
        self.fill = 0;
        if self.stage != Stage::Trailer {
            self.crc.update(self.buf.get(..filled).unwrap_or(&[]));
        }
        match self.stage {
            Stage::Header => self.header().map(|()| None),
            Stage::Setup => self.setup_block(),
            Stage::Component => self.component(),
            Stage::Tag => self.tag().map(|()| None),
            Stage::Imu => Ok(Some(self.imu())),
            Stage::Gnss => self.gnss().map(Some),
            Stage::Trailer => self.trailer().map(|()| None),
            Stage::Done | Stage::Failed(_) => Ok(None),
        }
    }

    /// Checks that the log ended exactly after a valid checksum; returns the record count.
    pub fn finish(&self) -> Result<u32, NavReplayError> {
        match self.stage {
            Stage::Done => Ok(self.count),
            Stage::Failed(e) => Err(e),
            _ => Err(NavReplayError::Truncated),
        }
    }

    fn fail<T>(&mut self, e: NavReplayError) -> Result<T, NavReplayError> {
        self.stage = Stage::Failed(e);
        Err(e)
    }

    fn header(&mut self) -> Result<(), NavReplayError> {
        let mut r = Le(&self.buf, 0);
        let magic: [u8; 4] = r.take();
        let version = u16::from_le_bytes(r.take());
        let reserved = u16::from_le_bytes(r.take());
        self.count = u32::from_le_bytes(r.take());
        if magic != MAGIC {
            return self.fail(NavReplayError::BadMagic);
        }
        if version != VERSION {
            return self.fail(NavReplayError::BadVersion);
        }
        if reserved != 0 {
            return self.fail(NavReplayError::BadField);
        }
        self.stage = Stage::Setup;
        Ok(())
    }

    fn setup_block(&mut self) -> Result<Option<Event>, NavReplayError> {
        let mut r = Le(&self.buf, 0);
        let s = &mut self.setup;
        s.t0 = r.f64();
        s.pos = Geodetic {
            lat: r.f64(),
            lon: r.f64(),
            h: r.f64(),
        };
        s.att = Quat {
            w: r.f64(),
            x: r.f64(),
            y: r.f64(),
            z: r.f64(),
        };
        s.vel = [r.f64(), r.f64(), r.f64()];
        let b = [r.f64(), r.f64(), r.f64()];
        s.gyro_bias = b.iter().all(|v| !v.is_nan()).then_some(b);
        s.lever_arm = [r.f64(), r.f64(), r.f64()];
        s.init.sd_att = Vector3::new(r.f64(), r.f64(), r.f64());
        s.init.sd_vel = r.f64();
        s.init.sd_pos = r.f64();
        s.obs_sd = [(); 6].map(|()| r.f64());
        s.step = r.f64();
        let gate = r.f64();
        s.gate = (!gate.is_nan()).then_some(gate);
        s.max_imu_gap = r.f64();
        s.sd_factor = [r.f64(), r.f64()];
        s.heading_sd = r.f64();
        let sf = [r.f64(), r.f64()];
        s.scale_factor_sd = sf.iter().all(|v| !v.is_nan()).then_some(sf);
        s.max_rejections = r.u8();
        let counts: [u8; 6] = r.take();
        let pad = r.u8();
        s.imu = ImuErrorModel::default();
        let too_many = counts.iter().any(|&c| usize::from(c) > MAX_AXIS_COMPONENTS);
        if too_many || pad != 0 {
            return self.fail(NavReplayError::BadField);
        }
        self.left = counts;
        self.after_component()
    }

    fn component(&mut self) -> Result<Option<Event>, NavReplayError> {
        let mut r = Le(&self.buf, 0);
        let code = r.u8();
        let v = [r.f64(), r.f64(), r.f64()];
        let Some(kind) = ComponentKind::from_code(code) else {
            return self.fail(NavReplayError::BadField);
        };
        let axis = self.left.iter().position(|&c| c > 0);
        let imu = &mut self.setup.imu;
        let slot = match axis {
            Some(i @ 0..=2) => imu.gyro.get_mut(i),
            Some(i) => imu.accel.get_mut(i.wrapping_sub(3)),
            None => None,
        };
        let pushed = slot.is_some_and(|a| a.push(kind.with_quantities(&v)).is_ok());
        let left = axis.and_then(|i| self.left.get_mut(i));
        match (pushed, left) {
            (true, Some(l)) => *l = l.saturating_sub(1),
            _ => return self.fail(NavReplayError::BadField),
        }
        self.after_component()
    }

    /// The next stage after the setup block or a component.
    fn after_component(&mut self) -> Result<Option<Event>, NavReplayError> {
        if self.left.iter().any(|&c| c > 0) {
            self.stage = Stage::Component;
            return Ok(None);
        }
        self.stage = self.after_record();
        Ok(Some(Event::Setup))
    }

    fn after_record(&self) -> Stage {
        if self.seen >= self.count {
            Stage::Trailer
        } else {
            Stage::Tag
        }
    }

    fn tag(&mut self) -> Result<(), NavReplayError> {
        let [tag, ..] = self.buf;
        self.stage = match tag {
            TAG_IMU => Stage::Imu,
            TAG_GNSS => Stage::Gnss,
            _ => return self.fail(NavReplayError::BadField),
        };
        Ok(())
    }

    fn imu(&mut self) -> Event {
        let mut r = Le(&self.buf, 0);
        let rec = ImuRecord {
            t: r.f64(),
            gyro: r.f32x3(),
            accel: r.f32x3(),
        };
        self.seen = self.seen.saturating_add(1);
        self.stage = self.after_record();
        Event::Record(Record::Imu(rec))
    }

    fn gnss(&mut self) -> Result<Event, NavReplayError> {
        let mut r = Le(&self.buf, 0);
        let rec = GnssRecord {
            t: r.f64(),
            pos: Geodetic {
                lat: r.f64(),
                lon: r.f64(),
                h: r.f64(),
            },
            vel: r.f32x3(),
            sd_pos: r.f32x3(),
            sd_vel: r.f32x3(),
            flags: r.u8(),
            yaw: r.f64(),
        };
        if rec.flags & !gnss_flags::ALL != 0 {
            return self.fail(NavReplayError::BadField);
        }
        self.seen = self.seen.saturating_add(1);
        self.stage = self.after_record();
        Ok(Event::Record(Record::Gnss(rec)))
    }

    fn trailer(&mut self) -> Result<(), NavReplayError> {
        let mut r = Le(&self.buf, 0);
        if u32::from_le_bytes(r.take()) != self.crc.value() {
            return self.fail(NavReplayError::BadChecksum);
        }
        self.stage = Stage::Done;
        Ok(())
    }
}

#[cfg(test)]
#[path = "replay_tests.rs"]
mod tests;
