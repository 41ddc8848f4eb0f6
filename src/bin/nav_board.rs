//! Firmware for an STM32F405 navigation computer: the strapdown INS/GNSS navigator with the
//! online identification of its IMU's noise, started and driven by its sensors alone.
//!
//! Kept thin on purpose: the serial decoders ([`SerialNav`]), the live loop ([`LiveNav`]:
//! levelling, start, per-fix decisions, the navigator) and the bank of shadow filters live in
//! the library, where the host tests them and the emulated board runs them on recorded wires
//! (`imu-ident-nav-qemu`, `hal-sim/tests/nav_qemu_wire.rs`); this file wires the board to them.
//!
//! - Clocks: the internal 16 MHz HSI through the PLL to 168 MHz.
//! - IMU: USART2 RX on PA3 (AF7), [`IMU_BAUD`] 8N1, one frame per sample
//!   (`imu_ident::nav::imu_frame`: `A5 5B | t f64 | gyro 3 x f32 | accel 3 x f32 | CRC-32`),
//!   stamped by the sender on the GNSS time scale (GPS seconds since 1980: a sensor hub or an
//!   IMU with a PPS input). 100 Hz takes 3 800 B/s. Or, from a hub with only its own counter,
//!   counted samples and the receiver's pulse edges captured on that counter
//!   (`imu_ident::nav::counted`: `A5 5C | count u32 | gyro | accel | CRC-32`,
//!   `A5 5D | count u32 | CRC-32`), put on GPS time by the board (a `TimerStamps`: the
//!   receiver's `TIM-TP` on the GNSS port pairs each edge with its second; the hub's counter
//!   at `HUB_TIMER_HZ`); samples before the clock locks are dropped and counted.
//! - GNSS: USART3 RX on PB11 (AF7), [`GNSS_BAUD`] 8N1 (a u-blox M8 / F9 UART1's default), the
//!   receiver's UBX `NAV-TIMEGPS` and `NAV-PVT`, and `TIM-TP` for a counting hub (enable them
//!   on that port; NMEA and other
//!   messages between them are passed over).
//! - Each port's bytes are moved into a queue by its interrupt; the loop reads both queues
//!   ([`SerialNav::poll`], a bounded number of bytes per call), gives every sample and fix to
//!   the live loop, and sleeps (`wfi`) when both are empty.
//! - Output (defmt over RTT, `probe-rs run` decodes it): the start, `nav` per GNSS epoch
//!   (time, position, NED velocity, position sigmas, flags; the run's, [`LATENCY_S`] behind
//!   the newest sample), `now` every tenth sample (the solution at the newest
//!   sample: time, position, NED velocity, roll, pitch, yaw [rad]; the output predictor,
//!   `imu_ident::nav::predictor`), `online` per decision of the bank
//!   (each coordinate's factor, Cramér-Rao sd, identifiable flag), refused inputs, and the
//!   ports' loss counters when they change.
//! - Setup: [`board_setup`] (the IMU's datasheet noise, the antenna's lever arm, the levelling
//!   window, the receiver's latency budget, the bank on). Edit it for another IMU or mounting.
//! - Memory: the live loop in a static in `.bss` (about 13 KB), the bank in the CCM (about
//!   59 KB), the queues in SRAM; no heap.
//!
//! Panics: none are expected; `--features prove-no-panic` proves at link time that no panic
//! path is linked (RELIABILITY.md).

#![cfg_attr(all(target_arch = "arm", target_os = "none"), no_std, no_main)]

#[cfg(not(all(target_arch = "arm", target_os = "none")))]
fn main() {
    // Built for the host only by an --all-features build; the firmware needs the ARM target.
    eprintln!("imu-ident-nav-board is firmware: build it with --target thumbv7em-none-eabihf");
    std::process::exit(2);
}

#[cfg(all(target_arch = "arm", target_os = "none"))]
#[path = "board_support/mod.rs"]
mod board_support;

