//! The hardware edge: small traits the core owns, and adapters from the embedded-hal 1.0 /
//! embedded-io 0.6 traits that board crates implement.
//!
//! - [`ObservationSource`]: where the velocity observations come from. [`SerialSource`] reads
//!   CRC-framed messages ([frame format](FrameDecoder)) from any `embedded_io::Read + ReadReady`
//!   serial port without blocking.
//! - [`Tick`]: what paces the 1 Hz loop. [`DelayTick`] waits on any `embedded_hal::delay::DelayNs`;
//!   a board with a hardware timer implements [`Tick`] on it directly.
//! - The telemetry sink is [`TelemetrySink`](crate::telemetry::TelemetrySink).
//!
//! Fault injection wraps a source, as in smoltcp: the core never knows.
//!
//! ```
//! use imu_ident::edge::{encode_frame, FrameDecoder, FRAME_LEN};
//! use imu_ident::replay::Row;
//! let frame = encode_frame(Row { t: 12.0, z: 0.25 });
//! let mut dec = FrameDecoder::new();
//! // Line noise before the frame is skipped; a corrupted copy is rejected and counted.
//! let mut bad = frame;
//! bad[7] ^= 0x10;
//! let mut got = None;
//! for b in [0x00, 0x55].iter().chain(bad.iter()).chain(frame.iter()) {
//!     if let Some(row) = dec.push(*b) {
//!         got = Some(row);
//!     }
//! }
//! assert_eq!(got, Some(Row { t: 12.0, z: 0.25 }));
//! assert_eq!(dec.rejected(), 1);
//! assert_eq!(frame.len(), FRAME_LEN);
//! ```

use crate::crc::{seal_frame, CrcFrames};
use crate::replay::Row;

/// Two sync bytes that start every frame.
pub const SYNC: [u8; 2] = [0xA5, 0x5A];
/// Frame length: sync (2), `t` f64 (8), `z` f32 (4), CRC-32 of `t` and `z` (4).
pub const FRAME_LEN: usize = 18;

/// A source of observations, polled once per tick.
pub trait ObservationSource {
    /// What the transport can fail with.
    type Error;
    /// The newest complete observation received since the last poll, if any. Must not block.
    fn poll(&mut self) -> Result<Option<Row>, Self::Error>;
}

/// What paces the loop: returns at the next tick.
pub trait Tick {
    /// Blocks until the next tick.
    fn wait(&mut self);
}

/// A [`Tick`] from a delay provider: waits a fixed period after the previous return (drifts by
/// the loop's own run time; a hardware timer does not).
#[derive(Debug)]
pub struct DelayTick<D> {
    delay: D,
    period_us: u32,
}

impl<D: embedded_hal::delay::DelayNs> DelayTick<D> {
    /// Ticks every `period_us` microseconds.
    pub fn new(delay: D, period_us: u32) -> Self {
        Self { delay, period_us }
    }
}

impl<D: embedded_hal::delay::DelayNs> Tick for DelayTick<D> {
    fn wait(&mut self) {
        self.delay.delay_us(self.period_us);
    }
}

/// Encodes one observation as a frame: `SYNC | t (f64 LE) | z (f32 LE) | CRC-32 (LE)` where the
/// CRC (IEEE, as zlib) covers `t` and `z`.
pub fn encode_frame(row: Row) -> [u8; FRAME_LEN] {
    let mut f = [0u8; FRAME_LEN];
    if let Some(t) = f.get_mut(2..10) {
        t.copy_from_slice(&row.t.to_le_bytes());
    }
    if let Some(z) = f.get_mut(10..14) {
        z.copy_from_slice(&row.z.to_le_bytes());
    }
    seal_frame(SYNC, &mut f);
    f
}

