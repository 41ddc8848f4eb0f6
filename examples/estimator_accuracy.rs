//! Accuracy of the Markov-1 / exp-cosine estimators against the Cramér-Rao bound (issue 3), and
//! host timing of `Autocorrelator::push`. Reproduces the tables of `BENCHMARKS.md`:
//!
//! ```text
//! cargo run --release --example estimator_accuracy
//! ```
//!
//! Data: direct samples of a Gauss-Markov process, dt = 1 s, 12 h (N = 43200), tau = 100 s and
//! 1200 s, exact discretisation phi = exp(-dt/tau), q = sigma^2 (1 - phi^2), started in steady
//! state, plus a constant offset (so the mean removal is exercised). 100 fixed seeds per tau, the
//! same as `tests/estimators.rs`. The 12-h ACF is computed in batch (`acf_batch`), lags up to
//! `8 tau` (tau = 100 s) and `6 tau` (tau = 1200 s) so that the exp-cosine fit finds its zero
//! crossing; the streaming `Autocorrelator` is shown to give the same numbers on the first seed.

use std::hint::black_box;
use std::time::Instant;

use imu_ident::autocorr::{acf_batch, Autocorrelator};
use imu_ident::ident::{
    exp_cosine, lag1_corrected, lag1_raw, ls_slope, paper_eq15, AlphaEstimate, Clamp, IdentError,
    SampleAcf,
};
use imu_ident::Real;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

const N: usize = 43_200;
const DT: f64 = 1.0;
const SIGMA: f64 = 0.7;
const OFFSET: f64 = 3.0;
const SEEDS: u64 = 100;
const NAMES: [&str; 5] = [
    "lag1_corrected",
    "lag1_raw",
    "ls_slope",
    "paper_eq15",
    "exp_cosine",
];

/// Same generator and seeds as `tests/estimators.rs`.
fn gauss_markov(seed: u64, tau: f64, n: usize) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let phi = (-DT / tau).exp();
    let q_sd = SIGMA * (1.0 - phi * phi).sqrt();
    let mut x = SIGMA * rng.sample::<f64, _>(StandardNormal);
    (0..n)
        .map(|_| {
            let v = x + OFFSET;
            x = phi * x + q_sd * rng.sample::<f64, _>(StandardNormal);
            v
        })
        .collect()
}

fn seed_of(tau: f64, i: u64) -> u64 {
    (tau as u64) * 1_000_000 + i
}

/// Relative standard deviation of alpha at the Cramér-Rao bound: var(phi) = (1 - phi^2)/N,
/// delta method sd(alpha) = sd(phi) / (phi dt).
fn crb_rel(tau: f64) -> f64 {
    let alpha = 1.0 / tau;
    let phi = (-alpha * DT).exp();
    ((1.0 - phi * phi) / N as f64).sqrt() / (phi * DT) / alpha
}

/// One estimator on one seed: alpha, last lag, clamped; or the error.
type Outcome = Result<(f64, u16, bool), IdentError>;

fn alpha_outcome(r: Result<AlphaEstimate<f64>, IdentError>) -> Outcome {
    r.map(|e| (e.alpha, e.last_lag, e.clamp != Clamp::No))
}

