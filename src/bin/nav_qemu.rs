//! Firmware for QEMU's mps2-an386 (Cortex-M4F): the 3D INS/GNSS navigator
//! ([`imu_ident::nav::NavReplay`], `f32`, [`NAV_N`] states) over a binary replay of an IMU +
//! GNSS log ([`imu_ident::nav::replay`], written by `hal_sim::nav_qemu`). One defmt frame per
//! GNSS epoch, then instruction counts and the stack high-water marks.
//!
//! Thin on purpose: the replay codec, the navigator's construction and the per-record loop are
//! the library's ([`imu_ident::nav::run`]), shared with the host driver; this file reads the
//! bytes over semihosting, times the calls with SysTick and sends the frames.
//!
//! A live replay (its setup has [`NavSetup::live`]: the raw stream, written by
//! `hal_sim::nav_qemu::encode_live_replay`) runs through the live loop instead
//! ([`imu_ident::nav::live::LiveNav`]): the firmware levels, places the run at its fix and
//! decides every fix itself, as a navigation computer fed by its sensors would.
//!
//! With a second file (a second argument), the live replay gives only the setup and the
//! second file is the serial wire ([`imu_ident::nav::serial`]: IMU sample frames and a u-blox
//! receiver's `NAV-TIMEGPS` / `NAV-PVT` messages, written by `hal_sim::nav_io::ubx`): its
//! bytes go through the core's decoders into the live loop, as a board's ports would feed
//! them. A wire of counted samples (a hub that stamps them with its timer, and captures the
//! receiver's pulses on it: [`imu_ident::nav::counted`]) is put on GPS time by a
//! [`TimerStamps`] on the way ([`HUB_TIMER_HZ`](nav_support::HUB_TIMER_HZ)). The decoders'
//! refusals are reported at the end (`wire`), and the clock's (`stamps`); `icount wire`
//! counts the decoding (and stamping) of each full 256-byte read.
//!
//! - Input: the file named by the first semihosting argument after the program name (default
//!   `nav.bin`), relative to QEMU's working directory.
//! - Output (defmt on semihosting stdout): `nav` per GNSS epoch (time, position f64 rad/m,
//!   NED velocity, position sigmas N/E/D, flags); in a live run, `now` every tenth sample
//!   (the solution at the newest sample, the output predictor's: time, position, NED
//!   velocity, roll, pitch, yaw, and the standard deviations of the attitude, velocity and
//!   position errors; the navigation board's frame); first, `icount clock_stamp` and
//!   `clock_pulse` and `clock worst_ns=...`, the GPS clock's start-up bench (`clock_bench`);
//!   then `icount` per class: `imu` (an IMU sample
//!   mechanised, no filter step), `step` (an IMU sample whose end starts the 1 Hz filter step:
//!   mechanisation + propagation, and the zero-velocity update when one is applied),
//!   `nhc` (the same with the non-holonomic constraint applied
//!   after the propagation: gate + two sequential updates + closed-loop correction; none
//!   without the constraint), `gnss` (a fix fused: gate + six sequential updates +
//!   closed-loop correction); in a live run, `live` (every call, whatever it did: the loop's
//!   whole cost, the output predictor's included; with a latency budget the fixes are fused
//!   inside the sample calls that pass them, so `imu` and `step` include them and `gnss`
//!   counts none) and `present` (the solution at the newest sample and its standard
//!   deviations for a `now` frame, outside `live`); `stack` for start-up and for the run.
//! - Exit: status 0 after a complete, checksum-valid replay; 1 otherwise.
//!
//! ```text
//! qemu-system-arm -cpu cortex-m4 -machine mps2-an386 -nographic -icount shift=0 \
//!   -semihosting-config enable=on,target=native,arg=imu-ident-nav-qemu,arg=nav.bin \
//!   -kernel imu-ident-nav-qemu | defmt-print -e imu-ident-nav-qemu
//! ```
//!
//! Instruction counts: with `-icount shift=0` one SysTick count is 40 instructions; they are
//! instruction counts on a Cortex-M4, not cycle times (QEMU models no pipeline or wait states).

#![cfg_attr(all(target_arch = "arm", target_os = "none"), no_std, no_main)]

#[cfg(not(all(target_arch = "arm", target_os = "none")))]
fn main() {
    // Built for the host only by an --all-features build; the firmware needs the ARM target.
    eprintln!("imu-ident-nav-qemu is firmware: build it with --target thumbv7em-none-eabihf");
    std::process::exit(2);
}

