//! Single precision proved, not assumed: the f32 filter (the Cortex-M4F build) against the f64
//! reference over a 12-h run of the `paper` scenario, on the same observations.

use hal_sim::{scenario, sim};
use imu_ident::filter::InsFilter;

/// Bar of issue 2: |delta_hat_f32 - delta_hat_f64| <= 0.05 sigma_delta at every step, and the
/// f32 covariance positive definite at every step (Cholesky of the active block).
#[test]
fn f32_tracks_f64_over_12_hours_on_paper() {
    let model = scenario::load("paper").unwrap().to_core().unwrap();
    let log = sim::simulate(&model, 12 * 3600, 20_261_122).unwrap();
    let mut f64f = InsFilter::<f64>::new(model.clone()).unwrap();
    let mut f32f = InsFilter::<f32>::new(model.cast()).unwrap();
    let mut worst = 0.0f64;
    let mut worst_t = 0.0;
    for row in &log {
        f64f.step(row.z);
        f32f.step(row.z as f32);
        assert!(
            f32f.kalman().is_healthy(),
            "f32 P lost positive definiteness at t = {}",
            row.t
        );
        let (a, b) = (f64f.estimates(), f32f.estimates());
        let dev = (a.delta - b.delta as f64).abs() / a.sigma_delta;
        if dev > worst {
            worst = dev;
            worst_t = row.t;
        }
    }
    println!("largest |delta_f32 - delta_f64| / sigma_delta = {worst:.3e} at t = {worst_t} s");
    assert!(
        worst <= 0.05,
        "f32 deviates by {worst} sigma_delta at t = {worst_t}"
    );
}