#[cfg(all(target_arch = "arm", target_os = "none"))]
#[path = "nav_support/mod.rs"]
mod nav_support;

#[cfg(all(target_arch = "arm", target_os = "none"))]
mod firmware {
    use super::board_support::{drain, park, QueueRx, RxCounts};
    use super::nav_support::{
        count_sample, decisions_of, report_decision, send_epoch, start_bank, Bank, HUB_TIMER_HZ,
    };
    use core::cell::RefCell;
    use core::mem::MaybeUninit;
    use core::sync::atomic::{AtomicBool, Ordering};

    use cortex_m::interrupt::{self as irq, Mutex};
    use cortex_m::peripheral::NVIC;
    use cortex_m_rt::entry;
    use heapless::spsc::{Producer, Queue};
    use imu_ident::model::{Component, RandomWalk, WhiteNoise};
    use imu_ident::nav::gps_clock::ClockConfig;
    use imu_ident::nav::live::{LiveConfig, LiveEvent, LiveNav};
    use imu_ident::nav::serial::{feed, NavInput, SerialNav, TimerStamps, WireCounts};
    use imu_ident::nav::{ImuErrorModel, NavInit, NavSetup, OnlineConfig, NAV_N};
    use nalgebra::Vector3;
    use static_cell::StaticCell;
    use stm32f4xx_hal::pac::{self, interrupt, Interrupt, USART2, USART3};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::serial::{config::Config, CommonPins, Rx};

    /// System clock [Hz] (the STM32F405 maximum).
    const SYSCLK_HZ: u32 = 168_000_000;
    /// IMU link speed [baud]: room for 400 Hz of frames (15 200 B/s).
    const IMU_BAUD: u32 = 460_800;
    /// GNSS link speed [baud].
    const GNSS_BAUD: u32 = 38_400;
    /// IMU receive queue: about 0.27 s of 100-Hz frames, the longest call (a decision of the
    /// bank, about 8 million instructions: 50 ms at 168 MHz) with room to spare.
    const IMU_QUEUE_LEN: usize = 1024;
    /// GNSS receive queue: four epochs of `NAV-TIMEGPS` + `NAV-PVT` (124 bytes each).
    const GNSS_QUEUE_LEN: usize = 512;
    /// Bytes read from a port per poll: bounds one pass of the loop.
    const MAX_BYTES_PER_POLL: usize = 256;
    /// IMU samples the live start holds until its fix (1.28 s at 100 Hz).
    const LIVE_BUFFER: usize = 128;

    /// The IMU's noise (the real drive's datasheet values, `hal-sim`'s `drive-datasheet`: a
    /// MEMS IMU). Gyro: white 0.0038 deg/s/sqrt(Hz), bias random walk 3.8e-5 deg/s^2/sqrt(Hz)
    /// from 0.1 deg/s; accelerometer: white 70 ug/sqrt(Hz), bias random walk 7 ug/s/sqrt(Hz)
    /// from 0.1 m/s^2. The bank identifies the factors on these online.
    const GYRO_WHITE_DEG: f64 = 0.0038;
    const GYRO_BIAS_RW_DEG: f64 = 3.8e-5;
    const ACCEL_WHITE_G: f64 = 70e-6;
    const ACCEL_BIAS_RW_G: f64 = 7e-6;
    const G0: f64 = 9.806_65;
    /// Antenna from the IMU, body FRD [m].
    const ANTENNA_LEVER: [f64; 3] = [0.0, 0.0, -0.65];
    /// Levelling window at rest after the first sample [s].
    const ALIGN_S: f64 = 20.0;
    /// The receiver's latency budget [s]: a `NAV-PVT` arrives after its epoch (PX4's default
    /// GNSS delay is 0.11 s); the samples wait this long so that its fix is taken in time order.
    const LATENCY_S: f64 = 0.15;

    type Live = LiveNav<f32, NAV_N, Option<&'static mut Bank>, LIVE_BUFFER>;

