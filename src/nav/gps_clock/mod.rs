//! Sample times from a local counter: a free-running timer's counts mapped to GPS time through
//! the receiver's time pulse (PPS).
//!
//! A board whose IMU is read over SPI on a data-ready line stamps each sample with its own
//! timer, and the fixes come in GPS time. The two time bases differ by an unknown offset and by
//! the crystal's frequency error (tens of ppm: 72 ms an hour at 20 ppm), which wanders with
//! temperature. The receiver gives what maps one onto the other: a pulse at every whole GPS
//! second, captured by the timer (an input-capture channel: the count at the edge, to one
//! tick), and before each pulse a `TIM-TP` message with the pulse's GPS time
//! ([`TimePulse`](super::ubx::TimePulse)). [`GpsClock`] pairs the two and tracks the counter
//! with a two-state Kalman filter, the standard clock model:
//! - state: the counter's time offset `x` (local time `count / hz` minus GPS time) and its
//!   fractional frequency error `y`, with `dx/dt = y + w1`, `dy/dt = w2` (white and
//!   random-walk frequency noise of intensities `q1` [s], `q2` [1/s]; Allan variance
//!   `q1 / tau + q2 tau / 3`);
//! - over `dt` between pulses: `Phi = [[1, dt], [0, 1]]`,
//!   `Qd = [[q1 dt + q2 dt^3 / 3, q2 dt^2 / 2], [q2 dt^2 / 2, q2 dt]]` (exact for this model);
//! - each pulse observes `x` as `count / hz - T`, with the capture's variance
//!   ([`ClockConfig::sd_capture`]); gated by chi-square(1) at `1 - 1e-9`, Joseph-form update.
//!
//! A count then maps to GPS time `T = T_k + (dL - r_k) / (1 + y_k)`, where `T_k` is the last
//! pulse's GPS time, `dL` the local time since its count and `r_k` the filter's offset minus
//! that pulse's own reading. Its one-sigma follows from the covariance and the noise since
//! the pulse, so a stamp is given through pulse gaps (a tunnel: u-blox's default pulse stops
//! without a fix) while it is within [`ClockConfig::max_sd`].
//!
//! Pairing a pulse with its time: until the clock is locked (two consistent pulses), with the
//! newest `TIM-TP` that came at most 1.5 periods before it; once locked, with the announced
//! time nearest the pulse's predicted time, or, when its `TIM-TP` was lost, with the whole
//! period nearest it. An edge that pairs with nothing, or that the gate refuses (a glitch),
//! is counted and ignored. Three refusals in a row: while acquiring, the first pairing was
//! wrong, and the acquisition starts again; once locked (the pulses were paired by the
//! prediction, so their times are right), the oscillator moved beyond its model (a
//! temperature shock, a counter reset), and the clock re-anchors at the newest pulse with the
//! frequency those pulses show, staying locked: the samples go on being stamped.
//!
//! The counter is a `u32` that wraps (a 32-bit timer: every 51 s at 84 MHz). Each call's count
//! is taken as the one nearest the newest count seen, so the clock must be called at least
//! once every `2^31` ticks (25 s at 84 MHz); the IMU's samples do that many times a second.
//! Time is `f64` (GPS seconds since 1980, as everywhere in the navigator), so that a stamp keeps
//! its 0.24-us resolution on the MCU too. No heap, no panics; counts and times that are not
//! finite are refused.
//!
//! The crystal's random-walk frequency noise `q2` is rarely on its datasheet; with
//! [`ClockConfig::identify`] (the default) it is identified online by three shadow clock
//! filters ([`ClockNoise`], `noise.rs`), the navigator bank's design in one coordinate. A `q2`
//! held wrong shows in the pulses' normalised innovations (their mean is 1 when the model is
//! right); identified, it comes within 0.08 decade from 0.01x to 100x (BENCHMARKS.md "Sample
//! times from a local timer").
//!
//! ```
//! use imu_ident::nav::gps_clock::{ClockConfig, GpsClock};
//! let hz = 1e6; // a 1-MHz timer, running 30 ppm fast
//! let count = |t: f64| ((t - 1.0e9 + 5.0) * hz * (1.0 + 30e-6)) as u64 as u32;
//! let mut clock = GpsClock::new(ClockConfig::crystal(hz)).unwrap();
//! for k in 0..10 {
//!     let t_pulse = 1.0e9 + f64::from(k);
//!     clock.announce(t_pulse, count(t_pulse - 0.6)); // TIM-TP, 0.6 s before its pulse
//!     clock.pulse(count(t_pulse));
//! }
//! let s = clock.stamp(count(1.0e9 + 9.25)).unwrap();
//! assert!((s.t - (1.0e9 + 9.25)).abs() < 3e-6 && s.sd < 2e-6);
//! ```

mod filter;
mod noise;

