//! The issue-3 table: the adaptive filter on the `paper` scenario from wrong starts, medians over
//! seeds, against the oracle (fixed true model on the same log), plus the baselines.
//!
//! ```text
//! CARGO_TARGET_DIR=/work/target-adapt cargo run --release -p hal-sim --example adaptive_bench -- \
//!     [seeds=20] [methods=rgn,acf-paper,acf-corr,fixed] [f32]
//! ```
//! Tuning overrides through the environment (for experiments): `K` (block), `H`, `W` (window, s),
//! `DAMP`, `HYST`, `MAXSTEP`.

// Table code indexes several parallel arrays by sensor and parameter number.
#![allow(clippy::needless_range_loop)]

use hal_sim::adaptive::{self, gm_params, run_acf_loop, tilt_window, AcfVariant};
use hal_sim::{mismatch, replay, scenario, sim};
use imu_ident::adapt::AdaptConfig;
use imu_ident::model::{ErrorSource, InsModel};
use std::time::Instant;

const STEPS: usize = 12 * 3600;
const T0: f64 = 8.0 * 3600.0;
const T1: f64 = 12.0 * 3600.0 + 1.0;

fn env(name: &str, default: f64) -> f64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn median(v: &mut [f64]) -> f64 {
    hal_sim::shared_data::median(v)
}

