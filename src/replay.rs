//! A compact binary form of an observation log, read by the firmware and written by the host.
//! The loop that steps through its rows is [`Estimator::push`](crate::step::Estimator::push).
//!
//! # Format (version 1, all integers and floats little-endian)
//!
//! ```text
//! header   magic "IMUR" | version u16 = 1 | row length u16 = 12 | row count u32     12 bytes
//! rows     t f64 [s] | z f32 [m/s]  (z NaN: missing observation)                    12 bytes each
//! trailer  CRC-32 (IEEE 802.3, as zlib) of the header and all rows                   4 bytes
//! ```
//!
//! Time is an `f64` because an `f32` cannot tell 1e7 s from 1e7 s + 1 (its spacing there is 1 s);
//! `f64` keeps sub-microsecond resolution over years. The observation is an `f32`: the firmware
//! filter runs in single precision, and host comparisons replay the same rounded values.
//! The row length is stored so that a later version can append columns (a model id, a second
//! channel) and an old reader still rejects it cleanly instead of misreading it.
//!
//! The [`Decoder`] is a byte-at-a-time state machine: it needs no buffer for the whole log, works
//! with any read size, and returns an error (never panics) for any input. Rows are handed out
//! as soon as they are complete, so the checksum is only known at the end: a consumer must call
//! [`Decoder::finish`] and treat its error as "everything read from this log is suspect".
//!
//! ```
//! use imu_ident::replay::{decode, encode, encoded_len, Row};
//! let rows = [Row { t: 1.0, z: 0.01 }, Row { t: 2.0, z: f32::NAN }];
//! let mut buf = [0u8; 64];
//! let n = encode(&rows, &mut buf).unwrap();
//! assert_eq!(Some(n), encoded_len(rows.len()));
//! let mut seen = 0;
//! assert_eq!(decode(&buf[..n], |_row| seen += 1), Ok(2));
//! assert_eq!(seen, 2);
//! ```

use crate::crc::Crc32;
/// First four bytes of every log.
pub const MAGIC: [u8; 4] = *b"IMUR";
/// Format version written by [`encode`] and accepted by [`Decoder`].
pub const VERSION: u16 = 1;
/// Header length in bytes.
pub const HEADER_LEN: usize = 12;
/// Length of one row in bytes.
pub const ROW_LEN: usize = 12;
/// Trailer (CRC-32) length in bytes.
pub const TRAILER_LEN: usize = 4;

/// One observation of the log.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Row {
    /// Time of the observation [s].
    pub t: f64,
    /// Velocity observation [m/s]; NaN when missing.
    pub z: f32,
}

/// Why a log could not be written or read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ReplayError {
    /// The output buffer is shorter than [`encoded_len`].
    BufferTooSmall,
    /// More rows than a `u32` count can describe.
    TooManyRows,
    /// The data does not start with [`MAGIC`].
    BadMagic,
    /// The header's version is not [`VERSION`].
    BadVersion,
    /// The header's row length is not [`ROW_LEN`].
    BadRowLength,
    /// The data ended before the last row or the checksum.
    Truncated,
    /// The checksum does not match the header and rows.
    BadChecksum,
    /// Bytes follow the checksum.
    TrailingData,
}

impl core::fmt::Display for ReplayError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::BufferTooSmall => "output buffer too small for the log",
            Self::TooManyRows => "too many rows for a u32 count",
            Self::BadMagic => "not a replay log (bad magic)",
            Self::BadVersion => "unsupported replay log version",
            Self::BadRowLength => "unsupported replay row length",
            Self::Truncated => "replay log is truncated",
            Self::BadChecksum => "replay log checksum mismatch",
            Self::TrailingData => "bytes after the end of the replay log",
        })
    }
}

impl core::error::Error for ReplayError {}

/// Number of bytes [`encode`] writes for `rows` rows (`None` if it overflows `usize` or the
/// count does not fit in a `u32`).
pub const fn encoded_len(rows: usize) -> Option<usize> {
    if rows > u32::MAX as usize {
        return None;
    }
    match rows.checked_mul(ROW_LEN) {
        Some(body) => body.checked_add(HEADER_LEN + TRAILER_LEN),
        None => None,
    }
}

/// Writes `rows` into `out`; returns the number of bytes written.
pub fn encode(rows: &[Row], out: &mut [u8]) -> Result<usize, ReplayError> {
    let count = u32::try_from(rows.len()).map_err(|_| ReplayError::TooManyRows)?;
    let len = encoded_len(rows.len()).ok_or(ReplayError::TooManyRows)?;
    let out = out.get_mut(..len).ok_or(ReplayError::BufferTooSmall)?;
    let mut w = Writer {
        out,
        pos: 0,
        crc: Crc32::new(),
    };
    w.put(&MAGIC);
    w.put(&VERSION.to_le_bytes());
    w.put(&(ROW_LEN as u16).to_le_bytes());
    w.put(&count.to_le_bytes());
    for row in rows {
        w.put(&row.t.to_le_bytes());
        w.put(&row.z.to_le_bytes());
    }
    let crc = w.crc.value();
    w.put_raw(&crc.to_le_bytes());
    Ok(w.pos)
}

