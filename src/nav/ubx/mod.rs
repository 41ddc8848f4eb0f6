//! GNSS fixes from a u-blox receiver: the UBX binary protocol's `NAV-PVT` (the position,
//! velocity and time solution) and `NAV-TIMEGPS` (the GPS week), read byte by byte into the
//! [`LiveFix`] a [`LiveNav`](super::live::LiveNav) takes; and `TIM-TP`, the GPS time of the
//! receiver's next time pulse, which a [`GpsClock`](super::gps_clock::GpsClock) pairs with the
//! pulse's capture to stamp a local clock's counts in GPS time.
//!
//! A UBX message is `B5 62 | class | id | length u16 LE | payload | CK_A CK_B`, the checksum
//! the 8-bit Fletcher sum over class, id, length and payload (u-blox's interface description,
//! "UBX checksum"). [`UbxDecoder`] finds the two messages read here (92 and 16 bytes of payload)
//! (and `TIM-TP`'s 16) among any others, and counts what it refused.
//!
//! The fix ([`UbxFixes`]), from `NAV-PVT`:
//! - taken only when `fixType` is 3D (3) or GNSS + dead reckoning (4) and `gnssFixOK` is set;
//!   other solutions are counted and dropped;
//! - time of validity `week * 604800 + iTOW / 1000` s: GPS seconds since 1980-01-06, the scale
//!   of `hal-sim`'s pinned GNSS CSV and of the IMU frames ([`imu_frame`](super::imu_frame)).
//!   The week comes from `NAV-TIMEGPS` (when its week is valid) or is given; a `NAV-PVT`
//!   before any week is dropped. A week's turn between the two messages is followed;
//! - position: `lat`, `lon` (1e-7 deg) and `height` above the ellipsoid (mm);
//! - velocity: `velN`, `velE`, `velD` (mm/s);
//! - standard deviations: `hAcc` for north and east, `vAcc` for down, `sAcc` for each velocity
//!   axis (mm, mm/s; the receiver's accuracy estimates read as one-sigma per axis, as PX4's
//!   u-blox driver does). An estimate of 0 is none (the setup's defaults).
//!
//! ```
//! use imu_ident::nav::ubx::{encode_nav_pvt, encode_nav_timegps, NavPvt, UbxFixes};
//! let pvt = NavPvt {
//!     itow_ms: 243_258_499,
//!     fix_type: 3,
//!     flags: 1,
//!     num_sv: 21,
//!     lat_e7: 400_966_268,
//!     lon_e7: -1_051_474_483,
//!     height_mm: 1_601_474,
//!     vel_ned_mm_s: [10, -2, -9],
//!     h_acc_mm: 10,
//!     v_acc_mm: 10,
//!     s_acc_mm_s: 59,
//! };
//! let mut fixes = UbxFixes::new(None);
//! let mut got = None;
//! let bytes = encode_nav_timegps(243_258_499, 2374).into_iter().chain(encode_nav_pvt(&pvt));
//! for b in bytes {
//!     got = got.or(fixes.push(b));
//! }
//! let fix = got.unwrap().live();
//! assert_eq!(fix.t, 2374.0 * 604_800.0 + 243_258.499);
//! assert!((fix.pos.lat.to_degrees() - 40.096_626_8).abs() < 1e-12);
//! assert_eq!(fix.sd_vel, Some([0.059; 3]));
//! ```

mod encode;

pub use encode::{encode_nav_pvt, encode_nav_timegps, encode_tim_tp, tim_tp_at};

use super::live::LiveFix;
use crate::strapdown::Geodetic;

/// The two bytes that start every UBX message.
pub const UBX_SYNC: [u8; 2] = [0xB5, 0x62];
/// `NAV-PVT`: class, id and payload length.
pub const NAV_PVT: (u8, u8, usize) = (0x01, 0x07, 92);
/// `NAV-TIMEGPS`: class, id and payload length.
pub const NAV_TIMEGPS: (u8, u8, usize) = (0x01, 0x20, 16);
/// `TIM-TP`: class, id and payload length.
pub const TIM_TP: (u8, u8, usize) = (0x0D, 0x01, 16);
/// Seconds in a GPS week.
pub const WEEK_S: f64 = 604_800.0;
/// Milliseconds in half a GPS week: a time of week this far from the week's message is in the
/// next or the previous week.
const HALF_WEEK_MS: u32 = 302_400_000;

