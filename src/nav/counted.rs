//! IMU samples counted by a local timer, and the receiver's time pulses captured on the same
//! timer: the frames of a sensor hub with no GPS time, and one decoder for every IMU frame on
//! a line ([`SampleFrames`]).
//!
//! The frames of [`imu_frame`](super::imu_frame) carry each sample's GPS time: their sender
//! stamps them. A hub (or an IMU) that has only its own free-running counter sends the count
//! instead, and captures the receiver's `TIMEPULSE` edges on that counter:
//! - a counted sample, `A5 5C | count u32 LE | gx gy gz f32 LE | ax ay az f32 LE | CRC-32 LE`
//!   (34 bytes);
//! - a pulse edge, `A5 5D | count u32 LE | CRC-32 LE` (10 bytes);
//!
//! the CRC (IEEE, as zlib) over the bytes between the sync and itself, as for every frame of
//! the project ([`CrcFrames`]). The receiver's `TIM-TP` messages (the GPS time of the next
//! pulse) come on the GNSS port as before. [`NavWire`](super::serial::NavWire) reads all of
//! them, and a [`TimerStamps`](super::serial::TimerStamps) puts the counted samples on GPS
//! time through a [`GpsClock`](super::gps_clock::GpsClock) before the navigator takes them.
//!
//! ```
//! use imu_ident::nav::counted::{encode_counted_sample, encode_edge, CountedSample};
//! use imu_ident::nav::gps_clock::ClockConfig;
//! use imu_ident::nav::serial::{NavInput, NavWire, TimerStamps};
//! use imu_ident::nav::ubx::{encode_tim_tp, tim_tp_at};
//! let hz = 1e6; // a 1-MHz counter, 30 ppm fast
//! let t0 = 2374.0 * 604_800.0;
//! let count = |t: f64| ((t - t0 + 5.0) * hz * (1.0 + 30e-6)) as u64 as u32;
//! let mut bytes = Vec::new();
//! for k in 0..5 {
//!     let pulse = t0 + f64::from(k);
//!     let s = CountedSample { count: count(pulse - 0.7), ..CountedSample::default() };
//!     bytes.extend(encode_counted_sample(&s));
//!     bytes.extend(encode_tim_tp(&tim_tp_at(pulse))); // 0.6 s before its pulse
//!     bytes.extend(encode_edge(count(pulse)));
//! }
//! let s = CountedSample { count: count(t0 + 4.25), ..CountedSample::default() };
//! bytes.extend(encode_counted_sample(&s));
//! let (mut wire, mut stamps) = (NavWire::new(None), TimerStamps::new(ClockConfig::crystal(hz)).unwrap());
//! let mut times = Vec::new();
//! for b in bytes {
//!     wire.push(b, &mut |i| if let Some(NavInput::Imu(s)) = stamps.stamp(i) { times.push(s.t) });
//! }
//! // The first two samples came before the lock (two pulses); the others are on GPS time.
//! assert_eq!((times.len(), stamps.unstamped()), (4, 2));
//! assert!((times[0] - (t0 + 1.3)).abs() < 3e-6 && (times[3] - (t0 + 4.25)).abs() < 3e-6);
//! ```

use super::imu_frame::{sample_of, ImuSample, IMU_FRAME_LEN, IMU_SYNC};
use crate::crc::{seal_frame, CrcFrames};

/// Two sync bytes that start every counted-sample frame.
pub const COUNTED_SYNC: [u8; 2] = [0xA5, 0x5C];
/// Counted-sample frame length: sync (2), count (4), six f32 (24), CRC-32 (4).
pub const COUNTED_FRAME_LEN: usize = 34;
/// Two sync bytes that start every pulse-edge frame.
pub const EDGE_SYNC: [u8; 2] = [0xA5, 0x5D];
/// Pulse-edge frame length: sync (2), count (4), CRC-32 (4).
pub const EDGE_FRAME_LEN: usize = 10;

/// One IMU sample stamped with the hub's counter.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CountedSample {
    /// The counter at the sample's time of validity (a `u32` timer's, wraps and all).
    pub count: u32,
    /// Angular rate, body frame [rad/s].
    pub gyro: [f32; 3],
    /// Specific force, body frame [m/s^2].
    pub accel: [f32; 3],
}

