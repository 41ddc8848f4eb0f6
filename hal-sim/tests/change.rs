//! The global stage's change monitor (`imu_ident::adapt::change`, `adapt::window::monitor`): a
//! sensor whose noise changes in service, with every state continuous (`sim::Seam::Continuous`),
//! is found and followed; stationary logs raise no alarm. Run in release for speed:
//! `cargo test --release -p hal-sim --test host change::`.

use hal_sim::adaptive::{self, tilt_window};
use hal_sim::{mismatch, replay, scenario, sim};
use imu_ident::adapt::AdaptConfig;
use imu_ident::model::InsModel;
use imu_ident::telemetry::SENSOR_CHANGE;

fn paper() -> InsModel<f64> {
    scenario::load("paper").unwrap().to_core().unwrap()
}

/// Host pace: a search every 2 h at 1000 filter steps per tick.
fn host_pace(change: f64) -> AdaptConfig<f64> {
    let mut cfg = AdaptConfig::global();
    cfg.global.every = 120;
    cfg.global.budget = 1000;
    cfg.global.change = change;
    cfg
}

/// Times [h] of the ticks flagged `sensor_change`.
fn changes(r: &adaptive::AdaptiveRun) -> Vec<f64> {
    r.flagged_hours(SENSOR_CHANGE)
}

/// 6 h of `paper`, then 12 h of a quieter sensor (sigma_a 0.10x, tau_a 0.29x, sigma_g 0.19x,
/// tau_g 3.31x: a draw of `examples/change_bench.rs`, development seed 31003), states
/// continuous. The monitor must date the change within 2 h of it, and over hours 12-18 the
/// filter must be within 1.10x the filter that knows the new model (issue 13's bar) and
/// nearer to it than the same run without the monitor, whose windows still hold the old
/// sensor (measured: 1.03x with the monitor, 1.48x without).
#[test]
fn a_change_in_service_without_a_seam_is_found_and_followed() {
    let a = paper();
    let b = mismatch::factored(&a, &[0.10, 0.29, 0.19, 3.31]).unwrap();
    let log = sim::simulate_change(&a, &b, (6 * 3600, 12 * 3600), 31003, sim::Seam::Continuous)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let (t0, t1) = (12.0 * 3600.0, 18.0 * 3600.0 + 1.0);
    let (oracle, _) = replay::estimates::<f64>(&b, &log).unwrap();
    let (orms, _) = tilt_window(&log, &oracle, t0, t1).unwrap();
    let with = adaptive::run::<f64>(
        &a,
        &log,
        host_pace(imu_ident::adapt::window::CHANGE_THRESHOLD),
    )
    .unwrap();
    let without = adaptive::run::<f64>(&a, &log, host_pace(0.0)).unwrap();
    let (rms, out) = tilt_window(&log, &with.estimates, t0, t1).unwrap();
    let (rms0, out0) = tilt_window(&log, &without.estimates, t0, t1).unwrap();
    let found = changes(&with);
    eprintln!(
        "changes found at {found:.2?} h; tilt / oracle B {:.3} ({:.2} % outside 3 sigma), without the monitor {:.3} ({:.2} %)",
        rms / orms,
        100.0 * out,
        rms0 / orms,
        100.0 * out0
    );
    assert!(changes(&without).is_empty());
    let first = *found.first().unwrap_or_else(|| panic!("no change found"));
    assert!(
        (6.0..8.0).contains(&first),
        "the change dated at {first:.2} h"
    );
    assert!(rms / orms <= 1.10, "{:.3}x oracle B", rms / orms);
    assert!(rms < rms0, "no better than without the monitor");
    assert!(out <= 0.03, "{:.2} % outside 3 sigma", 100.0 * out);
}

