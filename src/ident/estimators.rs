//! Estimators of the noise-model parameters on a [`SampleAcf`] (METHOD.md §3, paper eq. 13-21).
//!
//! Lags are counted in samples: `tau_j = j dt`. Every fit is done in lag units and divided by `dt`
//! at the end, and the sums of `j` and `j^2` use their closed forms, so `f32` loses nothing there.
//! Every `alpha` is finite-checked, then clamped to [`SampleAcf::alpha_range`].

use super::{AlphaEstimate, Clamp, ExpCosEstimate, IdentError, LagStop, SampleAcf, Sigma2Estimate};
use crate::Real;

/// Number of standard deviations of the [noise floor](SampleAcf::noise_floor) (two-sided ~95 %).
pub const NOISE_FLOOR_Z: f64 = 2.0;

/// [`exp_cosine`] only uses lags with `cos(beta tau_j) >= COS_MIN`, i.e. `tau_j <= 0.84 tau_beta`.
/// Near the zero crossing `r_j / cos(beta tau_j)` is a ratio of two small, noisy numbers; at
/// `cos = 0.25` the slope of `ln cos` is `-tan(beta tau) = -3.9`, so an error of 1 % in `tau_beta`
/// still moves `ln cos` by only ~5 %.
pub const COS_MIN: f64 = 0.25;

/// Small-sample bias of the lag-1 autocorrelation of an AR(1) process with estimated mean, for
/// the `1/N` (Yule-Walker) estimator used here: `E[r_1] ~ phi - (1 + 4 phi) / N` (Kendall 1954;
/// Shaman & Stine 1988). The least-squares estimator of `phi` has `1 + 3 phi` instead; the
/// `1/N` normalisation of `R_1` over `N - 1` products adds `-phi/N`. `tests/estimators.rs` checks
/// the slope by Monte Carlo.
pub const LAG1_BIAS_SLOPE: f64 = 4.0;

/// `sum_{j=1}^{J} j` in `f64` (exact for `J <= u16::MAX`).
fn sum_j(last: u16) -> f64 {
    let j = f64::from(last);
    j * (j + 1.0) / 2.0
}

/// `sum_{j=1}^{J} j^2` in `f64` (exact for `J <= u16::MAX`: below `2^53`).
fn sum_j2(last: u16) -> f64 {
    let j = f64::from(last);
    j * (j + 1.0) * (2.0 * j + 1.0) / 6.0
}

/// Finite check, clamp, and packing of a Markov-1 estimate.
fn finish<T: Real>(
    acf: &SampleAcf<'_, T>,
    alpha: T,
    first_lag: u16,
    last_lag: u16,
    stop: LagStop,
) -> Result<AlphaEstimate<T>, IdentError> {
    if !alpha.is_finite() {
        return Err(IdentError::NonFinite);
    }
    let (alpha, clamp) = acf.clamp_alpha(alpha);
    Ok(AlphaEstimate {
        alpha,
        first_lag,
        last_lag,
        stop,
        clamp,
    })
}

/// The lags `1 ..= J` of the Markov-1 slope fits: every `r_j` with `j <= J` is above the
/// [noise floor](SampleAcf::noise_floor) (hence positive), `J` is the last such lag before the
/// first one at or below it. Also returns `sum_{j <= J} ln r_j` and `sum_{j <= J} j ln r_j`.
fn markov_lags<T: Real>(acf: &SampleAcf<'_, T>) -> Result<(u16, LagStop, T, T), IdentError> {
    let floor = acf.noise_floor();
    let mut last = 0u16;
    let mut stop = LagStop::EndOfAcf;
    let mut s_ln = T::zero();
    let mut s_jln = T::zero();
    // j as a scalar, stepped (exact) instead of converted per lag.
    let mut jt = T::zero();
    for j in 1..=acf.max_lag() {
        jt += T::one();
        match acf.rho(j) {
            Some(r) if r > floor => {
                let l = r.ln();
                s_ln += l;
                s_jln += jt * l;
                last = j;
            }
            _ => {
                stop = LagStop::NoiseFloor;
                break;
            }
        }
    }
    if last == 0 {
        return Err(IdentError::NoUsableLag);
    }
    Ok((last, stop, s_ln, s_jln))
}

