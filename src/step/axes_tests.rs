//! The step over an error model other than the one-channel INS: one Gauss-Markov state seen by
//! two sensors (`N = 1`, `Z = 2`, the identification bank's own test model). The estimator knows
//! it only through [`IdentifiableModel`]: per-axis flags, the vector gate at the tail of the
//! one-axis gate, the time rules, and the generic telemetry.

extern crate std;
use super::*;
use crate::adapt::vector_bank_tests::{hostile_values, observations, TwoSensorMarkov, TRUTH};
use crate::telemetry::{
    AxesRecord, AxesSink, IdentRecord, BAD_INPUT, BRIDGED, GATED_OUTLIER, MISSING, SKIPPED,
};
use std::vec::Vec;

type TwoAxes = Estimator<f64, TwoSensorMarkov, 1, 2>;

#[derive(Default)]
struct Collect {
    records: Vec<AxesRecord<2, 1>>,
    idents: Vec<IdentRecord>,
}

impl AxesSink<2, 1> for Collect {
    fn record(&mut self, r: &AxesRecord<2, 1>) {
        self.records.push(*r);
    }
    fn ident(&mut self, p: &IdentRecord) {
        self.idents.push(*p);
    }
}

/// The gate for two axes is the chi-square(2) quantile at the tail of the one-axis gate `g`:
/// `Q_2(x) = exp(-x / 2)`, so `q_2 = -2 ln Q_1(g)` in closed form.
#[test]
fn the_two_axis_gate_has_the_tail_of_the_one_axis_gate() {
    let nav = TwoAxes::from_model(TRUTH, StepConfig::default()).unwrap();
    assert_eq!(nav.gate_threshold_axes(1), 30.0);
    let q2 = -2.0 * chi_square::survival(1, 30.0).ln();
    assert!((nav.gate_threshold_axes(2) - q2).abs() < 1e-9 * q2, "{q2}");
    assert!(nav.gate_threshold_axes(0).is_nan() && nav.gate_threshold_axes(3).is_nan());
    // A gate whose tail underflows an f64 (Q_1(2000) ~ 1e-436) keeps q_2 = g, not an error.
    let cfg = StepConfig {
        gate: 2000.0,
        ..StepConfig::default()
    };
    let nav = TwoAxes::from_model(TRUTH, cfg).unwrap();
    assert_eq!(nav.gate_threshold_axes(2), 2000.0);
}

/// With the true model, the fixed engine's NIS per degree of freedom averages 1: the sum of the
/// sequential `nu_k^2 / S_k` over `n` two-axis ticks is chi-square with `2n` degrees of freedom
/// (white innovations), so its mean per degree of freedom has sd `sqrt(2 / 2n)` (0.0071 for
/// `n = 20 000`), and the bound is 5 sd. No tick is gated: each is, with probability
/// `4.3e-8 x 2n < 2e-3` in all.
#[test]
fn a_two_axis_estimator_with_the_true_model_is_calibrated() {
    let (d, out) = calibration(11, 20_000);
    assert!(d < 5.0, "mean NIS per dof {d} sd from 1");
    // The fixed model reports its parameters once, at the start, without an interval.
    assert_eq!(out.idents.len(), 2);
    assert!(out
        .idents
        .iter()
        .all(|p| p.k == 0 && p.sd_ln.is_nan() && !p.flat));
    assert!((f64::from(out.idents[0].value) - TRUTH.sigma).abs() < 1e-6);
}

/// The true model's fixed engine over `n` ticks of seed `seed`: how many sd its mean NIS per
/// degree of freedom is from 1, and what it sent (asserts: no tick flagged, both axes on each).
fn calibration(seed: u64, n: usize) -> (f64, Collect) {
    let z = observations(seed, n);
    let mut nav = TwoAxes::from_model(TRUTH, StepConfig::default()).unwrap();
    let mut out = Collect::default();
    for (k, zk) in z.iter().enumerate() {
        nav.push_axes(k as f64, zk, &mut out);
    }
    assert_eq!(out.records.len(), n);
    assert!(out.records.iter().all(|r| r.flags == 0 && r.dof == 2));
    let mean = out.records.iter().map(|r| f64::from(r.nis)).sum::<f64>() / (2 * n) as f64;
    let sd = (2.0 / (2 * n) as f64).sqrt();
    ((mean - 1.0).abs() / sd, out)
}

