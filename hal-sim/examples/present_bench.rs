//! The present solution of a live run with a latency budget (`imu_ident::nav::predictor`,
//! `hal_sim::present`): per seed, a simulated drive (100 Hz, 1-Hz fixes delivered `delay`
//! late, the budget `latency`), and at every sample from 2 min on the horizontal, velocity and
//! attitude errors of three solutions against the truth at the newest sample's time: the
//! output predictor's, the run's read as the present (stale by the budget), and the run's at
//! its own time. Prints each seed's RMS and worst, then medians, 95th percentiles and worst
//! cases over the seeds, the predictions compared bit for bit, and the predictor's cost in
//! samples mechanised per sample. Also, with or without a truth, the horizontal distance of the
//! present and of the stale solution from the run's own when it reaches the same time.
//! With a truth, also the present's standard deviations (`LiveNav::present_sd`): per seed the
//! largest RMS over the nine axes of the normalised error (attitude, velocity, position N, E,
//! D) and the largest fraction outside 3 sd, carried to the present and as the filter had them
//! at its last propagation; over the seeds, median / p95 / worst of both.
//! `real=1`: the real drive (`../shared/data/real/rtklib-drive-0708`, 100 Hz and 4-Hz RTK
//! fixes, no outage), which has no truth at the IMU's rate: only that distance.
//!
//! Beside each run, the same log with its fixes on time and no budget (the host's batch run):
//! with a truth, the late run's RMS over the on-time run's per seed; on the real drive, the
//! horizontal distance of the present solution from the on-time run's at every sample. With
//! `latency=0` this measures a late fix taken after the samples it missed
//! (`imu_ident::nav::navigator::history`; BENCHMARKS.md "Late fixes without a budget").
//!
//! ```text
//! cargo run --release -p hal-sim --example present_bench -- [first=65800] [seeds=10] [minutes=20] [delay=0.25] [latency=0.3] [nhc=1] [real=0]
//! ```

use hal_sim::nav::NavArgs;
use hal_sim::nav_io::TruthRow;
use hal_sim::nav_io::{outages::north_east, read_gnss_csv, read_imu_csv, read_truth_csv};
use hal_sim::present::{present_run, simulated_drive, PresentRun, SolutionError};

#[path = "bench_args/mod.rs"]
mod bench_args;
use bench_args::{arg_or, pct};

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

fn worst(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |a, b| a.max(*b))
}

/// Median, 95th percentile and worst of the distances from the run's solution.
fn to_run_line(r: &PresentRun) -> String {
    let mut s = String::new();
    for (k, name) in ["present", "stale"].iter().enumerate() {
        let mut v: Vec<f64> = r.to_run.iter().map(|d| d[k]).collect();
        s += &format!(
            " {name} {:.4}/{:.4}/{:.4} m (RMS {:.4})",
            pct(&mut v, 0.5),
            pct(&mut v, 0.95),
            pct(&mut v, 1.0),
            rms(&v)
        );
    }
    s
}

/// The horizontal distance [m] of each row of `rows` from the row of `reference` at the same
/// time (rows without one are skipped).
fn distances(rows: &[TruthRow], reference: &[TruthRow]) -> Vec<f64> {
    let at: std::collections::HashMap<u64, &TruthRow> =
        reference.iter().map(|r| (r.t.to_bits(), r)).collect();
    rows.iter()
        .filter_map(|r| {
            let o = at.get(&r.t.to_bits())?;
            let ne = north_east(o.lat_deg, o.lon_deg, o.h, r.lat_deg, r.lon_deg);
            Some(ne[0].hypot(ne[1]))
        })
        .collect()
}

