//! IMU samples on a serial line: one CRC frame per sample, the wire form of the samples a
//! [`LiveNav`](super::live::LiveNav) takes.
//!
//! `A5 5B | t f64 LE | gx gy gz f32 LE | ax ay az f32 LE | CRC-32 LE` (38 bytes; the CRC, IEEE
//! as zlib, over the 32 bytes between the sync and itself). `t` is the time of validity [s] on
//! the GNSS time scale (GPS seconds since 1980 when the fixes come from
//! [`ubx`](super::ubx) with their week): the sender, a sensor hub or an IMU with a PPS input,
//! stamps the samples. Rates in rad/s, body frame forward-right-down; specific force in m/s^2.
//! The values are single precision, as the navigator on the MCU reads them (a live replay
//! carries the same `f32`).
//!
//! The sync differs from the observation frames' ([`crate::edge::SYNC`]), so the two decoders
//! can share a line. At 100 Hz the frames take 3 800 B/s (38 400 baud with 8N1's 10 bits a
//! byte); at 400 Hz, 15 200 B/s (460 800 baud leaves room for the GNSS).
//!
//! ```
//! use imu_ident::nav::imu_frame::{encode_imu_frame, ImuFrameDecoder, ImuSample};
//! let s = ImuSample { t: 1_436_038_461.73, gyro: [0.01, -0.02, 0.003], accel: [0.1, 0.2, -9.8] };
//! let mut dec = ImuFrameDecoder::new();
//! let mut got = None;
//! for b in [0x00, 0xA5].iter().chain(encode_imu_frame(&s).iter()) {
//!     got = got.or(dec.push(*b));
//! }
//! assert_eq!(got, Some(s));
//! ```

use crate::crc::{seal_frame, CrcFrames};

/// Two sync bytes that start every IMU frame.
pub const IMU_SYNC: [u8; 2] = [0xA5, 0x5B];
/// IMU frame length: sync (2), `t` f64 (8), six f32 (24), CRC-32 (4).
pub const IMU_FRAME_LEN: usize = 38;

/// One IMU sample as it travels.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ImuSample {
    /// Time of validity [s].
    pub t: f64,
    /// Angular rate, body frame [rad/s].
    pub gyro: [f32; 3],
    /// Specific force, body frame [m/s^2].
    pub accel: [f32; 3],
}

/// Encodes one sample as a frame.
pub fn encode_imu_frame(s: &ImuSample) -> [u8; IMU_FRAME_LEN] {
    let mut f = [0u8; IMU_FRAME_LEN];
    if let Some(t) = f.get_mut(2..10) {
        t.copy_from_slice(&s.t.to_le_bytes());
    }
    for (k, v) in s.gyro.iter().chain(s.accel.iter()).enumerate() {
        if let Some(d) = f.get_mut(10 + 4 * k..14 + 4 * k) {
            d.copy_from_slice(&v.to_le_bytes());
        }
    }
    seal_frame(IMU_SYNC, &mut f);
    f
}

/// Byte-at-a-time IMU frame decoder ([`CrcFrames`]: resynchronises after noise, counts bad
/// CRCs). It checks the frame, not the values: a sample with a NaN is the navigator's to
/// refuse.
#[derive(Debug, Clone)]
pub struct ImuFrameDecoder {
    frames: CrcFrames<IMU_FRAME_LEN>,
}

impl Default for ImuFrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl ImuFrameDecoder {
    /// An empty decoder.
    pub const fn new() -> Self {
        Self {
            frames: CrcFrames::new(IMU_SYNC),
        }
    }

    /// Frames with a good sync but a bad CRC so far.
    pub fn rejected(&self) -> u32 {
        self.frames.rejected()
    }

    /// Takes one byte; returns a sample when its frame completes with a valid CRC.
    pub fn push(&mut self, byte: u8) -> Option<ImuSample> {
        sample_of(&self.frames.push(byte)?)
    }
}

/// The sample a frame (sync and CRC included, checked) carries.
pub(crate) fn sample_of(f: &[u8]) -> Option<ImuSample> {
    let word = |k: usize| -> Option<f32> {
        Some(f32::from_le_bytes(
            f.get(10 + 4 * k..14 + 4 * k)?.try_into().ok()?,
        ))
    };
    Some(ImuSample {
        t: f64::from_le_bytes(f.get(2..10)?.try_into().ok()?),
        gyro: [word(0)?, word(1)?, word(2)?],
        accel: [word(3)?, word(4)?, word(5)?],
    })
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use std::vec::Vec;

    #[test]
    fn every_single_bit_flip_is_rejected_and_the_next_frame_is_found() {
        let s = ImuSample {
            t: 12.5,
            gyro: [1.0, -2.0, 3.0],
            accel: [0.5, 0.25, -9.75],
        };
        let f = encode_imu_frame(&s);
        for bit in 16..IMU_FRAME_LEN * 8 {
            let mut g = f;
            g[bit / 8] ^= 1 << (bit % 8);
            let mut dec = ImuFrameDecoder::new();
            assert!(g.iter().all(|b| dec.push(*b).is_none()), "bit {bit}");
            let next: Vec<_> = f.iter().filter_map(|b| dec.push(*b)).collect();
            assert_eq!(next, [s], "bit {bit}");
        }
    }

    #[test]
    fn observation_frames_on_the_same_line_are_not_samples() {
        let row = crate::edge::encode_frame(crate::replay::Row { t: 1.0, z: 2.0 });
        let s = ImuSample {
            t: 2.0,
            ..ImuSample::default()
        };
        let mut dec = ImuFrameDecoder::new();
        let got: Vec<_> = row
            .iter()
            .chain(encode_imu_frame(&s).iter())
            .chain(row.iter())
            .filter_map(|b| dec.push(*b))
            .collect();
        assert_eq!(got, [s]);
    }
}