/// Per-axis flags and the vector gate: an outlier on one axis withholds the whole observation
/// (both axes flagged, the state only predicted), a missing axis lets the other one through,
/// and the time rules are the one-channel step's (bridged ticks, skipped rows).
#[test]
fn one_bad_axis_is_flagged_on_its_own() {
    let z = observations(12, 300);
    let mut nav = TwoAxes::from_model(TRUTH, StepConfig::default()).unwrap();
    let mut out = Collect::default();
    for (k, zk) in z.iter().take(200).enumerate() {
        nav.push_axes(k as f64, zk, &mut out);
    }
    let before = nav.state_si()[0];
    let phi = (-1.0 / TRUTH.tau).exp();
    // 50 sd of the second sensor's noise on top of a right value.
    let outlier = [z[200][0], z[200][1] + 50.0 * TRUTH.r[1].sqrt()];
    nav.push_axes(200.0, &outlier, &mut out);
    let r = out.records.last().unwrap();
    assert!(r.has(GATED_OUTLIER) && !r.has(MISSING), "{:#x}", r.flags);
    assert!(r.axis_has(0, GATED_OUTLIER) && r.axis_has(1, GATED_OUTLIER));
    assert!(
        (nav.state_si()[0] - phi * before).abs() < 1e-12,
        "only predicted"
    );
    // One axis missing: the other is used.
    nav.push_axes(201.0, &[f64::NAN, z[201][1]], &mut out);
    let r = out.records.last().unwrap();
    assert_eq!((r.axis_flags, r.flags, r.dof), ([MISSING, 0], 0, 1));
    assert!(r.nis.is_finite() && r.innovation[1].is_finite() && r.innovation[0].is_nan());
    // Both missing, and an infinite value (missing, and bad input).
    nav.push_axes(202.0, &[f64::NAN, f64::NAN], &mut out);
    assert!(out.records.last().unwrap().has(MISSING));
    nav.push_axes(203.0, &[f64::INFINITY, z[203][1]], &mut out);
    let r = out.records.last().unwrap();
    assert!(r.has(BAD_INPUT) && r.axis_has(0, MISSING) && !r.has(MISSING));
    // Two rows lost: two bridged ticks, then the row; a repeated time is skipped.
    nav.push_axes(206.0, &z[206], &mut out);
    let tail: Vec<u16> = out.records.iter().rev().take(3).map(|r| r.flags).collect();
    assert_eq!(tail, [0, BRIDGED | MISSING, BRIDGED | MISSING]);
    nav.push_axes(206.0, &z[207], &mut out);
    assert!(out.records.last().unwrap().has(SKIPPED));
    assert_eq!(nav.ticks(), 207);
}

/// Online from a wrong start (sigma 10x and tau 0.1x, a direction the bank's tests do not
/// use): the estimator reports the identified parameters with their Cramér-Rao sd whenever
/// they move, and the last report is within 4 of its sd of the truth (`P(|N(0,1)| > 4) = 6e-5`
/// per coordinate for an asymptotically normal estimate), unflagged.
#[test]
fn a_two_axis_estimator_identifies_online_and_says_so() {
    let (moves, d, flat) = identification(13);
    // Measured: 11 moves on this seed.
    assert!(moves >= 3, "parameters reported at {moves} moves");
    assert!(
        !flat && d.iter().all(|d| *d < 4.0),
        "{d:?} sd from the truth"
    );
}

