//! Estimators on the sample ACF (METHOD.md §3-4): exact recovery on analytic ACFs, bad input,
//! the lag-1 bias constant by Monte Carlo, and accuracy against the Cramér-Rao bound (issue 3).

use imu_ident::autocorr::acf_batch;
use imu_ident::ident::{
    exp_cosine, lag1_corrected, lag1_raw, ls_slope, paper_eq15, sigma2, Clamp, IdentError, LagStop,
    SampleAcf, Sigma2Estimate, COS_MIN, LAG1_BIAS_SLOPE,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// `R_j = s2 exp(-alpha j dt)`, exact.
fn exp_acf(s2: f64, alpha: f64, dt: f64, lags: usize) -> Vec<f64> {
    (0..=lags)
        .map(|j| s2 * (-alpha * j as f64 * dt).exp())
        .collect()
}

/// `R_j = s2 exp(-alpha j dt) cos(beta j dt)`, exact.
fn exp_cos_acf(s2: f64, alpha: f64, beta: f64, dt: f64, lags: usize) -> Vec<f64> {
    (0..=lags)
        .map(|j| {
            let t = j as f64 * dt;
            s2 * (-alpha * t).exp() * (beta * t).cos()
        })
        .collect()
}

#[test]
fn markov_slopes_recover_alpha_on_an_exact_exponential() {
    let (alpha, dt, n) = (0.05, 0.5, 1_000_000u32);
    let r = exp_acf(2.5, alpha, dt, 400);
    let acf = SampleAcf::new(&r, dt, n).unwrap();
    // The floor rule, recomputed here: 2 sqrt((1 + phi^2) / ((1 - phi^2) N)), phi = r_1.
    let phi = (-alpha * dt).exp();
    let floor = 2.0 * ((1.0 + phi * phi) / ((1.0 - phi * phi) * n as f64)).sqrt();
    assert!(rel(acf.noise_floor(), floor) < 1e-12);
    let last = (1..=400u16)
        .take_while(|&j| r[j as usize] / r[0] > floor)
        .last()
        .unwrap();
    for est in [ls_slope(&acf).unwrap(), paper_eq15(&acf).unwrap()] {
        assert!(rel(est.alpha, alpha) < 1e-9, "{est:?}");
        assert_eq!((est.first_lag, est.last_lag), (1, last));
        assert_eq!((est.stop, est.clamp), (LagStop::NoiseFloor, Clamp::No));
    }
    // All lags above the floor: the fit runs to the end of the ACF.
    let short = &r[..=20];
    let est = ls_slope(&SampleAcf::new(short, dt, n).unwrap()).unwrap();
    assert_eq!((est.last_lag, est.stop), (20, LagStop::EndOfAcf));
    assert!(rel(est.alpha, alpha) < 1e-9);
    // Lag 1, raw: exact.
    let est = lag1_raw(&acf).unwrap();
    assert!(rel(est.alpha, alpha) < 1e-9);
    assert_eq!((est.last_lag, est.stop), (1, LagStop::SingleLag));
}

#[test]
fn lag1_correction_inverts_the_bias_map() {
    // Feed the expected r_1 of a window of N samples, E[r_1] = phi - (1 + 4 phi)/N: the corrected
    // estimator must return the true alpha.
    let (alpha, dt) = (1.0f64 / 1200.0, 1.0);
    for n in [43_200u32, 2_000] {
        let phi = (-alpha * dt).exp();
        let n_f = n as f64;
        let r1 = phi - (1.0 + LAG1_BIAS_SLOPE * phi) / n_f;
        let r = [3.0, 3.0 * r1];
        let acf = SampleAcf::new(&r, dt, n).unwrap();
        let est = lag1_corrected(&acf).unwrap();
        assert!(rel(est.alpha, alpha) < 1e-9, "N = {n}: {est:?}");
        assert_eq!(est.clamp, Clamp::No);
    }
}

#[test]
fn exp_cosine_recovers_alpha_and_beta() {
    // Zero crossing on the lag grid: tau_beta = 20 dt exactly, so linear interpolation is exact.
    let (alpha, dt) = (0.02, 0.1);
    let beta = std::f64::consts::FRAC_PI_2 / (20.0 * dt);
    let r = exp_cos_acf(1.7, alpha, beta, dt, 60);
    let acf = SampleAcf::new(&r, dt, 100_000).unwrap();
    let est = exp_cosine(&acf).unwrap();
    assert!(rel(est.beta, beta) < 1e-6, "{est:?}");
    assert!(rel(est.tau_beta, 20.0 * dt) < 1e-6);
    assert!(rel(est.alpha, alpha) < 1e-6, "{est:?}");
    // cos(pi/2 j/20) >= 0.25 for j <= 16, < 0.25 at j = 17.
    assert_eq!(
        (est.first_lag, est.last_lag, est.stop),
        (1, 16, LagStop::CosineLimit)
    );

    // Crossing between lags: linear interpolation errs by about |f''/(8 f')| dt^2 = alpha dt^2/4
    // at the root (f = exp(-alpha t) cos(beta t): f' = -beta e, f'' = 2 alpha beta e there); the
    // bound below allows twice that. The alpha fit then moves by at most
    // max_j tan(beta tau_j) |d beta| <= tan(acos(COS_MIN)) |d beta| to first order, since
    // d ln cos(beta tau) = -tau tan(beta tau) d beta and the fit is a weighted mean over tau_j.
    let (alpha, dt) = (0.3, 1.0);
    let tau_beta = 20.5 * dt;
    let beta = std::f64::consts::FRAC_PI_2 / tau_beta;
    let r = exp_cos_acf(1.0, alpha, beta, dt, 60);
    let est = exp_cosine(&SampleAcf::new(&r, dt, 100_000).unwrap()).unwrap();
    let d_tau = (est.tau_beta - tau_beta).abs();
    assert!(
        d_tau <= alpha * dt * dt / 2.0,
        "tau_beta {} vs {tau_beta}",
        est.tau_beta
    );
    let d_beta = (est.beta - beta).abs();
    let tan_max = (1.0 - COS_MIN * COS_MIN).sqrt() / COS_MIN;
    assert!(
        (est.alpha - alpha).abs() <= 1.1 * tan_max * d_beta,
        "{est:?}"
    );

    // A pure exponential never crosses zero.
    let r = exp_acf(1.0, 0.1, 1.0, 30);
    let acf = SampleAcf::new(&r, 1.0, 1000).unwrap();
    assert_eq!(exp_cosine(&acf), Err(IdentError::NoZeroCrossing));
}

#[test]
fn bad_input_is_an_error_never_a_panic_or_nan() {
    let ok = [1.0, 0.5, 0.25];
    assert_eq!(
        SampleAcf::new(&ok[..1], 1.0, 100).err(),
        Some(IdentError::NotEnoughLags)
    );
    assert_eq!(
        SampleAcf::<f64>::new(&[], 1.0, 100).err(),
        Some(IdentError::NotEnoughLags)
    );
    for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert_eq!(
            SampleAcf::new(&ok, dt, 100).err(),
            Some(IdentError::InvalidDt)
        );
    }
    assert_eq!(
        SampleAcf::new(&ok, 1.0, 7).err(),
        Some(IdentError::InvalidWindow)
    );
    assert_eq!(
        SampleAcf::new(&[1.0; 20], 1.0, 19).err(),
        Some(IdentError::InvalidWindow)
    );
    assert_eq!(
        SampleAcf::new(&[1.0, f64::NAN], 1.0, 100).err(),
        Some(IdentError::NonFinite)
    );
    assert_eq!(
        SampleAcf::new(&[0.0, 0.0], 1.0, 100).err(),
        Some(IdentError::NonPositiveVariance)
    );
    assert_eq!(
        SampleAcf::new(&[-1.0, 0.5], 1.0, 100).err(),
        Some(IdentError::NonPositiveVariance)
    );

    // White noise: r_1 inside the 2/sqrt(N) band -> no usable lag for the slopes, alpha_max for
    // lag 1 (flagged).
    let white = [1.0, 0.01, -0.02, 0.005];
    let acf = SampleAcf::new(&white, 1.0, 1000).unwrap();
    assert_eq!(ls_slope(&acf), Err(IdentError::NoUsableLag));
    assert_eq!(paper_eq15(&acf), Err(IdentError::NoUsableLag));
    let est = lag1_corrected(&acf).unwrap();
    assert_eq!(est.clamp, Clamp::ToMax);
    assert_eq!(est.alpha, acf.alpha_range().1);
    // r_1 = 1 (or above): alpha_min = 1/(N dt).
    let flat = [1.0, 1.0, 1.0];
    let acf = SampleAcf::new(&flat, 2.0, 100).unwrap();
    for est in [lag1_raw(&acf), lag1_corrected(&acf), ls_slope(&acf)] {
        let est = est.unwrap();
        assert_eq!((est.alpha, est.clamp), (1.0 / 200.0, Clamp::ToMin));
    }
    // Crossing at lag 1: nothing left for the exp-cosine alpha fit.
    let acf = SampleAcf::new(&[1.0, -0.3, 0.2], 1.0, 100).unwrap();
    assert_eq!(exp_cosine(&acf), Err(IdentError::NoUsableLag));

    // Random garbage (signs, magnitudes from 1e-30 to 1e30, f32 and f64): every estimator returns
    // a finite estimate or an error.
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    for _ in 0..20_000 {
        let len = rng.gen_range(2..12);
        let r: Vec<f64> = (0..len)
            .map(|_| rng.gen_range(-1.0..1.0) * 10f64.powi(rng.gen_range(-30..30)))
            .collect();
        let dt = 10f64.powi(rng.gen_range(-6..4));
        let n = rng.gen_range(8..100_000u32).max(len as u32);
        if let Ok(acf) = SampleAcf::new(&r, dt, n) {
            for a in [
                ls_slope(&acf),
                paper_eq15(&acf),
                lag1_raw(&acf),
                lag1_corrected(&acf),
            ]
            .into_iter()
            .flatten()
            {
                assert!(a.alpha.is_finite() && a.alpha > 0.0, "{r:?} {a:?}");
            }
            if let Ok(e) = exp_cosine(&acf) {
                assert!(e.alpha.is_finite() && e.beta.is_finite() && e.tau_beta.is_finite());
            }
        }
        let r32: Vec<f32> = r.iter().map(|&v| v as f32).collect();
        if let Ok(acf) = SampleAcf::new(&r32, dt as f32, n) {
            for a in [
                ls_slope(&acf),
                paper_eq15(&acf),
                lag1_raw(&acf),
                lag1_corrected(&acf),
            ]
            .into_iter()
            .flatten()
            {
                assert!(a.alpha.is_finite() && a.alpha > 0.0, "{r32:?} {a:?}");
            }
            if let Ok(e) = exp_cosine(&acf) {
                assert!(e.alpha.is_finite() && e.beta.is_finite());
            }
        }
    }
}

