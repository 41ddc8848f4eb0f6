//! The navigator's wire: IMU sample frames ([`imu_frame`](super::imu_frame)) and a u-blox
//! receiver's UBX messages ([`ubx`](super::ubx)) read from serial ports into the inputs of a
//! [`LiveNav`]. The hardware edge of a navigation computer, as [`crate::edge`] is the
//! one-channel step's: [`SerialNav`] reads any `embedded_io::Read + ReadReady` port without
//! blocking, a bounded number of bytes per poll.
//!
//! One decoder of each kind reads every byte ([`NavWire`]), so the IMU and the receiver may
//! share a line or have one each (a [`SerialNav`] per port). A stream's order is its order on
//! the wire: a fix is given to the navigator when its message ends, as a receiver's latency
//! makes it. `hal-sim`'s `serial_stream` writes a log in this form, and the emulated board runs
//! it (`imu-ident-nav-qemu` with a second file).
//!
//! ```
//! use imu_ident::nav::imu_frame::{encode_imu_frame, ImuSample};
//! use imu_ident::nav::serial::{NavInput, NavWire};
//! use imu_ident::nav::ubx::{encode_nav_pvt, encode_nav_timegps, NavPvt};
//! let pvt = NavPvt { itow_ms: 1_000, fix_type: 3, flags: 1, ..NavPvt::default() };
//! let s = ImuSample { t: 2374.0 * 604_800.0 + 0.99, ..ImuSample::default() };
//! let mut wire = NavWire::new(None);
//! let (mut samples, mut fixes) = (0, 0);
//! let bytes = encode_imu_frame(&s).into_iter()
//!     .chain(encode_nav_timegps(1_000, 2374))
//!     .chain(encode_nav_pvt(&pvt));
//! for b in bytes {
//!     wire.push(b, &mut |input| match input {
//!         NavInput::Imu(_) => samples += 1,
//!         NavInput::Fix(f) => { fixes += 1; assert_eq!(f.t, 2374.0 * 604_800.0 + 1.0) }
//!         _ => {}
//!     });
//! }
//! assert_eq!((samples, fixes), (1, 1));
//! ```

use super::counted::{CountedSample, SampleFrame, SampleFrames};
use super::gps_clock::{ClockConfig, ClockCounts, ClockError, GpsClock};
use super::imu_frame::ImuSample;
use super::live::{LiveEvent, LiveFix, LiveNav};
use super::navigator::NavObserver;
use super::ubx::{TimePulse, UbxEvent, UbxFixes};
use super::NavError;
use crate::Real;

/// One input of a live run, as the wire delivers it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NavInput {
    /// An IMU sample.
    Imu(ImuSample),
    /// A GNSS fix.
    Fix(LiveFix),
    /// The GPS time of the receiver's next time pulse (`TIM-TP`): for a
    /// [`GpsClock`](super::gps_clock::GpsClock) that stamps samples with a local counter; the
    /// navigator does not take it.
    Pulse(TimePulse),
    /// An IMU sample stamped with a hub's counter
    /// ([`counted`](super::counted)): [`TimerStamps`] puts it on
    /// GPS time; the navigator does not take it as it is.
    Counted(CountedSample),
    /// A time pulse's edge captured on a hub's counter, at this count: for
    /// [`TimerStamps`].
    Edge(u32),
}

/// What a wire refused so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct WireCounts {
    /// IMU frames with a bad CRC (counted samples and pulse edges included).
    pub imu_rejected: u32,
    /// UBX messages with a bad checksum or length.
    pub ubx_rejected: u32,
    /// Solutions that were not a good 3D fix.
    pub no_fix: u32,
    /// Solutions before the GPS week was known.
    pub no_week: u32,
    /// Pulse times on another GNSS's time, or on UTC before the leap seconds were known.
    pub time_base: u32,
}

/// Both decoders, fed every byte.
#[derive(Debug, Clone)]
pub struct NavWire {
    imu: SampleFrames,
    gnss: UbxFixes,
}

impl NavWire {
    /// A wire whose GPS week at the start is `week` when known (else a `NAV-TIMEGPS` gives it).
    pub const fn new(week: Option<u16>) -> Self {
        Self {
            imu: SampleFrames::new(),
            gnss: UbxFixes::new(week),
        }
    }

    /// Takes one byte; gives `out` the sample or fix it completes.
    pub fn push(&mut self, b: u8, out: &mut impl FnMut(NavInput)) {
        match self.imu.push(b) {
            Some(SampleFrame::Stamped(s)) => out(NavInput::Imu(s)),
            Some(SampleFrame::Counted(s)) => out(NavInput::Counted(s)),
            Some(SampleFrame::Edge(c)) => out(NavInput::Edge(c)),
            None => {}
        }
        match self.gnss.push_any(b) {
            Some(UbxEvent::Fix(f)) => out(NavInput::Fix(f.live())),
            Some(UbxEvent::Pulse(p)) => out(NavInput::Pulse(p)),
            None => {}
        }
    }

    /// What the decoders refused so far.
    pub fn counts(&self) -> WireCounts {
        let drops = self.gnss.drops();
        WireCounts {
            imu_rejected: self.imu.rejected(),
            ubx_rejected: self.gnss.decoder().rejected(),
            no_fix: drops.no_fix,
            no_week: drops.no_week,
            time_base: drops.time_base,
        }
    }
}

/// A [`NavWire`] on a serial port.
#[derive(Debug)]
pub struct SerialNav<R> {
    rx: R,
    wire: NavWire,
}

impl<R: embedded_io::Read + embedded_io::ReadReady> SerialNav<R> {
    /// Reads from `rx`; `week` as for [`NavWire::new`].
    pub fn new(rx: R, week: Option<u16>) -> Self {
        Self {
            rx,
            wire: NavWire::new(week),
        }
    }

