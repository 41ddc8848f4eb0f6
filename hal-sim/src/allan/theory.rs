//! Theoretical Allan variance of the usual inertial-sensor noise components.
//!
//! All functions return the Allan *variance* σ²(τ) in (unit of the output)²; take the
//! square root for the deviation. Independent components add in variance
//! ([`avar_sum`]). Out-of-domain input (τ ≤ 0, negative parameters, NaN) gives NaN rather
//! than a panic; [`NoiseComponent::validate`] reports such parameters as an error.
//!
//! # Continuous time
//! For a stationary output y(t) with autocovariance K(t), let
//! `G(t) = ∫₀ᵗ (t − s) K(s) ds` (so Var ∫₀ᵗ y = 2 G(t)). Two adjacent window integrals
//! I₀, I₁ of length τ satisfy Var(I₀ + I₁) = 2G(2τ) and E[(I₁ − I₀)²] = 8G(τ) − 2G(2τ), hence
//!
//! ```text
//! σ²(τ) = ½ E[(I₁ − I₀)²] / τ² = (4 G(τ) − G(2τ)) / τ² .
//! ```
//!
//! This is the "(2/τ²) ∫₀^τ (τ − t)(…)" formula of IEEE Std 952 Annex C rearranged; it
//! gives every closed form below. For K(t) = σ² e^{−c t} (c complex allowed),
//! `G(t) = σ² [t/c − (1 − e^{−ct})/c²]`, and with z = cτ
//!
//! ```text
//! σ²(τ) = σ² · h(z),   h(z) = (2z − 3 + 4e^{−z} − e^{−2z}) / z² .
//! ```
//!
//! * first-order Gauss–Markov, K = σ² e^{−|t|/T_c}: z = τ/T_c real. This is the IEEE 952
//!   form `(2σ²T_c/τ)[1 − (T_c/2τ)(3 − 4e^{−τ/T_c} + e^{−2τ/T_c})]`. Limits: K²τ/3 with
//!   K² = 2σ²/T_c for τ ≪ T_c (random-walk-like), N²/τ with N² = 2σ²T_c for τ ≫ T_c.
//! * exponential cosine, K = σ² e^{−α|t|} cos βt = Re σ² e^{−(α − iβ)t}: z = (α − iβ)τ and
//!   σ²(τ) = σ² Re h(z). For τ → ∞ it is white with N² = 2σ²α/(α² + β²), the two-sided PSD
//!   at zero frequency; β = 0 gives back Gauss–Markov with T_c = 1/α.
//!
//! h(z) = Σ_{k≥3} (4 − 2^k)(−z)^{k−2}/k! is entire; the series is used for |z| < 1, where
//! the closed form cancels (h ≈ 2z/3).
//!
//! # Discrete time (the high-frequency end)
//! The estimator works on samples. For a point-sampled process with semivariogram
//! γ(h) = ½ E[(y_{k+h} − y_k)²] (defined for random walks too), the expectation of the
//! overlapping estimator at cluster m is exactly
//!
//! ```text
//! E σ̂²(m) = −(1/m²) Σ_{h=1}^{2m−1} w(h) γ(h),   w(h) = 2m − 3h (h ≤ m),  −(2m − h) (h > m),
//! ```
//!
//! w being the autocorrelation of the cluster-difference filter (+1 × m, −1 × m), which sums
//! to zero. [`NoiseComponent::avar_sampled`] uses it; it differs from the continuous curve by
//! O(Δt/τ) at the first few clusters (e.g. a sampled rate random walk gives
//! K²(τ/3 + Δt²/(6τ))). Sampled white noise is taken with per-sample variance N²/Δt
//! (ideal averaging over the sample interval), quantization as the difference of a white
//! angle error of variance Q², both of which make the sampled value exact: N²/τ and 3Q²/τ².

use nalgebra::Complex;

use super::AllanError;

/// True for a positive number; false for zero, negatives and NaN.
fn is_positive(x: f64) -> bool {
    x > 0.0
}