use filter::Anchor;
pub use noise::{ClockNoise, BANK_GATE, NOISE_WINDOW};

/// Chi-square(1) `1 - 1e-9` quantile (6.1 sigma): the gate on a pulse's innovation. A pulse
/// the model explains is beyond it once in 1e9; what it stops is a pulse paired with the
/// wrong second, or a glitch next to a pulse. (At 0.9999, 10 simulated hours drawn from the
/// model itself had 6 legitimate rejections, two of them followed by two more, the drift the
/// filter no longer saw, and a restart: `hal-sim/tests/nav_clock.rs`.)
const GATE: f64 = 37.33;
/// Refused pulses in a row that start the acquisition again (acquiring) or re-anchor the
/// clock (locked).
const MAX_REJECTS: u8 = 3;
/// A gap between two pulses longer than this [s] starts the acquisition again (the filter's
/// covariance would not be finite; a real gap this long has lost the lock already).
const MAX_GAP: f64 = 1e5;
/// The counts of the first call start here, so that counts a little before it stay positive.
const BASE: u64 = 1 << 32;

/// How a [`GpsClock`] models its counter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClockConfig {
    /// The counter's nominal frequency [Hz].
    pub hz: f64,
    /// One-sigma of a pulse's capture [s]: the count's quantisation `1 / (hz sqrt 12)` and the
    /// pulse's own jitter, in quadrature.
    pub sd_capture: f64,
    /// White frequency noise `q1` [s]: Allan variance `q1 / tau`.
    pub q_white: f64,
    /// Random-walk frequency noise `q2` [1/s]: Allan variance `q2 tau / 3`.
    pub q_walk: f64,
    /// One-sigma of the fractional frequency error at the start (the crystal's tolerance).
    pub sd_freq: f64,
    /// A stamp is given while its one-sigma is at most this [s].
    pub max_sd: f64,
    /// The pulses fall on whole multiples of this [s] of GPS time (u-blox's default: 1 s), so
    /// once locked a pulse whose `TIM-TP` was lost is still used. 0: announced pulses only.
    pub period: f64,
    /// Identify the random-walk frequency noise online ([`ClockNoise`]); else `q_walk` holds.
    pub identify: bool,
}

impl ClockConfig {
    /// A counter at `hz` from an ordinary crystal: 50 ppm tolerance, Allan deviation 1e-9 at
    /// 1 s (white frequency noise) and 1e-7 at 100 s (a random walk: temperature), pulses with
    /// 20 ns of jitter, stamps up to 1 ms sd (about 35 min without pulses: `sqrt(q2 tau^3 / 3)`
    /// reaches 1 ms at 2 150 s).
    pub fn crystal(hz: f64) -> Self {
        let quantisation = 1.0 / (hz * libm::sqrt(12.0));
        Self {
            hz,
            sd_capture: libm::sqrt(quantisation * quantisation + 20e-9 * 20e-9),
            q_white: 1e-18,
            q_walk: 3e-16,
            sd_freq: 50e-6,
            max_sd: 1e-3,
            period: 1.0,
            identify: true,
        }
    }

    /// Every value finite and positive (`period` may be 0).
    pub fn check(&self) -> Result<(), ClockError> {
        let positive = [self.hz, self.sd_capture, self.sd_freq, self.max_sd];
        let non_negative = [self.q_white, self.q_walk, self.period];
        let ok = positive.iter().all(|v| v.is_finite() && *v > 0.0)
            && non_negative.iter().all(|v| v.is_finite() && *v >= 0.0);
        if ok {
            Ok(())
        } else {
            Err(ClockError::BadConfig)
        }
    }
}

/// Why a [`GpsClock`] was not made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClockError {
    /// A [`ClockConfig`] value not finite, or not positive where it must be.
    BadConfig,
}

/// A count's GPS time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stamp {
    /// GPS seconds since 1980.
    pub t: f64,
    /// Its one-sigma [s].
    pub sd: f64,
}

/// What became of a pulse.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PulseUse {
    /// The first of an acquisition.
    First,
    /// Fused.
    Used,
    /// No time to pair it with: dropped.
    Unpaired,
    /// Its time disagrees with the clock beyond the gate: dropped.
    Rejected,
}

/// What a [`GpsClock`] did so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ClockCounts {
    /// Pulses fused (the first of each acquisition included).
    pub used: u32,
    /// Of those, paired with the whole period nearest them (their `TIM-TP` lost).
    pub unannounced: u32,
    /// Pulses with no time to pair with.
    pub unpaired: u32,
    /// Pulses the gate refused.
    pub rejected: u32,
    /// Acquisitions started again (after refusals in a row while acquiring, or a gap the clock
    /// could not bridge).
    pub restarts: u32,
    /// Re-anchorings after refusals in a row once locked.
    pub reanchored: u32,
    /// Stamps refused: before the lock, or beyond [`ClockConfig::max_sd`].
    pub refused: u32,
}

