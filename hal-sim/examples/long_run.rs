//! Long run (issue 7): 1e7 steps (about 115 days at 1 Hz) of the f32 filter on `paper` against
//! the f64 filter on the same observations. Reports the largest |delta_f32 - delta_f64| /
//! sigma_delta, whether the f32 covariance stayed positive definite at every step, and repairs.
//!
//! `cargo run --release -p hal-sim --example long_run [-- STEPS]`

use hal_sim::{replay, scenario, sim};
use imu_ident::filter::is_positive_definite;
use imu_ident::telemetry::{Record, P_REPAIRED};

fn main() -> anyhow::Result<()> {
    let steps: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000_000);
    let model = scenario::load("paper")?.to_core()?;
    let mut a = replay::estimator::<f64>(&model, None)?;
    let mut b = replay::estimator::<f32>(&model, None)?;
    let chunk = 43_200;
    let (mut worst, mut worst_t, mut not_pd, mut repairs) = (0.0f64, 0usize, 0usize, 0usize);
    let mut done = 0;
    let mut seed = 7_000_000;
    while done < steps {
        // Independent 12-h truth segments, continued by the same filters.
        let log = sim::simulate(&model, chunk.min(steps - done), seed)?;
        seed += 1;
        // Segment times continue the clock of the previous segments.
        let t0 = done as f64 * model.dt;
        for row in &log {
            a.push(t0 + row.t, row.z, &mut |_: &Record| {});
            b.push(t0 + row.t, row.z as f32, &mut |r: &Record| {
                repairs += usize::from(r.has(P_REPAIRED));
            });
            // P is symmetric: the column-major array is P itself.
            let (p, n) = b.covariance_scaled();
            let p: [[f32; 8]; 8] = p.into();
            not_pd += !is_positive_definite(&p, n) as usize;
            let (ea, eb) = (a.estimates(), b.estimates());
            let d = (ea.delta - eb.delta as f64).abs() / ea.sigma_delta;
            if d > worst {
                worst = d;
                worst_t = done;
            }
            done += 1;
        }
    }
    println!("steps {done}: largest |delta_f32 - delta_f64| / sigma_delta = {worst:.3e} (step {worst_t}); steps with f32 P not positive definite: {not_pd}; repairs: {repairs}");
    Ok(())
}
