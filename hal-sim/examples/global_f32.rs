//! The global stage in f32 against f64 on one log (issue 13): every finished search's answer,
//! side by side. `cargo run --release -p hal-sim --example global_f32 -- [seed=1] [f=ka,ta,kg,tg]`
use hal_sim::{replay, scenario, sim};
use imu_ident::adapt::{AdaptConfig, AdaptiveFilter};
use imu_ident::Real;

fn trace<T: Real>(
    start: &imu_ident::model::InsModel<f64>,
    log: &[hal_sim::log::LogRow],
) -> Vec<(usize, [f64; imu_ident::adapt::params::MAXP], f64)> {
    let cfg = replay::adapt_config::<T>(&AdaptConfig::<f64>::global());
    let mut f = AdaptiveFilter::<T>::new(start.cast(), cfg).expect("filter");
    let mut out = Vec::new();
    let mut last = 0;
    for (k, r) in log.iter().enumerate() {
        f.step_gated(T::lit(r.z), Some(T::lit(30.0)));
        let g = f.last_global();
        if g.evaluations != last || (g.evaluations > 0 && out.is_empty()) {
            last = g.evaluations;
            out.push((k, g.theta.map(|v| v.as_f64()), g.gain.as_f64()));
        }
    }
    out
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let get = |k: &str| {
        args.iter()
            .find_map(|a| a.strip_prefix(&format!("{k}=")).map(str::to_string))
    };
    let seed: u64 = get("seed").and_then(|s| s.parse().ok()).unwrap_or(1);
    let f: Vec<f64> = get("f")
        .unwrap_or_else(|| "1,1,1,1".into())
        .split(',')
        .filter_map(|v| v.parse().ok())
        .collect();
    let truth = scenario::load("paper")?.to_core()?;
    let start =
        hal_sim::mismatch::factored(&truth, &f).ok_or_else(|| anyhow::anyhow!("start {f:?}"))?;
    let log = sim::simulate(&truth, 12 * 3600, seed)?;
    let a = trace::<f64>(&start, &log);
    let b = trace::<f32>(&start, &log);
    for (x, y) in a.iter().zip(b.iter()) {
        let d =
            x.1.iter()
                .zip(y.1.iter())
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f64::max);
        println!(
            "f64 t {} gain {:.3} | f32 t {} gain {:.3} | max |d ln theta| {:.2e}",
            x.0, x.2, y.0, y.2, d
        );
    }
    println!("searches: f64 {} f32 {}", a.len(), b.len());
    Ok(())
}
