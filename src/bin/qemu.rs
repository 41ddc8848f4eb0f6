//! Firmware for QEMU's mps2-an386 (Cortex-M4F): replays a recorded log through the 1 Hz step
//! ([`Estimator`]) at full speed and reports every tick, parameter change and autocorrelation
//! identification as defmt frames; then the instruction counts and the stack high-water mark.
//!
//! Kept thin on purpose: the model codec ([`imu_ident::model::wire`]), the log codec
//! ([`imu_ident::replay`]), the step and the records live in the library, where the host tests
//! them; this file only wires semihosting and the SysTick counter to them.
//!
//! - Input (semihosting, relative to QEMU's working directory): the arguments after the program
//!   name are the model file (written by `hal-sim qemu`: model and run options, see
//!   [`imu_ident::model::wire`]) and the binary replay log; defaults `model.bin`, `replay.bin`.
//! - Output: defmt frames on semihosting stdout (`semihost/mod.rs`, panic-free through
//!   `imu_ident::defmt_frame`): `tlm` per tick, `par` per component at each re-identification,
//!   `acf` on schedule, then `icount` and `stack` summaries.
//! - Exit: status 0 after a complete, checksum-valid log; 1 for anything else.
//!
//! ```text
//! qemu-system-arm -cpu cortex-m4 -machine mps2-an386 -nographic -icount shift=0 \
//!   -semihosting-config enable=on,target=native,arg=imu-ident-qemu,arg=model.bin,arg=log.bin \
//!   -kernel imu-ident-qemu | defmt-print -e imu-ident-qemu
//! ```
//!
//! Instruction counts: with `-icount shift=0` QEMU advances its virtual clock 1 ns per
//! instruction and SysTick counts at 25 MHz, so one SysTick count is 40 instructions. They are
//! instruction counts on a Cortex-M4, not cycle times (QEMU models no pipeline or wait states).

#![cfg_attr(all(target_arch = "arm", target_os = "none"), no_std, no_main)]

#[cfg(not(all(target_arch = "arm", target_os = "none")))]
fn main() {
    // Built for the host only by an --all-features build; the firmware needs the ARM target.
    eprintln!("imu-ident-qemu is firmware: build it with --target thumbv7em-none-eabihf");
    std::process::exit(2);
}

#[cfg(all(target_arch = "arm", target_os = "none"))]
#[path = "semihost/mod.rs"]
mod semihost;

#[cfg(all(target_arch = "arm", target_os = "none"))]
mod firmware {
    use core::ffi::CStr;

    use super::semihost::{self, Counts, HostError, HostFile};
    use cortex_m::peripheral::SYST;
    use cortex_m_rt::{entry, exception, ExceptionFrame};
    use cortex_m_semihosting::debug::{EXIT_FAILURE, EXIT_SUCCESS};
    use imu_ident::model::wire::{self, WireError};
    use imu_ident::replay::{Decoder, ReplayError};
    use imu_ident::step::{Estimator, StepConfig, StepError};
    use imu_ident::telemetry::DefmtSink;

    /// File names used when QEMU passes no arguments.
    const DEFAULT_MODEL: &CStr = c"model.bin";
    const DEFAULT_LOG: &CStr = c"replay.bin";
    /// Read size: the decoder takes any chunking, so this only trades RAM for host calls.
    const CHUNK: usize = 512;

    /// Why a replay failed.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
    enum FirmwareError {
        /// Argument or file access.
        Host(HostError),
        /// The model file is not valid.
        Model(WireError),
        /// The model or its options were rejected by the estimator.
        Estimator(StepError),
        /// The log is not a valid replay log.
        Log(ReplayError),
    }

    impl From<HostError> for FirmwareError {
        fn from(e: HostError) -> Self {
            Self::Host(e)
        }
    }

    /// The estimator lives in a static, not on the stack (about 32 KB; all zeros until
    /// initialised, so it sits in `.bss`).
    static mut NAV: Estimator<f32> = Estimator::BLANK;

