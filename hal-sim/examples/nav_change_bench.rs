//! A sensor that changes in service, in the strapdown INS/GNSS navigator (issue 16 with the
//! mission's "stays honest when the sensors change in service"): how fast the online
//! identification's bank follows, and what the navigation loses meanwhile.
//! BENCHMARKS.md "A sensor that changes in service".
//!
//!   cargo run --release -p hal-sim --example nav_change_bench -- \
//!       grade=mems seeds=4 first=9101 factor=3
//!
//! Per seed: the figure-eight drive of `nav_adapt_bench` (`hours=`, 3), simulated twice from
//! the same seed, with the grade's model and with every standard deviation of it (white
//! densities, sigmas) times `factor`; the IMU samples and the truth's sensor errors are the
//! first drive's before `change=` [s] (3600) and the second's from then on (the same random
//! draws, so the errors jump by the factor: an ageing or a shock). GNSS 1 Hz with 60-s
//! outages every 20 min, as in `nav_adapt_bench`. Runs, scored over t >= change + `settle=`
//! [s] (1800): a fixed filter with the model after the change (the reference), a fixed
//! filter with the model before it (no identification), and `nav --adapt --adapt-method bank`
//! started from the model before (its `OnlineConfig` defaults; `every=`, `memory=` set them).
//! Prints per run the horizontal and attitude RMS over the reference's, the worst 3-sigma
//! fraction, and when the bank's intensities followed: the first decision after the change
//! at which their mean log10 factor is within 0.15 decade of log10(factor).

#[path = "bench_args/mod.rs"]
mod bench_args;

use bench_args::nav::score;
use bench_args::{arg, arg_or, pct};
use hal_sim::nav::adapt::{AdaptConfig, AdaptMethod};
use hal_sim::nav::{run_with, NavArgs};
use hal_sim::trajectory::errors::ImuErrorModel as SimModel;
use hal_sim::trajectory::gnss::GnssConfig;
use hal_sim::trajectory::profile::Profile;
use hal_sim::trajectory::write::{simulate_drive, write_and_read_drive};

fn main() {
    let grade = arg("grade").unwrap_or_else(|| "mems".into());
    let seeds: u64 = arg_or("seeds", 4);
    let first: u64 = arg_or("first", 9101);
    let hours: f64 = arg_or("hours", 3.0);
    let factor: f64 = arg_or("factor", 3.0);
    let change: f64 = arg_or("change", 3600.0);
    let settle: f64 = arg_or("settle", 1800.0);
    let d = AdaptConfig::DEFAULT;
    let cfg = AdaptConfig {
        method: AdaptMethod::Bank,
        bank: imu_ident::nav::OnlineConfig {
            every: arg_or("every", d.bank.every),
            memory: arg_or("memory", d.bank.memory),
            ..d.bank
        },
        ..d
    };
    let sim = match grade.as_str() {
        "mems" => SimModel::mems(),
        "tactical" => SimModel::tactical(),
        g => panic!("grade={g}: mems or tactical"),
    };
    let after = sim.scaled_axes(|| factor);
    let from = change + settle;
    println!(
        "# {grade}, {seeds} seeds from {first}, {hours} h, every standard deviation x{factor} at {change} s, scored from {from} s; {:?}",
        cfg.bank
    );
    let mut rows: Vec<[f64; 6]> = vec![];
    let mut followed: Vec<f64> = vec![];
    for seed in first..first + seeds {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let profile = Profile::figure_eight_course(hours, 1.0).unwrap_or_else(|e| panic!("{e:#}"));
        let start = hal_sim::trajectory::write::course_start();
        let drive = |m: &SimModel| {
            simulate_drive(&profile, start, 0.01, m, GnssConfig::default(), seed)
                .unwrap_or_else(|e| panic!("{e:#}"))
        };
        let (mut spliced, later) = (drive(&sim), drive(&after));
        for (a, b) in spliced.imu.iter_mut().zip(later.imu) {
            if a.t >= change {
                *a = b;
            }
        }
        for (a, b) in spliced.truth.iter_mut().zip(later.truth) {
            if a.t >= change {
                *a = b;
            }
        }
        let (imu, fixes, truth) =
            write_and_read_drive(dir.path(), &spliced).unwrap_or_else(|e| panic!("{e:#}"));
        let before_model = sim.to_core().unwrap_or_else(|e| panic!("{e:#}"));
        let after_model = after.to_core().unwrap_or_else(|e| panic!("{e:#}"));
        let base = |model: imu_ident::nav::ImuErrorModel<f64>, name: &str| {
            NavArgs::simulated_drive(dir.path(), &fixes, &truth, model, name)
        };
        let run = |args: &NavArgs| {
            run_with::<f64>(args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"))
        };
        let reference = score(&run(&base(after_model, "after")), &truth, from);
        let stale = score(&run(&base(before_model.clone(), "before")), &truth, from);
        let adaptive = run(&NavArgs {
            adapt: Some(cfg),
            ..base(before_model, "bank")
        });
        let bank = score(&adaptive, &truth, from);
        // The intensities' mean factor at each decision after the change.
        let log = adaptive.adapt.as_ref().expect("adapt log");
        let coords = &log.coordinates;
        let target = factor.log10();
        let mut when = f64::INFINITY;
        for s in &log.searches {
            let v: Vec<f64> = s
                .log10_factors
                .iter()
                .zip(coords)
                .filter(|(_, c)| c.quantity != "tau")
                .map(|(x, _)| *x)
                .collect();
            let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
            if std::env::var("TRACE").is_ok() {
                println!(
                    "  t {:.0} mean intensity factor {mean:.2} {:?}",
                    s.t, s.log10_factors
                );
            }
            if s.t >= change && when.is_infinite() && (mean - target).abs() <= 0.15 {
                when = s.t - change;
            }
        }
        followed.push(when);
        let r = [
            stale.0 / reference.0,
            stale.1 / reference.1,
            stale.2,
            bank.0 / reference.0,
            bank.1 / reference.1,
            bank.2,
        ];
        rows.push(r);
        println!(
            "seed {seed}: reference {:.3} m, {:.4} deg, {:.2} % outside 3 sigma | model before: horizontal {:.3}x, attitude {:.3}x, {:.2} % | bank: horizontal {:.3}x, attitude {:.3}x, {:.2} %, followed after {when:.0} s",
            reference.0, reference.1, reference.2 * 100.0, r[0], r[1], r[2] * 100.0, r[3], r[4], r[5] * 100.0
        );
    }
    let col = |k: usize| rows.iter().map(|r| r[k]).collect::<Vec<_>>();
    let summary = |k: usize| {
        let mut v = col(k);
        (pct(&mut v.clone(), 0.5), pct(&mut v, 1.0))
    };
    println!(
        "# model before: horizontal median/worst {:.3?}, attitude {:.3?}, outside 3 sigma {:.4?}",
        summary(0),
        summary(1),
        summary(2)
    );
    println!(
        "# bank: horizontal median/worst {:.3?}, attitude {:.3?}, outside 3 sigma {:.4?}; followed after median {:.0} s, worst {:.0} s",
        summary(3),
        summary(4),
        summary(5),
        pct(&mut followed.clone(), 0.5),
        pct(&mut followed, 1.0)
    );
}