#[test]
fn sigma2_adds_the_filter_variance() {
    assert_eq!(
        sigma2(2.0, 0.5),
        Ok(Sigma2Estimate {
            r0: 2.0,
            corrected: 2.5
        })
    );
    assert_eq!(
        sigma2(2.0f32, 0.0),
        Ok(Sigma2Estimate {
            r0: 2.0,
            corrected: 2.0
        })
    );
    assert_eq!(sigma2(0.0, 0.5), Err(IdentError::NonPositiveVariance));
    assert_eq!(sigma2(f64::NAN, 0.5), Err(IdentError::NonFinite));
    assert_eq!(sigma2(1.0, -0.1), Err(IdentError::InvalidCovariance));
    assert_eq!(
        sigma2(1.0, f64::INFINITY),
        Err(IdentError::InvalidCovariance)
    );
    assert_eq!(sigma2(f64::MAX, f64::MAX), Err(IdentError::NonFinite));
}

/// Gauss-Markov samples, exact discretisation, steady-state start, constant offset. The same
/// generator and seeds as `examples/estimator_accuracy.rs`.
fn gauss_markov(seed: u64, phi: f64, sigma: f64, offset: f64, x: &mut [f64]) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let q_sd = sigma * (1.0 - phi * phi).sqrt();
    let mut v = sigma * rng.sample::<f64, _>(StandardNormal);
    for xi in x.iter_mut() {
        *xi = v + offset;
        v = phi * v + q_sd * rng.sample::<f64, _>(StandardNormal);
    }
}

