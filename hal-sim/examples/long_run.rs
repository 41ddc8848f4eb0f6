//! Long run (issue 7): 1e7 steps (about 115 days at 1 Hz) of the f32 filter on `paper` against
//! the f64 filter on the same observations. Reports the largest |delta_f32 - delta_f64| /
//! sigma_delta, whether the f32 covariance stayed positive definite at every step, and repairs.
//!
//! `cargo run --release -p hal-sim --example long_run [-- STEPS]`

use hal_sim::{scenario, sim};
use imu_ident::filter::{is_positive_definite, InsFilter};

fn main() -> anyhow::Result<()> {
    let steps: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000_000);
    let model = scenario::load("paper")?.to_core()?;
    let mut a = InsFilter::<f64>::new(model.clone())?;
    let mut b = InsFilter::<f32>::new(model.cast())?;
    let chunk = 43_200;
    let (mut worst, mut worst_t, mut not_pd, mut repairs) = (0.0f64, 0usize, 0usize, 0usize);
    let mut done = 0;
    let mut seed = 7_000_000;
    while done < steps {
        // Independent 12-h truth segments, continued by the same filters.
        let log = sim::simulate(&model, chunk.min(steps - done), seed)?;
        seed += 1;
        for row in &log {
            a.step(row.z);
            b.step(row.z as f32);
            repairs += b.repair() as usize;
            not_pd += !is_positive_definite(&b.kalman().P, b.kalman().active()) as usize;
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