impl CountedSample {
    /// The sample at GPS time `t`.
    pub fn at(&self, t: f64) -> ImuSample {
        ImuSample {
            t,
            gyro: self.gyro,
            accel: self.accel,
        }
    }
}

/// Encodes one counted sample as a frame.
pub fn encode_counted_sample(s: &CountedSample) -> [u8; COUNTED_FRAME_LEN] {
    let mut f = [0u8; COUNTED_FRAME_LEN];
    let values = s.gyro.iter().chain(&s.accel).map(|v| v.to_bits());
    for (k, w) in core::iter::once(s.count).chain(values).enumerate() {
        if let Some(d) = f.get_mut(2 + 4 * k..6 + 4 * k) {
            d.copy_from_slice(&w.to_le_bytes());
        }
    }
    seal_frame(COUNTED_SYNC, &mut f);
    f
}

/// Encodes one pulse edge captured at `count` as a frame.
pub fn encode_edge(count: u32) -> [u8; EDGE_FRAME_LEN] {
    let mut f = [0u8; EDGE_FRAME_LEN];
    if let Some(d) = f.get_mut(2..6) {
        d.copy_from_slice(&count.to_le_bytes());
    }
    seal_frame(EDGE_SYNC, &mut f);
    f
}

/// What a [`SampleFrames`] completes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SampleFrame {
    /// A sample with its GPS time ([`imu_frame`](super::imu_frame)).
    Stamped(ImuSample),
    /// A counted sample.
    Counted(CountedSample),
    /// A pulse edge at this count.
    Edge(u32),
}

/// Byte-at-a-time decoder of every IMU frame on a line: GPS-stamped samples, counted samples
/// and pulse edges, in one [`CrcFrames`] search (resynchronises after noise, counts bad CRCs;
/// a sync pattern inside one kind's frame is not tried as another's).
#[derive(Debug, Clone)]
pub struct SampleFrames {
    frames: CrcFrames<IMU_FRAME_LEN, 3>,
}

impl Default for SampleFrames {
    fn default() -> Self {
        Self::new()
    }
}

impl SampleFrames {
    /// An empty decoder.
    pub const fn new() -> Self {
        Self {
            frames: CrcFrames::of_kinds([
                (IMU_SYNC, IMU_FRAME_LEN),
                (COUNTED_SYNC, COUNTED_FRAME_LEN),
                (EDGE_SYNC, EDGE_FRAME_LEN),
            ]),
        }
    }

    /// Frames with a good sync but a bad CRC so far.
    pub fn rejected(&self) -> u32 {
        self.frames.rejected()
    }

    /// Takes one byte; returns a frame when one completes with a valid CRC.
    pub fn push(&mut self, byte: u8) -> Option<SampleFrame> {
        let f = self.frames.push(byte)?;
        let w = |k: usize| word(&f, k);
        let v = |k: usize| w(k).map(f32::from_bits);
        match f.get(..2)? {
            s if s == IMU_SYNC => sample_of(&f).map(SampleFrame::Stamped),
            s if s == COUNTED_SYNC => Some(SampleFrame::Counted(CountedSample {
                count: w(0)?,
                gyro: [v(1)?, v(2)?, v(3)?],
                accel: [v(4)?, v(5)?, v(6)?],
            })),
            _ => w(0).map(SampleFrame::Edge),
        }
    }
}

