//! Times the overlapping Allan deviation of one column of a CSV file (used by
//! `scripts/bench_adev.sh`, which runs allantools on the same samples in the same run).
//!
//! Prints the median (and minimum) wall time over `--repeats` runs of
//! * `full`: `overlapping_adev` with the octave grid and conservative chi-square intervals
//!   (what a user calls), and
//! * `no_ci`: the running sum plus the variance at each octave cluster, without intervals
//!   (the same work allantools `oadev` does),
//!
//! and writes the `full` result to `--out` as `tau,adev,ci_lo,ci_hi`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::Parser;
use hal_sim::allan::{
    cluster_sizes, overlapping_adev, write_adev_csv, AdevConfig, Estimator, RunningSum, TauGrid,
};
use hal_sim::series::{read_column, ReadOptions};

#[derive(Parser)]
struct Args {
    /// CSV or gzip CSV holding the samples.
    #[arg(long)]
    input: PathBuf,
    /// Column to read.
    #[arg(long, default_value = "x")]
    column: String,
    /// Sample rate [Hz].
    #[arg(long, default_value_t = 100.0)]
    rate: f64,
    /// Timed repetitions (the median is reported).
    #[arg(long, default_value_t = 7)]
    repeats: usize,
    /// Where to write the `tau,adev,ci_lo,ci_hi` table.
    #[arg(long)]
    out: Option<PathBuf>,
}

fn median(v: Vec<f64>) -> f64 {
    hal_sim::shared_data::median(&v)
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    anyhow::ensure!(args.repeats > 0, "--repeats must be at least 1");
    let t0 = Instant::now();
    let y = read_column(&args.input, &args.column, &ReadOptions::default())?;
    let read_s = t0.elapsed().as_secs_f64();
    let cfg = AdevConfig::octave(args.rate);

    let mut full = Vec::with_capacity(args.repeats);
    let mut rows = Vec::new();
    for _ in 0..args.repeats {
        let t = Instant::now();
        rows = overlapping_adev(&y, &cfg)?;
        full.push(t.elapsed().as_secs_f64());
    }

    let ms = cluster_sizes(&TauGrid::Octave, y.len())?;
    let mut no_ci = Vec::with_capacity(args.repeats);
    let mut checksum = 0.0;
    for _ in 0..args.repeats {
        let t = Instant::now();
        let sums = RunningSum::new(&y)?;
        for &m in &ms {
            checksum += sums.avar(m, Estimator::Standard)?.sqrt();
        }
        no_ci.push(t.elapsed().as_secs_f64());
    }
    // Keeps the timed loop from being optimised away, and cross-checks the two paths.
    let expected: f64 = rows.iter().map(|r| r.adev).sum::<f64>() * args.repeats as f64;
    anyhow::ensure!(
        ((checksum - expected) / expected).abs() < 1e-12,
        "inconsistent results between the two timed paths"
    );

    if let Some(out) = &args.out {
        write_adev_csv(out, &rows).with_context(|| format!("writing {}", out.display()))?;
    }
    println!("samples={} taus={} read_s={read_s:.3}", y.len(), rows.len());
    // The minimum is reported too: on a shared machine it is the least disturbed figure.
    let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    println!("hal_sim_full_min_s={:.6}", min(&full));
    println!("hal_sim_no_ci_min_s={:.6}", min(&no_ci));
    println!("hal_sim_full_median_s={:.6}", median(full));
    println!("hal_sim_no_ci_median_s={:.6}", median(no_ci));
    Ok(())
}
