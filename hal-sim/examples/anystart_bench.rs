//! Issue 13's "any start" bar: per seed, 24 starts drawn log-uniformly in [0.1, 10] for
//! (sigma_a, tau_a, sigma_g, tau_g) plus the 8 one-parameter corners, each run online for 12 h;
//! tilt RMS over hours 8-12 against the oracle (true model) and against the seed's ML reference
//! (an offline Nelder-Mead fit of the same structure to hours 0-8, run as a fixed filter).
//!
//! ```text
//! cargo run --release -p hal-sim --example anystart_bench -- [first=9100] [seeds=20] [starts=32] [design=global|probes] [f32] [scenario=paper] [mlref=1] [spread=1]
//! ```
//! Each seed's line also gives the fraction of hours 8-12 outside 3 sigma for the oracle, the
//! ML reference and the seed's worst run, so that a 3-sigma tail the data's best answer shares
//! can be told from a search failure.
//! `spread=D` draws the starts within `D` decades of the truth (corners `10^±D`; the issue's
//! `D = 1`).
//! `scenario=` is a built-in name or a model TOML: its identified quantities are the `p`
//! coordinates of the starts (`2p` corners, the rest log-uniform; more than five need the
//! `imu-ident/params8` feature); `mlref=0` skips the ML reference (then the bar is the oracle).
//! `design=global` is `AdaptConfig::global()`; the environment overrides its window settings
//! for experiments (`BLOCK`, `WIN`, `FIRST`, `EVERY`, `BUDGET`, `PM` probe factor, `GN` set:
//! recursion not held, `PEN` the structure test's penalty, `MARGIN` the jump margin [nats],
//! `KEEP=0` the start model not kept until rejected, `KEEPID=0` an identified model not kept
//! against a flat answer, `FILLING` the blocks between searches while the window fills);
//! `RUNS=FILE` appends every run's `seed,start,tilt ratio,% outside 3 sigma` to FILE for
//! paired comparisons; `TRACE=1` also prints the exact start of every run beyond 1.05x (for
//! `structure_bench START=...`: a rounded start can take another path); `PARAMS=1` prints the
//! ML reference's factors against the truth and every run's parameter rows (when and to what
//! each search moved the model). `design=probes` is `AdaptConfig::default()`, today's design.
#![allow(clippy::needless_range_loop)]

use hal_sim::adaptive::{self, tilt_window};
use hal_sim::{replay, scenario, sim};
use imu_ident::adapt::AdaptConfig;
use rand::{Rng, SeedableRng};

#[path = "bench_args/mod.rs"]
mod bench_args;
use bench_args::ml::{ml_fit, set, theta};
use bench_args::{arg_or, flag, pct};

