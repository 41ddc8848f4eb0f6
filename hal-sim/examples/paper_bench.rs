//! Issue-2 figures for BENCHMARKS.md: oracle and mismatched filters on `paper` (median of 20
//! seeds, 12 h each), the largest f32-vs-f64 tilt deviation, and host steps per second.
//!
//! `cargo run --release -p hal-sim --example paper_bench`

use hal_sim::{mismatch, replay, scenario, sim, summary};
use imu_ident::telemetry::Record;
use std::time::Instant;

fn median(v: Vec<f64>) -> f64 {
    hal_sim::shared_data::median(&v)
}

fn main() -> anyhow::Result<()> {
    let truth = scenario::load("paper")?.to_core()?;
    let steps = 12 * 3600;
    let seeds: Vec<u64> = (1000..1020).collect();
    let logs: Vec<_> = seeds
        .iter()
        .map(|&s| sim::simulate(&truth, steps, s))
        .collect::<Result<_, _>>()?;
    println!("| filter | tilt RMS [µrad] (median) | outside 3σ (median) | mean NIS (median) | ratio to oracle RMS |");
    println!("|---|---|---|---|---|");
    let mut oracle_rms = f64::NAN;
    for (name, k) in [
        ("oracle (true model)", 1.0),
        ("0.1x drift and diffusion", 0.1),
        ("10x drift and diffusion", 10.0),
    ] {
        let model = mismatch::scaled(&truth, k, k);
        let (mut rms, mut out, mut nis) = (vec![], vec![], vec![]);
        for log in &logs {
            let (est, counts) = replay::estimates::<f64>(&model, log)?;
            let s = summary::summarise(log, &est, counts);
            rms.push(s.tilt_rms.unwrap_or(f64::NAN));
            out.push(s.tilt_outside_3sigma.unwrap_or(f64::NAN));
            nis.push(s.nis_mean);
        }
        let r = median(rms);
        if k == 1.0 {
            oracle_rms = r;
        }
        println!(
            "| {name} | {:.2} | {:.2} % | {:.3} | {:.2} |",
            r * 1e6,
            median(out) * 100.0,
            median(nis),
            r / oracle_rms
        );
    }

    // f32 against f64 on the same observations, every step of every seed.
    let mut worst = 0.0f64;
    for log in &logs {
        let mut a = replay::estimator::<f64>(&truth, None)?;
        let mut b = replay::estimator::<f32>(&truth, None)?;
        let mut nop = |_: &Record| {};
        for row in log {
            a.push(row.t, row.z, &mut nop);
            b.push(row.t, row.z as f32, &mut nop);
            let (ea, eb) = (a.estimates(), b.estimates());
            worst = worst.max((ea.delta - eb.delta as f64).abs() / ea.sigma_delta);
        }
    }
    println!("\nlargest |delta_f32 - delta_f64| / sigma_delta over 20 x 43200 steps: {worst:.2e}");

    // Host throughput of the step (`Estimator::push` through the replay driver: predict,
    // Joseph update, gate, estimate autocorrelators), median of 7 repeats.
    for (label, f32_mode) in [("f64", false), ("f32", true)] {
        let mut rates = vec![];
        for _ in 0..7 {
            let t0 = Instant::now();
            let mut acc = 0.0;
            let mut sink = |r: &Record| acc += f64::from(r.nis);
            if f32_mode {
                let mut f = replay::estimator::<f32>(&truth, None)?;
                replay::drive(&mut f, &logs[0], &mut sink);
            } else {
                let mut f = replay::estimator::<f64>(&truth, None)?;
                replay::drive(&mut f, &logs[0], &mut sink);
            }
            std::hint::black_box(acc);
            rates.push(steps as f64 / t0.elapsed().as_secs_f64());
        }
        println!(
            "host steps per second ({label}, NX = 8): {:.3e} (median of 7)",
            median(rates)
        );
    }
    Ok(())
}