fn run_seed(tau: f64, lags: usize, i: u64) -> ([Outcome; 5], f64) {
    let x = gauss_markov(seed_of(tau, i), tau, N);
    let mut r = vec![0.0; lags + 1];
    let fail = [Err(IdentError::NotEnoughLags); 5];
    if acf_batch(&x, &mut r).is_err() {
        return (fail, f64::NAN);
    }
    let Ok(acf) = SampleAcf::new(&r, DT, N as u32) else {
        return (fail, f64::NAN);
    };
    let ec = exp_cosine(&acf);
    let tau_beta = ec.map(|e| e.tau_beta).unwrap_or(f64::NAN);
    (
        [
            alpha_outcome(lag1_corrected(&acf)),
            alpha_outcome(lag1_raw(&acf)),
            alpha_outcome(ls_slope(&acf)),
            alpha_outcome(paper_eq15(&acf)),
            ec.map(|e| (e.alpha, e.last_lag, e.clamp != Clamp::No)),
        ],
        tau_beta,
    )
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

fn accuracy_table(tau: f64, lags: usize) {
    // Two worker threads (the machine has 2 cores), each taking every other seed.
    let mut results: Vec<([Outcome; 5], f64)> = Vec::new();
    std::thread::scope(|s| {
        let workers: Vec<_> = (0..2u64)
            .map(|w| {
                s.spawn(move || {
                    (0..SEEDS)
                        .filter(|i| i % 2 == w)
                        .map(|i| (i, run_seed(tau, lags, i)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        let mut all: Vec<_> = workers
            .into_iter()
            .flat_map(|h| h.join().unwrap())
            .collect();
        all.sort_by_key(|(i, _)| *i);
        results = all.into_iter().map(|(_, r)| r).collect();
    });
    let alpha = 1.0 / tau;
    let crb = crb_rel(tau);
    println!(
        "\ntau = {tau} s (alpha = {alpha:.3e} 1/s), N = {N}, T/tau = {:.0}, {SEEDS} seeds, ACF lags 0..={lags}",
        N as f64 * DT / tau
    );
    println!("CRB: relative sd(alpha) = {:.2} %", 100.0 * crb);
    println!(
        "| estimator | ok | clamped | mean rel err | median rel err | median abs rel err | RMS rel err | RMS / CRB | last lag: median [min, max] |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (e, name) in NAMES.iter().enumerate() {
        let mut rel = Vec::new();
        let mut last = Vec::new();
        let mut clamped = 0;
        let mut errors: Vec<IdentError> = Vec::new();
        for (o, _) in &results {
            match o[e] {
                Ok((a, l, c)) => {
                    rel.push((a - alpha) / alpha);
                    last.push(f64::from(l));
                    clamped += usize::from(c);
                }
                Err(err) => errors.push(err),
            }
        }
        let ok = rel.len();
        let mean = rel.iter().sum::<f64>() / ok.max(1) as f64;
        let rms = (rel.iter().map(|r| r * r).sum::<f64>() / ok.max(1) as f64).sqrt();
        let mut abs: Vec<f64> = rel.iter().map(|r| r.abs()).collect();
        let med_abs = median(&mut abs);
        let med = median(&mut rel);
        let (lo, hi) = last
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &l| (a.min(l), b.max(l)));
        let med_last = median(&mut last);
        let err_note = if errors.is_empty() {
            String::new()
        } else {
            format!(" ({} x {:?})", errors.len(), errors[0])
        };
        println!(
            "| {name} | {ok}/{SEEDS}{err_note} | {clamped} | {:+.2} % | {:+.2} % | {:.2} % | {:.2} % | {:.2} | {med_last:.0} [{lo:.0}, {hi:.0}] |",
            100.0 * mean,
            100.0 * med,
            100.0 * med_abs,
            100.0 * rms,
            rms / crb
        );
    }
    let mut tb: Vec<f64> = results
        .iter()
        .map(|r| r.1)
        .filter(|t| t.is_finite())
        .collect();
    println!(
        "exp_cosine on Markov-1 data (true beta = 0): median zero crossing tau_beta = {:.0} s = {:.2} tau",
        median(&mut tb),
        median(&mut tb.clone()) / tau
    );
}

/// The two lag-1 estimators need only `R_0, R_1`, so they are cheap to run on many more seeds:
/// this shows how far the 100-seed RMS is from its limit (sampling error ~ 1/sqrt(2M)).
fn lag1_many_seeds(tau: f64, seeds: u64) {
    let alpha = 1.0 / tau;
    let crb = crb_rel(tau);
    let rel: Vec<[f64; 2]> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..2u64)
            .map(|w| {
                s.spawn(move || {
                    (0..seeds)
                        .filter(|i| i % 2 == w)
                        .map(|i| {
                            let x = gauss_markov(seed_of(tau, i), tau, N);
                            let mut r = [0.0; 2];
                            acf_batch(&x, &mut r).unwrap();
                            let acf = SampleAcf::new(&r, DT, N as u32).unwrap();
                            let c = lag1_corrected(&acf).unwrap().alpha;
                            let w = lag1_raw(&acf).unwrap().alpha;
                            [(c - alpha) / alpha, (w - alpha) / alpha]
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|h| h.join().unwrap())
            .collect()
    });
    for (e, name) in ["lag1_corrected", "lag1_raw"].iter().enumerate() {
        let mut v: Vec<f64> = rel.iter().map(|r| r[e]).collect();
        let m = v.len() as f64;
        let mean = v.iter().sum::<f64>() / m;
        let rms = (v.iter().map(|r| r * r).sum::<f64>() / m).sqrt();
        let sd = (v.iter().map(|r| (r - mean) * (r - mean)).sum::<f64>() / (m - 1.0)).sqrt();
        println!(
            "| {tau} | {name} | {seeds} | {:+.2} % | {:+.2} % | {:.2} % | {:.2} % | {:.3} | {:.3} |",
            100.0 * mean,
            100.0 * median(&mut v),
            100.0 * sd,
            100.0 * rms,
            sd / crb,
            rms / crb
        );
    }
}

/// The streaming autocorrelator over the whole 12-h window gives the batch numbers.
fn streaming_check(tau: f64) {
    const L: usize = 64;
    let x = gauss_markov(seed_of(tau, 0), tau, N);
    let mut batch = [0.0f64; L + 1];
    acf_batch(&x, &mut batch).unwrap();
    let mut s64 = Box::new(Autocorrelator::<f64, N, L>::new());
    let mut s32 = Box::new(Autocorrelator::<f32, N, L>::new());
    for &v in &x {
        s64.push(v).unwrap();
        s32.push(v as f32).unwrap();
    }
    let mut r64 = [0.0f64; L + 1];
    let mut r32 = [0.0f32; L + 1];
    s64.acf(&mut r64).unwrap();
    s32.acf(&mut r32).unwrap();
    let d64 = r64
        .iter()
        .zip(&batch)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
        / batch[0];
    let d32 = r32
        .iter()
        .zip(&batch)
        .map(|(a, b)| (f64::from(*a) - b).abs())
        .fold(0.0, f64::max)
        / batch[0];
    let a_batch = lag1_corrected(&SampleAcf::new(&batch, DT, N as u32).unwrap())
        .unwrap()
        .alpha;
    let a64 = lag1_corrected(&SampleAcf::new(&r64, DT, N as u32).unwrap())
        .unwrap()
        .alpha;
    let a32 = lag1_corrected(&SampleAcf::new(&r32, 1.0f32, N as u32).unwrap())
        .unwrap()
        .alpha;
    println!(
        "tau = {tau} s, seed 0, Autocorrelator<_, {N}, {L}> vs acf_batch (f64): max |dR_k|/R_0 = {d64:.1e} (f64), {d32:.1e} (f32, f32 input); \
         lag1_corrected alpha: batch {a_batch:.6e}, streaming f64 {a64:.6e}, f32 {:.6e}",
        f64::from(a32)
    );
}

/// Median over 7 repeats of the host time per push, `Autocorrelator<T, 1024, 64>`, full window.
fn time_push<T: Real>() -> (f64, f64) {
    let x: Vec<T> = gauss_markov(7, 50.0, 4096)
        .into_iter()
        .map(T::lit)
        .collect();
    let mut ac = Box::new(Autocorrelator::<T, 1024, 64>::new());
    for &v in &x {
        ac.push(v).unwrap();
    }
    const PUSHES: usize = 1 << 20;
    let mut per_push = Vec::new();
    let mut per_acf = Vec::new();
    let mut out = [T::zero(); 65];
    for _ in 0..7 {
        let t = Instant::now();
        for i in 0..PUSHES {
            let _ = black_box(&mut *ac).push(black_box(x[i & 4095]));
        }
        per_push.push(t.elapsed().as_nanos() as f64 / PUSHES as f64);
        let t = Instant::now();
        for _ in 0..10_000 {
            let _ = black_box(&*ac).acf(black_box(&mut out));
        }
        per_acf.push(t.elapsed().as_nanos() as f64 / 10_000.0);
    }
    black_box(out);
    (median(&mut per_push), median(&mut per_acf))
}

fn main() {
    println!(
        "host: arch {}, {} threads available",
        std::env::consts::ARCH,
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    // Optional argument: `accuracy`, `lag1` or `timing` runs only that part (default: all).
    let part = std::env::args().nth(1).unwrap_or_default();
    let run = |p: &str| part.is_empty() || part == p;
    if run("accuracy") {
        println!("\n## Streaming vs batch (12-h window)");
        for tau in [100.0, 1200.0] {
            streaming_check(tau);
        }
        println!("\n## Accuracy of alpha against the CRB");
        accuracy_table(100.0, 800);
        accuracy_table(1200.0, 7200);
    }
    if run("lag1") {
        println!("\n## Lag-1 estimators on 2000 seeds (seeds 0..100 are the ones above)");
        println!(
            "| tau (s) | estimator | seeds | mean rel err | median rel err | sd rel err | RMS rel err | sd / CRB | RMS / CRB |"
        );
        println!("|---|---|---|---|---|---|---|---|---|");
        lag1_many_seeds(100.0, 2000);
        lag1_many_seeds(1200.0, 2000);
    }
    if !run("timing") {
        return;
    }
    println!(
        "\n## Host time, Autocorrelator<T, 1024, 64>, full window (median of 7 x 2^20 pushes)"
    );
    let (p32, a32) = time_push::<f32>();
    let (p64, a64) = time_push::<f64>();
    println!("| T | ns / push | ns / acf() (65 lags) |");
    println!("|---|---|---|");
    println!("| f32 | {p32:.1} | {a32:.1} |");
    println!("| f64 | {p64:.1} | {a64:.1} |");
}