/// The fields of `NAV-PVT` read here (offsets in u-blox's description).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct NavPvt {
    /// GPS time of week of the navigation epoch [ms] (offset 0).
    pub itow_ms: u32,
    /// 0 none, 1 dead reckoning, 2 2D, 3 3D, 4 GNSS + dead reckoning, 5 time only (20).
    pub fix_type: u8,
    /// Bit 0 `gnssFixOK`, bit 1 `diffSoln`, bits 6-7 `carrSoln` (21).
    pub flags: u8,
    /// Satellites used (23).
    pub num_sv: u8,
    /// Longitude [1e-7 deg] (24).
    pub lon_e7: i32,
    /// Latitude [1e-7 deg] (28).
    pub lat_e7: i32,
    /// Height above the ellipsoid [mm] (32).
    pub height_mm: i32,
    /// Horizontal accuracy estimate [mm] (40).
    pub h_acc_mm: u32,
    /// Vertical accuracy estimate [mm] (44).
    pub v_acc_mm: u32,
    /// NED velocity [mm/s] (48, 52, 56).
    pub vel_ned_mm_s: [i32; 3],
    /// Speed accuracy estimate [mm/s] (68).
    pub s_acc_mm_s: u32,
}

/// A message read by [`UbxDecoder`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UbxMessage {
    /// `NAV-PVT`.
    NavPvt(NavPvt),
    /// `NAV-TIMEGPS`: time of week [ms] and the GPS week, when the receiver marks the week valid.
    NavTimeGps {
        /// GPS time of week [ms].
        itow_ms: u32,
        /// GPS week (none when not valid yet).
        week: Option<u16>,
        /// GPS minus UTC [s] (none when not valid yet).
        leap_s: Option<i8>,
    },
    /// `TIM-TP`.
    TimTp(TimTp),
}

/// The fields of `TIM-TP` (offsets in u-blox's description): the time of the next pulse.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TimTp {
    /// Time of week of the next pulse in the time base [ms] (offset 0).
    pub tow_ms: u32,
    /// Its sub-millisecond part [2^-32 ms] (4).
    pub tow_sub_ms: u32,
    /// The pulse's quantisation error [ps] (8): tens of nanoseconds, far below what the
    /// navigator's stamps need, so not applied.
    pub q_err_ps: i32,
    /// Week of the next pulse in the time base (12).
    pub week: u16,
    /// Bit 0 `timeBase` (0 GNSS, 1 UTC), bit 1 `utc` available (14).
    pub flags: u8,
    /// Bits 0-3 `timeRefGnss` (0 GPS), bits 4-7 `utcStandard` (15).
    pub ref_info: u8,
}

/// Byte-at-a-time UBX message decoder for the three messages read here. Constant memory, no
/// panics.
///
/// It keeps the bytes from the last candidate sync, at most one `NAV-PVT`'s worth, and checks
/// them as they come: the sync, a class and id read here, that message's length, then the
/// checksum. Anything else is not a candidate: its first byte is dropped and the search goes
/// on from the next one, inside the buffered bytes too. So another message type's payload is
/// searched rather than stepped over by its length, and a sync pattern inside an IMU frame on
/// a shared line, or a corrupted length, never swallows the messages after it.
#[derive(Debug, Clone)]
pub struct UbxDecoder {
    buf: [u8; MAX_MESSAGE],
    len: usize,
    rejected: u32,
}

/// The longest message kept: `NAV-PVT`, its header and checksum.
const MAX_MESSAGE: usize = NAV_PVT.2 + 8;

