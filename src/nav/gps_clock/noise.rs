//! The oscillator's random-walk frequency noise identified online, the seed's idea applied to
//! the board's own clock: a crystal's `q2` is rarely on its datasheet, and it changes with
//! the temperature's swings. Three shadow clock filters at `10^(-d)`, 1 and `10^(+d)` times the
//! running filter's `q2` ([`OFFSET`] decade) fuse every pulse the clock paired, each summing
//! its Gaussian innovation log-likelihood. They are not gated as the running filter is (a
//! model too quiet shows precisely in the pulses its gate refuses: with `q2` 30x too small it
//! refused 10 % of them, and a bank that saw only the others never moved); only a pulse
//! [`BANK_GATE`] sigmas off any shadow (a glitch next to a pulse) is left out. Every
//! [`NOISE_WINDOW`] pulses (after a burn-in of [`BURN_IN`], the shadows' covariances settling
//! from the running filter's) the parabola through the three sums gives the maximum in
//! `log10 q2`, at most `2 d` from the shadows' centre. Inside the grid (within `d`) the
//! running filter takes it and the shadows stay, so their sums, and the estimate's precision,
//! keep growing (to [`MAX_WINDOW`] pulses, then they restart about the estimate: a crystal's
//! noise changes with its temperature's swings). Outside, the estimate moves when the step
//! promises [`MIN_GAIN`] nat, and the shadows restart about it. A likelihood not concave (the
//! pulses do not bound `q2`: it is swamped by the capture and the white noise) moves only
//! where its slope promises the gain, and has no Cramér-Rao sd.
//!
//! This is the design of the navigator's bank (docs/ADAPTATION.md §9) in one coordinate; the
//! white frequency noise `q1` and the capture are held (at one pulse a second `q1 dt` and
//! `q2 dt^3 / 3` are not told apart; what the stamps' sds need over a gap is `q2`).

use super::filter::Anchor;
use super::ClockConfig;

/// Pulses per decision.
pub const NOISE_WINDOW: u32 = 300;
/// The longest window [pulses] before the shadows restart about the estimate.
pub const MAX_WINDOW: u32 = 3600;
/// Pulses after a (re)start before the sums count.
const BURN_IN: u32 = 30;
/// The shadows' offset [decade of `q2`].
const OFFSET: f64 = 0.25;
/// The factor's bounds [decade] about the configured `q2`.
const BOUNDS: (f64, f64) = (-2.0, 3.0);
/// The least gain a move must promise [nat].
const MIN_GAIN: f64 = 1.0;
/// A pulse further than this many sigmas from any shadow's prediction is not the bank's
/// (squared: 100 sigma).
pub const BANK_GATE: f64 = 1e4;

/// The identification of `q2` ([`GpsClock::noise`](super::GpsClock::noise)).
#[derive(Debug, Clone)]
pub struct ClockNoise {
    /// log10 of the factor on the configured `q2`.
    u: f64,
    /// The shadows' centre, in the same units.
    c: f64,
    /// `10^u`, and `10^(c - d)`, `10^c`, `10^(c + d)` (kept: `pow` in software `f64` costs
    /// thousands of instructions on the MCU).
    scale: f64,
    shadow_scales: [f64; 3],
    /// The shadows at `c - d`, `c`, `c + d`.
    shadows: [Option<Anchor>; 3],
    /// Log-likelihood sums at `u - d`, `u`, `u + d`.
    sums: [f64; 3],
    n: u32,
    decisions: u32,
    sd: Option<f64>,
}

impl Default for ClockNoise {
    fn default() -> Self {
        Self::new()
    }
}

impl ClockNoise {
    /// At the configured `q2`.
    pub const fn new() -> Self {
        Self {
            u: 0.0,
            c: 0.0,
            scale: 1.0,
            shadow_scales: [0.0; 3],
            shadows: [None; 3],
            sums: [0.0; 3],
            n: 0,
            decisions: 0,
            sd: None,
        }
    }