/// Least-squares slope of `ln r_j = -alpha tau_j` through the origin (METHOD.md §3, eq. 15
/// corrected): `alpha = - sum tau_j ln r_j / sum tau_j^2`, over the lags `1 ..= J` before `r_j`
/// first falls to the [noise floor](SampleAcf::noise_floor).
///
/// Errors: [`IdentError::NoUsableLag`] if `r_1` is already at the floor.
pub fn ls_slope<T: Real>(acf: &SampleAcf<'_, T>) -> Result<AlphaEstimate<T>, IdentError> {
    let (last, stop, _, s_jln) = markov_lags(acf)?;
    let alpha = -s_jln / (T::lit(sum_j2(last)) * acf.dt());
    finish(acf, alpha, 1, last, stop)
}

/// The paper's eq. 15 with the sign fixed, kept for comparison:
/// `alpha = - sum ln r_j / sum tau_j`, over the same lags as [`ls_slope`].
///
/// This is the mean of the single-lag rates `-ln r_j / tau_j` weighted by `tau_j`, not a least
/// squares fit; it is exact on an exact exponential but weighs the noisy long lags differently.
pub fn paper_eq15<T: Real>(acf: &SampleAcf<'_, T>) -> Result<AlphaEstimate<T>, IdentError> {
    let (last, stop, s_ln, _) = markov_lags(acf)?;
    let alpha = -s_ln / (T::lit(sum_j(last)) * acf.dt());
    finish(acf, alpha, 1, last, stop)
}

/// `alpha = -ln(phi) / dt` from a lag-1 coefficient, `phi <= 0` meaning white at this rate.
fn from_phi<T: Real>(acf: &SampleAcf<'_, T>, phi: T) -> Result<AlphaEstimate<T>, IdentError> {
    if !phi.is_finite() {
        return Err(IdentError::NonFinite);
    }
    if phi <= T::zero() {
        let (_, hi) = acf.alpha_range();
        return Ok(AlphaEstimate {
            alpha: hi,
            first_lag: 1,
            last_lag: 1,
            stop: LagStop::SingleLag,
            clamp: Clamp::ToMax,
        });
    }
    finish(acf, -phi.ln() / acf.dt(), 1, 1, LagStop::SingleLag)
}

/// Lag-1 estimator without bias correction: `phi = r_1`, `alpha = -ln(phi) / dt`. Reference for
/// [`lag1_corrected`].
pub fn lag1_raw<T: Real>(acf: &SampleAcf<'_, T>) -> Result<AlphaEstimate<T>, IdentError> {
    let r1 = acf.rho(1).ok_or(IdentError::NotEnoughLags)?;
    from_phi(acf, r1)
}

/// Lag-1 estimator with the small-sample bias of `r_1` removed.
///
/// For a Markov-1 process sampled directly, `phi = exp(-alpha dt)` is the AR(1) coefficient and
/// `r_1` is its Yule-Walker estimate, asymptotically efficient (variance `(1 - phi^2)/N`, the
/// Cramér-Rao bound). Its bias `E[r_1] ~ phi - (1 + 4 phi)/N` ([`LAG1_BIAS_SLOPE`]) is small in
/// `phi` but not in `alpha` when the window is only a few tens of correlation times (14 % for
/// `tau = 1200 s` in 12 h at 1 Hz), so it is inverted:
/// `phi = (N r_1 + 1) / (N - 4) = r_1 + (1 + 4 r_1) / (N - 4)`,
/// then `alpha = -ln(phi)/dt`, clamped to [`SampleAcf::alpha_range`] (so `phi >= 1` gives
/// `alpha_min` and `phi <= 0` gives `alpha_max`).
pub fn lag1_corrected<T: Real>(acf: &SampleAcf<'_, T>) -> Result<AlphaEstimate<T>, IdentError> {
    let r1 = acf.rho(1).ok_or(IdentError::NotEnoughLags)?;
    let b = T::lit(LAG1_BIAS_SLOPE);
    // n >= MIN_WINDOW = 8 > LAG1_BIAS_SLOPE, so the denominator is positive.
    let phi = r1 + (T::one() + b * r1) / (acf.n_real() - b);
    from_phi(acf, phi)
}

