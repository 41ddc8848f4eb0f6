//! Issue 3 bars for the online identification (`imu_ident::adapt`) on the `paper` scenario,
//! 12 h logs, 3 fixed seeds per start (the 20-seed medians are in
//! `examples/adaptive_bench.rs` and BENCHMARKS.md). Run in release for speed:
//! `cargo test --release -p hal-sim --test host adaptive::` (about 20 s on one core).

use hal_sim::adaptive::{self, gm_params, tilt_window, AdaptiveRun};
use hal_sim::log::LogRow;
use hal_sim::{mismatch, records, replay, scenario, sim};
use imu_ident::adapt::AdaptConfig;
use imu_ident::model::{ErrorSource, InsModel};

const STEPS: usize = 12 * 3600;
/// Hours 8-12 of the run, the window of the bars.
const T0: f64 = 8.0 * 3600.0;
const T1: f64 = 12.0 * 3600.0 + 1.0;
/// The same seeds as the first three of the bench (bench seeds are 1000 + i).
const SEEDS: [u64; 3] = [1000, 1001, 1002];
/// The bar's starts: drift and diffusion scaled by (accel, gyro) factors; (1, 1) is the truth.
const STARTS: [(f64, f64); 5] = [
    (1.0, 1.0),
    (0.1, 0.1),
    (10.0, 10.0),
    (0.1, 10.0),
    (10.0, 0.1),
];

fn truth() -> InsModel<f64> {
    scenario::load("paper").unwrap().to_core().unwrap()
}

fn median3(mut v: [f64; 3]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[1]
}

/// (tilt RMS / oracle RMS, fraction outside 3 sigma) over hours 8-12, and the run.
fn run(log: &[LogRow], start: &InsModel<f64>) -> (f64, f64, AdaptiveRun) {
    let (oracle, _) = replay::estimates::<f64>(&truth(), log).unwrap();
    let (orms, _) = tilt_window(log, &oracle, T0, T1).unwrap();
    let r = adaptive::run::<f64>(start, log, AdaptConfig::default()).unwrap();
    let (rms, out) = tilt_window(log, &r.estimates, T0, T1).unwrap();
    (rms / orms, out, r)
}

/// The bar: from each start, the median over the seeds of the tilt RMS over hours 8-12 is at most
/// 1.10x the oracle's (fixed true model on the same log), and the median fraction of steps outside
/// 3 sigma at most 2 %. The bar is stated on medians over >= 20 seeds; with 3 seeds the median
/// is noisier, but the 20-seed table has every start's median at <= 1.02 and its worst single
/// seed at 1.18 (BENCHMARKS.md), so a median of 3 above 1.10 would be a real regression.
/// Started at the truth, the same bound checks that it does not drift away.
#[test]
fn wrong_starts_reach_the_oracle() {
    let t = truth();
    let logs: Vec<Vec<LogRow>> = SEEDS
        .iter()
        .map(|&s| sim::simulate(&t, STEPS, s).unwrap())
        .collect();
    for (ka, kg) in STARTS {
        let start = mismatch::scaled(&t, ka, kg);
        let mut ratio = [0.0; 3];
        let mut out = [0.0; 3];
        for (i, log) in logs.iter().enumerate() {
            let (r, o, run) = run(log, &start);
            println!(
                "start ({ka}, {kg}) seed {}: ratio {r:.3}, outside {:.2} %, jumps {}, updates {}",
                SEEDS[i],
                o * 100.0,
                run.jumps,
                run.updates
            );
            ratio[i] = r;
            out[i] = o;
        }
        let (mr, mo) = (median3(ratio), median3(out));
        assert!(mr <= 1.10, "start ({ka}, {kg}): median tilt ratio {mr}");
        assert!(
            mo <= 0.02,
            "start ({ka}, {kg}): median outside 3 sigma {mo}"
        );
    }
}