impl Default for UbxDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl UbxDecoder {
    /// An empty decoder.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_MESSAGE],
            len: 0,
            rejected: 0,
        }
    }

    /// Messages refused so far: a `NAV-PVT`, `NAV-TIMEGPS` or `TIM-TP` with a bad checksum or the wrong
    /// length (an older protocol's `NAV-PVT` is 84 bytes).
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// Takes one byte; returns a message read here when one completes with a good checksum.
    pub fn push(&mut self, b: u8) -> Option<UbxMessage> {
        if self.len == 0 && b != UBX_SYNC[0] {
            // Not a message's start: nothing to keep (the common case on a shared line).
            return None;
        }
        if self.len >= MAX_MESSAGE {
            // Cannot happen (a full candidate is decided below); kept total.
            self.drop_first();
        }
        *self.buf.get_mut(self.len)? = b;
        self.len += 1;
        loop {
            match self.check() {
                Candidate::Partial => return None,
                Candidate::Complete(m) => {
                    self.len = 0;
                    return Some(m);
                }
                Candidate::Bad { counted } => {
                    if counted {
                        self.rejected = self.rejected.saturating_add(1);
                    }
                    self.drop_first();
                    if self.len == 0 {
                        return None;
                    }
                }
            }
        }
    }

    /// Drops the oldest buffered byte.
    fn drop_first(&mut self) {
        self.len = crate::crc::drop_first(&mut self.buf, self.len);
    }

    /// What the buffered bytes are so far.
    fn check(&self) -> Candidate {
        let bytes = self.buf.get(..self.len).unwrap_or_default();
        let n = bytes.len().min(2);
        if bytes.get(..n) != UBX_SYNC.get(..n) {
            return Candidate::Bad { counted: false };
        }
        let (Some(&class), Some(&id)) = (bytes.get(2), bytes.get(3)) else {
            return Candidate::Partial;
        };
        let want = match (class, id) {
            (c, i) if (c, i) == (NAV_PVT.0, NAV_PVT.1) => NAV_PVT.2,
            (c, i) if (c, i) == (NAV_TIMEGPS.0, NAV_TIMEGPS.1) => NAV_TIMEGPS.2,
            (c, i) if (c, i) == (TIM_TP.0, TIM_TP.1) => TIM_TP.2,
            _ => return Candidate::Bad { counted: false },
        };
        let (Some(&l0), Some(&l1)) = (bytes.get(4), bytes.get(5)) else {
            return Candidate::Partial;
        };
        if usize::from(u16::from_le_bytes([l0, l1])) != want {
            return Candidate::Bad { counted: true };
        }
        if bytes.len() < want + 8 {
            return Candidate::Partial;
        }
        let (mut a, mut c) = (0u8, 0u8);
        for x in bytes.get(2..6 + want).unwrap_or_default() {
            a = a.wrapping_add(*x);
            c = c.wrapping_add(a);
        }
        if bytes.get(6 + want..8 + want) != Some(&[a, c][..]) {
            return Candidate::Bad { counted: true };
        }
        match bytes.get(6..6 + want).and_then(|p| message(class, id, p)) {
            Some(m) => Candidate::Complete(m),
            None => Candidate::Bad { counted: true },
        }
    }
}

/// The state of the bytes from a candidate sync.
enum Candidate {
    /// A message read here, so far.
    Partial,
    /// A message read here, checked.
    Complete(UbxMessage),
    /// Not one: search on from the next byte (`counted`: a message of ours, refused).
    Bad { counted: bool },
}

/// The message of a checked payload `p` of `class`, `id` (its length already checked).
fn message(class: u8, id: u8, p: &[u8]) -> Option<UbxMessage> {
    let u32_at = |o: usize| Some(u32::from_le_bytes(p.get(o..o + 4)?.try_into().ok()?));
    let i32_at = |o: usize| Some(i32::from_le_bytes(p.get(o..o + 4)?.try_into().ok()?));
    if (class, id) == (NAV_PVT.0, NAV_PVT.1) {
        return Some(UbxMessage::NavPvt(NavPvt {
            itow_ms: u32_at(0)?,
            fix_type: *p.get(20)?,
            flags: *p.get(21)?,
            num_sv: *p.get(23)?,
            lon_e7: i32_at(24)?,
            lat_e7: i32_at(28)?,
            height_mm: i32_at(32)?,
            h_acc_mm: u32_at(40)?,
            v_acc_mm: u32_at(44)?,
            vel_ned_mm_s: [i32_at(48)?, i32_at(52)?, i32_at(56)?],
            s_acc_mm_s: u32_at(68)?,
        }));
    }
    let u16_at = |o: usize| Some(u16::from_le_bytes(p.get(o..o + 2)?.try_into().ok()?));
    if (class, id) == (TIM_TP.0, TIM_TP.1) {
        return Some(UbxMessage::TimTp(TimTp {
            tow_ms: u32_at(0)?,
            tow_sub_ms: u32_at(4)?,
            q_err_ps: i32_at(8)?,
            week: u16_at(12)?,
            flags: *p.get(14)?,
            ref_info: *p.get(15)?,
        }));
    }
    // NAV-TIMEGPS; valid (offset 11): bit 0 towValid, bit 1 weekValid, bit 2 leapSValid.
    let valid = *p.get(11)?;
    let leap = i8::from_le_bytes([*p.get(10)?]);
    Some(UbxMessage::NavTimeGps {
        itow_ms: u32_at(0)?,
        week: (valid & 0b11 == 0b11).then_some(u16_at(8)?),
        leap_s: (valid & 0b100 != 0).then_some(leap),
    })
}

