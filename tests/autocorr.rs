//! Streaming autocorrelator: agreement with the batch definition, bad input, memory, and no drift
//! over 1e7 samples (METHOD.md §3, eq. 11).

use std::collections::VecDeque;

use imu_ident::autocorr::{acf_batch, AcfError, Autocorrelator, PushError, MAX_ABS_INPUT};
use imu_ident::Real;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// Unit-variance Gauss-Markov sequence with correlation time `tau` samples plus an offset:
/// exact discretisation `x_{k+1} = phi x_k + sqrt(1 - phi^2) w_k`, started in steady state.
struct GaussMarkov {
    rng: ChaCha8Rng,
    phi: f64,
    q_sd: f64,
    x: f64,
    offset: f64,
}

impl GaussMarkov {
    fn new(seed: u64, tau: f64, offset: f64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let phi = (-1.0 / tau).exp();
        let x = rng.sample::<f64, _>(StandardNormal);
        GaussMarkov {
            rng,
            phi,
            q_sd: (1.0 - phi * phi).sqrt(),
            x,
            offset,
        }
    }
    fn next(&mut self) -> f64 {
        let v = self.x + self.offset;
        let w: f64 = self.rng.sample(StandardNormal);
        self.x = self.phi * self.x + self.q_sd * w;
        v
    }
}

/// After every push, the streaming ACF equals the batch ACF of the samples in the window,
/// through the fill-up phase, many wrap-arounds and several shadow swaps (every N pushes).
#[test]
fn streaming_matches_batch_every_push() {
    const N: usize = 16;
    const L: usize = 5;
    let mut ac = Autocorrelator::<f64, N, L>::new();
    let mut gm = GaussMarkov::new(1, 4.0, 3.0);
    let mut window: VecDeque<f64> = VecDeque::new();
    for step in 0..200 {
        let x = gm.next();
        ac.push(x).unwrap();
        window.push_back(x);
        if window.len() > N {
            window.pop_front();
        }
        assert_eq!(ac.len(), window.len());
        assert_eq!(ac.is_full(), window.len() == N);
        let w: Vec<f64> = window.iter().copied().collect();
        let mut s = [0.0; L + 1];
        ac.acf(&mut s).unwrap();
        let nb = (L + 1).min(w.len());
        let mut b = vec![0.0; nb];
        acf_batch(&w, &mut b).unwrap();
        let r0 = b[0].max(1e-300);
        for k in 0..=L {
            let want = if k < nb { b[k] } else { 0.0 };
            // Both are exact to ~1e-15 R_0 in f64 (compensated sums, pivot-centred data).
            assert!(
                (s[k] - want).abs() <= 1e-12 * r0,
                "step {step} lag {k}: {} vs {}",
                s[k],
                want
            );
        }
        let m = w.iter().sum::<f64>() / w.len() as f64;
        assert!((ac.mean().unwrap() - m).abs() <= 1e-12 * (1.0 + m.abs()));
        assert_eq!(ac.r0(), Some(s[0]));
    }
}

#[test]
fn non_finite_and_out_of_range_are_rejected_without_side_effects() {
    let mut ac = Autocorrelator::<f32, 32, 4>::new();
    let mut gm = GaussMarkov::new(2, 3.0, -1.0);
    for _ in 0..45 {
        ac.push(gm.next() as f32).unwrap();
    }
    let mut before = [0.0f32; 5];
    ac.acf(&mut before).unwrap();
    let (len, mean) = (ac.len(), ac.mean());
    let big = (MAX_ABS_INPUT * 2.0) as f32;
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!(ac.push(bad), Err(PushError::NonFinite));
    }
    assert_eq!(ac.push(big), Err(PushError::OutOfRange));
    assert_eq!(ac.push(-big), Err(PushError::OutOfRange));
    let mut after = [0.0f32; 5];
    ac.acf(&mut after).unwrap();
    assert_eq!(before.map(f32::to_bits), after.map(f32::to_bits));
    assert_eq!((ac.len(), ac.mean()), (len, mean));
    // The batch helper refuses the same inputs.
    let mut out = [0.0f32; 2];
    assert_eq!(
        acf_batch(&[1.0, f32::NAN, 2.0], &mut out),
        Err(AcfError::NonFinite)
    );
    assert_eq!(acf_batch(&[1.0, big], &mut out), Err(AcfError::NonFinite));
}

#[test]
fn lengths_empty_reset_and_constant_input() {
    let mut ac = Autocorrelator::<f64, 8, 3>::new();
    let mut out = [0.0; 4];
    assert_eq!(ac.acf(&mut out), Err(AcfError::Empty));
    assert_eq!((ac.mean(), ac.r0()), (None, None));
    assert!(ac.is_empty());
    for _ in 0..20 {
        ac.push(7.25).unwrap();
    }
    ac.acf(&mut out).unwrap();
    assert_eq!(out, [0.0; 4]); // constant signal: zero, not NaN
    assert_eq!(ac.mean(), Some(7.25));
    assert_eq!(ac.acf(&mut [0.0; 5]), Err(AcfError::BadLength));
    assert_eq!(ac.acf(&mut []), Err(AcfError::BadLength));
    let mut two = [0.0; 2]; // fewer lags than L + 1 is fine
    ac.acf(&mut two).unwrap();
    ac.reset();
    assert!(ac.is_empty());
    assert_eq!(ac.acf(&mut out), Err(AcfError::Empty));
    // Two samples: lags >= 2 have no product and are zero; lag 1 = (1/2)(1-1.5)(2-1.5).
    ac.push(1.0).unwrap();
    ac.push(2.0).unwrap();
    ac.acf(&mut out).unwrap();
    assert_eq!(out, [0.25, -0.125, 0.0, 0.0]);
    assert_eq!((ac.capacity(), ac.max_lag()), (8, 3));
    assert_eq!(acf_batch::<f64>(&[], &mut out), Err(AcfError::Empty));
    assert_eq!(acf_batch(&[1.0, 2.0], &mut out), Err(AcfError::BadLength));
}

