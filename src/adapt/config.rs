//! The tuning of the online identification ([`AdaptConfig`]): the recursive Gauss-Newton's block,
//! window, damping and step limits, the probe grid's epochs and margins, and the global stage's
//! [`WindowConfig`]. Its own file because it is plain data (with the measured defaults) that the
//! firmware, the host tools and the tests build, apart from the filter that reads it.

use super::WindowConfig;
use crate::Real;

/// Tuning of the recursive Gauss-Newton identification.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AdaptConfig<T> {
    /// Steps between parameter updates (`K`).
    pub block: u32,
    /// Finite-difference step in `ln` of each parameter (`h`).
    pub h: T,
    /// Memory of the exponential window [s]: `f = exp(-block dt / window)`.
    pub window: T,
    /// Levenberg-Marquardt damping `lambda` (relative to the diagonal).
    pub damping: T,
    /// Hysteresis: components smaller than this many standard errors are not applied.
    pub hysteresis: T,
    /// Largest change of any `ln` parameter per update (`ln 2`: a factor two).
    pub max_step: T,
    /// Longest correlation time allowed [s] (the shortest is `dt`).
    pub tau_max: T,
    /// Scales (sigma, q, density) stay within this many decades of their start.
    pub spread: T,
    /// Fraction of the windowed information kept after a move (`1`: all of it). Information
    /// gathered far from the new point describes the likelihood there poorly; discounting it
    /// lets the next blocks (gathered at the new point) steer.
    pub move_discount: T,
    /// Multiplier of the probe grid on the correlation times (`<= 1`: no probes).
    pub probe_factor: T,
    /// Steps per probe epoch (re-anchor, warm up, compare).
    pub epoch: u32,
    /// Steps at the start of an epoch before the likelihoods are summed.
    pub warmup: u32,
    /// Log-likelihood advantage [nats] a probe needs over the centre in one epoch to win.
    pub margin: T,
    /// The margin during the search phase, when the centre is only a guess and has no more
    /// claim than any probe to be the best point of the grid.
    pub first_margin: T,
    /// Hold the Gauss-Newton moves during the search phase (see `search_until_settled`).
    pub hold_first_epoch: bool,
    /// Keep searching (first-epoch margin, moves held) until an epoch ends without a jump,
    /// instead of for the first epoch only.
    pub search_until_settled: bool,
    /// `false`: never move (the bank still accumulates the Fisher information, for the CRB).
    pub adapt: bool,
    /// The global stage: maximum likelihood over a buffered window, searched from a grid
    /// ([`window`](super::window); `WindowConfig::OFF`: not run).
    pub global: WindowConfig<T>,
}

impl<T: Real> AdaptConfig<T> {
    /// All zeros (rejected by [`AdaptiveFilter::new`](super::AdaptiveFilter::new); a
    /// compile-time placeholder).
    pub const BLANK: Self = Self {
        block: 0,
        h: T::ZERO,
        window: T::ZERO,
        damping: T::ZERO,
        hysteresis: T::ZERO,
        max_step: T::ZERO,
        tau_max: T::ZERO,
        spread: T::ZERO,
        move_discount: T::ZERO,
        probe_factor: T::ZERO,
        epoch: 0,
        warmup: 0,
        margin: T::ZERO,
        first_margin: T::ZERO,
        hold_first_epoch: false,
        search_until_settled: false,
        adapt: false,
        global: WindowConfig::OFF,
    };
}

impl<T: Real> Default for AdaptConfig<T> {
    fn default() -> Self {
        Self {
            block: 600,
            h: T::lit(0.2),
            window: T::lit(4.0 * 3600.0),
            damping: T::lit(0.1),
            hysteresis: T::lit(1.0),
            max_step: T::lit(core::f64::consts::LN_2),
            tau_max: T::lit(1e6),
            spread: T::lit(3.0),
            move_discount: T::lit(1.0),
            probe_factor: T::lit(3.0),
            epoch: 3600,
            warmup: 900,
            margin: T::lit(20.0),
            first_margin: T::lit(5.0),
            hold_first_epoch: true,
            search_until_settled: true,
            adapt: true,
            global: WindowConfig::OFF,
        }
    }
}

impl<T: Real> AdaptConfig<T> {
    /// The global stage (issue 13, [`window`](super::window)): maximum likelihood over a
    /// buffered window of block means, searched from a grid around the start, every 2 h; it
    /// replaces the probe grid (off) and the recursion's moves (held: the bank still
    /// accumulates the information behind the Cramér-Rao deviations).
    pub fn global() -> Self {
        Self {
            probe_factor: T::zero(),
            global: WindowConfig::default_on(),
            ..Self::default()
        }
    }
}