/// Why a `NAV-PVT` gave no fix, or a `TIM-TP` no pulse time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct UbxDrops {
    /// Not a 3D fix, or `gnssFixOK` clear.
    pub no_fix: u32,
    /// No GPS week yet.
    pub no_week: u32,
    /// A `TIM-TP` on another GNSS's time, or on UTC before GPS - UTC (`NAV-TIMEGPS`'s leap
    /// seconds) is known.
    pub time_base: u32,
}

/// The GPS time of the receiver's next time pulse, from `TIM-TP`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimePulse {
    /// GPS seconds since 1980 at the pulse.
    pub t: f64,
    /// The message.
    pub tp: TimTp,
}

/// What [`UbxFixes::push_any`] reads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum UbxEvent {
    /// A good 3D fix.
    Fix(UbxFix),
    /// The time of the next time pulse.
    Pulse(TimePulse),
}

/// [`LiveFix`]es and pulse times from a UBX byte stream: a [`UbxDecoder`] and the GPS week.
#[derive(Debug, Clone)]
pub struct UbxFixes {
    decoder: UbxDecoder,
    /// The week, and the time of week [ms] of the last message in it (none when the week was
    /// given and no solution has come yet).
    week: Option<(u16, Option<u32>)>,
    /// GPS - UTC [s], once `NAV-TIMEGPS` gives it.
    leap_s: Option<i8>,
    drops: UbxDrops,
}

impl UbxFixes {
    /// Fixes from a stream; `week` is the GPS week at the start when known (else the first
    /// valid `NAV-TIMEGPS` gives it).
    pub const fn new(week: Option<u16>) -> Self {
        Self {
            decoder: UbxDecoder::new(),
            week: match week {
                Some(w) => Some((w, None)),
                None => None,
            },
            leap_s: None,
            drops: UbxDrops {
                no_fix: 0,
                no_week: 0,
                time_base: 0,
            },
        }
    }

    /// The message decoder (for its count of rejected messages).
    pub fn decoder(&self) -> &UbxDecoder {
        &self.decoder
    }

    /// The solutions that gave no fix so far.
    pub fn drops(&self) -> UbxDrops {
        self.drops
    }

    /// Takes one byte; returns a fix when a `NAV-PVT` with a good 3D solution completes.
    pub fn push(&mut self, b: u8) -> Option<UbxFix> {
        match self.push_any(b)? {
            UbxEvent::Fix(f) => Some(f),
            UbxEvent::Pulse(_) => None,
        }
    }

    /// Takes one byte; returns a fix as [`push`](Self::push) does, or the GPS time of the next
    /// time pulse when a `TIM-TP` on GPS time (or on UTC with the leap seconds known)
    /// completes.
    pub fn push_any(&mut self, b: u8) -> Option<UbxEvent> {
        match self.decoder.push(b)? {
            UbxMessage::NavTimeGps {
                itow_ms,
                week,
                leap_s,
            } => {
                if let Some(w) = week {
                    self.week = Some((w, Some(itow_ms)));
                }
                self.leap_s = leap_s.or(self.leap_s);
                None
            }
            UbxMessage::TimTp(tp) => {
                let Some(t) = pulse_time(&tp, self.leap_s) else {
                    let d = &mut self.drops;
                    d.time_base = d.time_base.saturating_add(1);
                    return None;
                };
                Some(UbxEvent::Pulse(TimePulse { t, tp }))
            }
            UbxMessage::NavPvt(p) => {
                let d = &mut self.drops;
                if !solution_ok(&p) {
                    d.no_fix = d.no_fix.saturating_add(1);
                    return None;
                }
                let Some((week, at)) = self.week else {
                    d.no_week = d.no_week.saturating_add(1);
                    return None;
                };
                // The epoch's week (its turn followed), and the time of week it is last seen at.
                let week = epoch_week(week, at, p.itow_ms);
                self.week = Some((week, Some(p.itow_ms)));
                Some(UbxEvent::Fix(UbxFix {
                    t: f64::from(week) * WEEK_S + f64::from(p.itow_ms) / 1000.0,
                    pvt: p,
                }))
            }
        }
    }
}

