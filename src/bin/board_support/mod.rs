//! What the STM32F405 firmwares share (`imu-ident-board`, `imu-ident-nav-board`): the RTT
//! defmt logger ([`rtt`]), a serial port's interrupt side ([`drain`] into a queue, counting
//! what is lost) and its loop side ([`QueueRx`], the `embedded_io` reader the core's decoders
//! take), [`park`], and the panic and hard-fault handlers (both park the core). Board wiring
//! only; the estimators and decoders are the library's.

use core::convert::Infallible;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m_rt::{exception, ExceptionFrame};
use heapless::spsc::{Consumer, Producer};
use stm32f4xx_hal::nb;
use stm32f4xx_hal::prelude::_embedded_hal_serial_nb_Read as SerialRead;

pub mod rtt;

/// Stops here for good (interrupts still run, so a queued defmt frame is not lost).
pub fn park() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

/// Bytes a receive interrupt lost.
pub struct RxCounts {
    /// Lost to line errors (overrun, framing, noise, parity).
    pub line_errors: AtomicU32,
    /// Dropped because the queue was full.
    pub queue_full: AtomicU32,
}

impl RxCounts {
    /// No loss yet.
    pub const fn new() -> Self {
        Self {
            line_errors: AtomicU32::new(0),
            queue_full: AtomicU32::new(0),
        }
    }
}

/// The receive interrupt's work: moves every byte the USART holds into `queue`, counting what
/// is lost in `counts`.
pub fn drain<R: SerialRead<u8>, const N: usize>(
    rx: &mut R,
    queue: &mut Producer<'static, u8, N>,
    counts: &RxCounts,
) {
    loop {
        match rx.read() {
            Ok(byte) => {
                if queue.enqueue(byte).is_err() {
                    counts.queue_full.fetch_add(1, Ordering::Relaxed);
                }
            }
            // Reading the data register cleared the error; the byte is gone.
            Err(nb::Error::Other(_)) => {
                counts.line_errors.fetch_add(1, Ordering::Relaxed);
            }
            Err(nb::Error::WouldBlock) => break,
        }
    }
}

/// The loop's side of a receive queue, as the core's serial readers take it
/// (`embedded_io::Read + ReadReady`). Line errors never reach it: the interrupt counts them.
pub struct QueueRx<const N: usize>(pub Consumer<'static, u8, N>);

impl<const N: usize> embedded_io::ErrorType for QueueRx<N> {
    type Error = Infallible;
}

impl<const N: usize> embedded_io::ReadReady for QueueRx<N> {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.0.ready())
    }
}

impl<const N: usize> embedded_io::Read for QueueRx<N> {
    /// Copies the queued bytes; blocks only while the queue is empty (as `embedded_io`
    /// requires), which the core's readers avoid by asking [`read_ready`] first.
    ///
    /// [`read_ready`]: embedded_io::ReadReady::read_ready
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        if buf.is_empty() {
            return Ok(0);
        }
        while !self.0.ready() {
            core::hint::spin_loop();
        }
        let mut n = 0;
        for slot in buf.iter_mut() {
            let Some(byte) = self.0.dequeue() else { break };
            *slot = byte;
            n += 1;
        }
        Ok(n)
    }
}

#[cfg(not(feature = "prove-no-panic"))]
#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    // No defmt here: the panic may come from inside the logger, which is not re-entrant.
    cortex_m::interrupt::disable();
    park()
}

// With `prove-no-panic` the panic handler is the library's (`imu_ident::panic_proof`).

#[exception]
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    park()
}
