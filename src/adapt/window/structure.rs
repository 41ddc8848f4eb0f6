//! The structure test of the global stage (issue 13, item 3: the paper's structural
//! identification, online): after a search has found the best parameters of the filter's
//! model over the window, each switchable component (the kind table's
//! [`alternative`](crate::model::ComponentKind::alternative): Gauss-Markov <-> exponential-cosine)
//! is tried with its kind replaced, on the same window, and the best alternative's maximum
//! log-likelihood is reported beside the model's. The filter switches when the alternative
//! wins by more than a complexity penalty ([`AdaptiveFilter`](crate::adapt::AdaptiveFilter)).
//!
//! Exponential-cosine from Gauss-Markov: `beta` is new, and the likelihood is sharply peaked in
//! it (its width in `beta` is about `alpha`), so a local polish from one guess finds the peak
//! only when it starts within a few widths. The test therefore first scans up to [`SCAN`] / 2 periods
//! `P_j = 3 x 1.5^j` blocks (the shortest, 3 blocks, above the block means' Nyquist period of
//! 2 blocks), each with `tau = P_j` (quality factor `beta tau / 2 = pi`: a peak about a third
//! of `beta` wide, so neighbouring periods, a factor 1.5 apart, overlap), and polishes the best
//! scan point in every parameter. Gauss-Markov from exponential-cosine: dropping `beta` needs no
//! scan; the polish starts from the same `sigma, tau`.
//!
//! Only oscillations the window holds at least [`MIN_CYCLES`] periods of are offered (the scan
//! and `beta`'s lower bound): measured, a `paper` log (fresh seed 9104) switched its gyro to a
//! 3-h period with a 37-h correlation time, a slow quasi-sinusoid that a 4-h window cannot tell
//! from the Schuler dynamics and the accelerometer's low frequencies, and the tilt over the
//! next hours went to 3-4x the oracle's.
//!
//! And only oscillations are offered: a polished exponential-cosine whose correlation time is
//! shorter than half its period (`beta tau < `[`MIN_QUALITY`]` = pi`) is not an alternative.
//! Such a component barely oscillates (its ACF's first trough, at half a period, is shallower
//! than `-1/e` of its variance); it is a Gauss-Markov of another spectral shape, and the window
//! fits its shape to noise. Measured on `paper` logs (seeds 9500-9519 and 74000-74019, firmware
//! pace): at the first search the best alternative was the accelerometer's in 35 of 39 logs,
//! with `beta tau` of 1.0-2.1, up to 4.1 nats; the issue's oscillation has `beta tau = 4 pi`.
//!
//! ```
//! use imu_ident::adapt::identifiable::IdentifiableModel;
//! use imu_ident::model::{ComponentKind, InsModel, ErrorSource};
//! let paper = InsModel::<f64>::paper();
//! // The paper's two Gauss-Markov components are the candidates, accelerometer first.
//! let s = paper.site(1).unwrap();
//! assert_eq!((s.sensor, s.index, s.kind), (ErrorSource::Gyro, 0, ComponentKind::ExpCosine));
//! assert!(paper.site(2).is_none());
//! let ec = paper.swapped(&s, 0.01).unwrap();
//! assert_eq!(ec.gyro[0].kind(), ComponentKind::ExpCosine);
//! ```

use super::{Phase, Switch};
use crate::adapt::guard::Bounds;
use crate::adapt::identifiable::IdentifiableModel;
use crate::adapt::params::{remap, Specs, MAXP};
use crate::model::Quantity;
use crate::Real;

/// Periods scanned for a new `beta`.
const PERIODS: usize = 12;
/// Scan points: every period around two points, the model's best and the start model (measured:
/// from the best alone, when a strong oscillation has pulled the best Gauss-Markov fit's other
/// components far from their values, the polish of the true alternative can end below a
/// wrong one: `examples/structure_bench.rs`, `docs/ADAPTATION.md` §7.6).
pub const SCAN: usize = 2 * PERIODS;
/// The test runs only after a search whose answer beats the previous answer (the anchor) by at
/// most this many nats on the same window, i.e. once the model has settled. A search that moved
/// the model far has just left a poor fit, and an alternative absorbs that fit's misfit.
/// Measured (any-start bench, `docs/ADAPTATION.md` §7.6): from wrong starts, exp-cosines near
/// the block means' Nyquist period or near the Schuler period won on `paper` data at the first
/// search.
pub const SETTLED: f64 = 5.0;
/// Periods of an offered oscillation the window must hold at least.
pub const MIN_CYCLES: f64 = 4.0;
/// The least `beta tau` of an offered exponential-cosine: its correlation lasts at least half
/// a period (module docs).
pub const MIN_QUALITY: f64 = core::f64::consts::PI;
/// The shortest scanned period [blocks] and the ratio of successive ones.
const SCAN_FIRST: f64 = 3.0;
const SCAN_RATIO: f64 = 1.5;

