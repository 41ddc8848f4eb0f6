//! Unit tests of the adaptive filter: configuration and model errors are values, bad
//! observations do not break it, and the start model is kept until a window rejects it.

use super::*;
use crate::model::{Component, RandomConstant};

#[test]
fn config_and_model_errors_are_values() {
    let bad = AdaptConfig::<f32> {
        block: 0,
        ..AdaptConfig::default()
    };
    assert_eq!(
        AdaptiveFilter::new(InsModel::paper(), bad).err(),
        Some(AdaptError::BadConfig)
    );
    let nan = AdaptConfig::<f32> {
        damping: f32::NAN,
        ..AdaptConfig::default()
    };
    assert!(AdaptiveFilter::new(InsModel::paper(), nan).is_err());
    let mut m = InsModel::<f32>::empty(1.0, 0.03);
    let _ = m
        .accel
        .push(Component::RandomConstant(RandomConstant { sigma: 1e-3 }));
    assert_eq!(
        AdaptiveFilter::new(m, AdaptConfig::default()).err(),
        Some(AdaptError::NoParameters)
    );
}

#[test]
fn missing_and_absurd_observations_do_not_break_it() {
    let cfg = AdaptConfig::<f32> {
        block: 50,
        epoch: 200,
        warmup: 20,
        ..AdaptConfig::default()
    };
    let mut f = AdaptiveFilter::new(InsModel::<f32>::paper(), cfg).unwrap();
    for k in 0..1000u32 {
        let z = match k % 97 {
            3 => f32::NAN,
            5 => 1e6,
            _ => 0.01 * ((k as f32) * 0.37).sin(),
        };
        let r = f.step(z);
        if z.is_nan() {
            assert_eq!(r.status, StepStatus::Missing);
        }
    }
    assert!(f.theta().iter().all(|v| v.is_finite()));
    let e = f.estimates();
    assert!(e.sigma_delta.is_finite() && e.sigma_delta > 0.0);
    assert!(f.model().is_ok());
}

/// `WindowConfig::keep_start` (on in `AdaptConfig::global()`): a search's answer replaces the
/// start model only when it beats it by half the 95 % chi-square quantile with `p` degrees of
/// freedom, 9.488 / 2 = 4.744 nats for `paper`'s four parameters (Wilks: twice the gain of the
/// maximum over the true model is chi-square(p)). Once the filter has left the start, the margin
/// alone (0) applies, except against an answer the window does not bound (`keep_identified`).
#[test]
fn the_start_is_kept_until_a_window_rejects_it() {
    let mut f = AdaptiveFilter::new(InsModel::<f64>::paper(), AdaptConfig::global()).unwrap();
    let start = *f.theta();
    let mut found = Found::BLANK;
    found.theta = start;
    found.theta[0] += 0.5;
    found.fisher = [[0.0; MAXP]; MAXP];
    for (i, row) in found.fisher.iter_mut().enumerate() {
        row[i] = 100.0;
    }
    found.gain = 4.7;
    assert!(!f.global_end(&found), "4.7 nats do not reject the start");
    assert_eq!(*f.theta(), start);
    found.gain = 4.8;
    assert!(f.global_end(&found), "4.8 nats reject it");
    assert_eq!(f.theta()[0], start[0] + 0.5);
    // Away from the start, any gain above the margin moves the filter.
    found.theta[1] += 0.5;
    found.gain = 0.1;
    assert!(f.global_end(&found));
    assert_eq!(f.theta()[1], start[1] + 0.5);
    // An identified model (the last answer had no flat coordinate) is kept against an answer
    // whose first coordinate the window does not bound (sd 10 in `ln`), unless rejected.
    found.theta[2] += 0.5;
    found.fisher[0][0] = 0.01;
    found.gain = 4.7;
    assert!(
        !f.global_end(&found),
        "a flat answer does not replace an identified model"
    );
    assert_eq!(f.theta()[2], start[2]);
    assert_eq!(f.flat(), 0, "the model the filter runs keeps its flags");
    found.gain = 4.8;
    assert!(f.global_end(&found));
    assert_eq!(f.theta()[2], start[2] + 0.5);
    assert_eq!(f.flat() & 1, 1);
    // From a flat model, a flat answer is taken at any gain.
    found.theta[3] += 0.5;
    found.gain = 0.1;
    assert!(f.global_end(&found));
    assert_eq!(f.theta()[3], start[3] + 0.5);
    // Without the rules the first answer is taken at any gain.
    let mut cfg = AdaptConfig::global();
    cfg.global.keep_start = false;
    cfg.global.keep_identified = false;
    let mut g = AdaptiveFilter::new(InsModel::<f64>::paper(), cfg).unwrap();
    assert!(g.global_end(&found));
}

/// `WindowConfig::conservative`: the filter runs each identified intensity (`paper`'s two
/// sigmas, coordinates 0 and 2) raised by `k` of the window's marginal Cramér-Rao standard
/// deviations, at most `CONSERVATIVE_CAP`; the correlation times, and an intensity the window
/// does not bound, as answered.
#[test]
fn a_conservative_filter_runs_the_intensities_raised() {
    let mut cfg = AdaptConfig::global();
    cfg.global.keep_start = false;
    cfg.global.keep_identified = false;
    cfg.global.conservative = 1.0;
    let mut f = AdaptiveFilter::new(InsModel::<f64>::paper(), cfg).unwrap();
    let mut found = Found::BLANK;
    found.theta = *f.theta();
    for v in found.theta.iter_mut().take(4) {
        *v += 0.3;
    }
    // Marginal deviations 0.1, 0.1, 0.5 (beyond the cap) and 0.1 in `ln`.
    for (i, info) in [100.0, 100.0, 4.0, 100.0].into_iter().enumerate() {
        found.fisher[i][i] = info;
    }
    found.gain = 1.0;
    assert!(f.global_end(&found));
    let t = *f.theta();
    assert!((t[0] - (found.theta[0] + 0.1)).abs() < 1e-12, "{t:?}");
    assert_eq!(t[1], found.theta[1], "a correlation time is not raised");
    assert!((t[2] - (found.theta[2] + window::CONSERVATIVE_CAP)).abs() < 1e-12);
    assert_eq!(t[3], found.theta[3]);
    // The gyro sigma flat (deviation 10 in `ln`): run as answered.
    found.fisher[2][2] = 0.01;
    assert!(f.global_end(&found));
    assert_eq!(f.theta()[2], found.theta[2]);
    assert!((f.theta()[0] - (found.theta[0] + 0.1)).abs() < 1e-12);
}