/// No alarm on stationary `paper` logs (12 h, three seeds, from the truth and from 10x sigmas).
/// Lorden's bound: with the right model each of the two sums alarms at most once in `e^24`
/// blocks on average, so two sums over 720 blocks alarm with probability at most
/// `2 x 720 / e^24 = 5e-8` per run; the model here is each search's estimate, not the truth,
/// which the bound does not cover, hence the test.
#[test]
fn stationary_logs_raise_no_alarm() {
    let truth = paper();
    for seed in [1000, 1001, 1002] {
        let log = sim::simulate(&truth, 12 * 3600, seed).unwrap_or_else(|e| panic!("{e:#}"));
        for f in [[1.0; 4], [10.0, 1.0, 10.0, 1.0]] {
            let start = mismatch::factored(&truth, &f).unwrap();
            let r = adaptive::run::<f64>(
                &start,
                &log,
                host_pace(imu_ident::adapt::window::CHANGE_THRESHOLD),
            )
            .unwrap();
            let found = changes(&r);
            assert!(
                found.is_empty(),
                "seed {seed} from {f:?}: changes at {found:.2?} h"
            );
        }
    }
}

/// A continuous change carries the states over one for one, so the two models must lay them out
/// alike: a model with one more component is refused, with a message that says why.
#[test]
fn a_continuous_change_between_different_structures_is_refused() {
    use imu_ident::model::ComponentKind;
    let a = paper();
    let mut b = a.clone();
    b.gyro
        .push(ComponentKind::RandomWalk.with_quantities(&[1e-12]))
        .unwrap_or_else(|_| panic!("room for a component"));
    let err = sim::simulate_change(&a, &b, (60, 60), 1, sim::Seam::Continuous)
        .err()
        .unwrap_or_else(|| panic!("accepted"));
    assert!(format!("{err:#}").contains("same structure"), "{err:#}");
    // The fresh seam draws each part from its own model: accepted.
    assert!(sim::simulate_change(&a, &b, (60, 60), 1, sim::Seam::Fresh).is_ok());
}

/// `examples/change_bench.rs` development seed 31008, states continuous, firmware pace: after
/// the change (sigma_a 2.81x, tau_a 3.58x, sigma_g 8.40x, tau_g 9.00x) the windows are flat
/// along the accelerometer's Gauss-Markov, and their maximum ends the ridge at about 0.13 m/s^2
/// over 6-9 days (a near-constant bias, which one channel cannot tell from tilt): measured,
/// 2.85x oracle B over hours 12-18. With the prior (`WindowConfig::prior`, 2 decades about the
/// start model) the flat direction stays near the start's values: 1.08x. The test: within
/// 1.10x with the prior, and over 1.5x without it.
#[test]
fn a_flat_ridge_after_a_change_runs_at_the_prior() {
    use rand::{Rng, SeedableRng};
    let a = paper();
    let seed = 31008u64;
    // The bench's draw of the factors for this seed.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed * 7919 + 13);
    let f: Vec<f64> = (0..4)
        .map(|_| 10f64.powf(rng.gen_range(-1.0..1.0)))
        .collect();
    let b = mismatch::factored(&a, &f).unwrap();
    let log = sim::simulate_change(&a, &b, (6 * 3600, 12 * 3600), seed, sim::Seam::Continuous)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let (t0, t1) = (12.0 * 3600.0, 18.0 * 3600.0 + 1.0);
    let (oracle, _) = replay::estimates::<f64>(&b, &log).unwrap();
    let (orms, _) = tilt_window(&log, &oracle, t0, t1).unwrap();
    let ratio = |prior: f64| {
        let mut cfg = AdaptConfig::<f64>::global();
        cfg.global.prior = prior;
        let r = adaptive::run::<f64>(&a, &log, cfg).unwrap();
        tilt_window(&log, &r.estimates, t0, t1).unwrap().0 / orms
    };
    let (with, without) = (ratio(2.0), ratio(0.0));
    eprintln!("factors {f:.2?}: tilt / oracle B {with:.3} with the prior, {without:.3} without");
    assert!(with <= 1.10, "{with:.3}x oracle B with the prior");
    assert!(
        without > 1.5,
        "{without:.3}x without: the case no longer shows the ridge"
    );
}