/// Identified parameters at 12 h from the farthest start (10x drift and diffusion on both
/// sensors). Bound: |ln(estimate / truth)| <= 3 sqrt(3) CRB_12h, where CRB_12h is the Cramér-Rao
/// standard deviation of ln(parameter) from 12 h of z (bench, mean information of 20 seeds: 0.058 sigma_a, 0.152 tau_a,
/// 0.124 sigma_g, 0.377 tau_g); sqrt(3) because the exponential window (4 h) uses a third of the
/// data, and 3 for a three-sigma bound on a median of three. Gyro tau is the weakest (the
/// likelihood is flat along it: 3 sqrt(3) 0.36 = 1.9, a factor 6.5).
#[test]
fn identified_parameters_near_truth() {
    let t = truth();
    let start = mismatch::scaled(&t, 10.0, 10.0);
    let crb = [0.058, 0.152, 0.124, 0.377];
    let truth_v = [
        gm_params(&t, ErrorSource::Accel).unwrap(),
        gm_params(&t, ErrorSource::Gyro).unwrap(),
    ];
    let mut err = [[0.0; 3]; 4];
    for (i, &seed) in SEEDS.iter().enumerate() {
        let log = sim::simulate(&t, STEPS, seed).unwrap();
        let r = adaptive::run::<f64>(&start, &log, AdaptConfig::default()).unwrap();
        for (s, sensor) in [ErrorSource::Accel, ErrorSource::Gyro]
            .into_iter()
            .enumerate()
        {
            let (tau, sigma) = gm_params(&r.final_model, sensor).unwrap();
            err[2 * s][i] = (sigma / truth_v[s].1).ln();
            err[2 * s + 1][i] = (tau / truth_v[s].0).ln();
        }
    }
    for (k, e) in err.iter().enumerate() {
        let m = median3(*e);
        let bound = 3.0 * 3f64.sqrt() * crb[k];
        println!("param {k}: ln errors {e:.3?}, median {m:.3}, bound {bound:.3}");
        assert!(m.abs() <= bound, "param {k}: median ln error {m} > {bound}");
    }
}

/// The Cramér-Rao bound from the bank's Fisher information: at the true model with adaptation
/// off, `sqrt(diag(I^-1))` over 12 h must be finite and in the range the bench reports for 20
/// seeds (0.058, 0.152, 0.124, 0.377 for ln sigma_a, ln tau_a, ln sigma_g, ln tau_g), within a
/// factor 1.5 (the observed Fisher information of one log varies by about 1/sqrt(steps / tau)).
#[test]
fn crb_from_fisher_information() {
    let t = truth();
    let log = sim::simulate(&t, STEPS, SEEDS[0]).unwrap();
    let cfg = AdaptConfig {
        adapt: false,
        ..AdaptConfig::default()
    };
    let r = adaptive::run::<f64>(&t, &log, cfg).unwrap();
    let crb = r.crb.unwrap();
    println!("CRB sqrt(diag(I^-1)) = {crb:.3?}");
    for (c, e) in crb.iter().zip([0.058, 0.152, 0.124, 0.377]) {
        assert!(*c > e / 1.5 && *c < e * 1.5, "{c} vs {e}");
    }
    assert_eq!(r.updates, 0);
}

