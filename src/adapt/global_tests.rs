//! The global stage ([`window`](crate::adapt::window)) on a model other than the one-channel
//! INS: the four-parameter model of [`identifier_tests`](super::identifier_tests) (a fast and a
//! slow Gauss-Markov component summed in two sensors), where the recursion and its probes end in
//! a wrong basin from half the starts (`docs/ADAPTATION.md` §2.7).

use super::identifier_tests::{
    env_var, from_any_start, gate, judge, loglik, observations, sound, start, TwoSpeeds, N, TRUTH,
};
use crate::adapt::{AdaptConfig, AdaptiveFilter, WindowConfig, WINDOW_CAP};
extern crate std;

type TwoSpeedsFilter<const W: usize = WINDOW_CAP> = AdaptiveFilter<f64, TwoSpeeds, N, 2, W>;

/// The global stage's settings for this model: blocks of `block` steps, a window of 480 blocks,
/// searches every 240, and a budget that lets a search end within its blocks' slack on the
/// host (the budget changes when a search ends, not what it finds).
fn global(block: u32) -> AdaptConfig<f64> {
    AdaptConfig {
        block: 500,
        global: WindowConfig {
            block,
            budget: 100_000,
            ..WindowConfig::default_on()
        },
        ..AdaptConfig::default()
    }
}

/// Runs the adaptive filter (its ring of `W` block means) from `m` over `z`; returns it and the
/// number of rejected steps.
fn identify<const W: usize>(
    m: TwoSpeeds,
    cfg: AdaptConfig<f64>,
    z: &[[f64; 2]],
) -> (TwoSpeedsFilter<W>, usize) {
    let mut f = TwoSpeedsFilter::<W>::from_model(m, cfg).unwrap();
    let rejected = z
        .iter()
        .filter(|zk| f.step_axes(zk, None).step.rejected)
        .count();
    (f, rejected)
}

/// Measurement, not a check: the global stage from the truth, the eight sigma-only and
/// tau-only corners and eight log-uniform starts in `[0.1, 10]` (`docs/ADAPTATION.md` §2.7):
///
/// ```text
/// STEPS=160000 BLOCK=5 HOLD=1 MARGIN=0 RING=600 WINDOW=480 SEED=1 \
///     cargo test --release --lib two_speeds_global_from_any_start -- --ignored --nocapture
/// ```
///
/// Per start as in `two_speeds_from_any_start`, with the last search's Cramér-Rao sd.
#[test]
#[ignore]
fn two_speeds_global_from_any_start() {
    let mut cfg = global(env_var("BLOCK", 5.0) as u32);
    // HOLD=0: the recursion refines between searches (its 4-h window is longer than the
    // search's).
    cfg.global.hold_recursion = env_var("HOLD", 1.0) != 0.0;
    // MARGIN: the nats a search's answer must gain over the filter's point on its window
    // before the filter jumps to it.
    cfg.global.margin = env_var("MARGIN", 0.0);
    // RING=2400 with WINDOW=2000: a window four times the default's.
    cfg.global.window = env_var("WINDOW", 480.0) as u32;
    if env_var("RING", 600.0) == 2400.0 {
        measure::<2400>(cfg);
    } else {
        measure::<WINDOW_CAP>(cfg);
    }
}

/// [`two_speeds_global_from_any_start`] with a ring of `W` block means.
fn measure<const W: usize>(cfg: AdaptConfig<f64>) {
    from_any_start(|m, z| {
        let (id, rejected) = identify::<W>(m, cfg, z);
        let note = std::format!(
            "jumps {}, last search {} passes, rejected {rejected}",
            id.jumps(),
            id.global().evaluations()
        );
        (*id.theta(), id.cr_sd(), id.flat(), note)
    });
}

