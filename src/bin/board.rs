//! Firmware for an STM32F405: the 1 Hz navigation step on a real board.
//!
//! Kept thin on purpose: the step ([`Estimator`]), the frame decoder ([`SerialSource`]) and the
//! telemetry ([`DefmtSink`]) live in the library, where the host tests them; this file only
//! wires the board to them.
//!
//! - Clocks: the internal 16 MHz HSI through the PLL to 168 MHz (APB1 42 MHz, its timers 84 MHz).
//!   A board with a crystal sets [`HSE_HZ`] for a more accurate tick.
//! - Input: USART2 RX on PA3 (AF7), 115200 baud, 8N1, carrying the frames of
//!   [`imu_ident::edge`] (`A5 5A | t f64 LE | z f32 LE | CRC-32 LE`, 18 bytes). The STM32F4
//!   USART has a one-byte receive register, so a byte is moved into a 1 KiB queue by the
//!   USART2 interrupt as soon as it arrives; the loop reads the queue through
//!   [`QueueRx`] (`embedded_io::Read + ReadReady`) once per tick. PA2 (TX) is left free.
//! - Tick: TIM2 counting microseconds, updating every 1 000 000 counts; [`TimerTick`] waits on
//!   its update flag (busy-waiting, interrupts still served). The tick period is the hardware
//!   timer's, not the loop's run time.
//! - Step: `t` = whole seconds since the timer started at boot, `z` = the newest frame received
//!   since the previous tick (NaN when none; the frame's own `t` is not used: the board's timer
//!   is the time base), then [`Estimator::tick`] and [`Estimator::emit`] to defmt over RTT
//!   (this file's RTT logger, laid out as defmt-rtt's; `probe-rs run` decodes it).
//! - Errors: a failed start-up is reported with `defmt::error!` and parks the core. Serial line
//!   errors, queue overflows, bad CRCs, superseded frames and late ticks are counted and
//!   reported with `defmt::warn!` when they change; the frame decoder resynchronises by
//!   itself, and the tick goes on with a missing observation.
//! - Memory: the estimator is a zero-initialised static in `.bss`, initialised in place
//!   ([`Estimator::init`]: no copy of it on the stack); no heap.
//!
//! Panics: none are expected; the handler below parks the core without formatting anything.
//! `--features prove-no-panic` proves at link time that no panic path is linked at all (see
//! RELIABILITY.md): the defmt logger is therefore this file's own RTT channel ([`rtt`]) over the
//! library's `imu_ident::defmt_frame`, which drops a re-entered frame where `defmt-rtt` panics.

#![cfg_attr(all(target_arch = "arm", target_os = "none"), no_std, no_main)]

#[cfg(not(all(target_arch = "arm", target_os = "none")))]
fn main() {
    // Built for the host only by an --all-features build; the firmware needs the ARM target.
    eprintln!("imu-ident-board is firmware: build it with --target thumbv7em-none-eabihf");
    std::process::exit(2);
}

#[cfg(all(target_arch = "arm", target_os = "none"))]
#[path = "board_support/mod.rs"]
mod board_support;

#[cfg(all(target_arch = "arm", target_os = "none"))]
mod firmware {
    use super::board_support::{drain, park, QueueRx, RxCounts};
    use core::cell::RefCell;
    use core::sync::atomic::{AtomicBool, Ordering};

    use cortex_m::interrupt::{self as irq, Mutex};
    use cortex_m::peripheral::NVIC;
    use cortex_m_rt::entry;
    use heapless::spsc::{Producer, Queue};
    use imu_ident::edge::{ObservationSource, SerialSource, Tick};
    use imu_ident::model::InsModel;
    use imu_ident::step::{Estimator, StepConfig, StepError};
    use imu_ident::telemetry::DefmtSink;
    use static_cell::StaticCell;
    use stm32f4xx_hal::pac::{self, interrupt, Interrupt, TIM2, USART2};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::rcc::Clocks;
    use stm32f4xx_hal::serial::{config::Config, Rx};
    use stm32f4xx_hal::timer::Timer;

    /// Frequency of the board's crystal, if it has one; `None` runs from the internal HSI.
    const HSE_HZ: Option<u32> = None;
    /// System clock [Hz] (the STM32F405 maximum).
    const SYSCLK_HZ: u32 = 168_000_000;
    /// Observation link speed [baud].
    const BAUD: u32 = 115_200;
    /// TIM2 count rate [Hz].
    const COUNT_HZ: u32 = 1_000_000;
    /// Tick period [counts of TIM2, us].
    const TICK_US: u32 = 1_000_000;
    /// Receive queue length: holds `RX_QUEUE_LEN - 1` bytes, about 56 frames.
    const RX_QUEUE_LEN: usize = 1024;