fn main() -> anyhow::Result<()> {
    let first: u64 = arg_or("first", 9100);
    let seeds: u64 = arg_or("seeds", 20);
    let nstarts: usize = arg_or("starts", 32);
    let design: String = arg_or("design", "global".into());
    let f32_mode = flag("f32");
    let mut cfg = AdaptConfig::<f64>::default();
    if design == "global" {
        cfg = AdaptConfig::global();
        if let Ok(v) = std::env::var("PM") {
            cfg.probe_factor = v.parse()?;
        }
        if std::env::var("GN").is_ok() {
            cfg.global.hold_recursion = false;
        }
        bench_args::window_env(&mut cfg.global);
        println!("{:?}", cfg.global);
    }
    let scenario_name: String = arg_or("scenario", "paper".into());
    let with_ml: bool = arg_or("mlref", 1u8) != 0;
    let truth = scenario::load(&scenario_name)?.to_core()?;
    let th0 = theta(&truth);
    let np = th0.len();
    println!("scenario {scenario_name}: {np} identified parameters");
    let (t0, t1) = (8.0 * 3600.0, 12.0 * 3600.0 + 1.0);
    // `spread=D`: starts wrong by up to `D` decades (the issue's 1; smaller for starts near
    // the truth, which a window may not reject).
    let spread: f64 = arg_or("spread", 1.0);
    let mut corners: Vec<Vec<f64>> = Vec::new();
    for i in 0..np {
        for k in [10f64.powf(spread), 10f64.powf(-spread)] {
            let mut f = vec![1.0; np];
            f[i] = k;
            corners.push(f);
        }
    }
    let (mut r_or, mut r_ml, mut outs, mut worst_vs_ref) = (vec![], vec![], vec![], vec![]);
    let mut truth_ratio = vec![];
    let mut false_alarms = 0usize;
    let mut flat_runs = 0usize;
    println!(
        "design {design}, seeds {first}..{}, {nstarts} starts",
        first + seeds
    );
    for seed in first..first + seeds {
        let log = sim::simulate(&truth, 12 * 3600, seed)?;
        let tilt = |e: &[hal_sim::records::EstimateRow]| tilt_window(&log, e, t0, t1).unwrap();
        let (oracle, oracle_out) = tilt(&replay::estimates::<f64>(&truth, &log)?.0);
        let (plocal, pglobal, llocal, lglobal) = if with_ml {
            ml_fit(&truth, &log[..8 * 3600], f64::NEG_INFINITY)
        } else {
            (th0.clone(), th0.clone(), 0.0, 0.0)
        };
        let pref = if lglobal > llocal { &pglobal } else { &plocal };
        let (mlref, mlref_out) = tilt(&replay::estimates::<f64>(&set(&truth, pref), &log)?.0);
        let ml_local = tilt(&replay::estimates::<f64>(&set(&truth, &plocal), &log)?.0).0;
        let bar = (mlref / oracle).max(1.0);
        if std::env::var_os("PARAMS").is_some() {
            let f: Vec<String> = pref
                .iter()
                .zip(th0.iter())
                .map(|(a, b)| format!("{:.3}", (a - b).exp()))
                .collect();
            println!(
                "  ML ref factors vs truth [{}] ll local {llocal:.2} global {lglobal:.2}",
                f.join(",")
            );
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed * 7919);
        let mut starts: Vec<Vec<f64>> = corners.clone();
        while starts.len() < nstarts.max(2 * np) {
            let mut f = vec![0.0; np];
            for v in f.iter_mut() {
                *v = 10f64.powf(rng.gen_range(-spread..spread));
            }
            starts.push(f);
        }
        starts.truncate(nstarts);
        starts.push(vec![1.0; np]);
        let mut worst: f64 = 0.0;
        let mut worst_out: f64 = 0.0;
        let mut line = String::new();
        for (k, f) in starts.iter().enumerate() {
            let s0: Vec<f64> = th0.iter().zip(f.iter()).map(|(a, k)| a + k.ln()).collect();
            let start = set(&truth, &s0);
            let r = if f32_mode {
                adaptive::run::<f32>(&start, &log, cfg)?
            } else {
                adaptive::run::<f64>(&start, &log, cfg)?
            };
            let (rms, out) = tilt(&r.estimates);
            if std::env::var_os("PARAMS").is_some() {
                // The run's parameter rows (written when the model changes).
                for p in r.params.iter() {
                    println!(
                        "    t {:.2} h {}{} tau {:.0} sigma {:.3e}",
                        p.t / 3600.0,
                        p.sensor,
                        p.component,
                        p.tau,
                        p.sigma
                    );
                }
            }
            let ratio = rms / oracle;
            // Changes found on a stationary log are false alarms: count them.
            let alarms = r.flagged_hours(imu_ident::telemetry::SENSOR_CHANGE);
            if !alarms.is_empty() {
                false_alarms += 1;
                if std::env::var_os("TRACE").is_some() {
                    println!(
                        "  seed {seed} from {f:.2?}: change found at {alarms:.2?} h, dated {:.2?} h",
                        r.last_change.map(|t| t / 3600.0)
                    );
                }
            }
            // Runs that spent part of the scored hours on a parameter flagged not identifiable.
            let flat = r.estimates.iter().any(|e| {
                e.t >= t0 && e.t < t1 && e.flags & imu_ident::telemetry::NOT_IDENTIFIABLE != 0
            });
            flat_runs += usize::from(flat);
            if k == starts.len() - 1 {
                truth_ratio.push(ratio);
                continue;
            }
            if let Some(path) = std::env::var_os("RUNS") {
                use std::io::Write;
                let mut f = std::fs::OpenOptions::new()
                    .create(true)
                    .append(true)
                    .open(path)?;
                writeln!(f, "{seed},{k},{ratio},{}", out * 100.0)?;
            }
            r_or.push(ratio);
            r_ml.push(rms / mlref);
            outs.push(out * 100.0);
            worst_out = worst_out.max(out * 100.0);
            worst = worst.max(ratio / bar);
            if ratio > 1.05 * bar {
                if std::env::var_os("TRACE").is_some() {
                    // The exact start, for `structure_bench START=...` (rounded starts can
                    // take another path).
                    println!("  seed {seed} exact start {f:?} -> {ratio:.3}");
                }
                let f: Vec<String> = f.iter().map(|v| format!("{v:.2}")).collect();
                line += &format!(" [{}]->{:.3}", f.join(","), ratio);
            }
        }
        worst_vs_ref.push(worst);
        println!(
            "seed {seed}: ML ref {:.3}x oracle (local fit from the truth {:.3}x, {:+.1} nats); from truth {:.3}x; worst run / max(ML ref, oracle) {:.3}{}; outside 3 sigma: oracle {:.2} %, ML ref {:.2} %, runs max {:.2} %",
            mlref / oracle,
            ml_local / oracle,
            llocal - lglobal.max(llocal),
            truth_ratio.last().unwrap(),
            worst,
            line,
            oracle_out * 100.0,
            mlref_out * 100.0,
            worst_out
        );
    }
    let n = r_or.len();
    let within = worst_vs_ref.iter().filter(|w| **w <= 1.05).count();
    println!(
        "runs {n}: tilt/oracle median {:.4} p95 {:.4} max {:.4}; outside 3 sigma median {:.2} % p95 {:.2} % max {:.2} %",
        pct(&mut r_or.clone(), 0.5),
        pct(&mut r_or.clone(), 0.95),
        pct(&mut r_or.clone(), 1.0),
        pct(&mut outs.clone(), 0.5),
        pct(&mut outs.clone(), 0.95),
        pct(&mut outs.clone(), 1.0)
    );
    println!(
        "seeds with every run within 1.05x of max(ML ref, oracle): {within}/{}; from truth median {:.4} max {:.4}",
        worst_vs_ref.len(),
        pct(&mut truth_ratio.clone(), 0.5),
        pct(&mut truth_ratio.clone(), 1.0)
    );
    println!("runs with a change found (false alarms: the logs are stationary): {false_alarms}");
    println!("runs with a parameter flagged not identifiable in the scored hours (of all, truth starts included): {flat_runs}");
    Ok(())
}
