//! Noise-model identification from a sample autocorrelation (METHOD.md §3-4, paper eq. 10-21).
//!
//! The input is `R_0 ..= R_L` of one sensor-error estimate (from
//! [`Autocorrelator`](crate::autocorr::Autocorrelator) or [`acf_batch`](crate::autocorr::acf_batch)),
//! the sample period `dt` and the window length `N` the ACF was computed over, wrapped and
//! validated once in a [`SampleAcf`]. Every estimator in [`estimators`] returns a small `Copy`
//! result that says which lags it used and why it stopped, or an [`IdentError`]; none panics and
//! none returns `NaN`.
//!
//! | estimator | model | lags used |
//! |---|---|---|
//! | [`lag1_corrected`] | Markov-1 | lag 1, small-sample bias of `r_1` removed |
//! | [`lag1_raw`] | Markov-1 | lag 1, no correction (reference) |
//! | [`ls_slope`] | Markov-1 | `1 ..= J`, `J` the last lag before `r_j` first falls to the [noise floor](SampleAcf::noise_floor) |
//! | [`paper_eq15`] | Markov-1 | same lags as `ls_slope` |
//! | [`exp_cosine`] | exp-cosine | `1 ..= J`, `J` the last lag with `cos(beta tau_j) >= COS_MIN` |
//! | [`sigma2`] | any | `R_0` and the mean filter covariance |
//!
//! # Example
//!
//! ```
//! use imu_ident::autocorr::Autocorrelator;
//! use imu_ident::ident::{lag1_corrected, ls_slope, LagStop, SampleAcf};
//!
//! // An AR(1) sequence with phi = 0.9 (tau = 9.5 dt), driven by a deterministic pseudo-noise.
//! let mut ac = Autocorrelator::<f32, 512, 32>::new();
//! let (mut x, mut seed) = (0.0f32, 12345u32);
//! for _ in 0..2000 {
//!     seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
//!     let w = (seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5;
//!     x = 0.9 * x + w;
//!     ac.push(x).unwrap();
//! }
//! let mut r = [0.0f32; 33];
//! ac.acf(&mut r).unwrap();
//! let acf = SampleAcf::new(&r, 0.01, 512).unwrap(); // dt = 10 ms, window N = 512
//! let lag1 = lag1_corrected(&acf).unwrap();
//! let slope = ls_slope(&acf).unwrap();
//! assert_eq!((lag1.first_lag, lag1.last_lag, lag1.stop), (1, 1, LagStop::SingleLag));
//! assert!(slope.last_lag >= 2); // lags 1..=last_lag were above the noise floor
//! let alpha = -(0.9f32.ln()) / 0.01; // 10.5 1/s
//! assert!((lag1.alpha - alpha).abs() < 0.5 * alpha);
//! ```
//!
//! # Valid range of `alpha`
//!
//! A window of `N` samples at `dt` resolves neither correlation times much longer than the window
//! nor much shorter than one sample. Every `alpha` is clamped to
//! `[alpha_min, alpha_max] = [1 / (N dt), -ln(rho_white) / dt]`, with
//! `rho_white = min(2 / sqrt(N), 1/e)` the two-sigma band of `r_1` for white noise (so
//! `alpha_max >= 1/dt`), and the result says whether it was clamped ([`Clamp`]).
//!
//! [`lag1_corrected`]: estimators::lag1_corrected
//! [`lag1_raw`]: estimators::lag1_raw
//! [`ls_slope`]: estimators::ls_slope
//! [`paper_eq15`]: estimators::paper_eq15
//! [`exp_cosine`]: estimators::exp_cosine
//! [`sigma2`]: estimators::sigma2

pub mod estimators;

pub use estimators::{
    exp_cosine, lag1_corrected, lag1_raw, ls_slope, paper_eq15, sigma2, COS_MIN, LAG1_BIAS_SLOPE,
    NOISE_FLOOR_Z,
};

use crate::Real;

/// `1/e`, the cap of the noise floor and of the white band.
const INV_E: f64 = 1.0 / core::f64::consts::E;