/// GPS seconds since 1980 at a `TIM-TP`'s pulse: its week and time of week in GPS time
/// (`timeBase` GNSS, `timeRefGnss` GPS), or in UTC plus the leap seconds (GPS = UTC + leap).
fn pulse_time(tp: &TimTp, leap_s: Option<i8>) -> Option<f64> {
    let utc = tp.flags & 1 == 1;
    let shift = match (utc, leap_s) {
        (false, _) if tp.ref_info & 0x0F == 0 => 0.0,
        (true, Some(l)) if tp.flags & 0b10 != 0 => f64::from(l),
        _ => return None,
    };
    // towSubMS is 2^-32 ms.
    let sub = f64::from(tp.tow_sub_ms) * (1.0 / 4_294_967_296.0);
    Some(f64::from(tp.week) * WEEK_S + (f64::from(tp.tow_ms) + sub) / 1000.0 + shift)
}

/// A good 3D solution and its time of validity [s] (GPS seconds since 1980).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UbxFix {
    /// Time of validity [s].
    pub t: f64,
    /// The message.
    pub pvt: NavPvt,
}

impl UbxFix {
    /// The fix a live run takes.
    pub fn live(&self) -> LiveFix {
        let p = &self.pvt;
        LiveFix {
            t: self.t,
            pos: Geodetic {
                lat: p.lat_deg().to_radians(),
                lon: p.lon_deg().to_radians(),
                h: p.height_m(),
            },
            vel: Some(p.vel_ned()),
            sd_pos: p.sd_pos(),
            sd_vel: p.sd_vel(),
        }
    }
}

impl NavPvt {
    /// Latitude [deg].
    pub fn lat_deg(&self) -> f64 {
        f64::from(self.lat_e7) / 1e7
    }

    /// Longitude [deg].
    pub fn lon_deg(&self) -> f64 {
        f64::from(self.lon_e7) / 1e7
    }

    /// Height above the ellipsoid [m].
    pub fn height_m(&self) -> f64 {
        f64::from(self.height_mm) / 1000.0
    }

    /// NED velocity [m/s].
    pub fn vel_ned(&self) -> [f64; 3] {
        self.vel_ned_mm_s.map(|v| f64::from(v) / 1000.0)
    }

    /// Position standard deviations N, E, D [m] (`hAcc`, `hAcc`, `vAcc`; none when either is 0).
    pub fn sd_pos(&self) -> Option<[f64; 3]> {
        let (h, v) = (self.h_acc_mm, self.v_acc_mm);
        (h > 0 && v > 0).then(|| {
            let (h, v) = (f64::from(h) / 1000.0, f64::from(v) / 1000.0);
            [h, h, v]
        })
    }

    /// Velocity standard deviations [m/s] (`sAcc` on each axis; none when 0).
    pub fn sd_vel(&self) -> Option<[f64; 3]> {
        (self.s_acc_mm_s > 0).then(|| [f64::from(self.s_acc_mm_s) / 1000.0; 3])
    }
}

/// A 3D solution (or GNSS + dead reckoning) that the receiver marks good (`gnssFixOK`).
fn solution_ok(p: &NavPvt) -> bool {
    (p.fix_type == 3 || p.fix_type == 4) && p.flags & 1 == 1
}

/// The week of an epoch at `itow_ms`, given a `week` whose last message was at `at` [ms]: a
/// time of week more than half a week before it is in the next week, more than half a week
/// after it in the previous one (the two messages of one epoch can straddle the turn).
fn epoch_week(week: u16, at: Option<u32>, itow_ms: u32) -> u16 {
    match at {
        Some(at) if itow_ms.saturating_add(HALF_WEEK_MS) < at => week.saturating_add(1),
        Some(at) if itow_ms > at.saturating_add(HALF_WEEK_MS) => week.saturating_sub(1),
        _ => week,
    }
}

#[cfg(test)]
#[path = "tests.rs"]
mod tests;