    /// The live loop (navigator, filter, model and the start's buffer: about 13 KB), written
    /// once at start-up.
    static mut LIVE: MaybeUninit<Live> = MaybeUninit::uninit();
    /// Set when [`LIVE`] has been written.
    static LIVE_TAKEN: AtomicBool = AtomicBool::new(false);
    static IMU_QUEUE: StaticCell<Queue<u8, IMU_QUEUE_LEN>> = StaticCell::new();
    static GNSS_QUEUE: StaticCell<Queue<u8, GNSS_QUEUE_LEN>> = StaticCell::new();
    /// What the USART interrupts own, handed over once at start-up.
    static IMU_ISR: Mutex<RefCell<Option<RxIsr<USART2, IMU_QUEUE_LEN>>>> =
        Mutex::new(RefCell::new(None));
    static GNSS_ISR: Mutex<RefCell<Option<RxIsr<USART3, GNSS_QUEUE_LEN>>>> =
        Mutex::new(RefCell::new(None));
    static IMU_COUNTS: RxCounts = RxCounts::new();
    static GNSS_COUNTS: RxCounts = RxCounts::new();

    struct RxIsr<U: CommonPins, const N: usize> {
        rx: Rx<U>,
        queue: Producer<'static, u8, N>,
    }

    /// Why the board could not start.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
    enum StartError {
        /// The device peripherals were already taken.
        Peripherals,
        /// A static was already initialised.
        Static,
        /// A USART rejected its configuration.
        Serial,
    }

    /// The run's settings: the defaults of `hal-sim nav` (its `--help`) with the constants
    /// above, the bank of shadow filters on (`OnlineConfig::default()`).
    fn board_setup() -> NavSetup {
        let mut imu = ImuErrorModel::default();
        let gyro = [
            Component::White(WhiteNoise {
                density: GYRO_WHITE_DEG.to_radians(),
            }),
            Component::RandomWalk(RandomWalk {
                q: GYRO_BIAS_RW_DEG.to_radians() * GYRO_BIAS_RW_DEG.to_radians(),
                sigma0: 0.1f64.to_radians(),
            }),
        ];
        let accel = [
            Component::White(WhiteNoise {
                density: ACCEL_WHITE_G * G0,
            }),
            Component::RandomWalk(RandomWalk {
                q: (ACCEL_BIAS_RW_G * G0) * (ACCEL_BIAS_RW_G * G0),
                sigma0: 0.1,
            }),
        ];
        // Two components fit MAX_AXIS_COMPONENTS: cannot fail.
        let _ = imu.set_all_gyro(&gyro);
        let _ = imu.set_all_accel(&accel);
        let init = NavInit {
            sd_att: Vector3::new(2f64, 2.0, 10.0).map(f64::to_radians),
            sd_vel: 0.1,
            sd_pos: 1.0,
        };
        NavSetup {
            lever_arm: ANTENNA_LEVER,
            gate: Some(1.0),
            online: Some(OnlineConfig::default()),
            live: Some(live_config()),
            ..NavSetup::new(imu, init)
        }
    }

    /// The live loop's rules: `hal-sim nav`'s, with the window and the latency budget above.
    fn live_config() -> LiveConfig {
        LiveConfig {
            latency: LATENCY_S,
            ..LiveConfig::new(ALIGN_S)
        }
    }

    #[entry]
    fn main() -> ! {
        match start() {
            Ok((live, ports)) => run(live, ports),
            Err(e) => {
                defmt::error!("nav board start failed: {}", e);
                park()
            }
        }
    }