    type RxQueue = Queue<u8, RX_QUEUE_LEN>;

    /// The estimator (~31 KB in f32): a static, not the stack. `BLANK` is all zero bits, so it
    /// sits in `.bss` and costs no flash; [`Estimator::init`] fills it in place (measured on
    /// the QEMU build: 24 KB of stack at start-up, against ~100 KB for a by-value `new`).
    static mut NAV: Estimator<f32> = Estimator::BLANK;
    /// Set when [`NAV`] has been handed out.
    static NAV_TAKEN: AtomicBool = AtomicBool::new(false);
    /// The receive queue between the USART2 interrupt (producer) and the loop (consumer).
    static RX_QUEUE: StaticCell<RxQueue> = StaticCell::new();
    /// What the USART2 interrupt owns, handed over once at start-up.
    static RX_ISR: Mutex<RefCell<Option<RxIsr>>> = Mutex::new(RefCell::new(None));
    /// Bytes lost on the line (overrun, framing, noise, parity) or to a full queue.
    static RX_COUNTS: RxCounts = RxCounts::new();

    struct RxIsr {
        rx: Rx<USART2>,
        queue: Producer<'static, u8, RX_QUEUE_LEN>,
    }

    /// Why the board could not start.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
    enum StartError {
        /// The device peripherals were already taken.
        Peripherals,
        /// A static was already initialised.
        Static,
        /// The USART rejected its configuration.
        Serial,
        /// The timer rejected its period.
        Timer,
        /// The estimator rejected the model or its settings.
        Nav(StepError),
    }

    /// The 1 Hz tick: TIM2 (32 bits) counting microseconds and wrapping every [`TICK_US`]; a
    /// tick is its update event. Programmed through its registers: the HAL's counters assert
    /// on their arguments, and the binary keeps panic paths out.
    struct TimerTick {
        tim: TIM2,
        /// Waits that found the tick already due: the step before took longer than a period
        /// (if it took more than two, ticks were lost and `t` runs slow).
        late: u32,
    }

    impl TimerTick {
        /// Starts TIM2; fails when its clock is not a whole number of MHz (not with
        /// [`SYSCLK_HZ`]).
        fn start(tim: TIM2, clocks: &Clocks) -> Result<Self, StartError> {
            let clk = clocks.timclk1().raw();
            if clk % COUNT_HZ != 0 {
                return Err(StartError::Timer);
            }
            let psc = (clk / COUNT_HZ)
                .checked_sub(1)
                .and_then(|p| u16::try_from(p).ok())
                .ok_or(StartError::Timer)?;
            // Enables and resets TIM2 in the RCC, then hands its registers back.
            let tim = Timer::new(tim, clocks).release();
            tim.psc().write(|w| w.psc().set(psc));
            tim.arr().write(|w| w.arr().set(TICK_US - 1));
            // Load the prescaler now (an update event), then start from a clear flag.
            tim.egr().write(|w| w.ug().set_bit());
            tim.sr().write(|w| w.uif().clear());
            tim.cr1().modify(|_, w| w.cen().set_bit());
            Ok(Self { tim, late: 0 })
        }
    }

    impl Tick for TimerTick {
        fn wait(&mut self) {
            if self.tim.sr().read().uif().bit_is_set() {
                self.late = self.late.saturating_add(1);
            }
            while self.tim.sr().read().uif().bit_is_clear() {
                core::hint::spin_loop();
            }
            self.tim.sr().write(|w| w.uif().clear());
        }
    }

    /// What the loop runs with.
    struct Board {
        nav: &'static mut Estimator<f32>,
        source: SerialSource<QueueRx<RX_QUEUE_LEN>>,
        tick: TimerTick,
    }

    #[entry]
    fn main() -> ! {
        match start() {
            Ok(board) => run(board),
            Err(e) => {
                defmt::error!("board start failed: {}", e);
                park()
            }
        }
    }