/// Why an estimate could not be produced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum IdentError {
    /// Fewer than two ACF values (`R_0`, `R_1`) were given.
    NotEnoughLags,
    /// `dt` is not finite and positive.
    InvalidDt,
    /// The window length `N` is below [`SampleAcf::MIN_WINDOW`] or not larger than the last lag.
    InvalidWindow,
    /// An ACF value (or an intermediate result) is `NaN` or infinite.
    NonFinite,
    /// `R_0 <= 0`: a constant signal has no noise model.
    NonPositiveVariance,
    /// No lag satisfies the estimator's selection rule (e.g. `r_1` already below the noise floor:
    /// the signal is white at this sample rate).
    NoUsableLag,
    /// [`exp_cosine`](estimators::exp_cosine): `R` never crosses zero within the given lags.
    NoZeroCrossing,
    /// [`sigma2`](estimators::sigma2): the mean filter variance is negative or not finite.
    InvalidCovariance,
}

/// Why the lag range of an estimate ends where it does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LagStop {
    /// The estimator uses lag 1 only by design.
    SingleLag,
    /// The next lag has `r_j <=` the noise floor (this includes `r_j <= 0`).
    NoiseFloor,
    /// The next lag has `cos(beta tau_j) <` [`COS_MIN`] (exp-cosine).
    CosineLimit,
    /// The next lag is at or beyond the first zero crossing of `R` (exp-cosine).
    ZeroCrossing,
    /// All given lags were used.
    EndOfAcf,
}

/// Whether `alpha` was clamped to the [valid range](self#valid-range-of-alpha).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Clamp {
    /// Inside the range.
    No,
    /// Raised to `alpha_min = 1 / (N dt)`: correlation time longer than the window.
    ToMin,
    /// Lowered to `alpha_max`: white at this sample rate.
    ToMax,
}

/// A Markov-1 decay rate `alpha = 1/tau` and how it was obtained.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AlphaEstimate<T> {
    /// Decay rate in 1/s (same time unit as `dt`).
    pub alpha: T,
    /// First lag used (in samples).
    pub first_lag: u16,
    /// Last lag used (in samples).
    pub last_lag: u16,
    /// Why the lag range ends at `last_lag`.
    pub stop: LagStop,
    /// Whether `alpha` was clamped.
    pub clamp: Clamp,
}

/// An exponential-cosine fit `r(t) = exp(-alpha |t|) cos(beta t)` (paper eq. 16, 19-21).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ExpCosEstimate<T> {
    /// Decay rate in 1/s.
    pub alpha: T,
    /// Angular frequency in rad/s, `(pi/2) / tau_beta`.
    pub beta: T,
    /// Interpolated first zero crossing of `R`, in s.
    pub tau_beta: T,
    /// First lag used by the `alpha` fit.
    pub first_lag: u16,
    /// Last lag used by the `alpha` fit.
    pub last_lag: u16,
    /// Why the `alpha` fit stops at `last_lag`.
    pub stop: LagStop,
    /// Whether `alpha` was clamped.
    pub clamp: Clamp,
}

/// Variance of the sensor error (METHOD.md §4: the estimates are filtered).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sigma2Estimate<T> {
    /// `R_0` of the estimates (paper eq. 13): underestimates `sigma^2` by about `mean(P)`.
    pub r0: T,
    /// `R_0 + mean(P_mumu)`: for a consistent filter `Var(x) ~ Var(x_hat) + P`.
    pub corrected: T,
}

/// A validated sample ACF `R_0 ..= R_L` with its sample period and window length.
///
/// Checks, once: at least `R_0, R_1`; every value finite; `R_0 > 0`; `dt` finite and positive;
/// `MIN_WINDOW <= N` and `L < N`. At most `u16::MAX` lags are kept (lags are reported as `u16`);
/// further values are ignored.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleAcf<'a, T> {
    r: &'a [T],
    dt: T,
    n: u32,
}

impl<'a, T: Real> SampleAcf<'a, T> {
    /// Shortest accepted window: below this there is no usable ACF information and the
    /// lag-1 bias correction `(N r_1 + 1) / (N - 4)` would be meaningless.
    pub const MIN_WINDOW: u32 = 8;

