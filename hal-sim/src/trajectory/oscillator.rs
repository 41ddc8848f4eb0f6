//! A board's local oscillator and its timer, with truth: what a free-running counter reads while
//! GPS time passes, for the GPS clock (`imu_ident::nav::gps_clock`). The clock model is the
//! core filter's own (an offset `x` and a fractional frequency error `y`; white and random-walk
//! frequency noise), drawn exactly over each step (`Phi = [[1, dt], [0, 1]]`, `Qd` of the
//! module docs there), seeded.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// An oscillator's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OscillatorSpec {
    /// The counter's nominal frequency [Hz].
    pub hz: f64,
    /// Fractional frequency error at the start.
    pub y0: f64,
    /// White frequency noise `q1` [s].
    pub q_white: f64,
    /// Random-walk frequency noise `q2` [1/s].
    pub q_walk: f64,
    /// Local time at GPS time 0 [s] (where the counter happens to stand).
    pub offset: f64,
    /// One-sigma of the receiver's pulse edge [s].
    pub pulse_jitter: f64,
}

/// The oscillator at a GPS time.
#[derive(Debug, Clone)]
pub struct Oscillator {
    spec: OscillatorSpec,
    t: f64,
    x: f64,
    y: f64,
    rng: ChaCha8Rng,
}

impl Oscillator {
    /// At GPS time `t0`, seeded.
    pub fn new(spec: OscillatorSpec, t0: f64, seed: u64) -> Self {
        Self {
            spec,
            t: t0,
            x: 0.0,
            y: spec.y0,
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }

    /// GPS time now [s].
    pub fn time(&self) -> f64 {
        self.t
    }

    /// The fractional frequency error now.
    pub fn frequency_error(&self) -> f64 {
        self.y
    }

    /// Advances to GPS time `t` (no step back), drawing the clock noise over the step exactly.
    pub fn advance(&mut self, t: f64) {
        let dt = t - self.t;
        if dt <= 0.0 {
            return;
        }
        let (q1, q2) = (self.spec.q_white, self.spec.q_walk);
        let q00 = q1 * dt + q2 * dt * dt * dt / 3.0;
        let q01 = q2 * dt * dt / 2.0;
        let q11 = q2 * dt;
        // Cholesky of Qd.
        let l00 = q00.sqrt();
        let l10 = if l00 > 0.0 { q01 / l00 } else { 0.0 };
        let l11 = (q11 - l10 * l10).max(0.0).sqrt();
        let (n0, n1): (f64, f64) = (
            StandardNormal.sample(&mut self.rng),
            StandardNormal.sample(&mut self.rng),
        );
        self.x += self.y * dt + l00 * n0;
        self.y += l10 * n0 + l11 * n1;
        self.t = t;
    }

    /// Steps the fractional frequency error by `dy` (a temperature shock, a supply step).
    pub fn shift_frequency(&mut self, dy: f64) {
        self.y += dy;
    }

    /// Local time now [s].
    pub fn local(&self) -> f64 {
        self.t + self.spec.offset + self.x
    }

    /// The counter now, as a 32-bit timer's input capture reads it: the count it last reached,
    /// half a tick below the local time on average, for a pulse's edge as for a sample's, so
    /// the clock's map of counts to times carries no bias from it.
    pub fn count(&self) -> u32 {
        (self.local() * self.spec.hz).floor() as u64 as u32
    }

    /// The count a pulse edge now is captured at (the edge's jitter drawn).
    pub fn pulse_count(&mut self) -> u32 {
        let j: f64 = StandardNormal.sample(&mut self.rng);
        ((self.local() + self.spec.pulse_jitter * j) * self.spec.hz).floor() as u64 as u32
    }
}