/// From the starts where the recursion and its probes end in the wrong basin (the slow
/// component takes the fast one's role; `two_speeds_from_any_start`, seed 1: 150-160 nats below
/// the truth over the last 80 000 steps, 20-80 sd from it, with no flag), the global stage ends
/// at the truth: after 40 000 steps (30 searches) each coordinate is within 4 Cramér-Rao sd of
/// the last search's window (asymptotic normality of the window's maximum;
/// `P(|N(0,1)| > 4) = 6e-5` per coordinate). A 2400-s window holds 8 correlation times of the
/// slow component, so its `tau` may be flagged (sd above `IDENTIFIABLE_SD`), as issue 13's
/// item 2 asks; the fast component's two, which the wrong basin gets wrong, may not.
#[test]
fn the_global_stage_leaves_the_wrong_basin() {
    let z = observations(20_261_201, 40_000);
    let at_truth = loglik(TRUTH, &z, z.len() / 2);
    for f in [
        [10.0, 1.0, 10.0, 1.0],
        [0.1, 1.0, 0.1, 1.0],
        [0.1, 1.0, 1.0, 1.0],
    ] {
        let (id, rejected) = identify::<WINDOW_CAP>(start(f), global(5), &z);
        assert_eq!(rejected, 0);
        assert!(id.jumps() > 0, "start {f:?}: no search moved the filter");
        let (within, end) = judge(id.theta(), id.cr_sd(), id.flat(), &z, at_truth);
        // The fast component's coordinates (the labels may swap: the data see only the sum).
        let th = id.theta();
        let fast = if th[1] > th[3] { 0b1100 } else { 0b0011 };
        assert!(within && id.flat() & fast == 0, "start {f:?}: {end}");
    }
}

/// No input breaks the adaptive filter on the four-parameter model with its global stage on
/// (blocks of 2 steps, a 40-block window searched every 10 blocks, and the change monitor, so
/// that searches, jumps and alarms happen within a case; a search builds at most one filter per
/// tick, so it takes a few hundred ticks). The observations mix ordinary rows
/// with rows of NaN, +-Inf, 1e30, `-f64::MAX`, subnormals and zeros, with or without the vector
/// gate.
/// After every step: no panic, `theta` finite and within its bounds, the centre's `P` positive
/// definite and its state finite. Over the cases, searches must have ended and moved the filter.
#[test]
fn the_global_stage_survives_any_input() {
    use super::vector_bank_tests::hostile_values;
    use proptest::prelude::*;
    use proptest::test_runner::{Config, TestRunner};
    // Mostly ordinary rows: a window with one non-finite or huge value has no likelihood, and
    // searches on windows that have one must also end in moves.
    let row = prop_oneof![
        8 => (-3.0..3.0f64, -3.0..3.0f64),
        1 => (hostile_values(), hostile_values()),
    ];
    let factor = prop_oneof![0.1..10.0f64, Just(1.0)];
    let case = (
        proptest::collection::vec(row, 1..2500),
        [factor.clone(), factor.clone(), factor.clone(), factor],
        any::<bool>(),
    );
    let cfg = AdaptConfig {
        block: 20,
        global: WindowConfig {
            block: 2,
            window: 40,
            first: 10,
            every: 10,
            filling_every: 0,
            budget: 100_000,
            change: 4.0,
            after_change: 5,
            ..WindowConfig::default_on()
        },
        ..AdaptConfig::default()
    };
    let jumps = std::cell::Cell::new(0);
    let mut runner = TestRunner::new(Config {
        cases: 32,
        ..Config::default()
    });
    runner
        .run(&case, |(rows, f, gated)| {
            let mut id = TwoSpeedsFilter::<WINDOW_CAP>::from_model(start(f), cfg).unwrap();
            let p = id.specs().len();
            for (a, b) in &rows {
                let g: Option<&dyn Fn(usize) -> f64> = if gated { Some(&gate) } else { None };
                let s = id.step_axes(&[*a, *b], g);
                jumps.set(jumps.get() + usize::from(s.step.jumped));
                sound(id.theta(), id.identifier().bounds(), p, &id.centre().kf)?;
            }
            Ok(())
        })
        .unwrap();
    // The path the test is about ran (a test of it that never ran would prove nothing).
    assert!(jumps.get() > 0, "jumps {jumps:?}");
}