/// Single precision (the Cortex-M4F) against double precision on 12-h runs from the (10, 10)
/// start, seed 1001.
/// 1. Numerics, parameters frozen (`adapt: false`, same bank and probes): the tilt estimates
///    agree within 0.01 of their standard deviation at every step (measured 0.0013).
/// 2. The adaptive loop: the same jumps, `ln` parameters within 0.05 (a small fraction of their
///    Cramér-Rao bounds 0.06-0.38), tilt RMS over hours 8-12 within 2 %. Not step by step: the
///    hysteresis turns rounding differences into slightly different move times, after which the
///    two filters differ transiently (measured up to 0.23 sigma; ln tau_g 0.029 apart at 12 h).
#[test]
fn f32_tracks_f64() {
    let t = truth();
    let log = sim::simulate(&t, STEPS, SEEDS[1]).unwrap();
    let start = mismatch::scaled(&t, 10.0, 10.0);
    let frozen = AdaptConfig {
        adapt: false,
        ..AdaptConfig::default()
    };
    let f64_run = adaptive::run::<f64>(&start, &log, frozen).unwrap();
    let f32_run = adaptive::run::<f32>(&start, &log, frozen).unwrap();
    let worst = f64_run
        .estimates
        .iter()
        .zip(&f32_run.estimates)
        .map(|(a, b)| ((a.delta_hat - b.delta_hat) / a.sigma_delta).abs())
        .fold(0.0, f64::max);
    println!("frozen: max |delta_64 - delta_32| / sigma_delta = {worst:.4}");
    assert!(worst < 0.01);

    let r64 = adaptive::run::<f64>(&start, &log, AdaptConfig::default()).unwrap();
    let r32 = adaptive::run::<f32>(&start, &log, AdaptConfig::default()).unwrap();
    assert_eq!(r64.jumps, r32.jumps);
    for (a, b) in r64.theta.iter().zip(r32.theta.iter()) {
        assert!((a - b).abs() < 0.05, "theta {a} vs {b}");
    }
    let (rms64, _) = tilt_window(&log, &r64.estimates, T0, T1).unwrap();
    let (rms32, _) = tilt_window(&log, &r32.estimates, T0, T1).unwrap();
    println!("adaptive: tilt RMS h8-12 f64 {rms64:.4e}, f32 {rms32:.4e}");
    assert!((rms32 / rms64 - 1.0).abs() < 0.02);
}

/// Missing observations (NaN) and a time gap: prediction only, no failure, and the identified
/// model stays usable (every parameter finite, the tilt consistent: at most 2 % outside 3 sigma
/// over hours 8-12).
#[test]
fn missing_observations_and_gaps() {
    let t = truth();
    let mut log = sim::simulate(&t, STEPS, SEEDS[2]).unwrap();
    for (i, r) in log.iter_mut().enumerate() {
        if i % 7 == 3 {
            r.z = f64::NAN;
        }
    }
    log.drain(20_000..20_300); // a 5-minute gap
    let start = mismatch::scaled(&t, 0.1, 10.0);
    let r = adaptive::run::<f64>(&start, &log, AdaptConfig::default()).unwrap();
    assert!(r.counts.missing > 6000 && r.counts.gaps == 1);
    assert!(r.theta.iter().all(|v| v.is_finite()));
    let (_, out) = tilt_window(&log, &r.estimates, T0, T1).unwrap();
    assert!(out <= 0.02, "outside 3 sigma {out}");
    assert!(!r.params.is_empty());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("params.csv");
    records::write_params_csv(&path, &r.params).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.starts_with("t,sensor,component,kind,tau,sigma,beta"));
}