/// The `k`-th little-endian word after a frame's sync.
fn word(f: &[u8], k: usize) -> Option<u32> {
    Some(u32::from_le_bytes(
        f.get(2 + 4 * k..6 + 4 * k)?.try_into().ok()?,
    ))
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use std::vec::Vec;

    #[test]
    fn every_single_bit_flip_is_rejected_and_the_next_frame_is_found() {
        let s = CountedSample {
            count: 0xDEAD_BEEF,
            gyro: [1.0, -2.0, 3.0],
            accel: [0.5, 0.25, -9.75],
        };
        let frames = [
            (encode_counted_sample(&s).to_vec(), SampleFrame::Counted(s)),
            (
                encode_edge(0x0102_0304).to_vec(),
                SampleFrame::Edge(0x0102_0304),
            ),
        ];
        for (f, want) in &frames {
            for bit in 16..f.len() * 8 {
                let mut g = f.clone();
                g[bit / 8] ^= 1 << (bit % 8);
                let mut dec = SampleFrames::new();
                assert!(g.iter().all(|b| dec.push(*b).is_none()), "bit {bit}");
                assert_eq!(dec.rejected(), 1, "bit {bit}");
                let next: Vec<_> = f.iter().filter_map(|b| dec.push(*b)).collect();
                assert_eq!(next, [*want], "bit {bit}");
            }
        }
    }

    #[test]
    fn every_kind_on_one_line_is_read_and_no_sync_inside_a_frame_is_tried() {
        // Payloads full of the other kinds' sync patterns: one search aligned on the frames
        // it reads never tries them (one decoder per kind would, and count the failures).
        let syncs = f32::from_le_bytes([0xA5, 0x5C, 0xA5, 0x5D]);
        let gps = ImuSample {
            t: f64::from_le_bytes([0xA5, 0x5D, 0xA5, 0x5C, 0xA5, 0x5B, 0, 0]),
            gyro: [syncs; 3],
            accel: [syncs; 3],
        };
        let s = CountedSample {
            count: 0x5DA5_5CA5,
            gyro: [syncs; 3],
            accel: [syncs; 3],
        };
        let edge = 0x5BA5_5DA5;
        let mut line = Vec::new();
        for _ in 0..3 {
            line.extend(crate::nav::imu_frame::encode_imu_frame(&gps));
            line.extend(encode_counted_sample(&s));
            line.extend(encode_edge(edge));
        }
        let mut dec = SampleFrames::new();
        let got: Vec<_> = line.iter().filter_map(|b| dec.push(*b)).collect();
        let want = [
            SampleFrame::Stamped(gps),
            SampleFrame::Counted(s),
            SampleFrame::Edge(edge),
        ];
        assert_eq!(got.len(), 9);
        assert!(got.chunks(3).all(|c| c == want), "{got:?}");
        assert_eq!(dec.rejected(), 0);
    }

    #[test]
    fn a_false_sync_before_a_shorter_frame_loses_nothing() {
        // Bytes that are no frame, with a GPS-stamped sample's sync (the longest kind) `gap`
        // bytes before a pulse edge: the false candidate, rejected, holds the whole edge and
        // the start of the sample after it. Every frame is still read, once.
        let s = CountedSample {
            count: 7,
            gyro: [1.0; 3],
            accel: [2.0; 3],
        };
        for gap in 0..IMU_FRAME_LEN {
            let mut line = Vec::from(IMU_SYNC);
            line.resize(2 + gap, 0);
            line.extend(encode_edge(1));
            line.extend(encode_counted_sample(&s));
            line.extend(encode_edge(2));
            let mut dec = SampleFrames::new();
            let got: Vec<_> = line.iter().filter_map(|b| dec.push(*b)).collect();
            let want = [
                SampleFrame::Edge(1),
                SampleFrame::Counted(s),
                SampleFrame::Edge(2),
            ];
            assert_eq!(got, want, "gap {gap}");
            assert_eq!(dec.rejected(), 1, "gap {gap}");
        }
    }

    #[test]
    fn a_sample_keeps_its_bits() {
        let s = CountedSample {
            count: 1,
            gyro: [f32::NAN, -0.0, 1e-30],
            accel: [f32::INFINITY, 2.5, -9.8],
        };
        let mut dec = SampleFrames::new();
        let got = encode_counted_sample(&s).iter().find_map(|b| dec.push(*b));
        let Some(SampleFrame::Counted(back)) = got else {
            panic!("{got:?}")
        };
        assert_eq!(back.count, 1);
        let at = back.at(12.5);
        assert_eq!(at.t, 12.5);
        assert!(at.gyro[0].is_nan() && at.gyro[1].to_bits() == (-0.0f32).to_bits());
        assert_eq!(at.accel[0], f32::INFINITY);
    }
}