/// White noise of density `n` [unit/√Hz = unit·√s] (angle/velocity random walk):
/// σ² = N²/τ (IEEE 952 Annex C).
pub fn avar_white(n: f64, tau: f64) -> f64 {
    if !is_positive(tau) || n.is_nan() {
        return f64::NAN;
    }
    n * n / tau
}

/// Rate random walk of coefficient `k` [unit/√s]: σ² = K²τ/3.
pub fn avar_random_walk(k: f64, tau: f64) -> f64 {
    if !is_positive(tau) || k.is_nan() {
        return f64::NAN;
    }
    k * k * tau / 3.0
}

/// A random constant (turn-on bias): σ² = 0 at every τ, because a difference of adjacent
/// cluster means removes any constant. The Allan variance therefore cannot see the turn-on
/// bias, and "bias instability" (a flicker floor, [`avar_flicker_floor`]) is a different
/// quantity.
pub fn avar_random_constant(_value: f64, tau: f64) -> f64 {
    if !is_positive(tau) {
        return f64::NAN;
    }
    0.0
}

/// Deterministic rate ramp of slope `r` [unit/s]: σ² = R²τ²/2.
pub fn avar_ramp(r: f64, tau: f64) -> f64 {
    if !is_positive(tau) || r.is_nan() {
        return f64::NAN;
    }
    0.5 * r * r * tau * tau
}

/// Quantization noise of coefficient `q` [unit·s] (angle quantization for a gyro):
/// σ² = 3Q²/τ².
pub fn avar_quantization(q: f64, tau: f64) -> f64 {
    if !is_positive(tau) || q.is_nan() {
        return f64::NAN;
    }
    3.0 * q * q / (tau * tau)
}

/// The floor that flicker noise of bias-instability coefficient `b` produces for τ well
/// above the flicker cut-off: σ² → (2 ln 2/π) B² (IEEE 952 Annex C), i.e. ADEV ≈ 0.664 B.
/// Only the asymptote is given: the full curve depends on the cut-off frequency.
pub fn avar_flicker_floor(b: f64) -> f64 {
    2.0 * std::f64::consts::LN_2 / std::f64::consts::PI * b * b
}

/// First-order Gauss–Markov process of standard deviation `sigma` and correlation time
/// `tc` [s]: σ²(τ) = σ² h(τ/T_c) (exact; see the module documentation).
pub fn avar_gauss_markov(sigma: f64, tc: f64, tau: f64) -> f64 {
    if !(tau > 0.0 && tc > 0.0) || sigma.is_nan() {
        return f64::NAN;
    }
    sigma * sigma * h(Complex::new(tau / tc, 0.0)).re
}

/// Exponential-cosine process, K(t) = σ² e^{−α|t|} cos βt (α ≥ 0 [1/s], β [rad/s]):
/// σ²(τ) = σ² Re h((α − iβ)τ) (exact; see the module documentation).
pub fn avar_exp_cosine(sigma: f64, alpha: f64, beta: f64, tau: f64) -> f64 {
    if !(tau > 0.0 && alpha >= 0.0 && beta.is_finite()) || sigma.is_nan() {
        return f64::NAN;
    }
    sigma * sigma * h(Complex::new(alpha * tau, -beta * tau)).re
}

/// h(z) = (2z − 3 + 4e^{−z} − e^{−2z}) / z², by its Taylor series near 0.
fn h(z: Complex<f64>) -> Complex<f64> {
    if z.norm() < 1.0 {
        // Σ_{k≥3} (4 − 2^k) u_k with u_k = (−z)^{k−2}/k!; |u_k| 2^k < 2^k/k! converges fast.
        let mut u = -z / 6.0;
        let mut pow2 = 8.0;
        let mut sum = u * (4.0 - pow2);
        for k in 4..60 {
            u = u * (-z) / k as f64;
            pow2 *= 2.0;
            let t = u * (4.0 - pow2);
            sum += t;
            if t.norm() <= 1e-17 * sum.norm() {
                break;
            }
        }
        sum
    } else {
        let e1 = (-z).exp();
        (2.0 * z - 3.0 + 4.0 * e1 - e1 * e1) / (z * z)
    }
}

