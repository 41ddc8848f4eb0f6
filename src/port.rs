//! Reading a serial port without blocking: the loop the hardware edge's sources share
//! ([`crate::edge::SerialSource`] for the one-channel step, [`crate::nav::serial::SerialNav`]
//! for the navigator).

/// Reads what `rx` has ready, at most `max_bytes` (the rest waits for the next call), and
/// gives each byte to `on_byte` in order. Returns the bytes read. Never blocks: it reads only
/// while the port says bytes are ready, in chunks of 32 on the stack.
pub fn read_ready<R: embedded_io::Read + embedded_io::ReadReady>(
    rx: &mut R,
    max_bytes: usize,
    mut on_byte: impl FnMut(u8),
) -> Result<usize, R::Error> {
    let mut chunk = [0u8; 32];
    let mut read = 0usize;
    while read < max_bytes && rx.read_ready()? {
        let want = (max_bytes - read).min(chunk.len());
        let Some(buf) = chunk.get_mut(..want) else {
            break;
        };
        let n = rx.read(buf)?;
        if n == 0 {
            break;
        }
        read = read.saturating_add(n);
        for &b in buf.iter().take(n) {
            on_byte(b);
        }
    }
    Ok(read)
}
