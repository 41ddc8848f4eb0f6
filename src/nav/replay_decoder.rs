//! The streaming [`Decoder`] of the navigation replay format ([`super`]): a byte-at-a-time
//! state machine that returns an error, never panics, for any input.

use super::{
    gnss_flags, live_flags, setup_flags, Event, GnssRecord, ImuRecord, NavReplayError, NavSetup,
    Record, COMPONENT_LEN, GNSS_LEN, HEADER_LEN, IMU_LEN, MAGIC, SETUP_LEN, TAG_GNSS, TAG_IMU,
    TRAILER_LEN, VERSION,
};
use crate::crc::Crc32;
use crate::model::ComponentKind;
use crate::nav::imu_model::{ImuErrorModel, MAX_AXIS_COMPONENTS};
use crate::nav::rest::Zupt;
use crate::nav::NavInit;
use crate::strapdown::{Geodetic, Quat};
use nalgebra::Vector3;

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
            setup: NavSetup::new(
                ImuErrorModel::default(),
                NavInit {
                    sd_att: Vector3::zeros(),
                    sd_vel: 0.0,
                    sd_pos: 0.0,
                },
            ),
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
            return self.fail(NavReplayError::BadVersion(version));
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
        let nhc_sd = r.f64();
        s.nhc_sd = (!nhc_sd.is_nan()).then_some(nhc_sd);
        s.nhc_lever = [r.f64(), r.f64(), r.f64()];
        let z = [r.f64(), r.f64(), r.f64(), r.f64()];
        s.zupt = (!z[0].is_nan()).then_some(Zupt {
            sd: z[0],
            gyro_max: z[1],
            accel_max: z[2],
            speed_max: z[3],
        });
        let o = [(); 9].map(|()| r.f64());
        let l = [(); 5].map(|()| r.f64());
        s.max_rejections = r.u8();
        let counts: [u8; 6] = r.take();
        let flags = r.u8();
        let lf = r.u8();
        s.live = (!l[0].is_nan()).then_some(crate::nav::live::LiveConfig {
            align: l[0],
            yaw: (!l[1].is_nan()).then_some(l[1]),
            static_gyro_bias: lf & live_flags::STATIC_GYRO_BIAS != 0,
            yaw_speed: l[2],
            fix_interval: l[3],
            use_velocity: lf & live_flags::USE_VELOCITY != 0,
            latency: l[4],
        });
        s.heading_known = flags & setup_flags::HEADING_KNOWN != 0;
        // The fix count is a small whole number on the wire (f64 like the rest of the block).
        let fixes = o[6];
        let fixes_ok = (0.0..=f64::from(u32::MAX)).contains(&fixes) && fixes == libm::trunc(fixes);
        if !o[0].is_nan() && !fixes_ok {
            return self.fail(NavReplayError::BadField);
        }
        s.online = (!o[0].is_nan()).then_some(crate::nav::OnlineConfig {
            first: o[0],
            every: o[1],
            offset: o[2],
            min_offset: o[3],
            bound: o[4],
            min_gain: o[5],
            min_fixes: if fixes_ok { fixes as u32 } else { 0 },
            memory: o[7],
            conservative: flags & setup_flags::ONLINE_CONSERVATIVE != 0,
            per_axis: flags & setup_flags::ONLINE_PER_AXIS != 0,
            taus: flags & setup_flags::ONLINE_TAUS != 0,
            hold_flat_taus: flags & setup_flags::ONLINE_HOLD_FLAT_TAUS != 0,
            gnss_sd: flags & setup_flags::ONLINE_GNSS_SD != 0,
            flat_waits: flags & setup_flags::ONLINE_FLAT_WAITS != 0,
            exit_z: o[8],
        });
        s.imu = ImuErrorModel::default();
        let too_many = counts.iter().any(|&c| usize::from(c) > MAX_AXIS_COMPONENTS);
        if too_many || flags & !setup_flags::ALL != 0 || lf & !live_flags::ALL != 0 {
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
