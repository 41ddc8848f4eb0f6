//! The checksum of the binary formats (log replay, model file, frames at the hardware edge).

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