    /// The live loop in [`LIVE`], once (its own frame: the construction's temporaries are not
    /// part of the loop's stack).
    #[inline(never)]
    fn live_slot() -> Option<&'static mut Live> {
        if LIVE_TAKEN.swap(true, Ordering::AcqRel) {
            return None;
        }
        // SAFETY: LIVE_TAKEN was false, so this is the only reference to LIVE ever made.
        let slot = unsafe { &mut *core::ptr::addr_of_mut!(LIVE) };
        Some(slot.write(Live::new(board_setup(), live_config(), start_bank)))
    }

    type Ports = (
        SerialNav<QueueRx<IMU_QUEUE_LEN>>,
        SerialNav<QueueRx<GNSS_QUEUE_LEN>>,
    );

    /// Clocks, the two USARTs and their interrupts, the live loop.
    fn start() -> Result<(&'static mut Live, Ports), StartError> {
        let dp = pac::Peripherals::take().ok_or(StartError::Peripherals)?;
        let clocks = dp.RCC.constrain().cfgr.sysclk(SYSCLK_HZ.Hz()).freeze();
        let config = |baud: u32| {
            Config::default()
                .baudrate(baud.bps())
                .wordlength_8()
                .parity_none()
        };

        let gpioa = dp.GPIOA.split();
        let mut imu_rx: Rx<USART2> = dp
            .USART2
            .rx(gpioa.pa3, config(IMU_BAUD), &clocks)
            .map_err(|_| StartError::Serial)?;
        let gpiob = dp.GPIOB.split();
        let mut gnss_rx: Rx<USART3> = dp
            .USART3
            .rx(gpiob.pb11, config(GNSS_BAUD), &clocks)
            .map_err(|_| StartError::Serial)?;

        let (imu_p, imu_c) = IMU_QUEUE
            .try_init(Queue::new())
            .ok_or(StartError::Static)?
            .split();
        let (gnss_p, gnss_c) = GNSS_QUEUE
            .try_init(Queue::new())
            .ok_or(StartError::Static)?
            .split();
        imu_rx.listen();
        gnss_rx.listen();
        let handed_over = irq::free(|cs| {
            let imu = IMU_ISR.borrow(cs).try_borrow_mut();
            let gnss = GNSS_ISR.borrow(cs).try_borrow_mut();
            match (imu, gnss) {
                (Ok(mut a), Ok(mut b)) => {
                    *a = Some(RxIsr {
                        rx: imu_rx,
                        queue: imu_p,
                    });
                    *b = Some(RxIsr {
                        rx: gnss_rx,
                        queue: gnss_p,
                    });
                    true
                }
                _ => false,
            }
        });
        if !handed_over {
            return Err(StartError::Static);
        }
        let live = live_slot().ok_or(StartError::Static)?;
        // SAFETY: no critical section is open, and the handlers only touch their own state
        // (through a critical section) and atomics.
        unsafe {
            NVIC::unmask(Interrupt::USART2);
            NVIC::unmask(Interrupt::USART3);
        }
        defmt::info!(
            "imu-ident-nav-board: sysclk={=u32} Hz, IMU frames USART2 RX PA3 {=u32} baud, UBX USART3 RX PB11 {=u32} baud",
            clocks.sysclk().raw(),
            IMU_BAUD,
            GNSS_BAUD
        );
        Ok((
            live,
            (
                SerialNav::new(QueueRx(imu_c), None),
                SerialNav::new(QueueRx(gnss_c), None),
            ),
        ))
    }

    /// What the ports and the live loop refused so far, reported when it changes.
    #[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
    struct Losses {
        imu_wire: WireCounts,
        gnss_wire: WireCounts,
        line_errors: u32,
        queue_full: u32,
        refused: u32,
        /// Counted samples not stamped (before the clock's lock, or beyond its `max_sd`).
        unstamped: u32,
    }

    /// One input through the live loop, with its telemetry. Returns whether it was refused.
    fn take(live: &mut Live, input: &NavInput) -> bool {
        let decisions = live.run().map_or(0, decisions_of);
        let mut on = |e: LiveEvent<'_, f32>| match e {
            LiveEvent::Fix { epoch, .. } => send_epoch(epoch),
            LiveEvent::Started(s) => defmt::info!("live start t0={=f64}", s.t0),
            LiveEvent::Realigning(_) => defmt::warn!("live: levelling again (not at rest)"),
            LiveEvent::NoFix => defmt::warn!("live: levelling again (no fix)"),
            LiveEvent::FixDropped(t, _) => defmt::warn!("live: fix at {=f64} dropped", t),
            LiveEvent::Imu(..) => {}
        };
        let refused = feed(live, input, &mut on).is_err();
        if let Some(run) = live.run() {
            if decisions_of(run) != decisions {
                report_decision(run, run.time());
            }
        }
        refused
    }

    /// The loop: both ports into the live loop, in the order their bytes are read.
    fn run(live: &'static mut Live, ports: Ports) -> ! {
        let (mut imu, mut gnss) = ports;
        let mut reported = Losses::default();
        let mut refused = 0u32;
        let mut samples = 0u32;
        // A hub's counted samples put on GPS time (a wire of GPS-stamped ones passes through).
        // The configuration is a constant the clock accepts; a refusal would leave the
        // board without counted samples only.
        let mut stamps = TimerStamps::new(ClockConfig::crystal(HUB_TIMER_HZ)).ok();
        loop {
            let mut on = |i: NavInput| {
                let Some(i) = stamps.as_mut().map_or(Some(i), |s| s.stamp(i)) else {
                    return;
                };
                refused = refused.saturating_add(u32::from(take(live, &i)));
                if matches!(i, NavInput::Imu(_)) {
                    count_sample(&mut samples, || {
                        live.present().map(|p| (p, live.present_sd()))
                    });
                }
            };
            let n = match (
                imu.poll(MAX_BYTES_PER_POLL, &mut on),
                gnss.poll(MAX_BYTES_PER_POLL, &mut on),
            ) {
                (Ok(a), Ok(b)) => a.saturating_add(b),
                (Err(e), _) | (_, Err(e)) => match e {},
            };
            let losses = Losses {
                imu_wire: imu.counts(),
                gnss_wire: gnss.counts(),
                line_errors: IMU_COUNTS
                    .line_errors
                    .load(Ordering::Relaxed)
                    .saturating_add(GNSS_COUNTS.line_errors.load(Ordering::Relaxed)),
                queue_full: IMU_COUNTS
                    .queue_full
                    .load(Ordering::Relaxed)
                    .saturating_add(GNSS_COUNTS.queue_full.load(Ordering::Relaxed)),
                refused,
                unstamped: stamps.as_ref().map_or(0, TimerStamps::unstamped),
            };
            if losses != reported {
                defmt::warn!(
                    "nav board: imu_crc={=u32} ubx_rejected={=u32} no_fix={=u32} no_week={=u32} line_errors={=u32} queue_full={=u32} refused={=u32} unstamped={=u32}",
                    losses.imu_wire.imu_rejected,
                    losses.gnss_wire.ubx_rejected,
                    losses.gnss_wire.no_fix,
                    losses.gnss_wire.no_week,
                    losses.line_errors,
                    losses.queue_full,
                    losses.refused,
                    losses.unstamped
                );
                reported = losses;
            }
            if n == 0 {
                // Both queues empty: sleep until the next byte's interrupt.
                cortex_m::asm::wfi();
            }
        }
    }

    #[interrupt]
    fn USART2() {
        irq::free(|cs| {
            if let Ok(mut s) = IMU_ISR.borrow(cs).try_borrow_mut() {
                if let Some(s) = s.as_mut() {
                    drain(&mut s.rx, &mut s.queue, &IMU_COUNTS);
                }
            }
        });
    }

    #[interrupt]
    fn USART3() {
        irq::free(|cs| {
            if let Ok(mut s) = GNSS_ISR.borrow(cs).try_borrow_mut() {
                if let Some(s) = s.as_mut() {
                    drain(&mut s.rx, &mut s.queue, &GNSS_COUNTS);
                }
            }
        });
    }
}
