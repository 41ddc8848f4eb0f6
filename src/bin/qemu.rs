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
//! - Output: defmt frames on semihosting stdout (this file's logger, panic-free through
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
mod firmware {
    use core::ffi::CStr;

    use cortex_m::peripheral::syst::SystClkSource;
    use cortex_m::peripheral::SYST;
    use cortex_m_rt::{entry, exception, ExceptionFrame};
    use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};
    use cortex_m_semihosting::{nr, syscall, syscall1};
    use imu_ident::model::wire::{self, WireError};
    use imu_ident::replay::{Decoder, ReplayError};
    use imu_ident::step::{Estimator, StepConfig, StepError};
    use imu_ident::telemetry::DefmtSink;

    /// File names used when QEMU passes no arguments.
    const DEFAULT_MODEL: &CStr = c"model.bin";
    const DEFAULT_LOG: &CStr = c"replay.bin";
    /// Longest accepted command line and file name (bytes, including the terminating NUL).
    const CMDLINE_LEN: usize = 256;
    /// Read size: the decoder takes any chunking, so this only trades RAM for host calls.
    const CHUNK: usize = 512;
    /// Stack paint pattern.
    const PAINT: u32 = 0xC0DE_5AFE;

    /// Why a replay failed.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
    enum FirmwareError {
        /// The command line could not be read, or a file name is too long.
        BadArgument,
        /// A file could not be opened.
        Open,
        /// Reading a file failed.
        Read,
        /// The model file is not valid.
        Model(WireError),
        /// The model or its options were rejected by the estimator.
        Estimator(StepError),
        /// The log is not a valid replay log.
        Log(ReplayError),
    }

    /// Instruction counts of one class of ticks (SysTick counts x 40).
    #[derive(Default)]
    struct Counts {
        n: u32,
        sum: u64,
        worst: u32,
        worst_k: u32,
    }

    impl Counts {
        fn add(&mut self, instr: u32, k: u32) {
            self.n = self.n.saturating_add(1);
            self.sum = self.sum.saturating_add(u64::from(instr));
            if instr > self.worst {
                self.worst = instr;
                self.worst_k = k;
            }
        }
        fn log(&self, class: &str) {
            let mean = if self.n == 0 {
                0
            } else {
                self.sum / u64::from(self.n)
            };
            defmt::info!(
                "icount class={=str} n={=u32} mean={=u64} worst={=u32} worst_k={=u32}",
                class,
                self.n,
                mean,
                self.worst,
                self.worst_k
            );
        }
    }

    /// The estimator lives in a static, not on the stack (about 32 KB; all zeros until
    /// initialised, so it sits in `.bss`).
    static mut NAV: Estimator<f32> = Estimator::BLANK;

    #[entry]
    fn main() -> ! {
        paint_stack();
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
        report_stack("run");
        exit(status)
    }

    fn exit(status: debug::ExitStatus) -> ! {
        debug::exit(status);
        // Only reached without a semihosting host (e.g. on a board): park the core.
        loop {
            cortex_m::asm::wfi();
        }
    }

    #[inline(never)]
    fn run() -> Result<u32, FirmwareError> {
        let mut names = [[0u8; CMDLINE_LEN]; 2];
        let [model_name, log_name] = &mut names;
        let (model_path, log_path) = paths(model_name, log_name)?;

        let mut model_bytes = [0u8; wire::MAX_LEN];
        let n = read_all(model_path, &mut model_bytes)?;
        let bytes = model_bytes.get(..n).ok_or(FirmwareError::Read)?;
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
        report_stack("init");
        paint_stack();
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
        let _syst = timer();
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
                // SysTick counts down and wraps at 2^24.
                let instr = (t0.wrapping_sub(t1) & 0x00FF_FFFF) * 40;
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

    fn timer() -> SYST {
        // SAFETY: the only user of the core peripherals.
        let mut p = unsafe { cortex_m::Peripherals::steal() };
        p.SYST.set_clock_source(SystClkSource::Core);
        p.SYST.set_reload(0x00FF_FFFF);
        p.SYST.clear_current();
        p.SYST.enable_counter();
        p.SYST
    }

    /// Reads a whole (small) file into `buf`; returns its length.
    fn read_all(path: &CStr, buf: &mut [u8]) -> Result<usize, FirmwareError> {
        let mut f = HostFile::open(path)?;
        let mut n = 0;
        loop {
            let rest = buf.get_mut(n..).ok_or(FirmwareError::Read)?;
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

    /// The model and log names: the first two arguments after the program name, else the
    /// defaults. Each is copied into its buffer to add the NUL that semihosting's open needs.
    fn paths<'a>(
        model: &'a mut [u8; CMDLINE_LEN],
        log: &'a mut [u8; CMDLINE_LEN],
    ) -> Result<(&'a CStr, &'a CStr), FirmwareError> {
        let mut line = [0u8; CMDLINE_LEN];
        let line = cmdline(&mut line)?;
        let mut it = Words(line).skip(1);
        let mut name = |buf: &'a mut [u8; CMDLINE_LEN], default: &'static CStr| {
            let Some(arg) = it.next() else {
                return Ok(default);
            };
            let dst = buf.get_mut(..arg.len()).ok_or(FirmwareError::BadArgument)?;
            dst.copy_from_slice(arg);
            // `buf` was zeroed, so the name is followed by a NUL unless it filled the buffer.
            CStr::from_bytes_until_nul(buf).map_err(|_| FirmwareError::BadArgument)
        };
        let m = name(model, DEFAULT_MODEL)?;
        let l = name(log, DEFAULT_LOG)?;
        Ok((m, l))
    }

    /// The semihosting command line (SYS_GET_CMDLINE), without its NUL.
    fn cmdline(buf: &mut [u8; CMDLINE_LEN]) -> Result<&[u8], FirmwareError> {
        // The parameter block: buffer address and size in; the host writes the length back.
        let mut block = [buf.as_mut_ptr() as usize, CMDLINE_LEN];
        // SAFETY: the host writes at most CMDLINE_LEN bytes into `buf` and one word of `block`.
        let r = unsafe { syscall1(nr::GET_CMDLINE, block.as_mut_ptr() as usize) };
        if r != 0 {
            return Err(FirmwareError::BadArgument);
        }
        let [_, len] = block;
        buf.get(..len).ok_or(FirmwareError::BadArgument)
    }

    /// The words of a command line: separated by blanks (space, tab); a word that starts with
    /// `"` or `'` runs to the matching quote (as the `semihosting` crate splits it).
    struct Words<'a>(&'a [u8]);

    impl<'a> Iterator for Words<'a> {
        type Item = &'a [u8];
        fn next(&mut self) -> Option<&'a [u8]> {
            let is_blank = |b: &u8| *b == b' ' || *b == b'\t';
            let start = self.0.iter().position(|b| !is_blank(b))?;
            let rest = self.0.get(start..)?;
            let (word, after) = match rest.split_first() {
                Some((&q, tail)) if q == b'"' || q == b'\'' => {
                    let end = tail.iter().position(|&b| b == q).unwrap_or(tail.len());
                    (
                        tail.get(..end)?,
                        tail.get(end.saturating_add(1)..).unwrap_or(&[]),
                    )
                }
                _ => {
                    let end = rest.iter().position(is_blank).unwrap_or(rest.len());
                    (rest.get(..end)?, rest.get(end..).unwrap_or(&[]))
                }
            };
            self.0 = after;
            Some(word)
        }
    }

    /// A host file opened for reading through raw semihosting calls (SYS_OPEN, SYS_READ,
    /// SYS_CLOSE): the `semihosting` crate's `File` carries panic paths.
    struct HostFile(usize);

    impl HostFile {
        fn open(path: &CStr) -> Result<Self, FirmwareError> {
            let len = path.to_bytes().len();
            // SAFETY: `path` is NUL-terminated and `len` excludes the NUL, as SYS_OPEN expects.
            let fd = unsafe { syscall!(OPEN, path.as_ptr(), nr::open::R_BINARY, len) };
            if fd as isize == -1 {
                return Err(FirmwareError::Open);
            }
            Ok(Self(fd))
        }

        /// Reads up to `buf.len()` bytes; 0 at the end of the file.
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, FirmwareError> {
            // SAFETY: the host writes at most `buf.len()` bytes into `buf`.
            let not_read = unsafe { syscall!(READ, self.0, buf.as_mut_ptr(), buf.len()) };
            // SYS_READ returns the number of bytes *not* read.
            buf.len().checked_sub(not_read).ok_or(FirmwareError::Read)
        }
    }

    impl Drop for HostFile {
        fn drop(&mut self) {
            // SAFETY: closes the handle this value owns.
            unsafe { syscall!(CLOSE, self.0) };
        }
    }

    /// The global defmt logger: the encoded frames go to semihosting stdout (`:tt`), the bytes
    /// `defmt-semihosting` writes, but without its panics. A frame started while another is
    /// being written (a logger re-entered from an exception handler) is dropped instead. This
    /// module is the transport (`write_stdout`); the frame handling is the library's
    /// `imu_ident::defmt_frame`, shared with the board firmware.
    mod stdout_log {
        use core::cell::UnsafeCell;
        use cortex_m_semihosting::hio::{self, HostStream};
        use imu_ident::defmt_frame;

        #[defmt::global_logger]
        struct Logger;

        /// Semihosting stdout, opened on first use by [`write_stdout`].
        struct Stdout(UnsafeCell<Option<HostStream>>);

        // SAFETY: only touched by `write_stdout`, with interrupts disabled (see there).
        unsafe impl Sync for Stdout {}

        static STDOUT: Stdout = Stdout(UnsafeCell::new(None));

        /// Writes `bytes` to stdout, opening it on first use; errors are ignored (there is
        /// nowhere to report them). Only the sink given to `defmt_frame`, which calls it
        /// between `acquire` and `release` (interrupts disabled) and never for a nested frame.
        fn write_stdout(bytes: &[u8]) {
            // SAFETY: interrupts are disabled (single core) and the sink is not re-entered, so
            // no other reference to `STDOUT` is live.
            let stdout = unsafe { &mut *STDOUT.0.get() };
            if stdout.is_none() {
                *stdout = hio::hstdout().ok();
            }
            if let Some(h) = stdout {
                let _ = h.write_all(bytes);
            }
        }

        // SAFETY: frames are written with interrupts disabled; nested frames are dropped
        // (`imu_ident::defmt_frame`).
        unsafe impl defmt::Logger for Logger {
            fn acquire() {
                defmt_frame::acquire(write_stdout);
            }

            unsafe fn flush() {}

            unsafe fn release() {
                // SAFETY: called after `acquire`, as the `Logger` contract requires.
                unsafe { defmt_frame::release(write_stdout) }
            }

            unsafe fn write(bytes: &[u8]) {
                // SAFETY: called between `acquire` and `release`, as the `Logger` contract
                // requires.
                unsafe { defmt_frame::write(bytes, write_stdout) }
            }
        }
    }

    extern "C" {
        static mut __sheap: u32;
        static mut _stack_start: u32;
    }

    /// Fills the unused stack (from the end of static RAM up to just below the current stack
    /// pointer) with [`PAINT`].
    #[inline(never)]
    fn paint_stack() {
        let sp = cortex_m::register::msp::read() as usize;
        let lo = core::ptr::addr_of_mut!(__sheap) as usize;
        let mut p = lo;
        // Leave 256 bytes below the current frame untouched.
        while p + 4 <= sp.saturating_sub(256) {
            // SAFETY: [__sheap, sp - 256) is RAM not used by anything yet (no heap).
            unsafe { core::ptr::write_volatile(p as *mut u32, PAINT) };
            p += 4;
        }
    }

    /// Reports the deepest stack use since the last paint: the lowest word that no longer holds
    /// [`PAINT`].
    #[inline(never)]
    fn report_stack(phase: &str) {
        let lo = core::ptr::addr_of_mut!(__sheap) as usize;
        let hi = core::ptr::addr_of_mut!(_stack_start) as usize;
        let mut p = lo;
        // SAFETY: reads of RAM between the statics and the stack top.
        while p < hi && unsafe { core::ptr::read_volatile(p as *const u32) } == PAINT {
            p += 4;
        }
        defmt::info!(
            "stack phase={=str} high_water={=u32} statics_end={=u32} ram_top={=u32}",
            phase,
            (hi - p) as u32,
            lo as u32,
            hi as u32
        );
    }

    #[cfg(not(feature = "prove-no-panic"))]
    #[panic_handler]
    fn panic(_info: &core::panic::PanicInfo) -> ! {
        // No defmt here: the panic may come from inside the logger, which is not re-entrant.
        exit(EXIT_FAILURE)
    }

    // With `prove-no-panic` the panic handler is the library's (`imu_ident::panic_proof`).

    #[exception]
    unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
        exit(EXIT_FAILURE)
    }
}