/// The Cramér-Rao deviations the step reports with each re-identification (`params.csv`'s
/// `sd_ln_*`, the sandwich variance of the windowed estimate) describe the actual spread of the
/// identified parameters. On `CR_SEEDS` fresh logs, from the issue-3 starts (0.1x, 10x), the
/// last record's normalised errors `z = ln(estimate / truth) / sd` of the four parameters are
/// pooled. If the reported sd were the estimator's standard deviation, `sum z^2` would be
/// chi-square with `n` = the number of values (correlated within a seed, so this is
/// approximate). Bounds on the mean z^2: the chi-square(n)/n 0.001 and 0.999 quantiles, widened
/// by a factor 2 both ways for what the ideal does not model (hysteresis holds the estimate up to
/// one standard error from the window's optimum; the window's weights change after a jump;
/// the four values of one seed are correlated). Every sd must be finite and positive at the end.
#[test]
fn cramer_rao_intervals_describe_the_spread() {
    let t = truth();
    let truth_v = [
        gm_params(&t, ErrorSource::Accel).unwrap(),
        gm_params(&t, ErrorSource::Gyro).unwrap(),
    ];
    let env = |k: &str, d: u64| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    // Overridable to measure on fresh seeds: CR_FIRST_SEED=9000 CR_SEEDS=20 (BENCHMARKS.md).
    let (first, count) = (
        env("CR_FIRST_SEED", CR_FIRST_SEED),
        env("CR_SEEDS", CR_SEEDS),
    );
    let mut z = Vec::new();
    let mut inside = [0usize; 4];
    for k in [0.1, 10.0] {
        let start = mismatch::scaled(&t, k, k);
        for seed in first..first + count {
            let log = sim::simulate(&t, STEPS, seed).unwrap();
            let r = adaptive::run::<f64>(&start, &log, AdaptConfig::default()).unwrap();
            for (s, sensor) in ["accel", "gyro"].into_iter().enumerate() {
                let last = r
                    .params
                    .iter()
                    .rev()
                    .find(|p| p.sensor == sensor && p.component == 0)
                    .unwrap();
                let (tau, sigma) = truth_v[s];
                for (j, (name, v, sd, tv)) in [
                    ("tau", last.tau, last.sd_ln_tau, tau),
                    ("sigma", last.sigma, last.sd_ln_sigma, sigma),
                ]
                .into_iter()
                .enumerate()
                {
                    assert!(
                        sd.is_finite() && sd > 0.0,
                        "seed {seed} {sensor} {name}: sd {sd}"
                    );
                    let e = (v / tv).ln();
                    inside[2 * s + j] += usize::from((e / sd).abs() <= 1.96);
                    println!("start {k} seed {seed} {sensor} {name}: ln err {e:+.3}, sd {sd:.3}, z {:+.2}", e / sd);
                    z.push(e / sd);
                }
            }
        }
    }
    let n = z.len() as f64;
    let mean_z2 = z.iter().map(|v| v * v).sum::<f64>() / n;
    // Chi-square(n) / n quantiles by the Wilson-Hilferty approximation.
    let wh = |zq: f64| (1.0 - 2.0 / (9.0 * n) + zq * (2.0 / (9.0 * n)).sqrt()).powi(3);
    let (lo, hi) = (wh(-3.09) / 2.0, 2.0 * wh(3.09));
    println!(
        "mean z^2 = {mean_z2:.3} over {} values; bounds [{lo:.3}, {hi:.3}]",
        z.len()
    );
    println!(
        "truth inside the 95 % interval (accel tau, accel sigma, gyro tau, gyro sigma): {inside:?} of {}",
        2 * count
    );
    assert!(
        mean_z2 > lo && mean_z2 < hi,
        "mean z^2 {mean_z2} outside [{lo}, {hi}]"
    );
}

/// Seeds of the Cramér-Rao check (not those of the other tests or of the bench).
const CR_FIRST_SEED: u64 = 3000;
const CR_SEEDS: u64 = 6;