pub use crate::adapt::params::Site;

/// A model that differs from the filter's in one component's kind, ready to be searched.
#[derive(Debug, Clone)]
pub struct Alternative<T: Real, M, const N: usize, const Z: usize> {
    /// The model with the component replaced (its parameter values are those of `start`).
    pub base: M,
    /// Its identified parameters.
    pub specs: Specs,
    /// Their bounds (the filter's, and for a new `beta` the physical range of the component's
    /// `tau` bounds: `[2 pi / tau_max, pi / dt]`).
    pub bounds: Bounds<T>,
    /// The starting point: the filter model's best point, mapped.
    pub start: [T; MAXP],
    /// The start model's point (the grid's centre), mapped (the scan's second origin).
    pub origin: [T; MAXP],
    /// The switch.
    pub site: Site,
    /// Indices of the new `beta` and of its component's `tau` in `theta`, when `beta` is scanned.
    pub scan: Option<(usize, usize)>,
    /// Scanned periods (those within the longest offered period), and the block length [s].
    pub periods: usize,
    /// Seconds per block.
    pub block_s: T,
}

/// The alternative at `site` of the filter's model (`base`, `specs`, best point `theta`, the
/// start model's point `centre`, `bounds`), for a window of `window_s` seconds in blocks of
/// `block_s` seconds. `None` if the site does not exist, the alternative's parameters do not
/// all fit in [`MAXP`], or the window is too short for any scanned period.
#[allow(clippy::too_many_arguments)]
pub fn alternative<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize>(
    base: &M,
    specs_now: &Specs,
    theta: &[T; MAXP],
    centre: &[T; MAXP],
    bounds: &Bounds<T>,
    site: Site,
    block_s: T,
    window_s: T,
) -> Option<Alternative<T, M, N, Z>> {
    let longest = window_s / T::lit(MIN_CYCLES);
    let periods = (0..PERIODS)
        .take_while(|&k| block_s * T::lit(scan_blocks(k)) <= longest)
        .count();
    let beta0 = T::lit(core::f64::consts::TAU) / (block_s * T::lit(scan_blocks(0)));
    let alt = base.swapped(&site, beta0)?;
    let specs_alt = alt.identified();
    let same = |s: &crate::adapt::params::ParamSpec, q| {
        s.sensor == site.sensor && s.index == site.index && s.kind == q
    };
    // Every quantity of the new component must be identified: a truncated list would fix it.
    for &q in site.kind.identified() {
        if !specs_alt.iter().any(|s| same(s, q)) {
            return None;
        }
    }
    let fill = alt.parameters(&specs_alt);
    let start = remap(specs_now, theta, &specs_alt, &fill);
    let origin = remap(specs_now, centre, &specs_alt, &fill);
    let mut lo = remap(specs_now, &bounds.lo, &specs_alt, &fill);
    let mut hi = remap(specs_now, &bounds.hi, &specs_alt, &fill);
    let tau_at = specs_alt.iter().position(|s| same(s, Quantity::Tau))?;
    let beta_at = specs_alt.iter().position(|s| same(s, Quantity::Beta));
    let scan = match beta_at {
        Some(b) if !specs_now.iter().any(|s| same(s, Quantity::Beta)) => {
            // `Bounds::new`'s tau range is `[ln dt + h, ln tau_max - h]`; its beta range is
            // `[ln(2 pi / tau_max) + h, ln(pi / dt) - h]`: the same numbers, mirrored.
            // Raised to the longest offered period.
            let (tl, th) = (*lo.get(tau_at)?, *hi.get(tau_at)?);
            let tau_ln = T::lit(core::f64::consts::TAU).ln();
            let l = (tau_ln - th).max(tau_ln - longest.ln());
            let u = T::lit(core::f64::consts::PI).ln() - tl;
            if periods == 0 || l.partial_cmp(&u) != Some(core::cmp::Ordering::Less) {
                return None;
            }
            *lo.get_mut(b)? = l;
            *hi.get_mut(b)? = u;
            Some((b, tau_at))
        }
        _ => None,
    };
    Some(Alternative {
        base: alt,
        specs: specs_alt,
        bounds: Bounds { lo, hi },
        start,
        origin,
        site,
        scan,
        periods,
        block_s,
    })
}

/// The `k`-th scanned period [blocks].
fn scan_blocks(k: usize) -> f64 {
    SCAN_FIRST * libm::pow(SCAN_RATIO, k as f64)
}

impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize>
    Alternative<T, M, N, Z>
{
    /// A placeholder (a compile-time value).
    pub const BLANK: Self = Self {
        base: M::BLANK,
        specs: Specs::new(),
        bounds: Bounds::BLANK,
        start: [T::ZERO; MAXP],
        origin: [T::ZERO; MAXP],
        site: Site::BLANK,
        scan: None,
        periods: 0,
        block_s: T::ZERO,
    };

    /// Scan points (`0` without a scan).
    pub fn scan_len(&self) -> usize {
        if self.scan.is_some() {
            2 * self.periods.min(PERIODS)
        } else {
            0
        }
    }

    /// The `j`-th of the [`scan_len`](Self::scan_len) scan points: the start (first half,
    /// else the origin) with period `P = 3 x 1.5^k` blocks, `k = j mod periods`,
    /// `beta = 2 pi / P`, `tau = P`; `None` past the last or without a scan.
    pub fn scan_point(&self, j: usize) -> Option<[T; MAXP]> {
        let (b, t) = self.scan?;
        if j >= self.scan_len() {
            return None;
        }
        let n = self.periods.max(1);
        let period = self.block_s * T::lit(scan_blocks(j % n));
        let mut th = if j < n { self.start } else { self.origin };
        *th.get_mut(t)? = period.ln();
        *th.get_mut(b)? = (T::lit(core::f64::consts::TAU) / period).ln();
        Some(self.bounds.clamp(&th, self.specs.len()))
    }
}

/// The structure test's phases of the window search (its state is the search's: this module is
/// a child of [`super`], so it reads the private fields).
impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize, const W: usize>
    super::WindowSearch<T, M, N, Z, W>
{
    /// The structure test's next alternative (the next switchable component of the model), or
    /// the end of the search.
    pub(super) fn next_alternative(
        &mut self,
        base: &M,
        specs: &Specs,
        bounds: &Bounds<T>,
    ) -> Phase {
        if self.cfg.structure.partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater) {
            return Phase::Idle;
        }
        // Bounded: a model has at most 2 MAX_COMPONENTS sensor components.
        for _ in 0..(2 * crate::model::ins::MAX_COMPONENTS) {
            let k = self.alt_k;
            self.alt_k += 1;
            let Some(site) = base.site(k) else {
                break;
            };
            let window_s = T::lit(self.wlen as f64) * self.block_s;
            let alt = alternative(
                base,
                specs,
                &self.best,
                &self.centre,
                bounds,
                site,
                self.block_s,
                window_s,
            );
            if let Some(a) = alt {
                let (start, scan) = (a.start, a.scan_len() > 0);
                self.scan_ll = T::lit(f64::NEG_INFINITY);
                self.scan_best = start;
                self.alt = a;
                return if scan {
                    Phase::AltScan(0)
                } else {
                    self.begin_polish(&start, Phase::AltRefine)
                };
            }
        }
        Phase::Idle
    }

    /// Keeps the polished alternative if its penalised log-likelihood beats the best one so
    /// far (`p`: the filter model's parameter count). Returns whether it was offered and wins
    /// against the model's best point so far ([`Switch::wins`]).
    pub(super) fn end_alternative(&mut self, p: usize) -> bool {
        let a = &self.alt;
        if !self.acc_ll.is_finite() {
            return false;
        }
        // A new exponential-cosine that does not oscillate is not offered (`MIN_QUALITY`):
        // `ln beta + ln tau < ln pi`.
        if let Some((b, t)) = a.scan {
            let (Some(&lb), Some(&lt)) = (self.acc_theta.get(b), self.acc_theta.get(t)) else {
                return false;
            };
            // NaN is not an oscillation either.
            match (lb + lt).partial_cmp(&T::lit(MIN_QUALITY).ln()) {
                Some(core::cmp::Ordering::Less) | None => return false,
                _ => {}
            }
        }
        let extra = i8::try_from(a.specs.len())
            .unwrap_or(0)
            .saturating_sub(i8::try_from(p).unwrap_or(0));
        let cand = Switch {
            site: a.site,
            theta: self.acc_theta,
            gain: self.acc_ll - self.best_ll,
            extra,
            valid: true,
        };
        let pen = self.cfg.structure;
        let penalised = |ll: T, s: &Switch<T>| ll - pen * T::lit(f64::from(s.extra));
        if !self.switch.valid
            || penalised(self.acc_ll, &cand) > penalised(self.switch_ll, &self.switch)
        {
            self.switch = cand;
            self.switch_ll = self.acc_ll;
        }
        cand.wins(pen)
    }
}
