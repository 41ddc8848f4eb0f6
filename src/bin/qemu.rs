//! Firmware for QEMU's mps2-an386 (Cortex-M4F): replays a recorded log through the filter and
//! reports every step as a defmt frame.
//!
//! Kept thin on purpose: the codec ([`imu_ident::replay`]), the loop ([`Replayer`]) and the
//! record ([`imu_ident::telemetry`]) live in the library, where the host tests them; this file
//! only wires semihosting to them.
//!
//! - Input: a binary replay log read from the host with semihosting. Its name is the first
//!   semihosting argument after the program name (`-semihosting-config arg=imu-ident-qemu,
//!   arg=log.bin`, or `-kernel ELF -append log.bin`); without one it is `replay.bin`. Relative
//!   names resolve against QEMU's working directory, which is how hal-sim's runner uses it
//!   (a temporary directory, so paths with spaces or commas never reach QEMU's option parser).
//! - Output: one defmt frame per row on semihosting stdout (defmt-semihosting), then a summary.
//! - Exit: semihosting exit status 0 after a complete, checksum-valid log; 1 for anything else
//!   (missing or corrupt log, bad model, panic, hard fault).
//!
//! ```text
//! qemu-system-arm -cpu cortex-m4 -machine mps2-an386 -nographic \
//!   -semihosting-config enable=on,target=native -kernel imu-ident-qemu -append log.bin \
//!   | defmt-print -e imu-ident-qemu
//! ```
//!
//! Panics: none are expected (the library returns errors as values); the handler below ends QEMU
//! with a failure status rather than hanging. A later issue adds a link-time proof that no
//! panic path is linked at all.

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

    use cortex_m_rt::{entry, exception, ExceptionFrame};
    use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};
    use defmt_semihosting as _; // the global defmt logger: frames go to semihosting stdout
    use imu_ident::filter::InsFilter;
    use imu_ident::model::{InsModel, ModelError};
    use imu_ident::replay::{Decoder, ReplayError, Replayer};
    use imu_ident::telemetry::{DefmtSink, TelemetrySink};
    use semihosting::experimental::env;
    use semihosting::fs::File;
    use semihosting::io::Read;

    /// Log name used when QEMU passes no argument.
    const DEFAULT_LOG: &CStr = c"replay.bin";
    /// Longest accepted command line and log name (bytes, including the terminating NUL).
    const CMDLINE_LEN: usize = 256;
    /// Read size: the decoder takes any chunking, so this only trades RAM for host calls.
    const CHUNK: usize = 512;

    /// Why a replay failed.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
    enum FirmwareError {
        /// The command line could not be read, or the log name is too long.
        BadArgument,
        /// The log file could not be opened.
        Open,
        /// Reading the log file failed.
        Read,
        /// The log is not a valid replay log.
        Log(ReplayError),
        /// The model was rejected by the filter.
        Model(ModelError),
    }

    /// The model the filter runs with. A later issue passes the model in (from a second
    /// semihosting file or from flash); it only has to replace this function.
    fn model() -> InsModel<f32> {
        InsModel::paper()
    }

    #[entry]
    fn main() -> ! {
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
        exit(status)
    }

    fn exit(status: debug::ExitStatus) -> ! {
        debug::exit(status);
        // Only reached without a semihosting host (e.g. on a board): park the core.
        loop {
            cortex_m::asm::wfi();
        }
    }

    fn run() -> Result<u32, FirmwareError> {
        let mut name = [0u8; CMDLINE_LEN];
        let path = log_path(&mut name)?;
        let mut file = File::open(path).map_err(|_| FirmwareError::Open)?;

        let filter = InsFilter::new(model()).map_err(FirmwareError::Model)?;
        let mut replay = Replayer::new(filter);
        let mut sink = DefmtSink;
        let mut decoder = Decoder::new();
        let mut buf = [0u8; CHUNK];
        loop {
            let n = file.read(&mut buf).map_err(|_| FirmwareError::Read)?;
            let Some(chunk) = buf.get(..n).filter(|c| !c.is_empty()) else {
                break;
            };
            for &byte in chunk {
                if let Some(row) = decoder.push(byte).map_err(FirmwareError::Log)? {
                    sink.record(&replay.step(row));
                }
            }
        }
        decoder.finish().map_err(FirmwareError::Log)
    }

    /// The log name: the first argument after the program name, else [`DEFAULT_LOG`]. The
    /// name is copied into `buf` to add the NUL that semihosting's open needs.
    fn log_path(buf: &mut [u8; CMDLINE_LEN]) -> Result<&CStr, FirmwareError> {
        let args = env::args::<CMDLINE_LEN>().map_err(|_| FirmwareError::BadArgument)?;
        let Some(arg) = (&args).nth(1) else {
            return Ok(DEFAULT_LOG);
        };
        let arg = arg.map_err(|_| FirmwareError::BadArgument)?.as_bytes();
        let dst = buf.get_mut(..arg.len()).ok_or(FirmwareError::BadArgument)?;
        dst.copy_from_slice(arg);
        // `buf` was zeroed, so the name is followed by a NUL unless it filled the buffer.
        CStr::from_bytes_until_nul(buf).map_err(|_| FirmwareError::BadArgument)
    }

    #[panic_handler]
    fn panic(_info: &core::panic::PanicInfo) -> ! {
        // No defmt here: the panic may come from inside the logger, which is not re-entrant.
        exit(EXIT_FAILURE)
    }

    #[exception]
    unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
        exit(EXIT_FAILURE)
    }
}