/// Sequential writer into a slice already checked to be long enough.
struct Writer<'a> {
    out: &'a mut [u8],
    pos: usize,
    crc: Crc32,
}

impl Writer<'_> {
    fn put(&mut self, bytes: &[u8]) {
        self.crc.update(bytes);
        self.put_raw(bytes);
    }

    fn put_raw(&mut self, bytes: &[u8]) {
        // `encode` sized `out` with `encoded_len`, so this always fits; `get_mut` keeps the
        // code free of panicking paths anyway.
        if let Some(dst) = self.out.get_mut(self.pos..self.pos + bytes.len()) {
            dst.copy_from_slice(bytes);
        }
        self.pos += bytes.len();
    }
}

/// Decodes a whole log held in memory, calling `on_row` for each row; returns the row count.
/// Rows are handed out before the checksum is checked (see the module docs).
pub fn decode(bytes: &[u8], mut on_row: impl FnMut(Row)) -> Result<u32, ReplayError> {
    let mut dec = Decoder::new();
    for &b in bytes {
        if let Some(row) = dec.push(b)? {
            on_row(row);
        }
    }
    dec.finish()
}

/// Where the decoder is in the log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    Header,
    Rows,
    Trailer,
    Done,
    Failed(ReplayError),
}

/// Streaming decoder: feed it bytes with [`push`](Self::push), then call
/// [`finish`](Self::finish). After the first error every call returns that error.
#[derive(Debug, Clone)]
pub struct Decoder {
    stage: Stage,
    // Large enough for the header and for a row (both 12 bytes).
    buf: [u8; 12],
    fill: usize,
    crc: Crc32,
    count: u32,
    seen: u32,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// A decoder waiting for the header.
    pub const fn new() -> Self {
        Self {
            stage: Stage::Header,
            buf: [0; 12],
            fill: 0,
            crc: Crc32::new(),
            count: 0,
            seen: 0,
        }
    }

    /// Row count announced by the header, once it has been read.
    pub fn count(&self) -> Option<u32> {
        match self.stage {
            Stage::Header | Stage::Failed(_) => None,
            _ => Some(self.count),
        }
    }

    /// Rows handed out so far.
    pub fn rows_seen(&self) -> u32 {
        self.seen
    }

    /// Consumes one byte; returns a row when that byte completed one.
    pub fn push(&mut self, byte: u8) -> Result<Option<Row>, ReplayError> {
        let need = match self.stage {
            Stage::Failed(e) => return Err(e),
            Stage::Done => return self.fail(ReplayError::TrailingData),
            Stage::Header => HEADER_LEN,
            Stage::Rows => ROW_LEN,
            Stage::Trailer => TRAILER_LEN,
        };
        if let Some(slot) = self.buf.get_mut(self.fill) {
            *slot = byte;
        }
        self.fill += 1;
        if self.fill < need {
            return Ok(None);
        }
        self.fill = 0;
        match self.stage {
            Stage::Header => self.header().map(|()| None),
            Stage::Rows => Ok(Some(self.row())),
            Stage::Trailer => self.trailer().map(|()| None),
            // Handled above; kept total so no byte can reach a panic.
            Stage::Done | Stage::Failed(_) => Ok(None),
        }
    }

    /// Checks that the log ended exactly after a valid checksum; returns the row count.
    pub fn finish(&self) -> Result<u32, ReplayError> {
        match self.stage {
            Stage::Done => Ok(self.count),
            Stage::Failed(e) => Err(e),
            _ => Err(ReplayError::Truncated),
        }
    }

    fn fail<T>(&mut self, e: ReplayError) -> Result<T, ReplayError> {
        self.stage = Stage::Failed(e);
        Err(e)
    }

    fn header(&mut self) -> Result<(), ReplayError> {
        let [m0, m1, m2, m3, v0, v1, r0, r1, c0, c1, c2, c3] = self.buf;
        self.crc.update(&self.buf);
        if [m0, m1, m2, m3] != MAGIC {
            return self.fail(ReplayError::BadMagic);
        }
        if u16::from_le_bytes([v0, v1]) != VERSION {
            return self.fail(ReplayError::BadVersion);
        }
        if usize::from(u16::from_le_bytes([r0, r1])) != ROW_LEN {
            return self.fail(ReplayError::BadRowLength);
        }
        self.count = u32::from_le_bytes([c0, c1, c2, c3]);
        self.stage = if self.count == 0 {
            Stage::Trailer
        } else {
            Stage::Rows
        };
        Ok(())
    }