/// Byte-at-a-time frame decoder that resynchronises after noise or corruption.
///
/// A [`CrcFrames`] of [`FRAME_LEN`] bytes behind [`SYNC`], whose frames are read as [`Row`]s.
/// Constant memory, no panics.
#[derive(Debug, Clone)]
pub struct FrameDecoder {
    frames: CrcFrames<FRAME_LEN>,
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameDecoder {
    /// An empty decoder.
    pub const fn new() -> Self {
        Self {
            frames: CrcFrames::new(SYNC),
        }
    }

    /// Frames with a good sync but a bad CRC so far.
    pub fn rejected(&self) -> u32 {
        self.frames.rejected()
    }

    /// Takes one byte; returns a frame when one completes with a valid CRC.
    pub fn push(&mut self, byte: u8) -> Option<Row> {
        let f = self.frames.push(byte)?;
        let t = f64::from_le_bytes(f.get(2..10)?.try_into().ok()?);
        let z = f32::from_le_bytes(f.get(10..14)?.try_into().ok()?);
        Some(Row { t, z })
    }
}

/// Largest number of bytes one [`SerialSource::poll`] reads (bounds the work per tick: a few
/// frames' worth at 115200 baud and 1 Hz would be 11520; a backlog beyond this waits).
pub const MAX_BYTES_PER_POLL: usize = 1024;

/// Observations as CRC frames from a serial port.
#[derive(Debug)]
pub struct SerialSource<R> {
    rx: R,
    decoder: FrameDecoder,
    superseded: u32,
}

impl<R: embedded_io::Read + embedded_io::ReadReady> SerialSource<R> {
    /// Reads frames from `rx`.
    pub fn new(rx: R) -> Self {
        Self {
            rx,
            decoder: FrameDecoder::new(),
            superseded: 0,
        }
    }

    /// The frame decoder (for its CRC rejection count).
    pub fn decoder(&self) -> &FrameDecoder {
        &self.decoder
    }

    /// Frames received but replaced by a newer one before a tick used them.
    pub fn superseded(&self) -> u32 {
        self.superseded
    }
}

impl<R: embedded_io::Read + embedded_io::ReadReady> ObservationSource for SerialSource<R> {
    type Error = R::Error;

    fn poll(&mut self) -> Result<Option<Row>, R::Error> {
        let mut newest = None;
        let (decoder, superseded) = (&mut self.decoder, &mut self.superseded);
        crate::port::read_ready(&mut self.rx, MAX_BYTES_PER_POLL, |b| {
            if let Some(row) = decoder.push(b) {
                if newest.is_some() {
                    *superseded = superseded.saturating_add(1);
                }
                newest = Some(row);
            }
        })?;
        Ok(newest)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_survive_noise_and_sync_bytes_in_payload() {
        // A payload that itself contains the sync pattern.
        let tricky = Row {
            t: f64::from_le_bytes([0xA5, 0x5A, 0xA5, 0x5A, 0, 0, 0xF0, 0x3F]),
            z: -1.5,
        };
        let mut stream = [0u8; 3 * FRAME_LEN + 3];
        stream[0] = 0xA5; // a lone sync byte
        stream[1..1 + FRAME_LEN].copy_from_slice(&encode_frame(tricky));
        stream[1 + FRAME_LEN] = 0x5A;
        stream[2 + FRAME_LEN..2 + 2 * FRAME_LEN].copy_from_slice(&encode_frame(Row {
            t: 3.0,
            z: f32::NAN,
        }));
        let mut dec = FrameDecoder::new();
        let mut out = [Row::default(); 4];
        let mut n = 0;
        for b in stream {
            if let Some(r) = dec.push(b) {
                out[n] = r;
                n += 1;
            }
        }
        assert_eq!(n, 2);
        assert_eq!(out[0], tricky);
        assert_eq!(out[1].t, 3.0);
        assert!(out[1].z.is_nan());
    }

    #[test]
    fn every_single_bit_flip_is_rejected() {
        let f = encode_frame(Row { t: 1.0e6, z: 0.125 });
        for bit in 16..FRAME_LEN * 8 {
            let mut g = f;
            g[bit / 8] ^= 1 << (bit % 8);
            let mut dec = FrameDecoder::new();
            assert!(g.iter().all(|b| dec.push(*b).is_none()), "bit {bit}");
        }
    }
}