#[cfg(all(target_arch = "arm", target_os = "none"))]
#[path = "semihost/mod.rs"]
mod semihost;

#[cfg(all(target_arch = "arm", target_os = "none"))]
#[path = "nav_support/mod.rs"]
mod nav_support;

#[cfg(all(target_arch = "arm", target_os = "none"))]
mod firmware {
    use super::nav_support::{
        count_sample, decisions_of, report_decision, send_epoch, start_bank, Bank, Run,
        HUB_TIMER_HZ,
    };
    use core::ffi::CStr;
    use core::mem::MaybeUninit;

    use super::semihost::{self, Counts, HostError, HostFile};
    use cortex_m::peripheral::SYST;
    use cortex_m_rt::{entry, exception, ExceptionFrame};
    use cortex_m_semihosting::debug::{EXIT_FAILURE, EXIT_SUCCESS};
    use imu_ident::nav::gps_clock::{ClockConfig, GpsClock};
    use imu_ident::nav::imu_frame::ImuSample;
    use imu_ident::nav::live::{LiveEvent, LiveFix, LiveNav};
    use imu_ident::nav::replay::{Decoder, Event, NavReplayError, Record};
    use imu_ident::nav::run::ImuStep;
    use imu_ident::nav::serial::{feed, NavInput, NavWire, TimerStamps};
    use imu_ident::nav::{Epoch, NavError, NavReplay, NavSetup, NAV_N};

    /// File read when QEMU passes no argument.
    const DEFAULT_LOG: &CStr = c"nav.bin";
    /// No second argument: no serial wire file.
    const NO_WIRE: &CStr = c"";
    /// Read size: the decoder takes any chunking, so this only trades RAM for host calls.
    const CHUNK: usize = 512;
    /// Read size of a serial wire file: its inputs are queued per read (see `read_wire`).
    const WIRE_CHUNK: usize = 256;

    /// IMU samples the live start holds until its fix (1.28 s at 100 Hz).
    const LIVE_BUFFER: usize = 128;

    type Live = LiveNav<f32, NAV_N, Option<&'static mut Bank>, LIVE_BUFFER>;

    /// What the log is: a replay of the host's start and decisions, or the raw stream of a
    /// live run ([`imu_ident::nav::live`]: the firmware levels, places the run and decides
    /// each fix itself). One static holds either (no heap to box the larger into).
    #[allow(clippy::large_enum_variant)]
    enum Mode {
        Replay(Run),
        Live(Live),
    }