/// Memory per channel, as stated in the module docs:
/// `(N + 4 L + 10) size_of::<T>() + 3 size_of::<usize>()`, rounded up to the struct alignment.
#[test]
fn memory_per_channel_formula() {
    fn formula<T>(n: usize, l: usize) -> usize {
        let raw = (n + 4 * l + 10) * core::mem::size_of::<T>() + 3 * core::mem::size_of::<usize>();
        let align = core::mem::align_of::<T>().max(core::mem::align_of::<usize>());
        raw.div_ceil(align) * align
    }
    assert_eq!(
        size_of::<Autocorrelator<f32, 1024, 64>>(),
        formula::<f32>(1024, 64)
    );
    assert_eq!(
        size_of::<Autocorrelator<f64, 1024, 64>>(),
        formula::<f64>(1024, 64)
    );
    assert_eq!(
        size_of::<Autocorrelator<f32, 33, 7>>(),
        formula::<f32>(33, 7)
    );
    assert_eq!(size_of::<Autocorrelator<f64, 5, 0>>(), formula::<f64>(5, 0));
    // On the 32-bit firmware: 4 (N + 4L + 13) = 5172 bytes for N = 1024, L = 64.
    if size_of::<usize>() == 4 {
        assert_eq!(size_of::<Autocorrelator<f32, 1024, 64>>(), 5172);
    }
}

/// 1e7 samples of a Gauss-Markov process (tau = 50 samples, unit variance, offset 5) through a
/// N = 1024, L = 64 window; at three checkpoints the streaming R_k is compared with a batch f64
/// computation over the same window (the f32 run feeds both with the same f32 samples).
///
/// Error bound, relative to R_0. With u = EPS/2 and d = x - c (c the pivot, a sample of the last
/// 2N): d is rounded once (u |d|), each product once more (so 3u |d_i d_j| in all), the
/// compensated sums add u |S| plus a second-order term (2N terms since the last shadow swap,
/// 2N u^2 sum|t| is negligible), and the final combination with the mean costs a few u (|S_k| +
/// |dm| (|A| + |H| + |T|)) / n. Each of those is at most ~(R_0 + dm^2) per term by Cauchy-Schwarz,
/// where dm = m - c. Over the window |m - c| < ~5 sd for a Gaussian process (probability of
/// exceeding ~1e-6 per checkpoint), so (R_0 + dm^2) / R_0 <= 26 and ~10 u * 26 = 130 u < 100 EPS.
/// The reference itself is f64 (error ~1e-14 R_0). Without the compensation and the shadow
/// rebuild an f32 running sum would random-walk by ~u sqrt(1e7) * (a few R_0) ~ 1e-4 R_0, and the
/// offset-5 data without a pivot would add a cancellation factor 26 on top: the bound fails.
fn no_drift<T: Real>(seed: u64) -> Vec<f64> {
    const N: usize = 1024;
    const L: usize = 64;
    let checkpoints = [1_000_003usize, 5_000_011, 10_000_000];
    let mut ac = Autocorrelator::<T, N, L>::new();
    let mut gm = GaussMarkov::new(seed, 50.0, 5.0);
    let mut window: VecDeque<f64> = VecDeque::with_capacity(N + 1);
    let mut worst = Vec::new();
    for i in 1..=checkpoints[2] {
        let x = T::lit(gm.next());
        ac.push(x).unwrap();
        window.push_back(x.as_f64());
        if window.len() > N {
            window.pop_front();
        }
        if checkpoints.contains(&i) {
            let w: Vec<f64> = window.iter().copied().collect();
            let mut b = [0.0f64; L + 1];
            acf_batch(&w, &mut b).unwrap();
            let mut s = [T::zero(); L + 1];
            ac.acf(&mut s).unwrap();
            let err = s
                .iter()
                .zip(&b)
                .map(|(a, r)| (a.as_f64() - r).abs() / b[0])
                .fold(0.0, f64::max);
            assert!(
                err <= 100.0 * T::EPS,
                "after {i} samples: max |dR_k| / R_0 = {err:e} > 100 eps = {:e}",
                100.0 * T::EPS
            );
            let m: f64 = w.iter().sum::<f64>() / N as f64;
            assert!((ac.mean().unwrap().as_f64() - m).abs() <= 100.0 * T::EPS * (1.0 + m.abs()));
            worst.push(err);
        }
    }
    worst
}

#[test]
fn no_drift_over_1e7_samples_f32() {
    let worst = no_drift::<f32>(11);
    println!(
        "f32: max |dR_k|/R_0 at 1e6, 5e6, 1e7 samples: {worst:?} (eps = {:e})",
        f32::EPSILON
    );
}

#[test]
fn no_drift_over_1e7_samples_f64() {
    let worst = no_drift::<f64>(12);
    println!(
        "f64: max |dR_k|/R_0 at 1e6, 5e6, 1e7 samples: {worst:?} (eps = {:e})",
        f64::EPSILON
    );
}