    /// The decoders' counts.
    pub fn counts(&self) -> WireCounts {
        self.wire.counts()
    }

    /// Reads what the port has ready, at most `max_bytes` (bounds the work of one call; the
    /// rest waits for the next), and gives `out` every input completed. Returns the bytes
    /// read. Never blocks.
    pub fn poll(
        &mut self,
        max_bytes: usize,
        out: &mut impl FnMut(NavInput),
    ) -> Result<usize, R::Error> {
        let wire = &mut self.wire;
        crate::port::read_ready(&mut self.rx, max_bytes, |b| wire.push(b, out))
    }
}

/// Gives a live run one input: [`LiveNav::imu`] for a sample, [`LiveNav::gnss`] for a fix
/// (a pulse time, a counted sample and a pulse edge are not the navigator's: nothing; a
/// [`TimerStamps`] before this call turns counted samples into
/// samples).
pub fn feed<T: Real, const N: usize, O: NavObserver<T, N>, const B: usize>(
    nav: &mut LiveNav<T, N, O, B>,
    input: &NavInput,
    out: &mut impl FnMut(LiveEvent<'_, T>),
) -> Result<(), NavError> {
    match input {
        NavInput::Imu(s) => nav.imu(s.t, s.gyro.map(f64::from), s.accel.map(f64::from), out),
        NavInput::Fix(f) => nav.gnss(f, out),
        NavInput::Pulse(_) | NavInput::Counted(_) | NavInput::Edge(_) => Ok(()),
    }
}

/// Counted samples put on GPS time: the wire's inputs in, the navigator's out
/// ([`counted`](super::counted) has the frames). Each pulse edge is a [`GpsClock::pulse`],
/// each `TIM-TP` a [`GpsClock::announce`] at the newest count the wire gave (the message's own
/// arrival is not on the hub's counter; the pairing allows 1.5 pulse periods, and samples
/// come every few ms), and each counted sample is stamped with [`GpsClock::stamp`] and passed
/// on as an ordinary sample. Samples before the clock locks (two pulses), or whose stamp's sd
/// is beyond [`ClockConfig::max_sd`], are counted and dropped: the live loop levels on the
/// stamped ones.
#[derive(Debug, Clone)]
pub struct TimerStamps {
    clock: GpsClock,
}

impl TimerStamps {
    /// Stamps with a clock of `cfg` (the hub's counter).
    pub fn new(cfg: ClockConfig) -> Result<Self, ClockError> {
        Ok(Self {
            clock: GpsClock::new(cfg)?,
        })
    }

    /// One input of the wire: a counted sample comes back as an ordinary sample on GPS time
    /// (`None` while it cannot be stamped); an edge goes to the clock (`None`); a `TIM-TP`
    /// goes to the clock and comes back (the navigator ignores it); samples with their own
    /// GPS time and fixes come back as they are.
    pub fn stamp(&mut self, input: NavInput) -> Option<NavInput> {
        match input {
            NavInput::Counted(s) => {
                let st = self.clock.stamp(s.count)?;
                Some(NavInput::Imu(s.at(st.t)))
            }
            NavInput::Edge(count) => {
                let _ = self.clock.pulse(count);
                None
            }
            NavInput::Pulse(p) => {
                self.clock.announce_at_newest(p.t);
                Some(input)
            }
            NavInput::Imu(_) | NavInput::Fix(_) => Some(input),
        }
    }

    /// The clock.
    pub fn clock(&self) -> &GpsClock {
        &self.clock
    }

    /// What the clock did so far.
    pub fn counts(&self) -> ClockCounts {
        self.clock.counts()
    }

    /// Counted samples dropped so far (before the lock, or beyond the clock's `max_sd`): the
    /// clock's refused stamps, which only counted samples ask for.
    pub fn unstamped(&self) -> u32 {
        self.clock.counts().refused
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nav::imu_frame::encode_imu_frame;
    use core::convert::Infallible;

    /// A port that has `ready` bytes of `data` at a time.
    struct Port<'a> {
        data: &'a [u8],
        ready: usize,
    }

    impl embedded_io::ErrorType for Port<'_> {
        type Error = Infallible;
    }

    impl embedded_io::ReadReady for Port<'_> {
        fn read_ready(&mut self) -> Result<bool, Infallible> {
            Ok(!self.data.is_empty())
        }
    }

    impl embedded_io::Read for Port<'_> {
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
            let n = buf.len().min(self.data.len()).min(self.ready);
            let (head, tail) = self.data.split_at(n);
            if let Some(b) = buf.get_mut(..n) {
                b.copy_from_slice(head);
            }
            self.data = tail;
            Ok(n)
        }
    }

    #[test]
    fn a_poll_reads_at_most_its_budget_and_the_rest_waits() {
        let mut bytes = [0u8; 10 * 38];
        for (k, f) in bytes.chunks_mut(38).enumerate() {
            let s = ImuSample {
                t: k as f64,
                ..ImuSample::default()
            };
            f.copy_from_slice(&encode_imu_frame(&s));
        }
        let mut port = SerialNav::new(
            Port {
                data: &bytes,
                ready: 7,
            },
            None,
        );
        let mut times = heapless::Vec::<f64, 16>::new();
        let mut on = |i: NavInput| {
            if let NavInput::Imu(s) = i {
                let _ = times.push(s.t);
            }
        };
        let first = port.poll(100, &mut on).unwrap();
        assert_eq!(first, 100);
        assert_eq!(port.poll(1000, &mut on).unwrap(), 280);
        assert_eq!(port.poll(1000, &mut on).unwrap(), 0);
        assert_eq!(
            times.as_slice(),
            &[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]
        );
        assert_eq!(port.counts(), WireCounts::default());
    }
}