/// Monte Carlo check of `LAG1_BIAS_SLOPE`: N = 200, phi = 0.5, 20000 windows. The mean of
/// N (r_1 - phi) should be -(1 + 4 phi) = -3.0 (Yule-Walker) and not -(1 + 3 phi) = -2.5
/// (least squares). Its standard error is N sqrt((1 - phi^2)/N / M) = 0.087, so the test asserts
/// |mean + 3| < 0.35 (4 standard errors; the O(1/N^2) term is ~ 0.05 here), which excludes 2.5
/// by 6 standard errors; and that the corrected phi is unbiased to within the same 4 standard
/// errors while the raw one is not.
#[test]
fn lag1_bias_slope_by_monte_carlo() {
    const N: usize = 200;
    const M: usize = 20_000;
    let phi = 0.5f64;
    let mut x = vec![0.0; N];
    let (mut raw, mut corr) = (0.0, 0.0);
    for seed in 0..M as u64 {
        gauss_markov(500_000 + seed, phi, 1.0, 0.0, &mut x);
        let mut r = [0.0; 2];
        acf_batch(&x, &mut r).unwrap();
        let acf = SampleAcf::new(&r, 1.0, N as u32).unwrap();
        raw += r[1] / r[0];
        corr += (-lag1_corrected(&acf).unwrap().alpha).exp();
    }
    let scaled_raw_bias = N as f64 * (raw / M as f64 - phi);
    let scaled_corr_bias = N as f64 * (corr / M as f64 - phi);
    let se = N as f64 * ((1.0 - phi * phi) / N as f64 / M as f64).sqrt();
    println!("N E[r1 - phi] = {scaled_raw_bias:.3}, corrected {scaled_corr_bias:.3}, se {se:.3}");
    assert!((scaled_raw_bias + (1.0 + LAG1_BIAS_SLOPE * phi)).abs() < 4.0 * se);
    assert!(scaled_corr_bias.abs() < 4.0 * se);
}