    #[entry]
    fn main() -> ! {
        semihost::paint_stack();
        let status = match run() {
            Ok(rows) => {
                defmt::info!("replay done rows={=u32}", rows);
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

    #[inline(never)]
    fn run() -> Result<u32, FirmwareError> {
        let mut names = [[0u8; semihost::CMDLINE_LEN]; 2];
        let [model_name, log_name] = &mut names;
        let model_path = semihost::arg(0, model_name, DEFAULT_MODEL)?;
        let log_path = semihost::arg(1, log_name, DEFAULT_LOG)?;

        let mut model_bytes = [0u8; wire::MAX_LEN];
        let n = read_all(model_path, &mut model_bytes)?;
        let bytes = model_bytes.get(..n).ok_or(HostError::Read)?;
        let (model, opts) = wire::decode_options::<f32>(bytes).map_err(FirmwareError::Model)?;
        let cfg = if opts & wire::OPT_STRUCTURE != 0 {
            StepConfig::adaptive_structure()
        } else if opts & wire::OPT_GLOBAL != 0 {
            StepConfig::adaptive_global()
        } else if opts & wire::OPT_ADAPT != 0 {
            StepConfig::adaptive()
        } else {
            StepConfig::default()
        };
        let block = cfg.adapt.map_or(0, |a| a.block);
        let epoch = cfg.adapt.map_or(0, |a| a.epoch);
        let nav = init(model, cfg)?;
        // Start-up and steady state are measured apart: paint again for the ticks.
        semihost::report_stack("init");
        semihost::paint_stack();
        replay(nav, log_path, block, epoch)
    }

    /// Initialises [`NAV`] in place (its own frame, so that its temporaries are not part of the
    /// replay loop's stack).
    #[inline(never)]
    fn init(
        model: imu_ident::model::InsModel<f32>,
        cfg: StepConfig<f32>,
    ) -> Result<&'static mut Estimator<f32>, FirmwareError> {
        // SAFETY: called once, from `run`; no other reference to NAV exists.
        let nav = unsafe { &mut *core::ptr::addr_of_mut!(NAV) };
        nav.init(model, cfg).map_err(FirmwareError::Estimator)?;
        Ok(nav)
    }

    /// Replays the log through `nav`, counting instructions per tick.
    #[inline(never)]
    fn replay(
        nav: &mut Estimator<f32>,
        log_path: &CStr,
        block: u32,
        epoch: u32,
    ) -> Result<u32, FirmwareError> {
        let mut file = HostFile::open(log_path)?;
        let _syst = semihost::timer();
        let mut sink = DefmtSink;
        let mut decoder = Decoder::new();
        let mut buf = [0u8; CHUNK];
        let (mut ordinary, mut reident) = (Counts::default(), Counts::default());
        loop {
            let n = file.read(&mut buf)?;
            let Some(chunk) = buf.get(..n).filter(|c| !c.is_empty()) else {
                break;
            };
            for &byte in chunk {
                let Some(row) = decoder.push(byte).map_err(FirmwareError::Log)? else {
                    continue;
                };
                // One tick per row when the log has no gaps (a gap's bridged ticks are counted
                // together with their row's): the instruction count of `push` without the sink.
                let k = nav.ticks();
                let mut counting = Counting::default();
                let t0 = SYST::get_current();
                nav.push(row.t, row.z, &mut counting);
                let t1 = SYST::get_current();
                let instr = semihost::instructions(t0, t1);
                let boundary = |p: u32| p != 0 && (k + 1) % p == 0;
                if boundary(block) || boundary(epoch) {
                    reident.add(instr, k);
                } else {
                    ordinary.add(instr, k);
                }
                counting.replay(nav, &mut sink);
            }
        }
        ordinary.log("ordinary");
        reident.log("reident");
        decoder.finish().map_err(FirmwareError::Log)
    }

    /// A sink that only remembers what `push` produced, so the telemetry's own cost (semihosting
    /// writes) stays out of the instruction count; the records are re-sent afterwards.
    #[derive(Default)]
    struct Counting {
        records: heapless::Vec<imu_ident::telemetry::Record, 4>,
        overflow: bool,
        reidentified: bool,
        acf: bool,
    }

    impl imu_ident::telemetry::TelemetrySink for Counting {
        fn record(&mut self, r: &imu_ident::telemetry::Record) {
            if self.records.push(*r).is_err() {
                // A long bridged gap: send the record now (it is counted, but rare).
                self.overflow = true;
                r.log();
            }
        }
        fn params(&mut self, _: &imu_ident::telemetry::ParamRecord) {
            self.reidentified = true;
        }
        fn acf(&mut self, _: &imu_ident::telemetry::AcfRecord) {
            self.acf = true;
        }
    }

    impl Counting {
        /// Sends what was collected, with the parameters and ACF records recomputed from the
        /// estimator (they describe the state after the last tick, which is what they were).
        fn replay(&self, nav: &Estimator<f32>, sink: &mut DefmtSink) {
            use imu_ident::step::Report;
            let n = self.records.len();
            for (i, r) in self.records.iter().enumerate() {
                let last = i + 1 == n;
                let rep = Report {
                    record: *r,
                    reidentified: last && self.reidentified,
                    jumped: false,
                    acf: last && self.acf,
                };
                nav.emit(&rep, sink);
            }
        }
    }

    /// Reads a whole (small) file into `buf`; returns its length.
    fn read_all(path: &CStr, buf: &mut [u8]) -> Result<usize, FirmwareError> {
        let mut f = HostFile::open(path)?;
        let mut n = 0;
        loop {
            let rest = buf.get_mut(n..).ok_or(HostError::Read)?;
            if rest.is_empty() {
                // Longer than any valid model: let the decoder reject it by length.
                return Ok(n);
            }
            let m = f.read(rest)?;
            if m == 0 {
                return Ok(n);
            }
            n += m;
        }
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
