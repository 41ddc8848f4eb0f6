//! The checksum of the binary formats (log replay, model file, frames at the hardware edge),
//! and the search for CRC-framed messages in a byte stream ([`CrcFrames`]).

/// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320, as zlib and PNG), with a 16-entry
/// table: 64 bytes of flash instead of 1 KiB, at two lookups per byte, which is plenty for a
/// log read once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Crc32(u32);

const CRC_NIBBLE: [u32; 16] = {
    let mut t = [0u32; 16];
    let mut i = 0;
    while i < 16 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 4 {
            c = if c & 1 != 0 {
                (c >> 1) ^ 0xEDB8_8320
            } else {
                c >> 1
            };
            k += 1;
        }
        t[i] = c;
        i += 1;
    }
    t
};

impl Default for Crc32 {
    fn default() -> Self {
        Self::new()
    }
}

impl Crc32 {
    /// A fresh checksum.
    pub const fn new() -> Self {
        Self(0xFFFF_FFFF)
    }

    /// Adds `bytes` to the checksum.
    pub fn update(&mut self, bytes: &[u8]) {
        let mut c = self.0;
        for &b in bytes {
            c ^= u32::from(b);
            // The mask keeps the index below 16, so the lookups cannot go out of bounds.
            c = (c >> 4) ^ CRC_NIBBLE[(c & 0xF) as usize];
            c = (c >> 4) ^ CRC_NIBBLE[(c & 0xF) as usize];
        }
        self.0 = c;
    }

    /// The checksum of everything added so far.
    pub const fn value(&self) -> u32 {
        !self.0
    }
}

/// The search for fixed-length CRC frames in a byte stream: `sync (2) | payload | CRC-32 (LE)`,
/// the CRC (IEEE, as zlib) over the payload. The observation frames of [`crate::edge`] and the IMU
/// sample frames of [`crate::nav::imu_frame`] are two lengths of it.
///
/// It keeps the last `LEN` bytes; when they start with the sync and the CRC matches, the frame
/// is returned and the buffer cleared. A frame whose CRC fails is counted in
/// [`rejected`](Self::rejected) and the search continues one byte later, so a sync pattern
/// inside the payload never locks the decoder out. Constant memory, no panics (a `LEN` below
/// 6 never yields a frame).
#[derive(Debug, Clone)]
pub struct CrcFrames<const LEN: usize> {
    sync: [u8; 2],
    buf: [u8; LEN],
    len: usize,
    rejected: u32,
}

impl<const LEN: usize> CrcFrames<LEN> {
    /// An empty search for frames behind `sync`.
    pub const fn new(sync: [u8; 2]) -> Self {
        Self {
            sync,
            buf: [0; LEN],
            len: 0,
            rejected: 0,
        }
    }

    /// Frames with a good sync but a bad CRC so far.
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// Takes one byte; returns the whole frame (sync and CRC included) when one completes with
    /// a valid CRC.
    pub fn push(&mut self, byte: u8) -> Option<[u8; LEN]> {
        if self.len == 0 && Some(&byte) != self.sync.first() {
            // Not a frame's start: nothing to keep (the common case between frames).
            return None;
        }
        if self.len >= LEN {
            // Full without a valid frame: drop the oldest byte (a sliding window).
            self.slide();
        }
        *self.buf.get_mut(self.len)? = byte;
        self.len += 1;
        // Drop leading bytes that cannot start a frame, so the window stays aligned on a sync.
        self.align();
        if self.len < LEN {
            return None;
        }
        if crc_ok(&self.buf) {
            self.len = 0;
            return Some(self.buf);
        }
        self.rejected = self.rejected.saturating_add(1);
        // Slide by one and re-align on the next candidate sync.
        self.slide();
        self.align();
        None
    }

    /// Drops the oldest buffered byte (moving only the bytes held).
    fn slide(&mut self) {
        self.len = drop_first(&mut self.buf, self.len);
    }

    /// Drops leading bytes until the buffer agrees with the sync as far as it goes.
    fn align(&mut self) {
        while self.len > 0 {
            let n = self.len.min(self.sync.len());
            if self.buf.get(..n) == self.sync.get(..n) {
                break;
            }
            self.slide();
        }
    }
}

/// Drops the first of the `len` bytes held at the start of `buf`; returns the new count. A
/// loop of checked accesses: `copy_within` with a range known only at run time keeps a panic
/// path the link-time proof refuses (RELIABILITY.md).
pub(crate) fn drop_first(buf: &mut [u8], len: usize) -> usize {
    let n = len.min(buf.len());
    for k in 1..n {
        if let (Some(v), Some(j)) = (buf.get(k).copied(), k.checked_sub(1)) {
            if let Some(d) = buf.get_mut(j) {
                *d = v;
            }
        }
    }
    n.saturating_sub(1)
}

/// A complete frame's CRC-32 (its last four bytes, LE) matches its payload.
fn crc_ok(f: &[u8]) -> bool {
    let Some(end) = f.len().checked_sub(4).filter(|&e| e >= 2) else {
        return false;
    };
    let (Some(payload), Some(crc)) = (f.get(2..end), f.get(end..)) else {
        return false;
    };
    let mut c = Crc32::new();
    c.update(payload);
    crc == c.value().to_le_bytes()
}

/// Writes `sync` at the start of `frame` and the CRC-32 of the payload (the bytes between) at
/// its end: the frame [`CrcFrames`] finds. The payload must already be in place; a frame too
/// short for a sync and a CRC is left as it is.
pub fn seal_frame<const LEN: usize>(sync: [u8; 2], frame: &mut [u8; LEN]) {
    let Some(end) = LEN.checked_sub(4).filter(|&e| e >= 2) else {
        return;
    };
    let mut c = Crc32::new();
    if let Some(payload) = frame.get(2..end) {
        c.update(payload);
    }
    if let Some(head) = frame.get_mut(..2) {
        head.copy_from_slice(&sync);
    }
    if let Some(tail) = frame.get_mut(end..) {
        tail.copy_from_slice(&c.value().to_le_bytes());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_matches_the_standard_check_value() {
        let mut c = Crc32::new();
        c.update(b"123456789");
        assert_eq!(c.value(), 0xCBF4_3926);
    }
}
