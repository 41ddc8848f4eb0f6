//! Unit tests of the adaptive filter: configuration and model errors are values, and bad
//! observations do not break it.

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