    /// log10 of the identified `q2` over the configured one.
    pub fn log10_factor(&self) -> f64 {
        self.u
    }

    /// The Cramér-Rao sd of [`log10_factor`](Self::log10_factor) at the last decision
    /// (none when that window's likelihood was not concave, or before the first).
    pub fn sd(&self) -> Option<f64> {
        self.sd
    }

    /// Decisions taken.
    pub fn decisions(&self) -> u32 {
        self.decisions
    }

    /// The random-walk frequency noise the running filter uses.
    pub(super) fn q_walk(&self, cfg: &ClockConfig) -> f64 {
        if cfg.identify {
            cfg.q_walk * self.scale
        } else {
            cfg.q_walk
        }
    }

    /// The shadows start again, at the next pulse, about the running filter's factor.
    pub(super) fn restart(&mut self) {
        self.shadows = [None; 3];
        self.sums = [0.0; 3];
        self.n = 0;
    }

    /// A pulse the clock paired at GPS time `t`, `count`: the shadows (started from the
    /// running filter's `anchor` when they have no state) fuse it.
    pub(super) fn observe(&mut self, t: f64, count: u64, anchor: &Anchor, cfg: &ClockConfig) {
        if !cfg.identify {
            return;
        }
        let r = cfg.sd_capture * cfg.sd_capture;
        let mut steps = [None; 3];
        if self.shadows[1].is_none() {
            // (Re)started: the shadows about the running filter's factor.
            self.c = self.u;
            self.shadow_scales = [-OFFSET, 0.0, OFFSET].map(|o| libm::pow(10.0, self.c + o));
        }
        for ((out, shadow), scale) in steps.iter_mut().zip(&self.shadows).zip(self.shadow_scales) {
            let from = shadow.unwrap_or(*anchor);
            let q2 = cfg.q_walk * scale;
            let dl = from.local_since(count, cfg.hz);
            let s = from.step(t, count, dl, cfg.q_white, q2, r);
            let ok = t > from.t && s.nu.is_finite() && s.nu * s.nu <= BANK_GATE * s.s;
            *out = ok.then_some(s);
        }
        let [Some(a), Some(b), Some(c)] = steps else {
            return;
        };
        self.n = self.n.saturating_add(1);
        if self.n > BURN_IN {
            for (sum, s) in self.sums.iter_mut().zip([&a, &b, &c]) {
                *sum += s.log_likelihood();
            }
        }
        self.shadows = [Some(a.next), Some(b.next), Some(c.next)];
        let counted = self.n.saturating_sub(BURN_IN);
        if counted > 0 && counted % NOISE_WINDOW == 0 {
            self.decide(counted >= MAX_WINDOW);
        }
    }

    /// The maximum of the window's parabola (module docs); `full`: the window is at its
    /// longest.
    fn decide(&mut self, full: bool) {
        let d = OFFSET;
        let [lm, l0, lp] = self.sums;
        let g = (lp - lm) / (2.0 * d);
        let h = (lp + lm - 2.0 * l0) / (d * d);
        let step = if h < 0.0 {
            (-g / h).clamp(-2.0 * d, 2.0 * d)
        } else if g >= 0.0 {
            2.0 * d
        } else {
            -2.0 * d
        };
        let gain = g * step + 0.5 * h * step * step;
        if !gain.is_finite() {
            self.restart();
            return;
        }
        self.decisions = self.decisions.saturating_add(1);
        self.sd = (h < 0.0).then(|| 1.0 / libm::sqrt(-h));
        let to = (self.c + step).clamp(BOUNDS.0, BOUNDS.1);
        if h < 0.0 && libm::fabs(step) <= d {
            // Inside the grid: taken, and the window grows.
            self.set(to);
            if full {
                self.restart();
            }
        } else if gain >= MIN_GAIN {
            self.set(to);
            self.restart();
        } else if full {
            self.restart();
        }
    }

    /// The running filter's factor `10^u`.
    fn set(&mut self, u: f64) {
        self.u = u;
        self.scale = libm::pow(10.0, u);
    }
}
