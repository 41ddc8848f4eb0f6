//! Issue 13, item 2: what a window search cannot identify is flagged "not identifiable from
//! these data yet" in telemetry, with its Cramér-Rao interval, and searched again sooner on
//! more data instead of being run for hours. Run in release for speed:
//! `cargo test --release -p hal-sim --test host identifiability::`.

use hal_sim::adaptive::{self, tilt_window};
use hal_sim::records::ParamRow;
use hal_sim::{mismatch, replay, scenario, sim};
use imu_ident::adapt::AdaptConfig;
use imu_ident::model::{InsModel, IDENTIFIABLE_SD};
use imu_ident::telemetry::NOT_IDENTIFIABLE;

fn paper() -> InsModel<f64> {
    scenario::load("paper").unwrap().to_core().unwrap()
}

/// Development seed 1002 of `examples/anystart_bench.rs`, started with the gyro's sigma at
/// 0.1x, firmware pace (`AdaptConfig::global()`). Its first search (a 4-h window) lands on the
/// accelerometer's random-walk ridge, a factor 10 in sigma_a and 100 in tau_a from the truth,
/// with Cramér-Rao deviations of 1 to 7 decades. Measured: run until the 8-h search ended
/// near hour 9, that answer left the filter at 16.7x the oracle over hours 8-12; searched
/// again 1 h later (`WindowConfig::flat_every`), 1.03x (flagged from 4.65 h to 6.26 h).
///
/// The flag must be raised on the first answer and carried by its parameter records with
/// deviations above the threshold, be gone by hour 8, and the run must end within 1.05x of
/// max(oracle, ML reference) (issue 13's any-start bar; this seed's ML reference is 0.992x the
/// oracle), while the same run without the early searches (neither this one nor the filling
/// pace's) must not (it is a check that the
/// run exercises the flag, not a statistical bound).
#[test]
fn a_flat_answer_is_flagged_and_searched_again_sooner() {
    let truth = paper();
    let start = mismatch::factored(&truth, &[1.0, 1.0, 0.1, 1.0]).unwrap();
    let log = sim::simulate(&truth, 12 * 3600, 1002).unwrap();
    let (t0, t1) = (8.0 * 3600.0, 12.0 * 3600.0 + 1.0);
    let (oracle, _) = replay::estimates::<f64>(&truth, &log).unwrap();
    let (orms, _) = tilt_window(&log, &oracle, t0, t1).unwrap();
    let cfg = AdaptConfig::global();
    assert!(cfg.global.flat_every > 0 && !cfg.global.hold_flat);
    let run = adaptive::run::<f64>(&start, &log, cfg).unwrap();
    let mut late = cfg;
    late.global.flat_every = 0;
    // The searches while the window fills (`WindowConfig::filling_every`, 2 h) also search
    // again before hour 8 (measured: 0.997x with them alone): without both, the first answer
    // runs until the 8-h search ends.
    late.global.filling_every = 0;
    let slow = adaptive::run::<f64>(&start, &log, late).unwrap();
    let (rms, _) = tilt_window(&log, &run.estimates, t0, t1).unwrap();
    let (rms0, _) = tilt_window(&log, &slow.estimates, t0, t1).unwrap();

    let flagged = run.flagged_hours(NOT_IDENTIFIABLE);
    let rows: Vec<&ParamRow> = run
        .params
        .iter()
        .filter(|p| !p.not_identifiable.is_empty())
        .collect();
    eprintln!(
        "flagged ticks {} (from {:.2?} h to {:.2?} h), {} flagged parameter records; tilt / oracle {:.3}, without the early search {:.3}",
        flagged.len(),
        flagged.first(),
        flagged.last(),
        rows.len(),
        rms / orms,
        rms0 / orms
    );
    assert!(
        !flagged.is_empty(),
        "the first answer is flat: it must be flagged"
    );
    assert!(
        flagged.iter().all(|t| *t > 4.0 && *t < 8.0),
        "the flag is raised by the first search and cleared by the next: {:.2?} .. {:.2?}",
        flagged.first(),
        flagged.last()
    );
    assert_eq!(run.counts.not_identifiable, flagged.len());
    // Each flagged quantity's record carries its interval, wider than the threshold's.
    let limit = IDENTIFIABLE_SD * std::f64::consts::LN_10;
    assert!(!rows.is_empty());
    for p in &rows {
        for q in p.not_identifiable.split(' ') {
            let sd = match q {
                "tau" => p.sd_ln_tau,
                "sigma" => p.sd_ln_sigma,
                "beta" => p.sd_ln_beta,
                other => panic!("unknown quantity {other:?} in {p:?}"),
            };
            // NaN: the window's information was singular (all flagged, no interval).
            assert!(sd.is_nan() || sd > limit, "{q}: sd {sd} in {p:?}");
        }
    }
    assert!(rms / orms <= 1.05, "tilt / oracle {:.3}", rms / orms);
    assert!(
        rms0 / orms > 1.05,
        "without the early search {:.3}",
        rms0 / orms
    );
}

/// From the truth on the same log the 8-h windows identify every parameter: the flag is not
/// raised after the first search on 8 h of data.
#[test]
fn identified_parameters_are_not_flagged() {
    let truth = paper();
    let log = sim::simulate(&truth, 12 * 3600, 1002).unwrap();
    let run = adaptive::run::<f64>(&truth, &log, AdaptConfig::global()).unwrap();
    let late = run
        .estimates
        .iter()
        .filter(|e| e.t > 9.5 * 3600.0 && e.flags & NOT_IDENTIFIABLE != 0)
        .count();
    assert_eq!(late, 0, "flagged ticks after the 8-h search");
    let last = run.params.last().map(|p| p.t).unwrap_or(0.0);
    for p in run.params.iter().filter(|p| p.t == last) {
        assert!(p.not_identifiable.is_empty(), "{p:?}");
    }
}