    fn row(&mut self) -> Row {
        let [t0, t1, t2, t3, t4, t5, t6, t7, z0, z1, z2, z3] = self.buf;
        self.crc.update(&self.buf);
        self.seen = self.seen.saturating_add(1);
        if self.seen >= self.count {
            self.stage = Stage::Trailer;
        }
        Row {
            t: f64::from_le_bytes([t0, t1, t2, t3, t4, t5, t6, t7]),
            z: f32::from_le_bytes([z0, z1, z2, z3]),
        }
    }

    fn trailer(&mut self) -> Result<(), ReplayError> {
        let [c0, c1, c2, c3, ..] = self.buf;
        if u32::from_le_bytes([c0, c1, c2, c3]) != self.crc.value() {
            return self.fail(ReplayError::BadChecksum);
        }
        self.stage = Stage::Done;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec;
    use std::vec::Vec;

    fn sample(n: usize) -> Vec<Row> {
        (0..n)
            .map(|k| Row {
                t: 1.0e7 + k as f64,
                z: if k % 7 == 3 {
                    f32::NAN
                } else {
                    k as f32 * 1e-3
                },
            })
            .collect()
    }

    fn encoded(rows: &[Row]) -> Vec<u8> {
        let mut buf = vec![0u8; encoded_len(rows.len()).unwrap()];
        assert_eq!(encode(rows, &mut buf), Ok(buf.len()));
        buf
    }

    fn decoded(bytes: &[u8]) -> Result<Vec<Row>, ReplayError> {
        let mut rows = Vec::new();
        decode(bytes, |r| rows.push(r))?;
        Ok(rows)
    }

    #[test]
    fn round_trip_keeps_time_exact_at_1e7_s() {
        let rows = sample(50);
        let back = decoded(&encoded(&rows)).unwrap();
        assert_eq!(back.len(), rows.len());
        for (a, b) in rows.iter().zip(&back) {
            assert_eq!(a.t.to_bits(), b.t.to_bits());
            assert_eq!(a.z.to_bits(), b.z.to_bits());
        }
        assert_eq!(back[1].t - back[0].t, 1.0);
    }

    #[test]
    fn empty_log_round_trips() {
        let bytes = encoded(&[]);
        assert_eq!(bytes.len(), HEADER_LEN + TRAILER_LEN);
        assert_eq!(decoded(&bytes), Ok(Vec::new()));
    }

    #[test]
    fn encode_rejects_a_short_buffer() {
        let rows = sample(3);
        let mut buf = vec![0u8; encoded_len(3).unwrap() - 1];
        assert_eq!(encode(&rows, &mut buf), Err(ReplayError::BufferTooSmall));
    }

    #[test]
    fn every_truncation_is_reported() {
        let bytes = encoded(&sample(4));
        for n in 0..bytes.len() {
            assert_eq!(
                decoded(&bytes[..n]),
                Err(ReplayError::Truncated),
                "length {n}"
            );
        }
    }

    #[test]
    fn every_single_bit_flip_is_detected() {
        let bytes = encoded(&sample(5));
        for i in 0..bytes.len() * 8 {
            let mut bad = bytes.clone();
            bad[i / 8] ^= 1 << (i % 8);
            assert!(decoded(&bad).is_err(), "bit {i} flipped undetected");
        }
    }

    #[test]
    fn header_errors_are_specific() {
        let good = encoded(&sample(2));
        let mut bad = good.clone();
        bad[0] = b'X';
        assert_eq!(decoded(&bad), Err(ReplayError::BadMagic));
        let mut bad = good.clone();
        bad[4] = 2;
        assert_eq!(decoded(&bad), Err(ReplayError::BadVersion));
        let mut bad = good.clone();
        bad[6] = 16;
        assert_eq!(decoded(&bad), Err(ReplayError::BadRowLength));
        // A count larger than the data: the rows run into the end.
        let mut bad = good.clone();
        bad[8] = 3;
        assert_eq!(decoded(&bad), Err(ReplayError::Truncated));
        let mut bad = good;
        bad.push(0);
        assert_eq!(decoded(&bad), Err(ReplayError::TrailingData));
    }

    #[test]
    fn errors_are_sticky() {
        let mut dec = Decoder::new();
        assert_eq!(dec.push(b'X'), Ok(None));
        for b in [0u8; 11] {
            let _ = dec.push(b);
        }
        assert_eq!(dec.push(0), Err(ReplayError::BadMagic));
        assert_eq!(dec.finish(), Err(ReplayError::BadMagic));
    }

    #[test]
    fn arbitrary_bytes_never_panic() {
        // A small xorshift generator: random garbage, random prefixes of a valid log, and
        // random corruptions of one, in every length up to a few rows.
        let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        let good = encoded(&sample(6));
        for _ in 0..2000 {
            let len = (next() % 120) as usize;
            let mut bytes: Vec<u8> = (0..len).map(|_| next() as u8).collect();
            if next() % 2 == 0 {
                bytes = good.clone();
                let i = (next() as usize) % bytes.len();
                bytes[i] = next() as u8;
                bytes.truncate((next() as usize) % (good.len() + 1));
            }
            let _ = decoded(&bytes);
        }
    }
}