fn std_ln(v: &[f64], truth: f64) -> (f64, f64) {
    // (RMS of ln(v/truth), std of ln v): accuracy and spread in relative units.
    let l: Vec<f64> = v.iter().map(|x| (x / truth).ln()).collect();
    let n = l.len() as f64;
    let m = l.iter().sum::<f64>() / n;
    let rms = (l.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
    let sd = (l.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
    (rms, sd)
}

struct Row {
    ratio: f64,
    outside: f64,
    est: [(f64, f64); 2],
    crb: Option<[f64; imu_ident::adapt::params::MAXP]>,
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let get = |k: &str| {
        args.iter()
            .find_map(|a| a.strip_prefix(&format!("{k}=")).map(str::to_string))
    };
    let seeds: u64 = get("seeds").and_then(|s| s.parse().ok()).unwrap_or(20);
    let methods = get("methods").unwrap_or_else(|| "rgn".into());
    let f32_mode = args.iter().any(|a| a == "f32");
    let trace = args.iter().any(|a| a == "trace");
    let starts: Vec<(f64, f64)> = match get("starts") {
        Some(s) if s == "truth" => vec![(1.0, 1.0)],
        Some(s) if s.contains(',') => {
            let v: Vec<f64> = s.split(',').filter_map(|x| x.parse().ok()).collect();
            vec![(v[0], v[1])]
        }
        _ => vec![
            (1.0, 1.0),
            (0.1, 0.1),
            (10.0, 10.0),
            (0.1, 10.0),
            (10.0, 0.1),
        ],
    };
    let d = AdaptConfig::<f64>::default();
    let cfg = AdaptConfig {
        block: env("K", f64::from(d.block)) as u32,
        h: env("H", d.h),
        window: env("W", d.window),
        damping: env("DAMP", d.damping),
        hysteresis: env("HYST", d.hysteresis),
        max_step: env("MAXSTEP", d.max_step),
        move_discount: env("BETA", d.move_discount),
        probe_factor: env("PM", d.probe_factor),
        epoch: env("EPOCH", f64::from(d.epoch)) as u32,
        warmup: env("WARM", f64::from(d.warmup)) as u32,
        margin: env("MARGIN", d.margin),
        first_margin: env("FMARGIN", d.first_margin),
        hold_first_epoch: env("HOLD", 1.0) > 0.5,
        search_until_settled: env("SEARCH", 1.0) > 0.5,
        ..d
    };
    println!("config {cfg:?}, seeds {seeds}, f32 {f32_mode}");
    let truth = scenario::load("paper")?.to_core()?;
    let tv = [
        gm_params(&truth, ErrorSource::Accel).unwrap_or_default(),
        gm_params(&truth, ErrorSource::Gyro).unwrap_or_default(),
    ];
    if methods == "cost" {
        return cost(&truth, cfg);
    }
    if methods == "cost32" {
        // One f32 adaptive run only, for instruction counting under valgrind --tool=callgrind.
        let log = sim::simulate(&truth, STEPS, 4242)?;
        let start = mismatch::scaled(&truth, 10.0, 10.0);
        let r = adaptive::run::<f32>(&start, &log, cfg)?;
        println!("jumps {} updates {}", r.jumps, r.updates);
        return Ok(());
    }
    if methods == "crb" {
        return crb(&truth, seeds);
    }
    if methods == "track" {
        return track(&truth, seeds, cfg);
    }
    let acf_window: usize = get("acfwin").and_then(|s| s.parse().ok()).unwrap_or(3600);
    for method in methods.split(',') {
        println!("\n## method {method}");
        println!("| start (ka, kg) | tilt RMS / oracle (med, max) | outside 3 sigma % (med, max) | accel tau | accel sigma | gyro tau | gyro sigma | rms ln err (ta, sa, tg, sg) | ns/step |");
        println!("|---|---|---|---|---|---|---|---|---|");
        for &(ka, kg) in &starts {
            let mut start = mismatch::scaled(&truth, ka, kg);
            // `SIGMA=k`: also multiply every Gauss-Markov sigma of the start by k (tau kept).
            let ks = env("SIGMA", 1.0);
            for c in start.accel.iter_mut().chain(start.gyro.iter_mut()) {
                if let imu_ident::model::Component::GaussMarkov(g) = c {
                    g.sigma *= ks;
                }
            }
            let mut rows = Vec::new();
            let t_run = Instant::now();
            let mut steps = 0usize;
            for seed in 0..seeds {
                let log = sim::simulate(&truth, STEPS, 1000 + seed)?;
                let (oracle, _) = replay::estimates::<f64>(&truth, &log)?;
                let (orms, _) = tilt_window(&log, &oracle, T0, T1).unwrap_or((f64::NAN, 0.0));
                let (est, model, crb): (_, InsModel<f64>, _) = match method {
                    "rgn" => {
                        let r = if f32_mode {
                            adaptive::run::<f32>(&start, &log, cfg)?
                        } else {
                            adaptive::run::<f64>(&start, &log, cfg)?
                        };
                        if trace {
                            let ll = |m: &InsModel<f64>| -> f64 {
                                let (e, _) = replay::estimates::<f64>(m, &log).unwrap();
                                e.iter()
                                    .map(|r| -0.5 * (r.innovation_var.ln() + r.nis))
                                    .sum()
                            };
                            println!(
                                "  LL truth {:.2} start {:.2} final {:.2}",
                                ll(&truth),
                                ll(&start),
                                ll(&r.final_model)
                            );
                            println!(
                                "  final {:?} {:?} jumps {} updates {}",
                                gm_params(&r.final_model, ErrorSource::Accel),
                                gm_params(&r.final_model, ErrorSource::Gyro),
                                r.jumps,
                                r.updates
                            );
                            for p in r
                                .params
                                .iter()
                                .filter(|_| seed == 0 && std::env::var("TR").is_ok())
                                .filter(|p| p.t % 1800.0 == 0.0)
                            {
                                println!(
                                    "  t {:6.0} {:5} tau {:10.3} sigma {:.4e}",
                                    p.t, p.sensor, p.tau, p.sigma
                                );
                            }
                        }
                        (r.estimates, r.final_model, r.crb)
                    }
                    "acf-paper" => {
                        let (e, m) =
                            run_acf_loop(&start, &log, AcfVariant::Paper, 600, acf_window, 200)?;
                        (e, m, None)
                    }
                    "acf-corr" => {
                        let (e, m) = run_acf_loop(
                            &start,
                            &log,
                            AcfVariant::Corrected,
                            600,
                            acf_window,
                            200,
                        )?;
                        (e, m, None)
                    }
                    _ => {
                        let (e, _) = replay::estimates::<f64>(&start, &log)?;
                        (e, start.clone(), None)
                    }
                };
                steps += est.len();
                let (rms, out) = tilt_window(&log, &est, T0, T1).unwrap_or((f64::NAN, 1.0));
                rows.push(Row {
                    ratio: rms / orms,
                    outside: out,
                    est: [
                        gm_params(&model, ErrorSource::Accel).unwrap_or_default(),
                        gm_params(&model, ErrorSource::Gyro).unwrap_or_default(),
                    ],
                    crb,
                });
            }
            let ns = t_run.elapsed().as_nanos() as f64 / steps as f64;
            let mut ratio: Vec<f64> = rows.iter().map(|r| r.ratio).collect();
            let mut out: Vec<f64> = rows.iter().map(|r| r.outside * 100.0).collect();
            let rmax = ratio.iter().cloned().fold(f64::MIN, f64::max);
            let omax = out.iter().cloned().fold(f64::MIN, f64::max);
            let mut cells = Vec::new();
            let mut errs = Vec::new();
            for s in 0..2 {
                for (q, truth_v) in [(0usize, tv[s].0), (1, tv[s].1)] {
                    let v: Vec<f64> = rows
                        .iter()
                        .map(|r| if q == 0 { r.est[s].0 } else { r.est[s].1 })
                        .collect();
                    let mut vv = v.clone();
                    let med = median(&mut vv);
                    cells.push(format!("{:.3}x", med / truth_v));
                    errs.push(format!("{:.2}", std_ln(&v, truth_v).0));
                }
            }
            println!(
                "| {ka}, {kg} | {:.3}, {:.3} | {:.2}, {:.2} | {} | {} | {} | {} | {} | {:.0} |",
                median(&mut ratio),
                rmax,
                median(&mut out),
                omax,
                cells[0],
                cells[1],
                cells[2],
                cells[3],
                errs.join(", "),
                ns
            );
            if method == "rgn" && ka == 1.0 && kg == 1.0 {
                let c: Vec<[f64; imu_ident::adapt::params::MAXP]> =
                    rows.iter().filter_map(|r| r.crb).collect();
                if let Some(first) = c.first() {
                    println!("  sqrt(I_total^-1) of ln(sigma_a, tau_a, sigma_g, tau_g), seed 0: {first:.3?}");
                }
            }
        }
    }
    Ok(())
}

/// Host cost per step of the adaptive filter alone (f64 and f32) against the plain filter, on one
/// 12-h log, the best of three repetitions; and the f32-vs-f64 agreement of the tilt estimates.
fn cost(truth: &InsModel<f64>, cfg: AdaptConfig<f64>) -> anyhow::Result<()> {
    let log = sim::simulate(truth, STEPS, 4242)?;
    let start = mismatch::scaled(truth, 10.0, 10.0);
    let time = |f: &dyn Fn() -> anyhow::Result<()>| -> anyhow::Result<f64> {
        let mut best = f64::MAX;
        for _ in 0..3 {
            let t = Instant::now();
            f()?;
            best = best.min(t.elapsed().as_nanos() as f64 / STEPS as f64);
        }
        Ok(best)
    };
    let plain = time(&|| replay::estimates::<f64>(truth, &log).map(|_| ()))?;
    let plain32 = time(&|| replay::estimates::<f32>(truth, &log).map(|_| ()))?;
    let a64 = time(&|| adaptive::run::<f64>(&start, &log, cfg).map(|_| ()))?;
    let a32 = time(&|| adaptive::run::<f32>(&start, &log, cfg).map(|_| ()))?;
    println!("| filter | ns/step (host, incl. estimate rows) |");
    println!("|---|---|");
    println!("| plain InsFilter f64 | {plain:.0} |");
    println!("| plain InsFilter f32 | {plain32:.0} |");
    println!("| adaptive (bank + probes) f64 | {a64:.0} |");
    println!("| adaptive (bank + probes) f32 | {a32:.0} |");
    println!(
        "size_of AdaptiveFilter<f32> = {} bytes, <f64> = {} bytes",
        std::mem::size_of::<imu_ident::adapt::AdaptiveFilter<f32>>(),
        std::mem::size_of::<imu_ident::adapt::AdaptiveFilter<f64>>()
    );
    // Per-row host time of the f32 step identifying online (`Estimator::push`, no estimate
    // rows): mean, 99.9 % and worst row.
    let mut f = replay::estimator::<f32>(&start, Some(&cfg))?;
    let mut ns: Vec<f64> = Vec::with_capacity(log.len());
    for r in &log {
        let t = Instant::now();
        f.push(
            r.t,
            r.z as f32,
            &mut |rec: &imu_ident::telemetry::Record| {
                std::hint::black_box(rec);
            },
        );
        ns.push(t.elapsed().as_nanos() as f64);
    }
    let mean = ns.iter().sum::<f64>() / ns.len() as f64;
    ns.sort_by(|a, b| a.total_cmp(b));
    println!(
        "f32 step (push): mean {mean:.0} ns, median {:.0}, 99.9 % {:.0}, worst {:.0} ns",
        ns[ns.len() / 2],
        ns[ns.len() * 999 / 1000],
        ns[ns.len() - 1]
    );
    let r64 = adaptive::run::<f64>(&start, &log, cfg)?;
    let r32 = adaptive::run::<f32>(&start, &log, cfg)?;
    let (rms64, _) = tilt_window(&log, &r64.estimates, T0, T1).unwrap_or_default();
    let (rms32, _) = tilt_window(&log, &r32.estimates, T0, T1).unwrap_or_default();
    let dmax = r64
        .estimates
        .iter()
        .zip(&r32.estimates)
        .map(|(a, b)| ((a.delta_hat - b.delta_hat) / a.sigma_delta).abs())
        .fold(0.0, f64::max);
    println!(
        "f32 vs f64 from (10, 10): tilt RMS h8-12 {rms32:.4e} vs {rms64:.4e}; max |d delta_hat| / sigma_delta {dmax:.3}"
    );
    println!(
        "theta f64 {:?}\ntheta f32 {:?}\njumps {} / {}, updates {} / {}",
        r64.theta, r32.theta, r64.jumps, r32.jumps, r64.updates, r32.updates
    );
    Ok(())
}

/// The Cramér-Rao bound of the identified parameters from z: the bank at the true model with
/// adaptation off accumulates the Fisher information of the innovation likelihood by finite
/// differences over 12 h; `sqrt(diag(I^-1))` is the bound on the standard deviation of each
/// `ln` parameter. Reported per seed (median) and from the mean information, with the check of
/// the information equality: at the truth the score `g` has covariance `I`, so
/// `g^T I^-1 g ~ chi2(4)` with mean 4.
fn crb(truth: &InsModel<f64>, seeds: u64) -> anyhow::Result<()> {
    let cfg = AdaptConfig {
        adapt: false,
        ..AdaptConfig::default()
    };
    let mut mean_i = [[0.0f64; 4]; 4];
    let mut per: Vec<[f64; imu_ident::adapt::params::MAXP]> = Vec::new();
    let mut t2 = Vec::new();
    for seed in 0..seeds {
        let log = sim::simulate(truth, STEPS, 1000 + seed)?;
        let r = adaptive::run::<f64>(truth, &log, cfg)?;
        for i in 0..4 {
            for j in 0..4 {
                mean_i[i][j] += r.total_fisher[i][j] / seeds as f64;
            }
        }
        if let Some(c) = r.crb {
            per.push(c);
        }
        let m = nalgebra::Matrix4::from_fn(|i, j| r.total_fisher[i][j]);
        let g = nalgebra::Vector4::from_fn(|i, _| r.total_score[i]);
        if let Some(inv) = m.try_inverse() {
            t2.push((g.transpose() * inv * g)[0]);
        }
    }
    let m = nalgebra::Matrix4::from_fn(|i, j| mean_i[i][j]);
    let inv = m.try_inverse().unwrap_or_else(nalgebra::Matrix4::zeros);
    let crb: Vec<f64> = (0..4).map(|i| inv[(i, i)].max(0.0).sqrt()).collect();
    let corr = |i: usize, j: usize| inv[(i, j)] / (inv[(i, i)] * inv[(j, j)]).sqrt();
    println!("CRB (mean I over {seeds} seeds, 12 h): ln sigma_a {:.3}, ln tau_a {:.3}, ln sigma_g {:.3}, ln tau_g {:.3}", crb[0], crb[1], crb[2], crb[3]);
    println!(
        "correlations: (sa, ta) {:.2}, (sg, tg) {:.2}, (ta, tg) {:.2}",
        corr(0, 1),
        corr(2, 3),
        corr(1, 3)
    );
    for k in 0..4 {
        let mut v: Vec<f64> = per.iter().map(|c| c[k]).collect();
        print!("per-seed median {:.3}; ", median(&mut v));
    }
    let mt = t2.iter().sum::<f64>() / t2.len().max(1) as f64;
    println!("\nmean g^T I^-1 g = {mt:.2} (chi2(4) mean 4)");
    Ok(())
}

/// Tracking: the sensors change in service. Hours 0-6 follow the truth A; hours 6-18 a model B
/// (gyro diffusion 3x, accelerometer drift and diffusion 0.3x: `mismatch::scaled(A, 0.3, 3)`),
/// simulated from a fresh stationary state (the seam is a one-step jump of the true state).
/// Tilt over hours 14-18 of the adaptive filter started at A, of the fixed A filter, against the
/// oracle B (the fixed B model on the whole log, which has forgotten hours 0-6 by hour 14).
fn track(truth: &InsModel<f64>, seeds: u64, cfg: AdaptConfig<f64>) -> anyhow::Result<()> {
    let b = mismatch::scaled(truth, 0.3, 3.0);
    let (t0, t1) = (14.0 * 3600.0, 18.0 * 3600.0 + 1.0);
    let mut ra = Vec::new();
    let mut rf = Vec::new();
    let mut oa = Vec::new();
    let mut est_b = Vec::new();
    let mut o_out = Vec::new();
    for seed in 0..seeds {
        let log = sim::simulate_change(truth, &b, (6 * 3600, 12 * 3600), seed, sim::Seam::Fresh)?;
        let (oracle, _) = replay::estimates::<f64>(&b, &log)?;
        let (orms, oout) = tilt_window(&log, &oracle, t0, t1).unwrap_or((f64::NAN, 0.0));
        o_out.push(oout * 100.0);
        let r = adaptive::run::<f64>(truth, &log, cfg)?;
        let (arms, aout) = tilt_window(&log, &r.estimates, t0, t1).unwrap_or((f64::NAN, 1.0));
        let (fixed, _) = replay::estimates::<f64>(truth, &log)?;
        let (frms, fout) = tilt_window(&log, &fixed, t0, t1).unwrap_or((f64::NAN, 1.0));
        ra.push(arms / orms);
        rf.push(frms / orms);
        oa.push((aout * 100.0, fout * 100.0));
        let bt = gm_params(&b, ErrorSource::Gyro).unwrap_or_default();
        let at = gm_params(&r.final_model, ErrorSource::Gyro).unwrap_or_default();
        let aa = gm_params(&r.final_model, ErrorSource::Accel).unwrap_or_default();
        let ba = gm_params(&b, ErrorSource::Accel).unwrap_or_default();
        println!(
            "  seed {seed}: accel tau {:.2}x sigma {:.2}x, gyro tau {:.2}x sigma {:.2}x, jumps {}, out {:.2} %",
            aa.0 / ba.0,
            aa.1 / ba.1,
            at.0 / bt.0,
            at.1 / bt.1,
            r.jumps,
            aout * 100.0
        );
        est_b.push((at.0 / bt.0, at.1 / bt.1));
    }
    let mut a_out: Vec<f64> = oa.iter().map(|v| v.0).collect();
    let mut f_out: Vec<f64> = oa.iter().map(|v| v.1).collect();
    let mut gt: Vec<f64> = est_b.iter().map(|v| v.0).collect();
    let mut gs: Vec<f64> = est_b.iter().map(|v| v.1).collect();
    println!("| filter (h 14-18 after a change at 6 h) | tilt RMS / oracle B (median) | outside 3 sigma % (median) |");
    println!("|---|---|---|");
    println!(
        "| adaptive, started at A | {:.3} | {:.2} |",
        median(&mut ra),
        median(&mut a_out)
    );
    println!(
        "| fixed A | {:.3} | {:.2} |",
        median(&mut rf),
        median(&mut f_out)
    );
    println!("| oracle B | 1 | {:.2} |", median(&mut o_out));
    println!(
        "identified gyro at 18 h vs B: tau {:.3}x, sigma {:.3}x (medians)",
        median(&mut gt),
        median(&mut gs)
    );
    Ok(())
}