    /// The run of [`Mode`], once built.
    enum Nav {
        Replay(&'static mut Run),
        Live(&'static mut Live),
    }

    /// What the record calls did, counted per class of call.
    #[derive(Default)]
    struct Tally {
        imu: Counts,
        step: Counts,
        nhc: Counts,
        fuse: Counts,
        /// Decoding a full chunk of a serial wire file.
        wire: Counts,
        /// Every call of a live run, whatever it did (`icount live`: the whole loop's cost,
        /// the output predictor's included).
        live: Counts,
        /// The solution at the newest sample and its standard deviations, for a `now` frame
        /// (`icount present`; outside `live`: the board asks for it every tenth sample).
        present: Counts,
        n_imu: u32,
        live_calls: u32,
        /// IMU samples given to the live loop (the board's count for its `now` frames).
        live_samples: u32,
        epochs: u32,
        chunks: u32,
    }

    impl Tally {
        /// Counts a sample's call by what it did.
        fn sample(&mut self, done: &ImuStep<f32>, instr: u32) {
            let class = match (done.stepped, done.nhc.is_some()) {
                (_, true) => &mut self.nhc,
                (true, false) => &mut self.step,
                (false, false) => &mut self.imu,
            };
            class.add(instr, self.n_imu);
            self.n_imu = self.n_imu.wrapping_add(1);
        }
    }

    /// Why a replay failed.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
    enum FirmwareError {
        /// Argument or file access.
        Host(HostError),
        /// The replay is not valid.
        Log(NavReplayError),
        /// A record before the setup (cannot happen with a valid replay; kept total).
        NoSetup,
        /// The navigator refused the setup or a record.
        Nav(NavError),
        /// A serial wire file with a setup that is not a live one.
        NotLive,
        /// The hub's clock configuration was refused (cannot happen with the constant one).
        Clock,
    }

    impl From<HostError> for FirmwareError {
        fn from(e: HostError) -> Self {
            Self::Host(e)
        }
    }

    /// The run (navigator, filter, model: about 10 KB; with the live start's buffer, about
    /// 13 KB) lives in a static, written once the setup has been read.
    static mut MODE: MaybeUninit<Mode> = MaybeUninit::uninit();

    #[entry]
    fn main() -> ! {
        semihost::paint_stack();
        let status = match run() {
            Ok((records, epochs)) => {
                defmt::info!("replay done records={=u32} epochs={=u32}", records, epochs);
                EXIT_SUCCESS
            }
            Err(e) => {
                defmt::error!("replay failed: {}", e);
                EXIT_FAILURE
            }
        };
        semihost::report_stack("run");
        semihost::exit(status)
    }

    /// Builds the run in [`MODE`] (its own frame: the temporaries of the navigator's
    /// construction are not part of the record loop's stack). A live replay builds the live
    /// loop, which builds the navigator when it has placed the run.
    #[inline(never)]
    fn init(setup: &NavSetup) -> Result<Nav, FirmwareError> {
        // SAFETY: called once, before any other reference to MODE exists.
        let slot = unsafe { &mut *core::ptr::addr_of_mut!(MODE) };
        if let Some(cfg) = setup.live {
            let live = Live::new(setup.clone(), cfg, start_bank);
            return match slot.write(Mode::Live(live)) {
                Mode::Live(l) => Ok(Nav::Live(l)),
                Mode::Replay(_) => Err(FirmwareError::NoSetup),
            };
        }
        let plain = NavReplay::<f32, NAV_N>::new(setup).map_err(FirmwareError::Nav)?;
        let bank = start_bank(setup, &plain).map_err(FirmwareError::Nav)?;
        match slot.write(Mode::Replay(plain.with_observer(bank))) {
            Mode::Replay(r) => Ok(Nav::Replay(r)),
            Mode::Live(_) => Err(FirmwareError::NoSetup),
        }
    }

    /// One record of a replay through the run.
    fn replay_record(run: &mut Run, r: &Record, tally: &mut Tally) -> Result<(), FirmwareError> {
        match r {
            Record::Imu(r) => {
                let decisions = decisions_of(run);
                let t0 = SYST::get_current();
                let done = run.imu(r).map_err(FirmwareError::Nav)?;
                let t1 = SYST::get_current();
                if decisions_of(run) != decisions {
                    report_decision(run, r.t);
                }
                tally.sample(&done, semihost::instructions(t0, t1));
            }
            Record::Gnss(r) => {
                let t0 = SYST::get_current();
                let fused = run.gnss(r).map_err(FirmwareError::Nav)?;
                let t1 = SYST::get_current();
                if fused.is_some() {
                    tally.fuse.add(semihost::instructions(t0, t1), tally.epochs);
                }
                send_epoch(&run.epoch(r, fused.as_ref()));
                tally.epochs = tally.epochs.wrapping_add(1);
            }
        }
        Ok(())
    }

    /// What one call of the live loop did (its epochs are sent after the call, outside the
    /// instruction count; more than fit are sent at once).
    #[derive(Default)]
    struct LiveCall {
        samples: u32,
        last: Option<ImuStep<f32>>,
        fused: bool,
        epochs: heapless::Vec<Epoch<f32>, 8>,
    }

    /// A live replay's record as the wire would deliver it.
    fn input_of(r: &Record) -> NavInput {
        match r {
            Record::Imu(s) => NavInput::Imu(ImuSample {
                t: s.t,
                gyro: s.gyro,
                accel: s.accel,
            }),
            Record::Gnss(g) => NavInput::Fix(LiveFix::from_record(g)),
        }
    }

    /// One input through the live loop: a sample, or a fix decoded as the receiver would give
    /// it. A call that ran one sample is counted as the replay's; the calls that start the run
    /// (the buffered samples) are not counted.
    fn live_input(live: &mut Live, r: &NavInput, tally: &mut Tally) -> Result<(), FirmwareError> {
        let decisions = live.run().map_or(0, decisions_of);
        let mut call = LiveCall::default();
        let mut on = |e: LiveEvent<'_, f32>| match e {
            LiveEvent::Imu(_, done) => {
                call.samples += 1;
                call.last = Some(*done);
            }
            LiveEvent::Fix { fused, epoch, .. } => {
                call.fused |= fused.is_some();
                if call.epochs.push(*epoch).is_err() {
                    send_epoch(epoch);
                }
            }
            LiveEvent::Started(s) => defmt::info!("live start t0={=f64}", s.t0),
            LiveEvent::Realigning(_) => defmt::warn!("live: levelling again (not at rest)"),
            LiveEvent::NoFix => defmt::warn!("live: levelling again (no fix)"),
            LiveEvent::FixDropped(t, _) => defmt::warn!("live: fix at {=f64} dropped", t),
        };
        let t0 = SYST::get_current();
        feed(live, r, &mut on).map_err(FirmwareError::Nav)?;
        let t1 = SYST::get_current();
        let instr = semihost::instructions(t0, t1);
        tally.live.add(instr, tally.live_calls);
        tally.live_calls = tally.live_calls.wrapping_add(1);
        match (r, call.samples, &call.last) {
            (NavInput::Imu(_), 1, Some(done)) => tally.sample(done, instr),
            (NavInput::Fix(_), 0, _) if call.fused => tally.fuse.add(instr, tally.epochs),
            _ => {}
        }
        for e in &call.epochs {
            send_epoch(e);
        }
        tally.epochs = tally.epochs.wrapping_add(call.epochs.len() as u32);
        if let Some(run) = live.run() {
            if decisions_of(run) != decisions {
                report_decision(run, run.time());
            }
        }
        // The solution at the newest sample, at the board's pace (`imu-ident-nav-board`).
        if matches!(r, NavInput::Imu(_)) {
            let (cost, k) = (&mut tally.present, tally.live_samples / 10);
            count_sample(&mut tally.live_samples, || {
                let t0 = SYST::get_current();
                let now = live.present().map(|p| (p, live.present_sd()));
                cost.add(semihost::instructions(t0, SYST::get_current()), k);
                now
            });
        }
        Ok(())
    }

