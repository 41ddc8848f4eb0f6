//! Board wiring shared by the QEMU firmware binaries (`imu-ident-qemu`, `imu-ident-nav-qemu`;
//! each includes it with `#[path]`): host files and the command line over raw semihosting
//! calls, the defmt logger on semihosting stdout, the SysTick instruction counter, the painted
//! stack and the exit. Raw calls because the `semihosting` and `defmt-semihosting` crates carry
//! panic paths (the binaries must pass the `prove-no-panic` link check). No navigation or
//! filter logic lives here.

use core::ffi::CStr;

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_semihosting::debug;
use cortex_m_semihosting::{nr, syscall, syscall1};

/// Longest accepted command line and file name (bytes, including the terminating NUL).
pub const CMDLINE_LEN: usize = 256;
/// Stack paint pattern.
const PAINT: u32 = 0xC0DE_5AFE;

/// Why a host file or argument could not be had.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum HostError {
    /// The command line could not be read, or a file name is too long.
    BadArgument,
    /// A file could not be opened.
    Open,
    /// Reading a file failed.
    Read,
}

/// Instruction counts of one class of calls (SysTick counts x 40).
#[derive(Default)]
pub struct Counts {
    n: u32,
    sum: u64,
    worst: u32,
    worst_k: u32,
}

impl Counts {
    /// Adds one call's count; `k` identifies the call (its index) for the worst case.
    pub fn add(&mut self, instr: u32, k: u32) {
        self.n = self.n.saturating_add(1);
        self.sum = self.sum.saturating_add(u64::from(instr));
        if instr > self.worst {
            self.worst = instr;
            self.worst_k = k;
        }
    }

    /// Sends the `icount` summary frame.
    pub fn log(&self, class: &str) {
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

/// Starts SysTick free-running from the core clock (under `-icount shift=0`: one count per 40
/// instructions).
pub fn timer() -> SYST {
    // SAFETY: the only user of the core peripherals.
    let mut p = unsafe { cortex_m::Peripherals::steal() };
    p.SYST.set_clock_source(SystClkSource::Core);
    p.SYST.set_reload(0x00FF_FFFF);
    p.SYST.clear_current();
    p.SYST.enable_counter();
    p.SYST
}

/// Instructions between two SysTick readings `t0` then `t1` (it counts down and wraps at 2^24).
pub fn instructions(t0: u32, t1: u32) -> u32 {
    (t0.wrapping_sub(t1) & 0x00FF_FFFF).saturating_mul(40)
}

/// Ends QEMU with `status`.
pub fn exit(status: debug::ExitStatus) -> ! {
    debug::exit(status);
    // Only reached without a semihosting host (e.g. on a board): park the core.
    loop {
        cortex_m::asm::wfi();
    }
}

/// The `i`-th argument after the program name copied into `buf` with its NUL, else `default`.
pub fn arg<'a>(
    i: usize,
    buf: &'a mut [u8; CMDLINE_LEN],
    default: &'static CStr,
) -> Result<&'a CStr, HostError> {
    let mut line = [0u8; CMDLINE_LEN];
    let line = cmdline(&mut line)?;
    let Some(arg) = Words(line).nth(i.saturating_add(1)) else {
        return Ok(default);
    };
    let dst = buf.get_mut(..arg.len()).ok_or(HostError::BadArgument)?;
    dst.copy_from_slice(arg);
    // `buf` was zeroed, so the name is followed by a NUL unless it filled the buffer.
    CStr::from_bytes_until_nul(buf).map_err(|_| HostError::BadArgument)
}

/// The semihosting command line (SYS_GET_CMDLINE), without its NUL.
fn cmdline(buf: &mut [u8; CMDLINE_LEN]) -> Result<&[u8], HostError> {
    // The parameter block: buffer address and size in; the host writes the length back.
    let mut block = [buf.as_mut_ptr() as usize, CMDLINE_LEN];
    // SAFETY: the host writes at most CMDLINE_LEN bytes into `buf` and one word of `block`.
    let r = unsafe { syscall1(nr::GET_CMDLINE, block.as_mut_ptr() as usize) };
    if r != 0 {
        return Err(HostError::BadArgument);
    }
    let [_, len] = block;
    buf.get(..len).ok_or(HostError::BadArgument)
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

/// A host file opened for reading (SYS_OPEN, SYS_READ, SYS_CLOSE).
pub struct HostFile(usize);

impl HostFile {
    /// Opens `path` for binary reading.
    pub fn open(path: &CStr) -> Result<Self, HostError> {
        let len = path.to_bytes().len();
        // SAFETY: `path` is NUL-terminated and `len` excludes the NUL, as SYS_OPEN expects.
        let fd = unsafe { syscall!(OPEN, path.as_ptr(), nr::open::R_BINARY, len) };
        if fd as isize == -1 {
            return Err(HostError::Open);
        }
        Ok(Self(fd))
    }

    /// Reads up to `buf.len()` bytes; 0 at the end of the file.
    pub fn read(&mut self, buf: &mut [u8]) -> Result<usize, HostError> {
        // SAFETY: the host writes at most `buf.len()` bytes into `buf`.
        let not_read = unsafe { syscall!(READ, self.0, buf.as_mut_ptr(), buf.len()) };
        // SYS_READ returns the number of bytes *not* read.
        buf.len().checked_sub(not_read).ok_or(HostError::Read)
    }
}

impl Drop for HostFile {
    fn drop(&mut self) {
        // SAFETY: closes the handle this value owns.
        unsafe { syscall!(CLOSE, self.0) };
    }
}

/// The global defmt logger on semihosting stdout, through `imu_ident::defmt_frame` (shared
/// with the board firmware): a frame started while another is being written (a logger
/// re-entered from an exception handler) is dropped; no panics.
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

    /// Writes `bytes` to stdout, opening it on first use; errors are ignored (there is nowhere
    /// to report them). Called by `defmt_frame` between `acquire` and `release` only.
    fn write_stdout(bytes: &[u8]) {
        // SAFETY: interrupts are disabled (single core) and the sink is not re-entered, so no
        // other reference to `STDOUT` is live.
        let stdout = unsafe { &mut *STDOUT.0.get() };
        if stdout.is_none() {
            *stdout = hio::hstdout().ok();
        }
        if let Some(h) = stdout {
            let _ = h.write_all(bytes);
        }
    }

    // SAFETY: frames are written with interrupts disabled; nested frames are dropped.
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
            // SAFETY: called between `acquire` and `release`, as the contract requires.
            unsafe { defmt_frame::write(bytes, write_stdout) }
        }
    }
}

extern "C" {
    static mut __sheap: u32;
    static mut _stack_start: u32;
}

/// Fills the unused stack (from the end of static RAM up to just below the current stack
/// pointer) with the paint pattern.
#[inline(never)]
pub fn paint_stack() {
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

/// Sends the deepest stack use since the last paint (the lowest word that no longer holds the
/// pattern) as a `stack` frame.
#[inline(never)]
pub fn report_stack(phase: &str) {
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