/// Expected overlapping Allan variance at cluster `m` of a sampled process given its
/// semivariogram `gamma(h)` (h = lag in samples, h ≥ 1). O(m); see the module documentation.
pub fn avar_from_semivariogram(m: usize, gamma: impl Fn(usize) -> f64) -> f64 {
    if m == 0 {
        return f64::NAN;
    }
    let mf = m as f64;
    // Neumaier-compensated: the weights sum to −m while single terms reach ~m·γ.
    let mut acc = super::Neumaier::default();
    for lag in 1..2 * m {
        let w = if lag <= m {
            2.0 * mf - 3.0 * lag as f64
        } else {
            -(2.0 * mf - lag as f64)
        };
        acc.add(w * gamma(lag));
    }
    -acc.value() / (mf * mf)
}

/// One independent noise component of a sensor output model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NoiseComponent {
    /// White noise, density N [unit·√s].
    White { n: f64 },
    /// Rate random walk, K [unit/√s].
    RandomWalk { k: f64 },
    /// Random constant (zero Allan variance; kept so a model can list it).
    RandomConstant { value: f64 },
    /// Deterministic ramp, R [unit/s].
    Ramp { r: f64 },
    /// Quantization, Q [unit·s].
    Quantization { q: f64 },
    /// First-order Gauss–Markov, σ [unit], T_c [s].
    GaussMarkov { sigma: f64, tc: f64 },
    /// Exponential cosine, σ [unit], α [1/s], β [rad/s].
    ExpCosine { sigma: f64, alpha: f64, beta: f64 },
}

impl NoiseComponent {
    /// Rejects NaN/infinite parameters, negative magnitudes and non-positive T_c.
    pub fn validate(&self) -> Result<(), AllanError> {
        let bad = |name: &'static str, value: f64| AllanError::BadParameter { name, value };
        let finite_nonneg = |name, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(bad(name, v))
            }
        };
        match *self {
            Self::White { n } => finite_nonneg("n", n),
            Self::RandomWalk { k } => finite_nonneg("k", k),
            Self::RandomConstant { value } if value.is_finite() => Ok(()),
            Self::RandomConstant { value } => Err(bad("value", value)),
            Self::Ramp { r } if r.is_finite() => Ok(()),
            Self::Ramp { r } => Err(bad("r", r)),
            Self::Quantization { q } => finite_nonneg("q", q),
            Self::GaussMarkov { sigma, tc } => {
                finite_nonneg("sigma", sigma)?;
                if tc.is_finite() && tc > 0.0 {
                    Ok(())
                } else {
                    Err(bad("tc", tc))
                }
            }
            Self::ExpCosine { sigma, alpha, beta } => {
                finite_nonneg("sigma", sigma)?;
                finite_nonneg("alpha", alpha)?;
                if beta.is_finite() {
                    Ok(())
                } else {
                    Err(bad("beta", beta))
                }
            }
        }
    }

    /// Continuous-time Allan variance at τ [s].
    pub fn avar(&self, tau: f64) -> f64 {
        match *self {
            Self::White { n } => avar_white(n, tau),
            Self::RandomWalk { k } => avar_random_walk(k, tau),
            Self::RandomConstant { value } => avar_random_constant(value, tau),
            Self::Ramp { r } => avar_ramp(r, tau),
            Self::Quantization { q } => avar_quantization(q, tau),
            Self::GaussMarkov { sigma, tc } => avar_gauss_markov(sigma, tc, tau),
            Self::ExpCosine { sigma, alpha, beta } => avar_exp_cosine(sigma, alpha, beta, tau),
        }
    }

    /// Semivariogram γ(h) = ½E[(y_{k+h} − y_k)²] of the process sampled every `dt` seconds
    /// (`lag` ≥ 1 samples). Written so that small lags do not cancel (expm1, sin²).
    pub fn semivariogram_sampled(&self, lag: usize, dt: f64) -> f64 {
        if lag == 0 {
            return 0.0;
        }
        let t = lag as f64 * dt;
        match *self {
            Self::White { n } => n * n / dt,
            Self::RandomWalk { k } => 0.5 * k * k * t,
            Self::RandomConstant { .. } => 0.0,
            Self::Ramp { r } => 0.5 * r * r * t * t,
            // y_k = (e_{k+1} − e_k)/dt, e white with variance Q²: r(0) = 2Q²/dt²,
            // r(1) = −Q²/dt², r(h ≥ 2) = 0.
            Self::Quantization { q } => {
                let s = q * q / (dt * dt);
                if lag == 1 {
                    3.0 * s
                } else {
                    2.0 * s
                }
            }
            Self::GaussMarkov { sigma, tc } => -sigma * sigma * (-t / tc).exp_m1(),
            // 1 − e^{−αt} cos βt = −expm1(−αt) + e^{−αt} · 2 sin²(βt/2)
            Self::ExpCosine { sigma, alpha, beta } => {
                let s = (0.5 * beta * t).sin();
                sigma * sigma * (-(-alpha * t).exp_m1() + (-alpha * t).exp() * 2.0 * s * s)
            }
        }
    }

    /// Exact expectation of the overlapping estimator at cluster `m` for the process
    /// point-sampled every `dt` seconds. Closed forms where they exist, else the O(m)
    /// semivariogram sum ([`avar_from_semivariogram`]).
    pub fn avar_sampled(&self, m: usize, dt: f64) -> f64 {
        if m == 0 || !is_positive(dt) {
            return f64::NAN;
        }
        let mf = m as f64;
        let tau = mf * dt;
        match *self {
            Self::White { n } => avar_white(n, tau),
            // −(1/m²) Σ w(h) K²dt h/2 = K² dt (2m² + 1)/(6m)
            Self::RandomWalk { k } => k * k * dt * (2.0 * mf * mf + 1.0) / (6.0 * mf),
            Self::RandomConstant { value } => avar_random_constant(value, tau),
            Self::Ramp { r } => avar_ramp(r, tau),
            Self::Quantization { q } => avar_quantization(q, tau),
            Self::GaussMarkov { .. } | Self::ExpCosine { .. } => {
                avar_from_semivariogram(m, |lag| self.semivariogram_sampled(lag, dt))
            }
        }
    }
}

