//! The chi-square distribution with an integer number of degrees of freedom: its survival
//! function in closed form and its quantiles, for the outlier gates of vector observations.
//!
//! A gate set for one axis at the threshold `g` (a chi-square(1) quantile) rejects a right
//! observation with probability `p = Q_1(g)`. An observation with `m` finite axes is gated on
//! its NIS against the chi-square(`m`) quantile at the same `p`, so that the false-rejection
//! rate does not depend on how many axes a row happens to have.
//!
//! ```
//! use imu_ident::filter::chi_square::{quantile, survival};
//! let p = survival(1, 30.0); // the step's default gate: about 4.3e-8
//! assert!((p - 4.3e-8).abs() < 0.1e-8);
//! let q3 = quantile(3, p); // the same tail for three axes
//! assert!((survival(3, q3) / p - 1.0).abs() < 1e-9);
//! assert!(q3 > 30.0);
//! ```

/// `Q_m(x) = P(chi2_m > x)` for `m >= 1` degrees of freedom (1 for `x <= 0`, NaN for NaN;
/// `m = 0` is the point mass at 0: 0 for `x > 0`). With `h = x / 2` (Abramowitz and Stegun
/// 26.4.4 and 26.4.5):
///
/// ```text
/// m even:  Q = exp(-h) sum_{k=0}^{m/2-1} h^k / k!
/// m odd:   Q = erfc(sqrt h) + exp(-h) sum_{k=0}^{(m-3)/2} h^(k+1/2) / Gamma(k+3/2)
/// ```
///
/// Each term is the previous one times `h / (k + 1)` (even) or `h / (k + 3/2)` (odd), so the
/// sum costs `m / 2` multiplications after one `exp` (and one `erfc`).
pub fn survival(m: usize, x: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    let h = 0.5 * x;
    let e = libm::exp(-h);
    if m % 2 == 0 {
        let mut term = e;
        let mut sum = 0.0;
        for k in 0..m / 2 {
            sum += term;
            term *= h / (k as f64 + 1.0);
        }
        sum
    } else {
        let r = libm::sqrt(h);
        // h^(1/2) / Gamma(3/2), Gamma(3/2) = sqrt(pi) / 2.
        let mut term = e * r * core::f64::consts::FRAC_2_SQRT_PI;
        let mut sum = libm::erfc(r);
        for k in 0..(m - 1) / 2 {
            sum += term;
            term *= h / (k as f64 + 1.5);
        }
        sum
    }
}

/// The `x` with `Q_m(x) = p` (`m >= 1`, `0 < p < 1`; NaN otherwise), by bisection: `Q_m` is
/// decreasing, the bracket doubles until it holds `x` (at most 1100 doublings reach the
/// largest `f64`) and 200 halvings exhaust an `f64`'s precision. Bounded work, for the
/// set-up of a gate, not for a tick.
pub fn quantile(m: usize, p: f64) -> f64 {
    // Not `!(p > 0.0 && p < 1.0)` inverted: NaN fails both.
    if m == 0 || p.is_nan() || p <= 0.0 || p >= 1.0 {
        return f64::NAN;
    }
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..1100 {
        if survival(m, hi) <= p {
            break;
        }
        lo = hi;
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if survival(m, mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against published quantiles: at `1 - 1e-4` for 1 to 6 degrees of freedom, to 3 decimals
    /// (the navigator's `CHI2_9999` gate table), and two textbook values at 0.95.
    #[test]
    fn quantiles_match_the_tables() {
        let table = [15.137, 18.421, 21.108, 23.513, 25.745, 27.856];
        for (m, q) in table.iter().enumerate() {
            let ours = quantile(m + 1, 1.0e-4);
            assert!(
                (ours - q).abs() < 1.0e-3,
                "m = {}: {ours} against {q}",
                m + 1
            );
        }
        assert!((quantile(1, 0.05) - 3.841_459).abs() < 1.0e-6);
        assert!((quantile(2, 0.05) - 5.991_465).abs() < 1.0e-6);
    }

    /// The closed forms against each other: `Q_2(x) = exp(-x/2)`, `Q_1(x) = erfc(sqrt(x/2))`,
    /// and `Q_m` increasing in `m` at fixed `x` (a chi-square(m+1) is a chi-square(m) plus a
    /// positive variable).
    #[test]
    fn the_survival_function_is_consistent() {
        for x in [0.1, 1.0, 7.5, 30.0, 200.0] {
            assert!((survival(2, x) - libm::exp(-0.5 * x)).abs() <= 1e-15);
            assert!((survival(1, x) - libm::erfc(libm::sqrt(0.5 * x))).abs() <= 1e-15);
            for m in 1..12 {
                assert!(survival(m + 1, x) >= survival(m, x), "m = {m}, x = {x}");
            }
        }
        assert_eq!(survival(3, 0.0), 1.0);
        assert!(survival(3, f64::NAN).is_nan());
        assert!(quantile(2, 0.0).is_nan() && quantile(0, 0.5).is_nan());
    }
}
