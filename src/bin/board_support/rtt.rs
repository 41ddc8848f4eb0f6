//! The global defmt logger: one RTT up channel named `defmt` in a `_SEGGER_RTT` control
//! block, as `defmt-rtt` lays it out (so `probe-rs run` finds and decodes it the same way),
//! without its panics: a frame started inside another (the logger re-entered from an
//! exception handler) is dropped. This module is the transport (`write_all`, `flush`);
//! the frame handling is the library's `imu_ident::defmt_frame`, shared with the QEMU
//! firmware.

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicU32, Ordering};
use imu_ident::defmt_frame;

/// Up buffer size [bytes] (defmt-rtt's default).
const BUF_SIZE: usize = 1024;
/// The flags' mode bits; the host sets "block if full" when it is attached.
const MODE_MASK: u32 = 0b11;
const MODE_BLOCK_IF_FULL: u32 = 2;
const MODE_NON_BLOCKING_TRIM: u32 = 1;

#[repr(C)]
struct Channel {
    name: *const u8,
    buffer: *mut u8,
    size: u32,
    write: AtomicU32,
    read: AtomicU32,
    flags: AtomicU32,
}

#[repr(C)]
struct Header {
    id: [u8; 16],
    max_up_channels: u32,
    max_down_channels: u32,
    up_channel: Channel,
}

// SAFETY: the pointers are to statics; the cursors are atomics.
unsafe impl Sync for Header {}

struct Buffer(UnsafeCell<[u8; BUF_SIZE]>);

// SAFETY: written only by the logger, with interrupts disabled; the host reads it.
unsafe impl Sync for Buffer {}

#[link_section = ".uninit.defmt-rtt.BUFFER"]
static BUFFER: Buffer = Buffer(UnsafeCell::new([0; BUF_SIZE]));

#[link_section = ".data.defmt-rtt.NAME"]
static NAME: [u8; 6] = *b"defmt\0";

#[no_mangle]
static _SEGGER_RTT: Header = Header {
    id: *b"SEGGER RTT\0\0\0\0\0\0",
    max_up_channels: 1,
    max_down_channels: 0,
    up_channel: Channel {
        name: NAME.as_ptr(),
        buffer: BUFFER.0.get() as *mut u8,
        size: BUF_SIZE as u32,
        write: AtomicU32::new(0),
        read: AtomicU32::new(0),
        flags: AtomicU32::new(MODE_NON_BLOCKING_TRIM),
    },
};

/// Free bytes between the write and the read cursor (one slot stays empty).
fn available(read: usize, write: usize) -> usize {
    if read > write {
        read - write - 1
    } else {
        BUF_SIZE - 1 - write + read
    }
}

/// Copies `bytes` into the buffer from `cursor` on, wrapping; returns the new cursor.
/// `bytes.len() < BUF_SIZE`.
fn copy_wrapping(bytes: &[u8], cursor: usize) -> usize {
    let cursor = cursor % BUF_SIZE;
    let first = bytes.len().min(BUF_SIZE - cursor);
    let Some((head, tail)) = bytes.split_at_checked(first) else {
        return cursor;
    };
    let base = BUFFER.0.get() as *mut u8;
    // SAFETY: `cursor + head.len() <= BUF_SIZE` and `tail.len() < BUF_SIZE`; the
    // buffer is written only here (interrupts disabled), the host only reads it.
    unsafe {
        core::ptr::copy_nonoverlapping(head.as_ptr(), base.add(cursor), head.len());
        core::ptr::copy_nonoverlapping(tail.as_ptr(), base, tail.len().min(BUF_SIZE));
    }
    (cursor + bytes.len()) % BUF_SIZE
}

/// Writes all of `bytes`: waits for the host when it asked for blocking mode, else
/// overwrites what it has not read (as defmt-rtt does).
fn write_all(mut bytes: &[u8]) {
    let ch = &_SEGGER_RTT.up_channel;
    while !bytes.is_empty() {
        let blocking = ch.flags.load(Ordering::Relaxed) & MODE_MASK == MODE_BLOCK_IF_FULL;
        let write = ch.write.load(Ordering::Acquire) as usize % BUF_SIZE;
        let room = if blocking {
            available(ch.read.load(Ordering::Relaxed) as usize % BUF_SIZE, write)
        } else {
            BUF_SIZE - 1
        };
        let Some((now, rest)) = bytes.split_at_checked(bytes.len().min(room)) else {
            return;
        };
        if !now.is_empty() {
            let next = copy_wrapping(now, write);
            ch.write.store(next as u32, Ordering::Release);
        }
        bytes = rest;
    }
}

#[defmt::global_logger]
struct Logger;

// SAFETY: frames are written with interrupts disabled; nested frames are dropped
// (`imu_ident::defmt_frame`).
unsafe impl defmt::Logger for Logger {
    fn acquire() {
        defmt_frame::acquire(write_all);
    }

    unsafe fn flush() {
        let ch = &_SEGGER_RTT.up_channel;
        if ch.flags.load(Ordering::Relaxed) & MODE_MASK != MODE_BLOCK_IF_FULL {
            return;
        }
        while ch.read.load(Ordering::Relaxed) != ch.write.load(Ordering::Relaxed) {
            core::hint::spin_loop();
        }
    }

    unsafe fn release() {
        // SAFETY: called after `acquire`, as the `Logger` contract requires.
        unsafe { defmt_frame::release(write_all) }
    }

    unsafe fn write(bytes: &[u8]) {
        // SAFETY: called between `acquire` and `release`, as the `Logger` contract
        // requires.
        unsafe { defmt_frame::write(bytes, write_all) }
    }
}
