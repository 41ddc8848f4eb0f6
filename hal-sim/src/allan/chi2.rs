//! Chi-square quantiles for Allan-deviation confidence intervals.
//!
//! Only what the intervals need: `ln Γ`, the regularized lower incomplete gamma function
//! `P(a, x)` and its inverse. The equivalent degrees of freedom of an overlapping Allan
//! variance are not integers and reach ~1e6 at small τ, so the inversion must work for
//! real ν from ~0.5 up to millions; a table or Wilson–Hilferty alone would not do.

/// `ln Γ(x)` for `x > 0`: Lanczos approximation (g = 7, 9 terms), relative error ~1e-15,
/// with the reflection formula below 0.5. Returns NaN for `x <= 0` or NaN.
pub(crate) fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x.is_nan() || x <= 0.0 {
        return f64::NAN;
    }
    if x < 0.5 {
        // Γ(x) Γ(1 - x) = π / sin(π x)
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    for (i, &c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    let t = x + G + 0.5;
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularized lower incomplete gamma `P(a, x)`: series for `x < a + 1`, Lentz continued
/// fraction for `Q = 1 - P` otherwise (Numerical Recipes, 3rd ed., §6.2). The iteration
/// limit allows the ~9·√a terms that large `a` needs near `x ≈ a`.
pub(crate) fn gamma_p(a: f64, x: f64) -> f64 {
    if x.is_nan() || a.is_nan() || a <= 0.0 {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 0.0;
    }
    if x.is_infinite() {
        return 1.0;
    }
    let max_iter = 100 + (20.0 * a.sqrt()) as usize + (x.sqrt() * 20.0) as usize;
    let log_prefactor = log_prefactor(a, x);
    if x < a + 1.0 {
        let mut ap = a;
        let mut del = 1.0 / a;
        let mut sum = del;
        for _ in 0..max_iter {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-17 {
                break;
            }
        }
        (sum * log_prefactor.exp()).clamp(0.0, 1.0)
    } else {
        const TINY: f64 = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..=max_iter {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-17 {
                break;
            }
        }
        (1.0 - log_prefactor.exp() * h).clamp(0.0, 1.0)
    }
}

/// `ln(x^a e^{-x} / Γ(a))`. For large `a` the three terms are ~a ln a each and cancel to
/// O(1), so there it is rewritten with Stirling's series as
/// `a (ln(1+t) − t) + ½ ln(a/2π) − c(a)`, t = (x − a)/a, which keeps full relative accuracy
/// (c(a) = 1/12a − 1/360a³ + 1/1260a⁵ − 1/1680a⁷, error < 1e-13 for a ≥ 10).
fn log_prefactor(a: f64, x: f64) -> f64 {
    if a >= 10.0 {
        let t = (x - a) / a;
        let a2 = a * a;
        let corr =
            (1.0 / 12.0 - (1.0 / 360.0 - (1.0 / 1260.0 - 1.0 / (1680.0 * a2)) / a2) / a2) / a;
        a * (t.ln_1p() - t) + 0.5 * (a / (2.0 * std::f64::consts::PI)).ln() - corr
    } else {
        a * x.ln() - x - ln_gamma(a)
    }
}

/// Standard normal quantile, Acklam's rational approximation (relative error < 1.2e-9).
/// Only used as the starting point of the chi-square inversion.
fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    const P_LOW: f64 = 0.02425;
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < P_LOW {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - P_LOW {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// Quantile of the chi-square distribution with `nu` (real, > 0) degrees of freedom:
/// the `x` with `P(nu/2, x/2) = p`. Newton iteration from the Wilson–Hilferty guess,
/// kept inside a bisection bracket so that it cannot diverge for small `nu`.
/// Returns `None` for `p` outside (0, 1) or `nu` not positive and finite.
pub fn chi2_quantile(p: f64, nu: f64) -> Option<f64> {
    if !(p > 0.0 && p < 1.0 && nu > 0.0 && nu.is_finite()) {
        return None;
    }
    let a = 0.5 * nu;
    let z = normal_quantile(p);
    let h = 2.0 / (9.0 * nu);
    let wh = nu * (1.0 - h + z * h.sqrt()).powi(3);
    // Work in y = x/2, the argument of P(a, ·).
    let mut y = if wh > 0.0 { 0.5 * wh } else { 0.5 * nu * 1e-3 };
    let (mut lo, mut hi) = (0.0_f64, f64::INFINITY);
    for _ in 0..200 {
        let f = gamma_p(a, y) - p;
        if f == 0.0 {
            return Some(2.0 * y);
        }
        if f < 0.0 {
            lo = y;
        } else {
            hi = y;
        }
        // d/dy P(a, y) = y^(a−1) e^(−y) / Γ(a)
        let dens = log_prefactor(a, y).exp() / y;
        let mut next = y - f / dens;
        if !(next.is_finite() && next > lo && next < hi) {
            next = if hi.is_finite() {
                0.5 * (lo + hi)
            } else {
                2.0 * y.max(lo) + 1.0
            };
        }
        // P(a, ·) itself is only good to ~1e-12 relative for a ~ 1e6 (long series), so
        // asking for more than 1e-14 in y would only make Newton dither.
        if (next - y).abs() <= 1e-14 * y.abs() {
            return Some(2.0 * next);
        }
        y = next;
    }
    Some(2.0 * y)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    #[test]
    fn ln_gamma_known_values() {
        assert!(rel(ln_gamma(0.5), std::f64::consts::PI.sqrt().ln()) < 1e-14);
        assert!(ln_gamma(1.0).abs() < 1e-14);
        assert!(rel(ln_gamma(10.0), (362_880.0_f64).ln()) < 1e-14);
        // ln Γ(1e6) from Stirling with three correction terms.
        let x = 1e6_f64;
        let stirling =
            (x - 0.5) * x.ln() - x + 0.5 * (2.0 * std::f64::consts::PI).ln() + 1.0 / (12.0 * x);
        assert!(rel(ln_gamma(x), stirling) < 1e-14);
    }

    #[test]
    fn chi2_quantiles_match_tables() {
        // Values from scipy.stats.chi2.ppf (scipy 1.x), 10 significant digits.
        let cases = [
            (0.025, 1.0, 9.820_691_171e-4),
            (0.975, 1.0, 5.023_886_187),
            (0.025, 10.0, 3.246_972_780),
            (0.975, 10.0, 20.483_177_35),
            (0.95, 100.0, 124.342_113_4),
            (0.5, 2.0, 1.386_294_361),
        ];
        for (p, nu, want) in cases {
            let got = chi2_quantile(p, nu).expect("valid input");
            assert!(rel(got, want) < 1e-8, "p={p} nu={nu}: {got} vs {want}");
        }
    }

    #[test]
    fn chi2_quantile_round_trips_over_a_wide_range() {
        for &nu in &[0.3, 1.0, 2.5, 17.0, 1e3, 1e5, 2e6] {
            for &p in &[1e-4, 0.005, 0.025, 0.16, 0.5, 0.84, 0.975, 0.995, 0.9999] {
                let x = chi2_quantile(p, nu).expect("valid input");
                // P itself carries ~k·eps relative error after the k ≈ 9√a series terms, and
                // the 1e-14 relative stop in x moves P by up to ~1e-14·x·density ∝ √ν.
                let back = gamma_p(0.5 * nu, 0.5 * x);
                let tol = 1e-11 * p.max(1e-2) * (1.0 + nu.sqrt() / 100.0);
                assert!((back - p).abs() < tol, "nu={nu} p={p}: {back}");
            }
        }
        assert!(chi2_quantile(0.0, 3.0).is_none());
        assert!(chi2_quantile(0.5, -1.0).is_none());
        assert!(chi2_quantile(f64::NAN, 3.0).is_none());
    }
}