    /// Wraps `r = [R_0, R_1, ..]` computed over a window of `n` samples at period `dt`.
    pub fn new(r: &'a [T], dt: T, n: u32) -> Result<Self, IdentError> {
        let keep = r.len().min(u16::MAX as usize + 1);
        let r = r.get(..keep).unwrap_or(r);
        if r.len() < 2 {
            return Err(IdentError::NotEnoughLags);
        }
        if !(dt.is_finite() && dt > T::zero()) {
            return Err(IdentError::InvalidDt);
        }
        if n < Self::MIN_WINDOW || (n as usize) < r.len() {
            return Err(IdentError::InvalidWindow);
        }
        if r.iter().any(|v| !v.is_finite()) {
            return Err(IdentError::NonFinite);
        }
        match r.first() {
            Some(&r0) if r0 > T::zero() => Ok(SampleAcf { r, dt, n }),
            _ => Err(IdentError::NonPositiveVariance),
        }
    }

    /// `R_0`.
    pub fn r0(&self) -> T {
        self.r.first().copied().unwrap_or_else(T::zero)
    }

    /// Largest lag `L` available (`>= 1`).
    pub fn max_lag(&self) -> u16 {
        // r.len() <= u16::MAX + 1 by construction.
        u16::try_from(self.r.len().saturating_sub(1)).unwrap_or(u16::MAX)
    }

    /// Sample period.
    pub fn dt(&self) -> T {
        self.dt
    }

    /// Window length `N`.
    pub fn window(&self) -> u32 {
        self.n
    }

    /// Normalised `r_j = R_j / R_0`, `None` beyond `L`. May be non-finite only if `R_0` is so
    /// small that the ratio overflows; the estimators check their results.
    pub fn rho(&self, j: u16) -> Option<T> {
        self.r.get(usize::from(j)).map(|&v| v / self.r0())
    }

    /// Lag time `tau_j = j dt`.
    pub fn tau(&self, j: u16) -> T {
        T::lit(f64::from(j)) * self.dt
    }

    /// `N` as a scalar.
    pub(crate) fn n_real(&self) -> T {
        T::lit(f64::from(self.n))
    }

    /// Two-sigma band of `r_1` for white noise, `min(2 / sqrt(N), 1/e)`.
    pub fn white_band(&self) -> T {
        (T::lit(NOISE_FLOOR_Z) / self.n_real().sqrt()).min(T::lit(INV_E))
    }

    /// Valid range of `alpha`, see the [module docs](self#valid-range-of-alpha).
    pub fn alpha_range(&self) -> (T, T) {
        let lo = T::one() / (self.n_real() * self.dt);
        let hi = -self.white_band().ln() / self.dt;
        (lo, hi)
    }

    /// Noise floor of `r_j` used to stop the Markov-1 slope fits.
    ///
    /// Bartlett's formula for an AR(1) process gives, at lags well beyond the correlation time,
    /// `var(r_j) ~ (1 + phi^2) / ((1 - phi^2) N)`. The floor is two standard deviations of that,
    /// with `phi = r_1` clamped to `[0, exp(-1/N)]`, capped at `1/e`:
    ///
    /// `floor = min(2 sqrt((1 + phi^2) / ((1 - phi^2) N)), 1/e)`.
    ///
    /// For white noise (`phi = 0`) it is the usual `2/sqrt(N)` band; for a correlated process the
    /// white-noise band is too low by `sqrt(2 tau / dt)` and would let the fit run into lags that
    /// are pure noise (for `tau = 1200 s`, `N = 43200` the floor is 0.33, not 0.0096). The cap
    /// keeps the lags within the first correlation time usable when the window is short
    /// (`N (1 - phi) < ~15`), where the band would exceed 1.
    pub fn noise_floor(&self) -> T {
        let phi_max = (-T::one() / self.n_real()).exp();
        let phi = self.rho(1).unwrap_or_else(T::zero);
        let phi = if phi.is_finite() { phi } else { T::zero() };
        let phi = phi.max(T::zero()).min(phi_max);
        let p2 = phi * phi;
        let band =
            T::lit(NOISE_FLOOR_Z) * ((T::one() + p2) / ((T::one() - p2) * self.n_real())).sqrt();
        let cap = T::lit(INV_E);
        if band.is_finite() {
            band.min(cap)
        } else {
            cap
        }
    }

    /// Clamps a finite `alpha` to [`alpha_range`](Self::alpha_range).
    pub(crate) fn clamp_alpha(&self, alpha: T) -> (T, Clamp) {
        let (lo, hi) = self.alpha_range();
        if alpha < lo {
            (lo, Clamp::ToMin)
        } else if alpha > hi {
            (hi, Clamp::ToMax)
        } else {
            (alpha, Clamp::No)
        }
    }
}
