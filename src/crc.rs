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
/// sample frames of [`crate::nav::imu_frame`] are two lengths of it; `K` kinds of frame, each
/// with its sync and length (at most `LEN`), can share one search
/// ([`crate::nav::counted::SampleFrames`]).
///
/// It keeps up to `LEN` bytes from a candidate sync; when they make a frame of the kind that
/// sync names and the CRC matches, the frame is returned and the buffer cleared. A frame whose
/// CRC fails is counted in [`rejected`](Self::rejected) and the search continues one byte
/// later, so a sync pattern inside the payload never locks the decoder out. One search for
/// every kind on a line (rather than one per kind) never tries the sync patterns inside the
/// frames it reads: a decoder that sees frames not its own would, and count the failures.
/// Constant memory, no panics (a kind shorter than 6 bytes never yields a frame).
#[derive(Debug, Clone)]
pub struct CrcFrames<const LEN: usize, const K: usize = 1> {
    /// Each kind's sync and frame length.
    kinds: [([u8; 2], usize); K],
    buf: [u8; LEN],
    len: usize,
    /// The length of the frame the held sync names (0 before two bytes are held).
    want: usize,
    rejected: u32,
}

impl<const LEN: usize> CrcFrames<LEN, 1> {
    /// An empty search for frames of `LEN` bytes behind `sync`.
    pub const fn new(sync: [u8; 2]) -> Self {
        Self::of_kinds([(sync, LEN)])
    }
}

impl<const LEN: usize, const K: usize> CrcFrames<LEN, K> {
    /// An empty search for frames of `K` kinds: each kind's sync and length (at most `LEN`).
    pub const fn of_kinds(kinds: [([u8; 2], usize); K]) -> Self {
        Self {
            kinds,
            buf: [0; LEN],
            len: 0,
            want: 0,
            rejected: 0,
        }
    }

    /// Frames with a good sync but a bad CRC so far.
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// Takes one byte; returns the buffer when a frame completes with a valid CRC: the frame
    /// (sync and CRC included) in its first bytes, as many as its kind's length (its sync
    /// names the kind); the bytes after it are not the frame's.
    pub fn push(&mut self, byte: u8) -> Option<[u8; LEN]> {
        if self.len == 0 && !self.kinds.iter().any(|(s, _)| s.first() == Some(&byte)) {
            // Not a frame's start: nothing to keep (the common case between frames).
            return None;
        }
        if self.len >= LEN {
            // Full without a valid frame (a kind longer than the buffer): drop the oldest byte
            // (a sliding window).
            self.slide();
            self.align();
        }
        *self.buf.get_mut(self.len)? = byte;
        self.len += 1;
        if self.len <= 2 {
            // Drop leading bytes that cannot start a frame, so the window stays aligned on a
            // sync (a byte after the first two leaves the held sync as it was).
            self.align();
        }
        if self.len < self.want || self.want == 0 {
            return None;
        }
        self.complete()
    }

    /// The held bytes make a frame's length: checks them, and goes on while they do. A
    /// rejection can leave a whole frame held, and bytes after it: a false sync of a longer
    /// kind that began less than the difference of the lengths before a shorter frame (fresh
    /// seed 66402 of `examples/hub_bench.rs`: a pulse edge after a false sample sync; clearing
    /// the buffer with the edge lost the sample behind it). So the held bytes are checked
    /// until they are short of the frame their sync names, and the bytes after a frame are
    /// kept. Each pass returns or drops a byte: at most `LEN`. Out of line: once a frame, not
    /// on every byte's path.
    #[inline(never)]
    fn complete(&mut self) -> Option<[u8; LEN]> {
        for _ in 0..=LEN {
            if self.len < self.want || self.want == 0 {
                return None;
            }
            if self.buf.get(..self.want).is_some_and(crc_ok) {
                let frame = self.buf;
                self.len = drop_front(&mut self.buf, self.len, self.want);
                self.align();
                return Some(frame);
            }
            self.rejected = self.rejected.saturating_add(1);
            // Slide by one and re-align on the next candidate sync.
            self.slide();
            self.align();
        }
        None
    }

    /// Drops the oldest buffered byte (moving only the bytes held).
    fn slide(&mut self) {
        self.len = drop_first(&mut self.buf, self.len);
    }

    /// Drops leading bytes until the buffer agrees with a sync as far as it goes, and takes
    /// the length of the frame that sync names.
    fn align(&mut self) {
        while self.len > 0 {
            let n = self.len.min(2);
            let head = self.buf.get(..n);
            if self.kinds.iter().any(|(s, _)| s.get(..n) == head) {
                break;
            }
            self.slide();
        }
        let head = self.buf.get(..2).filter(|_| self.len >= 2);
        self.want = self
            .kinds
            .iter()
            .find(|(s, _)| Some(&s[..]) == head)
            .map_or(0, |&(_, n)| n);
    }
}

/// Drops the first of the `len` bytes held at the start of `buf`; returns the new count.
pub(crate) fn drop_first(buf: &mut [u8], len: usize) -> usize {
    drop_front(buf, len, 1)
}

/// Drops the first `n` of the `len` bytes held at the start of `buf`; returns the new count.
/// A loop of checked accesses: `copy_within` with a range known only at run time keeps a panic
/// path the link-time proof refuses (RELIABILITY.md). Always inlined: with `n` known (1 on the
/// searches' per-byte path) it folds to the one-byte move.
#[inline(always)]
pub(crate) fn drop_front(buf: &mut [u8], len: usize, n: usize) -> usize {
    let len = len.min(buf.len());
    let n = n.min(len);
    for k in n..len {
        if let (Some(v), Some(j)) = (buf.get(k).copied(), k.checked_sub(n)) {
            if let Some(d) = buf.get_mut(j) {
                *d = v;
            }
        }
    }
    len.saturating_sub(n)
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