/// A local counter mapped to GPS time by the receiver's pulses (module docs).
#[derive(Debug, Clone)]
pub struct GpsClock {
    cfg: ClockConfig,
    /// The newest count seen, extended past the counter's wraps.
    now: Option<u64>,
    /// Announced pulse times and the counts they came at (oldest first).
    announced: [Option<(f64, u64)>; 2],
    /// A pulse time announced before any count ([`announce_at_newest`](Self::announce_at_newest)):
    /// announced at the first count.
    held: Option<f64>,
    last: Option<Anchor>,
    /// Pulses fused since the acquisition started: locked from 2.
    fused: u32,
    rejects: u8,
    counts: ClockCounts,
    noise: ClockNoise,
}

impl GpsClock {
    /// A clock with no pulse yet.
    pub fn new(cfg: ClockConfig) -> Result<Self, ClockError> {
        cfg.check()?;
        Ok(Self {
            cfg,
            now: None,
            announced: [None; 2],
            held: None,
            last: None,
            fused: 0,
            rejects: 0,
            counts: ClockCounts::default(),
            noise: ClockNoise::new(),
        })
    }

    /// What the clock did so far.
    pub fn counts(&self) -> ClockCounts {
        self.counts
    }

    /// Two consistent pulses fused: stamps are given.
    pub fn locked(&self) -> bool {
        self.fused >= 2
    }

    /// The identification of the oscillator's random-walk frequency noise
    /// ([`ClockNoise`]).
    pub fn noise(&self) -> &ClockNoise {
        &self.noise
    }

    /// The counter's fractional frequency error and its one-sigma, once locked.
    pub fn frequency_error(&self) -> Option<(f64, f64)> {
        let a = self.last.filter(|_| self.locked())?;
        Some((a.y, libm::sqrt(a.p[1][1])))
    }

    /// The receiver announced its next pulse at GPS time `t` (`TIM-TP`); `count` is the
    /// counter when the message was read.
    pub fn announce(&mut self, t: f64, count: u32) {
        let c = self.extend(count);
        if t.is_finite() {
            self.announced = [self.announced[1], Some((t, c))];
        }
    }

    /// [`announce`](Self::announce) for a counter that is not read when the message comes
    /// (a hub's, whose counts come only with its samples and edges): at the newest count seen.
    /// Before any count, one tick before the first count to come (it was read before that
    /// count): a hub's wire often opens with the receiver's `TIM-TP`, and read at no count it
    /// left its pulse unpaired and the lock a second later. The receiver sends the message
    /// after the pulse before the one it announces, so the first edge after it is its own.
    pub fn announce_at_newest(&mut self, t: f64) {
        if !t.is_finite() {
            return;
        }
        match self.now {
            Some(c) => self.announced = [self.announced[1], Some((t, c))],
            None => self.held = Some(t),
        }
    }

    /// A pulse's edge, captured at `count`.
    pub fn pulse(&mut self, count: u32) -> PulseUse {
        let c = self.extend(count);
        let Some(t) = self.pulse_time(c) else {
            self.counts.unpaired = self.counts.unpaired.saturating_add(1);
            return PulseUse::Unpaired;
        };
        let used = self.fuse(t, c);
        if matches!(used, PulseUse::First | PulseUse::Used) {
            self.counts.used = self.counts.used.saturating_add(1);
        }
        used
    }

    /// The GPS time of `count`, once locked and while its one-sigma is within
    /// [`ClockConfig::max_sd`].
    pub fn stamp(&mut self, count: u32) -> Option<Stamp> {
        let c = self.extend(count);
        let s = self.stamp_of(c).filter(|s| s.sd <= self.cfg.max_sd);
        if s.is_none() {
            self.counts.refused = self.counts.refused.saturating_add(1);
        }
        s
    }

    /// `count` extended past the wraps: the count nearest the newest one seen.
    fn extend(&mut self, count: u32) -> u64 {
        let now = self.now.unwrap_or(BASE + u64::from(count));
        // Reinterpreting the wrapped difference as signed is the point: the nearest count.
        let d = i64::from(count.wrapping_sub(now as u32) as i32);
        let c = now.saturating_add_signed(d);
        self.now = Some(now.max(c));
        // Held only while no count was seen (`announce_at_newest`): this is the first.
        if let Some(t) = self.held.take() {
            self.announced = [self.announced[1], Some((t, c.saturating_sub(1)))];
        }
        c
    }

