//! Frame bookkeeping shared by the firmware's global defmt loggers (`src/bin/qemu.rs` over
//! semihosting, `src/bin/board.rs` over RTT): interrupts disabled while a frame is written, and
//! a frame started inside another one dropped.
//!
//! Why not `defmt-semihosting` / `defmt-rtt`: both panic when the logger is re-entered (a
//! `defmt` call from an exception handler that runs while a frame is being written, e.g. a
//! HardFault), and the release firmware must contain no panic path at all (RELIABILITY.md,
//! "Panic-free firmware, proved at link time"). Here a nested frame is counted and dropped
//! instead; the outer frame is written complete.
//!
//! Each binary keeps only its transport, a `sink` that writes encoded bytes, and an
//! `impl defmt::Logger` whose `acquire`, `release` and `write` call the functions below with
//! that sink (always the same one: there is a single [`defmt::Encoder`] for the program). The
//! sink is called only between [`acquire`] and the matching [`release`], with interrupts
//! disabled, and only for the outermost frame.
//!
//! Single core only (as the `critical-section-single-core` feature of `cortex-m`): disabling
//! interrupts is what makes the state below exclusive.

use core::cell::UnsafeCell;

struct State {
    /// Frames in progress: 1 while a frame is written; more when re-entered.
    depth: UnsafeCell<u32>,
    /// PRIMASK's active bit before the outermost `acquire`.
    enable: UnsafeCell<bool>,
    encoder: UnsafeCell<defmt::Encoder>,
}

// SAFETY: only touched with interrupts disabled (between acquire and release).
unsafe impl Sync for State {}

static STATE: State = State {
    depth: UnsafeCell::new(0),
    enable: UnsafeCell::new(false),
    encoder: UnsafeCell::new(defmt::Encoder::new()),
};

/// Starts a frame (for [`defmt::Logger::acquire`]): disables interrupts, and for the outermost
/// frame saves whether they were enabled and writes the frame start through `sink`. A nested
/// call only counts the nesting.
#[inline]
pub fn acquire(sink: fn(&[u8])) {
    let active = cortex_m::register::primask::read().is_active();
    cortex_m::interrupt::disable();
    // SAFETY: interrupts are disabled (single core).
    unsafe {
        let depth = &mut *STATE.depth.get();
        *depth = depth.saturating_add(1);
        if *depth > 1 {
            // Nested: the outer frame keeps interrupts off until its release.
            return;
        }
        *STATE.enable.get() = active;
        (*STATE.encoder.get()).start_frame(sink);
    }
}

/// Ends a frame (for [`defmt::Logger::release`]): for the outermost frame writes the frame end
/// through `sink` and re-enables interrupts if [`acquire`] found them enabled; for a nested one
/// only counts it down. Does nothing without a frame in progress.
///
/// # Safety
/// Called after [`acquire`] (interrupts still disabled since), as `defmt::Logger` requires.
#[inline]
pub unsafe fn release(sink: fn(&[u8])) {
    // SAFETY: interrupts are disabled since `acquire`.
    unsafe {
        let depth = &mut *STATE.depth.get();
        match *depth {
            0 => {}
            1 => {
                *depth = 0;
                (*STATE.encoder.get()).end_frame(sink);
                if *STATE.enable.get() {
                    cortex_m::interrupt::enable();
                }
            }
            _ => *depth -= 1,
        }
    }
}

/// Encodes `bytes` into the current frame through `sink` (for [`defmt::Logger::write`]);
/// dropped when no frame or a nested one is in progress.
///
/// # Safety
/// Called between [`acquire`] and [`release`] (interrupts disabled), as `defmt::Logger`
/// requires.
#[inline]
pub unsafe fn write(bytes: &[u8], sink: fn(&[u8])) {
    // SAFETY: interrupts are disabled since `acquire`.
    unsafe {
        if *STATE.depth.get() != 1 {
            return;
        }
        (*STATE.encoder.get()).write(bytes, sink);
    }
}
