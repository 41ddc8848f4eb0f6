//! Any observation sequence is safe for the f32 filter (the firmware precision): NaN, +-Inf,
//! 1e30, subnormals, zero-variance runs, dropouts and outliers never panic, and after each step
//! (with the covariance repair the step runs) the estimate is finite and P symmetric positive
//! definite.

use imu_ident::filter::{is_positive_definite, InsFilter, UpdateStatus};
use imu_ident::model::InsModel;
use proptest::prelude::*;

fn hostile() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -0.2f32..0.2,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(1e30f32),
        1 => Just(-1e30f32),
        1 => Just(f32::MAX),
        1 => Just(f32::MIN_POSITIVE / 4.0),
        1 => Just(0.0f32),
        1 => -1e6f32..1e6,
    ]
}

fn check_healthy(f: &InsFilter<f32>) {
    let p = &f.kalman().P;
    let n = f.kalman().active();
    assert!(f.kalman().x.iter().all(|v| v.is_finite()));
    assert!(is_positive_definite(p, n), "P not positive definite: {p:?}");
    for (i, row) in p.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            assert_eq!(*v, p[j][i], "P not symmetric at ({i},{j})");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Ungated filter: hostile values pass straight into the update.
    #[test]
    fn any_sequence_keeps_the_filter_healthy(zs in proptest::collection::vec(hostile(), 1..400)) {
        let mut f = InsFilter::<f32>::new(InsModel::paper()).unwrap();
        for z in zs {
            let inn = f.step(z);
            f.repair();
            if !z.is_finite() {
                prop_assert_eq!(inn.status, UpdateStatus::Missing);
            }
            check_healthy(&f);
        }
    }

    /// With a chi-square gate, outliers are rejected and flagged instead of used.
    #[test]
    fn gate_rejects_outliers(zs in proptest::collection::vec(hostile(), 1..400)) {
        let mut f = InsFilter::<f32>::new(InsModel::paper()).unwrap();
        // 1-dof chi-square at p = 1e-6.
        f.set_gate(Some(23.9));
        for z in zs {
            let inn = f.step(z);
            f.repair();
            if inn.status == UpdateStatus::Updated {
                prop_assert!(inn.nis <= 23.9);
            }
            check_healthy(&f);
        }
    }
}

/// A dropout of 6 hours (no observations), then data again: P grows but stays healthy, and the
/// filter recovers (its velocity sigma returns below sigma_v within a minute of data).
#[test]
fn recovers_after_a_six_hour_dropout() {
    let mut f = InsFilter::<f32>::new(InsModel::paper()).unwrap();
    for _ in 0..6 * 3600 {
        f.step(f32::NAN);
        assert!(!f.repair());
    }
    check_healthy(&f);
    let before = f.estimates().sigma_dv;
    for _ in 0..60 {
        f.step(0.0);
        assert!(!f.repair());
    }
    check_healthy(&f);
    assert!(
        before > 0.03 && f.estimates().sigma_dv < 0.03,
        "sigma_dv {before} -> {}",
        f.estimates().sigma_dv
    );
}