    /// The storage of [`NAV`], once.
    fn nav_slot() -> Option<&'static mut Estimator<f32>> {
        if NAV_TAKEN.swap(true, Ordering::AcqRel) {
            return None;
        }
        // SAFETY: NAV_TAKEN was false, so this is the only reference to NAV ever made.
        Some(unsafe { &mut *core::ptr::addr_of_mut!(NAV) })
    }

    /// Clocks, USART, estimator, timer.
    fn start() -> Result<Board, StartError> {
        let dp = pac::Peripherals::take().ok_or(StartError::Peripherals)?;

        let rcc = dp.RCC.constrain();
        let cfgr = match HSE_HZ {
            Some(hz) => rcc.cfgr.use_hse(hz.Hz()),
            None => rcc.cfgr,
        };
        let clocks = cfgr.sysclk(SYSCLK_HZ.Hz()).freeze();

        // The observation input: USART2 RX on PA3, interrupt-driven into the queue.
        let gpioa = dp.GPIOA.split();
        let config = Config::default()
            .baudrate(BAUD.bps())
            .wordlength_8()
            .parity_none();
        let mut rx: Rx<USART2> = dp
            .USART2
            .rx(gpioa.pa3, config, &clocks)
            .map_err(|_| StartError::Serial)?;
        let queue = RX_QUEUE.try_init(Queue::new()).ok_or(StartError::Static)?;
        let (producer, consumer) = queue.split();
        rx.listen();
        let state = RxIsr {
            rx,
            queue: producer,
        };
        let handed_over = irq::free(|cs| match RX_ISR.borrow(cs).try_borrow_mut() {
            Ok(mut slot) => {
                *slot = Some(state);
                true
            }
            Err(_) => false,
        });
        if !handed_over {
            return Err(StartError::Static);
        }
        // SAFETY: no critical section is open, and the handler only touches RX_ISR (through
        // a critical section) and atomics.
        unsafe { NVIC::unmask(Interrupt::USART2) };
        let source = SerialSource::new(QueueRx(consumer));

        let nav = nav_slot().ok_or(StartError::Static)?;
        nav.init(InsModel::paper(), StepConfig::adaptive())
            .map_err(StartError::Nav)?;

        let tick = TimerTick::start(dp.TIM2, &clocks)?;

        defmt::info!(
            "imu-ident-board: sysclk={=u32} Hz, USART2 RX PA3 {=u32} baud 8N1, 1 Hz tick",
            clocks.sysclk().raw(),
            BAUD
        );
        Ok(Board { nav, source, tick })
    }

    /// The 1 Hz loop: wait, poll, step, report.
    fn run(board: Board) -> ! {
        let Board {
            nav,
            mut source,
            mut tick,
        } = board;
        let mut sink = DefmtSink;
        let mut seconds: u32 = 0;
        let mut reported = SerialCounts::default();
        loop {
            tick.wait();
            seconds = seconds.wrapping_add(1);
            let z = match source.poll() {
                Ok(Some(row)) => row.z,
                Ok(None) => f32::NAN,
                Err(e) => match e {},
            };
            let report = nav.tick(f64::from(seconds), z);
            nav.emit(&report, &mut sink);

            let counts = SerialCounts {
                line_errors: RX_COUNTS.line_errors.load(Ordering::Relaxed),
                queue_full: RX_COUNTS.queue_full.load(Ordering::Relaxed),
                crc_rejected: source.decoder().rejected(),
                superseded: source.superseded(),
                late_ticks: tick.late,
            };
            if counts != reported {
                defmt::warn!(
                    "board: line_errors={=u32} queue_full={=u32} crc_rejected={=u32} superseded={=u32} late_ticks={=u32}",
                    counts.line_errors,
                    counts.queue_full,
                    counts.crc_rejected,
                    counts.superseded,
                    counts.late_ticks
                );
                reported = counts;
            }
        }
    }

    /// The loss counters of the input and the tick, reported when they change.
    #[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
    struct SerialCounts {
        /// Bytes lost to line errors ([`RxCounts::line_errors`]).
        line_errors: u32,
        /// Bytes dropped on a full queue ([`RxCounts::queue_full`]).
        queue_full: u32,
        /// Frames with a bad CRC.
        crc_rejected: u32,
        /// Frames replaced by a newer one before a tick used them.
        superseded: u32,
        /// Ticks that came late ([`TimerTick::late`]).
        late_ticks: u32,
    }

    /// Moves every received byte into the queue; counts what is lost.
    #[interrupt]
    fn USART2() {
        irq::free(|cs| {
            let Ok(mut state) = RX_ISR.borrow(cs).try_borrow_mut() else {
                return;
            };
            let Some(state) = state.as_mut() else {
                return;
            };
            drain(&mut state.rx, &mut state.queue, &RX_COUNTS);
        });
    }
}