/// Issue 13: the global stage reaches the oracle from starts today's recursion cannot leave:
/// both sigmas 10x and 0.1x with the right taus (the recursion ends at 2.1x the oracle from the
/// first, BENCHMARKS.md §7) and a start wrong in four directions at once (factors 0.24, 6.43,
/// 0.48, 0.73 of sigma_a, tau_a, sigma_g, tau_g). The bound 1.10 is the 95th
/// percentile bar; on this seed the offline ML reference is at 0.995x and all 32 starts of the
/// bench ended within 1.05x of it (docs/ADAPTATION.md §7), so 1.10 leaves room without letting
/// a wrong basin (1.2-9x) pass. Host pace: a search every 2 h at 1000 filter steps per tick.
#[test]
fn global_stage_reaches_the_oracle_from_any_start() {
    let truth = truth();
    let log = sim::simulate(&truth, STEPS, 1001).unwrap_or_else(|e| panic!("{e:#}"));
    let (oracle, _) = replay::estimates::<f64>(&truth, &log).unwrap_or_else(|e| panic!("{e:#}"));
    let (orms, _) = tilt_window(&log, &oracle, T0, T1).unwrap_or_else(|| panic!("oracle"));
    let mut cfg = AdaptConfig::global();
    cfg.global.every = 120;
    cfg.global.budget = 1000;
    for f in [
        [10.0, 1.0, 10.0, 1.0],
        [0.1, 1.0, 0.1, 1.0],
        [0.24, 6.43, 0.48, 0.73],
    ] {
        let start = mismatch::factored(&truth, &f).unwrap_or_else(|| panic!("start {f:?}"));
        let r = adaptive::run::<f64>(&start, &log, cfg).unwrap_or_else(|e| panic!("{e:#}"));
        let (rms, out) = tilt_window(&log, &r.estimates, T0, T1).unwrap_or_else(|| panic!("run"));
        eprintln!(
            "global stage from {f:?}: tilt/oracle {:.3}, outside 3 sigma {:.2} %, jumps {}",
            rms / orms,
            out * 100.0,
            r.jumps
        );
        assert!(
            rms / orms <= 1.10,
            "from {f:?}: {:.3}x the oracle",
            rms / orms
        );
        assert!(
            out <= 0.03,
            "from {f:?}: {:.2} % outside 3 sigma",
            out * 100.0
        );
        assert!(r.jumps >= 1, "from {f:?}: the search never moved the model");
    }
}

/// Issue 13, "the start no longer matters", at the firmware's pace (`AdaptConfig::global()`):
/// on seed 95517 (traced, `docs/ADAPTATION.md` §7.13) the first full window's search gave the
/// run started at the truth the window's maximum (accelerometer 8.4e-4 m/s^2, 67 s; gyro 182 s)
/// and the run started at a 10x accelerometer sigma a white-noise gyro basin (16 s), so that
/// run kept the 6-h answer (gyro 1 864 s) until 10.9 h. With the last search's points carried
/// into the next, both runs hold the same model an hour after the 8-h search began.
#[test]
fn the_first_full_window_gives_the_same_answer_from_two_starts() {
    let truth = truth();
    let hours = 9.5;
    let log = sim::simulate(&truth, (hours * 3600.0) as usize, 95_517)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let answer = |f: [f64; 4]| -> Vec<(f64, f64)> {
        let start = mismatch::factored(&truth, &f).unwrap_or_else(|| panic!("start {f:?}"));
        let r = adaptive::run::<f64>(&start, &log, AdaptConfig::global())
            .unwrap_or_else(|e| panic!("{e:#}"));
        // The model the filter runs at the end: the last row of each sensor's component 0.
        ["accel", "gyro"]
            .iter()
            .map(|s| {
                let p = r
                    .params
                    .iter()
                    .rev()
                    .find(|p| p.sensor == *s && p.component == 0)
                    .unwrap_or_else(|| panic!("no {s} row"));
                (p.sigma, p.tau)
            })
            .collect()
    };
    let from_truth = answer([1.0; 4]);
    let from_wrong = answer([10.0, 1.0, 1.0, 1.0]);
    eprintln!("from the truth {from_truth:?}, from 10x accelerometer sigma {from_wrong:?}");
    // The same maximum of the same window: the two polishes end within their stopping step
    // (0.05 in ln) of each other, far inside the 1.6 decades that separated the answers.
    for ((s1, t1), (s2, t2)) in from_truth.iter().zip(&from_wrong) {
        for (a, b) in [(s1, s2), (t1, t2)] {
            assert!((a / b).ln().abs() < 0.1, "{from_truth:?} vs {from_wrong:?}");
        }
    }
}
