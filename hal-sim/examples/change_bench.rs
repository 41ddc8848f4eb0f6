//! Issue 13's "change in service" bar: BENCHMARKS.md §6's setup (6 h from the truth A, then
//! 12 h from B, a fresh stationary state at the seam), but B has A's four parameters
//! (sigma_a, tau_a, sigma_g, tau_g) each multiplied by a factor drawn log-uniformly in
//! [0.1, 10]. The bar: within 6 h of the change the filter is within 1.10x oracle B, measured
//! here as tilt RMS over hours 12-18 (6-12 h after the change) against the filter that knows B.
//!
//! ```text
//! cargo run --release -p hal-sim --example change_bench -- [first=9700] [seeds=20] [design=global|probes]
//! ```
//! `EVERY`, `BUDGET` override the global stage's pace (host pace: `EVERY=120 BUDGET=1000`).

use hal_sim::adaptive::{self, tilt_window};
use hal_sim::{mismatch, replay, sim};
use imu_ident::adapt::AdaptConfig;
use imu_ident::model::InsModel;
use rand::{Rng, SeedableRng};

#[path = "bench_args/mod.rs"]
mod bench_args;
use bench_args::{arg_or, env_or, pct};

fn main() -> anyhow::Result<()> {
    let first: u64 = arg_or("first", 9700);
    let seeds: u64 = arg_or("seeds", 20);
    let design: String = arg_or("design", "global".into());
    let mut cfg = if design == "global" {
        AdaptConfig::<f64>::global()
    } else {
        AdaptConfig::default()
    };
    cfg.global.every = env_or("EVERY", cfg.global.every);
    cfg.global.budget = env_or("BUDGET", cfg.global.budget);
    let a = InsModel::<f64>::paper();
    let (t0, t1) = (12.0 * 3600.0, 18.0 * 3600.0 + 1.0);
    let (mut ratios, mut fixed, mut outs) = (vec![], vec![], vec![]);
    for seed in first..first + seeds {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed * 7919 + 13);
        let f: Vec<f64> = (0..4)
            .map(|_| 10f64.powf(rng.gen_range(-1.0..1.0)))
            .collect();
        let b = mismatch::factored(&a, &f).ok_or_else(|| anyhow::anyhow!("factors {f:?}"))?;
        let log = sim::simulate_change(&a, &b, 6 * 3600, 12 * 3600, seed)?;
        let (oracle, _) = replay::estimates::<f64>(&b, &log)?;
        let (orms, _) = tilt_window(&log, &oracle, t0, t1).unwrap_or((f64::NAN, 0.0));
        let r = adaptive::run::<f64>(&a, &log, cfg)?;
        let (rms, out) = tilt_window(&log, &r.estimates, t0, t1).unwrap_or((f64::NAN, 1.0));
        let (fa, _) = replay::estimates::<f64>(&a, &log)?;
        let (frms, _) = tilt_window(&log, &fa, t0, t1).unwrap_or((f64::NAN, 0.0));
        println!(
            "seed {seed}: factors [{:.2}, {:.2}, {:.2}, {:.2}]: adaptive {:.3}x oracle B, fixed A {:.3}x, outside 3 sigma {:.2} %",
            f[0],
            f[1],
            f[2],
            f[3],
            rms / orms,
            frms / orms,
            100.0 * out
        );
        ratios.push(rms / orms);
        fixed.push(frms / orms);
        outs.push(100.0 * out);
    }
    let within = ratios.iter().filter(|r| **r <= 1.10).count();
    println!(
        "design {design}, seeds {first}..{}: tilt/oracle B over hours 12-18 median {:.3} p95 {:.3} max {:.3}; within 1.10x {within}/{}; fixed A median {:.3} max {:.3}; outside 3 sigma median {:.2} % max {:.2} %",
        first + seeds,
        pct(&mut ratios.clone(), 0.5),
        pct(&mut ratios.clone(), 0.95),
        pct(&mut ratios.clone(), 1.0),
        ratios.len(),
        pct(&mut fixed.clone(), 0.5),
        pct(&mut fixed.clone(), 1.0),
        pct(&mut outs.clone(), 0.5),
        pct(&mut outs.clone(), 1.0)
    );
    Ok(())
}