/// The adaptive engine from sigma 10x and tau 0.1x over 40 000 ticks of seed `seed`: the moves
/// it reported, how many Cramér-Rao sd (its own, in the last report) each parameter ends from
/// the truth, and whether either was flagged.
fn identification(seed: u64) -> (usize, [f64; 2], bool) {
    let z = observations(seed, 40_000);
    let start = TwoSensorMarkov {
        sigma: TRUTH.sigma * 10.0,
        tau: TRUTH.tau * 0.1,
        ..TRUTH
    };
    let adapt = AdaptConfig {
        block: 500,
        window: 5000.0,
        probe_factor: 3.0,
        ..AdaptConfig::default()
    };
    let cfg = StepConfig {
        adapt: Some(adapt),
        ..StepConfig::default()
    };
    let mut nav = TwoAxes::from_model(start, cfg).unwrap();
    let mut out = Collect::default();
    for (k, zk) in z.iter().enumerate() {
        nav.push_axes(k as f64, zk, &mut out);
    }
    assert!(out.records.iter().all(|r| r.nis.is_finite()));
    // Two records per move (sigma, tau).
    let moves = out.idents.iter().filter(|p| p.k > 0).count() / 2;
    let last = &out.idents[out.idents.len() - 2..];
    let mut d = [0.0; 2];
    for ((di, p), truth) in d.iter_mut().zip(last).zip([TRUTH.sigma, TRUTH.tau]) {
        *di = (f64::from(p.value).ln() - truth.ln()).abs() / f64::from(p.sd_ln);
    }
    (moves, d, last.iter().any(|p| p.flat))
}

/// Any rows (NaN, +-Inf, 1e30, `-f64::MAX`, subnormals in either axis; times repeated, going
/// back, jumping or NaN) through either engine: no panic, the state finite, `P` positive
/// definite, one record per row or bridged tick.
#[test]
fn the_two_axis_step_survives_any_input() {
    use proptest::prelude::*;
    use proptest::test_runner::{Config, TestRunner};
    let value = hostile_values();
    let dt = prop_oneof![8 => Just(1.0), 1 => Just(0.0), 1 => Just(-3.0), 1 => Just(5.0),
                         1 => Just(1.0e7), 1 => Just(f64::NAN)];
    let row = (dt, value.clone(), value);
    let case = (proptest::collection::vec(row, 1..400), any::<bool>());
    let mut runner = TestRunner::new(Config {
        cases: 32,
        ..Config::default()
    });
    runner
        .run(&case, |(rows, adaptive)| {
            let cfg = StepConfig {
                adapt: adaptive.then(|| AdaptConfig {
                    block: 20,
                    window: 200.0,
                    probe_factor: 3.0,
                    ..AdaptConfig::default()
                }),
                max_bridge: 50,
                ..StepConfig::default()
            };
            let mut nav = TwoAxes::from_model(TRUTH, cfg).unwrap();
            let mut out = Collect::default();
            let mut t = 0.0;
            for (d, a, b) in rows.iter() {
                t += d;
                nav.push_axes(if d.is_nan() { f64::NAN } else { t }, &[*a, *b], &mut out);
                let kf = nav.kalman();
                prop_assert!(kf.x.iter().all(|v| v.is_finite()));
                prop_assert!(crate::linalg::is_positive_definite(&kf.P, kf.active()));
                prop_assert!(nav.gate_threshold_axes(2).is_finite());
                if t.is_nan() {
                    t = 0.0;
                }
            }
            prop_assert!(out.records.len() >= rows.len());
            prop_assert_eq!(out.records.len() as u32 - nav.ticks(), skipped(&out));
            Ok(())
        })
        .unwrap();
}

fn skipped(out: &Collect) -> u32 {
    out.records.iter().filter(|r| r.has(SKIPPED)).count() as u32
}