/// Allan variance of a sum of independent components: the variances add.
pub fn avar_sum(components: &[NoiseComponent], tau: f64) -> f64 {
    components.iter().map(|c| c.avar(tau)).sum()
}

/// Sampled counterpart of [`avar_sum`].
pub fn avar_sampled_sum(components: &[NoiseComponent], m: usize, dt: f64) -> f64 {
    components.iter().map(|c| c.avar_sampled(m, dt)).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    /// σ²(τ) = (4G(τ) − G(2τ))/τ² with G(t) = ∫₀ᵗ (t − s) K(s) ds by composite Simpson:
    /// an independent check of the closed-form algebra.
    fn avar_by_quadrature(k: impl Fn(f64) -> f64, tau: f64) -> f64 {
        let g = |t: f64| {
            let n = 20_000;
            let hstep = t / n as f64;
            let f = |s: f64| (t - s) * k(s);
            let mut acc = f(0.0) + f(t);
            for i in 1..n {
                let w = if i % 2 == 1 { 4.0 } else { 2.0 };
                acc += w * f(i as f64 * hstep);
            }
            acc * hstep / 3.0
        };
        (4.0 * g(tau) - g(2.0 * tau)) / (tau * tau)
    }

    #[test]
    fn exp_cosine_closed_form_matches_quadrature() {
        let (sigma, alpha, beta) = (0.3, 0.7, 2.0 * std::f64::consts::PI * 1.3);
        for &tau in &[0.01, 0.3, 1.0, 2.7, 10.0, 55.0] {
            let closed = avar_exp_cosine(sigma, alpha, beta, tau);
            let quad = avar_by_quadrature(
                |t| sigma * sigma * (-alpha * t).exp() * (beta * t).cos(),
                tau,
            );
            assert!(rel(closed, quad) < 1e-7, "tau={tau}: {closed} vs {quad}");
        }
    }

    #[test]
    fn gauss_markov_limits_and_beta_zero() {
        let (sigma, tc) = (2.0, 5.0);
        for &tau in &[1e-6, 1e-3, 0.9, 1.1, 5.0, 100.0] {
            let gm = avar_gauss_markov(sigma, tc, tau);
            assert!(rel(avar_exp_cosine(sigma, 1.0 / tc, 0.0, tau), gm) < 1e-13);
            // IEEE 952 form, evaluated where it does not cancel.
            if tau >= 0.9 {
                let x = tau / tc;
                let ieee = 2.0 * sigma * sigma * tc / tau
                    * (1.0 - (3.0 - 4.0 * (-x).exp() + (-2.0 * x).exp()) / (2.0 * x));
                assert!(rel(gm, ieee) < 1e-12, "tau={tau}");
            }
        }
        // τ ≪ T_c: K²τ/3 with K² = 2σ²/T_c.
        assert!(
            rel(
                avar_gauss_markov(sigma, tc, 1e-6),
                2.0 * sigma * sigma / tc * 1e-6 / 3.0
            ) < 1e-6
        );
        // τ ≫ T_c: N²/τ with N² = 2σ²T_c (next term is −3T_c/2τ relative).
        let tau = 1e7;
        assert!(
            rel(
                avar_gauss_markov(sigma, tc, tau),
                2.0 * sigma * sigma * tc / tau
            ) < 1e-5
        );
    }

    #[test]
    fn exp_cosine_long_tau_is_white_at_zero_frequency_density() {
        let (sigma, alpha, beta) = (1.0, 0.5, 3.0);
        let tau = 1e7;
        let n2 = 2.0 * sigma * sigma * alpha / (alpha * alpha + beta * beta);
        assert!(rel(avar_exp_cosine(sigma, alpha, beta, tau), n2 / tau) < 1e-5);
    }

    #[test]
    fn sampled_closed_forms_equal_the_semivariogram_sum() {
        let dt = 0.01;
        let comps = [
            NoiseComponent::White { n: 0.3 },
            NoiseComponent::RandomWalk { k: 0.02 },
            NoiseComponent::Ramp { r: 1e-3 },
            NoiseComponent::Quantization { q: 1e-3 },
            NoiseComponent::RandomConstant { value: 4.0 },
        ];
        for c in comps {
            for m in [1, 2, 3, 7, 64, 1000] {
                let closed = c.avar_sampled(m, dt);
                let summed = avar_from_semivariogram(m, |h| c.semivariogram_sampled(h, dt));
                let tol = 1e-12 * closed.abs().max(1e-300);
                assert!((closed - summed).abs() <= tol.max(1e-20), "{c:?} m={m}");
            }
        }
    }

    #[test]
    fn sampled_tends_to_continuous_as_dt_shrinks() {
        let comps = [
            NoiseComponent::GaussMarkov {
                sigma: 0.5,
                tc: 3.0,
            },
            NoiseComponent::ExpCosine {
                sigma: 0.5,
                alpha: 0.4,
                beta: 2.5,
            },
        ];
        for c in comps {
            for &tau in &[0.5, 3.0, 20.0] {
                let m = 4096;
                let sampled = c.avar_sampled(m, tau / m as f64);
                assert!(rel(sampled, c.avar(tau)) < 1e-3, "{c:?} tau={tau}");
            }
        }
    }

    #[test]
    fn invalid_parameters() {
        assert!(avar_white(1.0, 0.0).is_nan());
        assert!(avar_gauss_markov(1.0, -1.0, 1.0).is_nan());
        assert!(NoiseComponent::GaussMarkov {
            sigma: 1.0,
            tc: 0.0
        }
        .validate()
        .is_err());
        assert!(NoiseComponent::White { n: f64::NAN }.validate().is_err());
        assert!(NoiseComponent::ExpCosine {
            sigma: 1.0,
            alpha: 0.1,
            beta: 3.0
        }
        .validate()
        .is_ok());
        let sum = avar_sum(
            &[
                NoiseComponent::White { n: 1.0 },
                NoiseComponent::RandomWalk { k: 1.0 },
            ],
            3.0,
        );
        assert!(rel(sum, 1.0 / 3.0 + 1.0) < 1e-15);
    }
}