    /// The GPS time of `count` with its one-sigma, once locked (no `max_sd` test).
    fn stamp_of(&self, count: u64) -> Option<Stamp> {
        let a = self.last.filter(|_| self.locked())?;
        let tau = (a.local_since(count, self.cfg.hz) - a.resid) / (1.0 + a.y);
        let (q1, q2) = (self.cfg.q_white, self.noise.q_walk(&self.cfg));
        let s = libm::fabs(tau);
        let var = a.p[0][0]
            + 2.0 * tau * a.p[0][1]
            + tau * tau * a.p[1][1]
            + q1 * s
            + q2 * s * s * s / 3.0;
        Some(Stamp {
            t: a.t + tau,
            sd: libm::sqrt(var.max(0.0)),
        })
    }

    /// The GPS time a pulse at `count` marks, if any (module docs: pairing).
    fn pulse_time(&mut self, count: u64) -> Option<f64> {
        let period = self.cfg.period;
        let tol = if period > 0.0 { 0.4 * period } else { 0.4 };
        if let Some(p) = self.stamp_of(count) {
            if p.sd < tol / 4.0 {
                return self.locked_time(p, tol);
            }
            // The gap was too long to bridge: acquire again.
            self.restart();
        }
        // Acquiring: the newest announcement, at most 1.5 periods before the pulse.
        let span = 1.5 * if period > 0.0 { period } else { 1.0 };
        let (i, (t, c)) = self
            .announced
            .iter()
            .enumerate()
            .rev()
            .find_map(|(i, a)| a.map(|a| (i, a)))?;
        let lead = (count.wrapping_sub(c) as i64) as f64 / self.cfg.hz;
        if !(lead > 0.0 && lead <= span) {
            return None;
        }
        self.take(i);
        Some(t)
    }

    /// A locked clock's pairing: the announced time nearest the prediction `p`, or the whole
    /// period nearest it.
    fn locked_time(&mut self, p: Stamp, tol: f64) -> Option<f64> {
        let near = |a: &Option<(f64, u64)>| a.map_or(f64::INFINITY, |(t, _)| libm::fabs(t - p.t));
        let i = usize::from(near(&self.announced[1]) < near(&self.announced[0]));
        // A real pulse is within microseconds of its prediction; a glitch is not.
        let tol = (1e-3 + 8.0 * p.sd).min(tol);
        if near(&self.announced[i]) < tol {
            let t = self.announced[i].map(|(t, _)| t);
            self.take(i);
            return t;
        }
        let period = self.cfg.period;
        if period > 0.0 && p.sd < tol / 8.0 {
            let t = libm::round(p.t / period) * period;
            if libm::fabs(t - p.t) < tol {
                self.counts.unannounced = self.counts.unannounced.saturating_add(1);
                return Some(t);
            }
        }
        None
    }

    /// Forgets announcement `i` (used).
    fn take(&mut self, i: usize) {
        if let Some(a) = self.announced.get_mut(i) {
            *a = None;
        }
    }

    /// Acquisition from the next pulse.
    fn restart(&mut self) {
        self.last = None;
        self.noise.restart();
        self.fused = 0;
        self.rejects = 0;
        self.counts.restarts = self.counts.restarts.saturating_add(1);
    }

    /// Fuses the pulse at GPS time `t`, count `count` (module docs: the filter).
    fn fuse(&mut self, t: f64, count: u64) -> PulseUse {
        let cfg = self.cfg;
        let r = cfg.sd_capture * cfg.sd_capture;
        let first = match self.last {
            Some(a) if t - a.t > MAX_GAP => {
                self.restart();
                None
            }
            a => a,
        };
        let Some(a) = first else {
            self.last = Some(Anchor::first(t, count, r, cfg.sd_freq));
            self.fused = 1;
            return PulseUse::First;
        };
        let dt = t - a.t;
        let q2 = self.noise.q_walk(&cfg);
        let step = a.step(t, count, a.local_since(count, cfg.hz), cfg.q_white, q2, r);
        let nu = step.nu;
        if self.locked() {
            self.noise.observe(t, count, &a, &cfg);
        }
        if dt > 0.0 && nu.is_finite() && nu * nu <= GATE * step.s {
            self.last = Some(step.next);
            self.fused = self.fused.saturating_add(1);
            self.rejects = 0;
            return PulseUse::Used;
        }
        self.counts.rejected = self.counts.rejected.saturating_add(1);
        if !(dt > 0.0 && nu.is_finite()) {
            // A second already fused (a glitch next to its pulse), or a time going back: not
            // evidence that the clock moved, so not one of the refusals in a row.
            return PulseUse::Rejected;
        }
        self.rejects = self.rejects.saturating_add(1);
        if self.rejects < MAX_REJECTS {
            return PulseUse::Rejected;
        }
        if !self.locked() {
            self.restart();
            return PulseUse::Rejected;
        }
        self.last = Some(a.reanchored(&step, r));
        self.rejects = 0;
        self.counts.reanchored = self.counts.reanchored.saturating_add(1);
        PulseUse::Used
    }
}

#[cfg(test)]
#[path = "tests.rs"]
mod tests;