/// Issue 3 bar: on 12 h of 1-Hz samples of a Gauss-Markov process (tau = 100 s and 1200 s), the
/// RMS relative error of the best estimator (lag-1, bias-corrected) is at most 1.3 x the
/// Cramér-Rao bound sd(alpha)/alpha = sqrt((1 - phi^2)/N) / (phi dt alpha).
///
/// Why 1.3 leaves room: with M seeds the RMS itself has a relative sampling error of about
/// 1/sqrt(2M). The asymptotic bound is reached at tau = 100 s (T/tau = 432: ratio 1.02 on 2000
/// seeds) but not quite at tau = 1200 s (T/tau = 36: ratio 1.145 on 2000 seeds, a finite-sample
/// effect of the O(1/N^2) terms; the bias left after the correction is only ~1 %). With M = 100
/// the sampling error (~8 %) would put 1.3 only ~2 sd above 1.145, so this test uses M = 1000
/// (~2.2 %, i.e. ~6 sd of room) and costs about a second. It can fail: the same estimator
/// without the bias correction fails (1.32 at tau = 1200 s), and so would the multi-lag slope fits
/// (1.7-2.4, see BENCHMARKS.md).
#[test]
fn lag1_corrected_within_1_3_crb() {
    const N: usize = 43_200;
    const SEEDS: u64 = 1000;
    let dt = 1.0;
    let mut x = vec![0.0; N];
    for tau in [100.0f64, 1200.0] {
        let alpha = 1.0 / tau;
        let phi = (-alpha * dt).exp();
        let crb = ((1.0 - phi * phi) / N as f64).sqrt() / (phi * dt) / alpha;
        let mut sq = 0.0;
        for i in 0..SEEDS {
            // seeds, sigma and offset as in examples/estimator_accuracy.rs
            gauss_markov((tau as u64) * 1_000_000 + i, phi, 0.7, 3.0, &mut x);
            let mut r = [0.0; 2];
            acf_batch(&x, &mut r).unwrap();
            let est = lag1_corrected(&SampleAcf::new(&r, dt, N as u32).unwrap()).unwrap();
            sq += ((est.alpha - alpha) / alpha).powi(2);
        }
        let rms = (sq / SEEDS as f64).sqrt();
        println!(
            "tau {tau}: RMS rel err {rms:.4}, CRB {crb:.4}, ratio {:.3}",
            rms / crb
        );
        assert!(rms <= 1.3 * crb, "tau {tau}: RMS {rms} > 1.3 x CRB {crb}");
    }
}