    #[inline(never)]
    fn run() -> Result<(u32, u32), FirmwareError> {
        let mut name = [0u8; semihost::CMDLINE_LEN];
        let path = semihost::arg(0, &mut name, DEFAULT_LOG)?;
        let mut file = HostFile::open(path)?;
        let _syst = semihost::timer();
        clock_bench();
        let mut decoder = Decoder::new();
        let mut buf = [0u8; CHUNK];
        let mut nav: Option<Nav> = None;
        let mut tally = Tally::default();
        loop {
            let n = file.read(&mut buf)?;
            let Some(chunk) = buf.get(..n).filter(|c| !c.is_empty()) else {
                break;
            };
            for &byte in chunk {
                match decoder.push(byte).map_err(FirmwareError::Log)? {
                    None => {}
                    Some(Event::Setup) => {
                        let setup = decoder.setup().ok_or(FirmwareError::NoSetup)?;
                        nav = Some(init(setup)?);
                        // Start-up and steady state are measured apart: paint again.
                        semihost::report_stack("init");
                        semihost::paint_stack();
                    }
                    Some(Event::Record(r)) => match nav.as_mut().ok_or(FirmwareError::NoSetup)? {
                        Nav::Replay(run) => replay_record(run, &r, &mut tally)?,
                        Nav::Live(live) => live_input(live, &input_of(&r), &mut tally)?,
                    },
                }
            }
        }
        let mut wire_name = [0u8; semihost::CMDLINE_LEN];
        let wire_path = semihost::arg(1, &mut wire_name, NO_WIRE)?;
        if !wire_path.is_empty() {
            let Some(Nav::Live(live)) = nav.as_mut() else {
                return Err(FirmwareError::NotLive);
            };
            read_wire(wire_path, live, &mut tally)?;
        }
        // A live run's samples still in its latency budget at the log's end.
        if let Some(Nav::Live(live)) = nav.as_mut() {
            let mut on = |e: LiveEvent<'_, f32>| {
                if let LiveEvent::Fix { epoch, .. } = e {
                    send_epoch(epoch);
                    tally.epochs = tally.epochs.wrapping_add(1);
                }
            };
            live.flush(&mut on).map_err(FirmwareError::Nav)?;
        }
        tally.imu.log("imu");
        tally.step.log("step");
        tally.nhc.log("nhc");
        tally.fuse.log("gnss");
        if matches!(nav, Some(Nav::Live(_))) {
            tally.live.log("live");
            tally.present.log("present");
        }
        let records = decoder.finish().map_err(FirmwareError::Log)?;
        Ok((records, tally.epochs))
    }