/// Exponential-cosine fit (paper eq. 19-21, corrected; METHOD.md §3).
///
/// 1. `tau_beta`: the first zero crossing of `R`, linearly interpolated between the last lag with
///    `R > 0` and the first with `R <= 0`; `beta = (pi/2) / tau_beta`.
/// 2. `alpha`: least squares through the origin of `ln r_j - ln cos(beta tau_j) = -alpha tau_j`
///    (eq. 21 has the same misprints as eq. 15), over `j = 1 ..= J` with `r_j > 0` and
///    `|beta tau_j| < pi/2` (every lag before the crossing), stopping at the first lag with
///    `cos(beta tau_j) <` [`COS_MIN`].
///
/// No noise floor is applied: the crossing itself bounds the lags. Errors:
/// [`IdentError::NoZeroCrossing`] if `R` stays positive up to `L`,
/// [`IdentError::NoUsableLag`] if no lag is left for the `alpha` fit.
pub fn exp_cosine<T: Real>(acf: &SampleAcf<'_, T>) -> Result<ExpCosEstimate<T>, IdentError> {
    // Step 1: first lag jc with r <= 0; r_{jc-1} > 0 (r_0 = 1).
    let mut prev = T::one();
    let mut crossing = None;
    for j in 1..=acf.max_lag() {
        let r = acf.rho(j).ok_or(IdentError::NotEnoughLags)?;
        if !r.is_finite() {
            return Err(IdentError::NonFinite);
        }
        if r <= T::zero() {
            // prev > 0 >= r, so prev - r >= prev > 0 and frac is in (0, 1].
            crossing = Some((j, prev / (prev - r)));
            break;
        }
        prev = r;
    }
    let (jc, frac) = crossing.ok_or(IdentError::NoZeroCrossing)?;
    let tau_beta_lags = T::lit(f64::from(jc - 1)) + frac;
    let beta_lag = T::frac_pi_2() / tau_beta_lags; // beta * dt
    let cos_min = T::lit(COS_MIN);

    // Step 2: lags 1 ..= jc - 1 all have r_j > 0 and j < tau_beta_lags, i.e. beta tau_j < pi/2.
    let mut last = 0u16;
    let mut stop = LagStop::ZeroCrossing;
    let mut s_jy = T::zero();
    let mut jt = T::zero();
    for j in 1..jc {
        jt += T::one();
        let c = (beta_lag * jt).cos();
        if c < cos_min {
            stop = LagStop::CosineLimit;
            break;
        }
        let r = acf.rho(j).ok_or(IdentError::NotEnoughLags)?;
        s_jy += jt * (r.ln() - c.ln());
        last = j;
    }
    if last == 0 {
        return Err(IdentError::NoUsableLag);
    }
    let dt = acf.dt();
    let alpha = -s_jy / (T::lit(sum_j2(last)) * dt);
    let beta = beta_lag / dt;
    let tau_beta = tau_beta_lags * dt;
    if !(alpha.is_finite() && beta.is_finite() && tau_beta.is_finite()) {
        return Err(IdentError::NonFinite);
    }
    let (alpha, clamp) = acf.clamp_alpha(alpha);
    Ok(ExpCosEstimate {
        alpha,
        beta,
        tau_beta,
        first_lag: 1,
        last_lag: last,
        stop,
        clamp,
    })
}

/// Variance of the sensor error from `R_0` of its filtered estimates and the mean of the filter's
/// variance `P_mumu` of that state over the same window (METHOD.md §4).
///
/// Errors: [`IdentError::NonFinite`] / [`IdentError::NonPositiveVariance`] for a bad `r0`,
/// [`IdentError::InvalidCovariance`] if `p_mean` is negative or not finite.
pub fn sigma2<T: Real>(r0: T, p_mean: T) -> Result<Sigma2Estimate<T>, IdentError> {
    if !r0.is_finite() {
        return Err(IdentError::NonFinite);
    }
    if r0 <= T::zero() {
        return Err(IdentError::NonPositiveVariance);
    }
    if !(p_mean.is_finite() && p_mean >= T::zero()) {
        return Err(IdentError::InvalidCovariance);
    }
    let corrected = r0 + p_mean;
    if !corrected.is_finite() {
        return Err(IdentError::NonFinite);
    }
    Ok(Sigma2Estimate { r0, corrected })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_form_sums() {
        let (mut s1, mut s2) = (0.0, 0.0);
        for j in 1..=1000u16 {
            s1 += f64::from(j);
            s2 += f64::from(j) * f64::from(j);
        }
        assert_eq!(sum_j(1000), s1);
        assert_eq!(sum_j2(1000), s2);
    }
}