fn real(delay: f64, latency: f64) -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let Some((args, imu, fixes)) = hal_sim::nav::real::drive_0708(dir.path())? else {
        anyhow::bail!("the real drive is not in ../shared/data/real");
    };
    let args = NavArgs {
        outages: None,
        ..args
    };
    let r = present_run(&args, &imu, &fixes, None, (delay, latency, 120.0))?;
    let on_time = present_run(&args, &imu, &fixes, None, (0.0, 0.0, 120.0))?;
    let t_settle = imu.first().map_or(0.0, |s| s.t) + 120.0;
    let rows: Vec<TruthRow> = r.rows.iter().filter(|w| w.t >= t_settle).cloned().collect();
    let mut d = distances(&rows, &on_time.rows);
    println!(
        "real drive: the present solution from the on-time run's at {} samples from 2 min on: \
         median {:.4} / p95 {:.4} / worst {:.4} m, RMS {:.4} m",
        d.len(),
        pct(&mut d, 0.5),
        pct(&mut d, 0.95),
        pct(&mut d, 1.0),
        rms(&d)
    );
    println!(
        "real drive, fixes {delay} s late, budget {latency} s: {} samples, {} distances; from \
         the run's solution at the same time (median/p95/worst):{}; compared {} (differ {}), \
         predicted {:.2} samples per sample",
        r.samples,
        r.to_run.len(),
        to_run_line(&r),
        r.compared,
        r.differ,
        r.predicted as f64 / r.samples as f64
    );
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let first: u64 = arg_or("first", 65_800);
    let seeds: u64 = arg_or("seeds", 10);
    let minutes: f64 = arg_or("minutes", 20.0);
    let delay: f64 = arg_or("delay", 0.25);
    let latency: f64 = arg_or("latency", 0.3);
    let nhc = arg_or("nhc", 1u8) == 1;
    if arg_or("real", 0u8) == 1 {
        return real(delay, latency);
    }
    let names = ["present", "stale", "run"];
    // Per solution, per quantity (horizontal, velocity, attitude): per-seed RMS and worst.
    let mut rms_of = vec![[vec![], vec![], vec![]]; 3];
    let mut worst_of = vec![[vec![], vec![], vec![]]; 3];
    let (mut compared, mut differ, mut cost) = (0, 0, vec![]);
    // Per quantity: the run's per-seed RMS over the on-time run's.
    let mut over_on_time = [vec![], vec![], vec![]];
    // Per seed, carried and not: the largest RMS of the normalised error over the nine axes,
    // and the largest fraction outside 3 sd.
    let mut z_worst = [vec![], vec![]];
    let mut out_worst = [vec![], vec![]];
    for seed in first..first + seeds {
        let dir = tempfile::tempdir()?;
        let args = simulated_drive(dir.path(), minutes / 60.0, seed, false, nhc)?;
        let imu = read_imu_csv(&args.imu)?;
        let fixes = read_gnss_csv(&args.gnss)?;
        let truth = read_truth_csv(&dir.path().join("truth.csv"))?;
        let r = present_run(&args, &imu, &fixes, Some(&truth), (delay, latency, 120.0))?;
        let on_time = present_run(&args, &imu, &fixes, Some(&truth), (0.0, 0.0, 120.0))?;
        let q = |s: &SolutionError| [s.horizontal, s.velocity, s.attitude];
        for (j, list) in over_on_time.iter_mut().enumerate() {
            let late: Vec<f64> = r.errors.iter().map(|e| q(&e[2])[j]).collect();
            let ok: Vec<f64> = on_time.errors.iter().map(|e| q(&e[2])[j]).collect();
            list.push(rms(&late) / rms(&ok));
        }
        let mut line = format!("seed {seed}:");
        for (k, name) in names.iter().enumerate() {
            line += &format!(" {name}");
            for j in 0..3 {
                let v: Vec<f64> = r.errors.iter().map(|e| q(&e[k])[j]).collect();
                rms_of[k][j].push(rms(&v));
                worst_of[k][j].push(worst(&v));
                line += &format!(" {:.3}/{:.3}", rms(&v), worst(&v));
            }
        }
        for w in 0..2 {
            let n = r.normalised.len().max(1) as f64;
            let zr = (0..9).map(|k| rms(&r.normalised.iter().map(|z| z[w][k]).collect::<Vec<_>>()));
            let out = (0..9)
                .map(|k| r.normalised.iter().filter(|z| z[w][k].abs() > 3.0).count() as f64 / n);
            z_worst[w].push(zr.fold(0.0f64, f64::max));
            out_worst[w].push(out.fold(0.0f64, f64::max));
        }
        line += &format!(
            "; sd: max RMS z {:.3} (not carried {:.3}), outside 3 sd {:.4} ({:.4})",
            z_worst[0][z_worst[0].len() - 1],
            z_worst[1][z_worst[1].len() - 1],
            out_worst[0][out_worst[0].len() - 1],
            out_worst[1][out_worst[1].len() - 1]
        );
        compared += r.compared;
        differ += r.differ;
        cost.push(r.predicted as f64 / r.samples as f64);
        println!(
            "{line}; from the run's:{}; compared {} (differ {}), predicted {:.2} samples per \
             sample",
            to_run_line(&r),
            r.compared,
            r.differ,
            r.predicted as f64 / r.samples as f64
        );
    }
    // Before the summaries below, which sort the per-seed lists.
    let mut ratios =
        String::from("present / run at its own time, per-seed RMS ratio, median / p95 / worst:");
    for (j, name) in ["horizontal", "velocity", "attitude"].iter().enumerate() {
        let mut r: Vec<f64> = rms_of[0][j]
            .iter()
            .zip(&rms_of[2][j])
            .map(|(a, b)| a / b)
            .collect();
        ratios += &format!(
            " {name} {:.4}/{:.4}/{:.4};",
            pct(&mut r, 0.5),
            pct(&mut r, 0.95),
            pct(&mut r, 1.0)
        );
    }
    println!(
        "errors from 2 min on, RMS per seed and worst sample per seed (horizontal m, velocity \
         m/s, attitude deg), median / p95 / worst over {seeds} seeds:"
    );
    for (k, name) in names.iter().enumerate() {
        let mut line = format!("  {name:8}");
        for (j, unit) in ["m", "m/s", "deg"].iter().enumerate() {
            let (a, b) = (&mut rms_of[k][j], &mut worst_of[k][j]);
            line += &format!(
                " | RMS {:.4}/{:.4}/{:.4} {unit}, worst {:.4}/{:.4}/{:.4}",
                pct(a, 0.5),
                pct(a, 0.95),
                pct(a, 1.0),
                pct(b, 0.5),
                pct(b, 0.95),
                pct(b, 1.0)
            );
        }
        println!("{line}");
    }
    println!("{ratios}");
    let mut line =
        String::from("run / on-time run (no budget), per-seed RMS ratio, median / p95 / worst:");
    for (j, name) in ["horizontal", "velocity", "attitude"].iter().enumerate() {
        let r = &mut over_on_time[j];
        line += &format!(
            " {name} {:.4}/{:.4}/{:.4};",
            pct(r, 0.5),
            pct(r, 0.95),
            pct(r, 1.0)
        );
    }
    println!("{line}");
    for (w, name) in ["carried to the present", "the filter's, not carried"]
        .iter()
        .enumerate()
    {
        let (z, o) = (&mut z_worst[w], &mut out_worst[w]);
        println!(
            "standard deviations {name}: per seed the largest RMS z over 9 axes {:.3}/{:.3}/{:.3}, \
             the largest fraction outside 3 sd {:.4}/{:.4}/{:.4} (median / p95 / worst)",
            pct(z, 0.5),
            pct(z, 0.95),
            pct(z, 1.0),
            pct(o, 0.5),
            pct(o, 0.95),
            pct(o, 1.0)
        );
    }
    println!(
        "bit for bit: {compared} predictions compared, {differ} differ; predictor cost \
         {:.2}/{:.2}/{:.2} samples mechanised per sample",
        pct(&mut cost, 0.5),
        pct(&mut cost, 0.95),
        pct(&mut cost, 1.0)
    );
    Ok(())
}
