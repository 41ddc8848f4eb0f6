use hal_sim::{scenario, sim};
use imu_ident::adapt::{AdaptConfig, AdaptiveFilter, WindowConfig};
fn main() -> anyhow::Result<()> {
    let truth = scenario::load("paper")?.to_core()?;
    let seed: u64 = std::env::var("SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1001);
    let log = sim::simulate(&truth, 12 * 3600, seed)?;
    let fs: Vec<f64> = std::env::var("F")
        .unwrap_or("1,1,1,1".into())
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let mut start = truth.clone();
    for (k, comps) in [&mut start.accel, &mut start.gyro].into_iter().enumerate() {
        if let Some(imu_ident::model::Component::GaussMarkov(g)) = comps.first_mut() {
            g.sigma *= fs[2 * k];
            g.tau *= fs[2 * k + 1];
        }
    }
    let mut cfg = AdaptConfig::<f64>::default();
    cfg.global = WindowConfig::default_on();
    if let Ok(b) = std::env::var("BUDGET") {
        cfg.global.budget = b.parse().unwrap();
    }
    cfg.probe_factor = 0.0;
    if std::env::var("NOGN").is_ok() {
        cfg.block = 1_000_000;
    }
    let th0 = *AdaptiveFilter::new(truth.clone(), cfg).unwrap().theta();
    let mut f = AdaptiveFilter::new(start, cfg).unwrap();
    let mut last = 0;
    for (k, r) in log.iter().enumerate() {
        f.step_gated(r.z, Some(30.0));
        let g = f.last_global();
        if g.evaluations != last || (k % 1800 == 0) {
            last = g.evaluations;
            let d: Vec<String> = f
                .theta()
                .iter()
                .zip(&th0)
                .map(|(a, b)| format!("{:.2}", (a - b).exp()))
                .collect();
            let gd: Vec<String> = g
                .theta
                .iter()
                .zip(&th0)
                .map(|(a, b)| format!("{:.2}", (a - b).exp()))
                .collect();
            if g.evaluations > 0 && k % 1800 != 0 {
                let b = f.base().clone();
                let sp = f.specs().clone();
                let a = f.global().window_loglik(&b, &sp, &g.theta);
                let nan = f
                    .global()
                    .window_blocks()
                    .filter(|v| !v.is_finite())
                    .count();
                let t0 = f.global().window_loglik(&b, &sp, &th0);
                println!("   window ll at found {a:?}, at truth {t0:?}, missing blocks {nan}");
            }
            println!(
                "t {k} theta/truth {d:?} found {gd:?} gain {:.2} blocks {} evals {}",
                g.gain, g.blocks, g.evaluations
            );
        }
    }
    let rows: Vec<hal_sim::log::LogRow> = f
        .global()
        .window_blocks()
        .enumerate()
        .map(|(i, z)| hal_sim::log::LogRow {
            t: 10.0 * (i + 1) as f64,
            z,
            truth: None,
        })
        .collect();
    let mut dt = truth.clone();
    dt.dt = 10.0;
    dt.sigma_v /= 10f64.sqrt();
    let (ll, n) = hal_sim::replay::log_likelihood(&dt, &rows)?;
    let sp = f.specs().clone();
    println!(
        "replay ll {ll} n {n}; window ll {:?}",
        f.global().window_loglik(&truth, &sp, &th0)
    );
    let zs: Vec<f64> = f.global().window_blocks().collect();
    println!("first blocks {:?} last {:?}", &zs[..5], &zs[zs.len() - 5..]);
    let lz: Vec<f64> = log.iter().map(|r| r.z).collect();
    let m: Vec<f64> = lz
        .chunks(10)
        .map(|c| c.iter().sum::<f64>() / 10.0)
        .collect();
    println!("log blocks near end {:?}", &m[m.len() - 5..]);
    Ok(())
}