    /// The GPS clock's cost on this core (`f64` in software): 60 s of a synthetic 84-MHz
    /// timer 30 ppm fast, a `TIM-TP` and a pulse every second, a sample stamped every 10 ms.
    /// Sends `icount clock_stamp` and `clock_pulse`, and `clock` with the worst stamp error
    /// [ns] after the lock (a check that the counts are of a working clock).
    #[inline(never)]
    fn clock_bench() {
        let count = |t: f64| ((t + 5.0) * 84e6 * (1.0 + 30e-6)) as u64 as u32;
        let Ok(mut clock) = GpsClock::new(ClockConfig::crystal(84e6)) else {
            return;
        };
        let (mut stamp, mut pulse) = (Counts::default(), Counts::default());
        let mut worst = 0f64;
        for k in 0..6000u32 {
            let t = 0.01 * f64::from(k);
            if k % 100 == 40 {
                clock.announce(libm::ceil(t), count(t));
            }
            if k % 100 == 0 {
                let c = count(t);
                let t0 = SYST::get_current();
                let _ = clock.pulse(c);
                pulse.add(semihost::instructions(t0, SYST::get_current()), k);
            }
            let c = count(t);
            let t0 = SYST::get_current();
            let s = clock.stamp(c);
            stamp.add(semihost::instructions(t0, SYST::get_current()), k);
            if let Some(s) = s {
                worst = worst.max(libm::fabs(s.t - t));
            }
        }
        stamp.log("clock_stamp");
        pulse.log("clock_pulse");
        defmt::info!("clock worst_ns={=f64}", worst * 1e9);
    }

    /// The serial wire file at `path` through the core's decoders into the live loop.
    fn read_wire(path: &CStr, live: &mut Live, tally: &mut Tally) -> Result<(), FirmwareError> {
        let mut file = HostFile::open(path)?;
        let mut wire = NavWire::new(None);
        let mut stamps = TimerStamps::new(ClockConfig::crystal(HUB_TIMER_HZ))
            .map_err(|_| FirmwareError::Clock)?;
        let mut buf = [0u8; WIRE_CHUNK];
        loop {
            let n = file.read(&mut buf)?;
            let Some(chunk) = buf.get(..n).filter(|c| !c.is_empty()) else {
                break;
            };
            // The chunk decoded first (timed: `icount wire`, per chunk of WIRE_CHUNK bytes),
            // then its inputs in order. A 38-byte frame per sample and 124 bytes per fix: at
            // most 7 samples and 3 fixes end in 256 bytes; a fuller queue is drained as it
            // fills. (Small: this frame is under the live loop's deepest stack.)
            let mut inputs = heapless::Vec::<NavInput, 10>::new();
            let mut spill: Result<(), FirmwareError> = Ok(());
            let t0 = SYST::get_current();
            for &byte in chunk {
                wire.push(byte, &mut |i| {
                    let Some(i) = stamps.stamp(i) else {
                        return;
                    };
                    if let Err(i) = inputs.push(i) {
                        spill = spill.and_then(|()| {
                            for q in &inputs {
                                live_input(live, q, tally)?;
                            }
                            inputs.clear();
                            live_input(live, &i, tally)
                        });
                    }
                });
            }
            let t1 = SYST::get_current();
            spill?;
            if n == WIRE_CHUNK {
                tally.wire.add(semihost::instructions(t0, t1), tally.chunks);
                tally.chunks = tally.chunks.wrapping_add(1);
            }
            for i in &inputs {
                live_input(live, i, tally)?;
            }
        }
        tally.wire.log("wire");
        let c = wire.counts();
        defmt::info!(
            "wire imu_rejected={=u32} ubx_rejected={=u32} no_fix={=u32} no_week={=u32}",
            c.imu_rejected,
            c.ubx_rejected,
            c.no_fix,
            c.no_week
        );
        let s = stamps.counts();
        defmt::info!(
            "stamps unstamped={=u32} used={=u32} unpaired={=u32} rejected={=u32} restarts={=u32}",
            stamps.unstamped(),
            s.used,
            s.unpaired,
            s.rejected,
            s.restarts
        );
        Ok(())
    }

    #[cfg(not(feature = "prove-no-panic"))]
    #[panic_handler]
    fn panic(_info: &core::panic::PanicInfo) -> ! {
        // No defmt here: the panic may come from inside the logger, which is not re-entrant.
        semihost::exit(EXIT_FAILURE)
    }

    // With `prove-no-panic` the panic handler is the library's (`imu_ident::panic_proof`).

    #[exception]
    unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
        semihost::exit(EXIT_FAILURE)
    }
}