/// The vector gate rejects a right observation with the same probability whatever its number
/// of finite axes. With the one-axis gate at the 1 % point of chi-square(1) (6.63) and the
/// second axis missing on a third of the ticks at random, each tick's rejection probability
/// is `Q_m(q_m s)` for its `m` finite axes, `q_m` the chi-square(`m`) 1 % point, and the gate
/// scale `s` before it (`s` moves with the
/// NIS, so it is read before each tick). The number of gated ticks is a sum of
/// independent Bernoulli variables (white innovations under the true model): the bound is 5 of
/// its sd around the sum of the probabilities, both for the ticks with one axis and for those
/// with two (measured 0.5 and 0.2 sd). A two-axis gate at `q_1` (the one-axis quantile)
/// rejects 3.6 % instead of 1 %: 38 sd off (mutation tried).
#[test]
fn the_vector_gate_keeps_its_tail_for_any_number_of_axes() {
    for (m, (count, mean, d)) in gate_tail(14).iter().enumerate() {
        assert!(
            *d < 5.0,
            "{} axes: {count} gated, {mean:.1} expected ({d:.1} sd)",
            m + 1
        );
        assert!(
            *mean > 50.0,
            "{} axes: too few expected rejections ({mean})",
            m + 1
        );
    }
}

/// 30 000 ticks of seed `seed` through the 1-% gate, the second axis missing on a third of
/// them: per number of finite axes, the gated ticks, the expected number, and the distance in
/// sd.
fn gate_tail(seed: u64) -> [(u32, f64, f64); 2] {
    use rand::{Rng, SeedableRng};
    let n = 30_000;
    let z = observations(seed, n);
    let g = chi_square::quantile(1, 0.01);
    let cfg = StepConfig {
        gate: g,
        ..StepConfig::default()
    };
    let mut nav = TwoAxes::from_model(TRUTH, cfg).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    // Per number of axes: expected rejections, their variance, the count.
    let mut tally = [(0.0f64, 0.0f64, 0u32); 2];
    for (k, zk) in z.iter().enumerate() {
        let mut row = *zk;
        if rng.gen_bool(1.0 / 3.0) {
            row[1] = f64::NAN;
        }
        let m = if row[1].is_nan() { 1 } else { 2 };
        // The intended tail, independent of the estimator's quantiles: the scale `s` from the
        // one-axis threshold, and `Q_2(q_2 s) = exp(-q_2 s / 2) = 0.01^s` at `q_2 = -2 ln 0.01`.
        let s = nav.gate_threshold_axes(1) / g;
        let p = if m == 1 {
            chi_square::survival(1, g * s)
        } else {
            0.01f64.powf(s)
        };
        let mut flags = 0;
        nav.push_axes(k as f64, &row, &mut |r: &AxesRecord<2, 1>| flags = r.flags);
        let t = &mut tally[m - 1];
        t.0 += p;
        t.1 += p * (1.0 - p);
        t.2 += u32::from(flags & GATED_OUTLIER != 0);
    }
    tally.map(|(mean, var, count)| (count, mean, (f64::from(count) - mean).abs() / var.sqrt()))
}

/// Measurement, not a check (`FIRST_SEED=k cargo test --release --lib two_axis_fresh_seeds --
/// --ignored --nocapture`): the three statistics of the tests above on 20 seeds from `k`
/// (default 65500; the tests' seeds 11-14 were the development set).
#[test]
#[ignore]
fn two_axis_fresh_seeds() {
    let first: u64 = std::env::var("FIRST_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(65_500);
    for seed in first..first + 20 {
        let (cal, _) = calibration(seed, 20_000);
        let (moves, d, flat) = identification(seed);
        let [(c1, e1, d1), (c2, e2, d2)] = gate_tail(seed);
        std::println!(
            "seed {seed}: NIS {cal:.2} sd; ident {moves} moves, {:.2} / {:.2} sd, flat {flat}; \
             gate 1 axis {c1} / {e1:.1} ({d1:.2} sd), 2 axes {c2} / {e2:.1} ({d2:.2} sd)",
            d[0],
            d[1]
        );
    }
}
