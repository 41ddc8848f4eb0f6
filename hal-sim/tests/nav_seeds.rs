//! Benchmark (ignored by default; `cargo test --release -p hal-sim --test host nav_seeds::
//! -- --ignored --nocapture`): the strapdown INS/GNSS navigator over many seeds of the simulated
//! figure-eight course (issue 16's simulation bar), for a MEMS and a tactical-grade IMU, with
//! the true noise model, with it 10x too small and 10x too large (standard deviations). GNSS at
//! 1 Hz (1.5/1.5/3 m, 0.05/0.05/0.1 m/s) with 60-s outages every 20 min from 10 min.
//! Printed per case: the fraction of epochs outside 3 sigma per axis (median and worst over the
//! seeds) and the horizontal error at the end of the outages (RMS over outages and seeds).

use hal_sim::nav::{run_with, NavArgs};
use hal_sim::trajectory::errors::ImuErrorModel as SimModel;
use hal_sim::trajectory::gnss::GnssConfig;
use hal_sim::trajectory::profile::Profile;
use hal_sim::trajectory::write::{simulate_drive, write_and_read_drive};

fn quantile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() - 1) as f64 * q).round() as usize]
}

#[test]
#[ignore = "benchmark: minutes in release"]
fn nav_over_seeds() {
    let hours: f64 = std::env::var("NAV_HOURS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
    let seeds: u64 = std::env::var("NAV_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let first: u64 = std::env::var("NAV_FIRST_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1001);
    let outages: Vec<(f64, f64)> = (0..)
        .map(|k| 600.0 + 1200.0 * k as f64)
        .take_while(|s| *s + 60.0 < hours * 3600.0 - 120.0)
        .map(|s| (s, s + 60.0))
        .collect();
    for (grade, sim) in [
        ("MEMS", SimModel::mems()),
        ("tactical", SimModel::tactical()),
    ] {
        // Per seed: mean NEES, inside its effective-n band, that band, worst 9-axis 3-sigma
        // fraction.
        type Nees = (f64, bool, [f64; 2], f64);
        type Case = (f64, Vec<[f64; 3]>, Vec<f64>, Vec<Nees>);
        let mut cases: Vec<Case> = vec![
            (1.0, vec![], vec![], vec![]),
            (0.1, vec![], vec![], vec![]),
            (10.0, vec![], vec![], vec![]),
        ];
        for seed in first..first + seeds {
            let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
            let profile =
                Profile::figure_eight_course(hours, 1.0).unwrap_or_else(|e| panic!("{e:#}"));
            let start = hal_sim::trajectory::write::course_start();
            // Every fix is in the file; the run withholds the outages' fixes (`--outages`), so
            // that it still writes an epoch, scored against the truth, at each withheld fix time.
            let gnss = GnssConfig::default();
            let drive = simulate_drive(&profile, start, 0.01, &sim, gnss, seed)
                .unwrap_or_else(|e| panic!("{e:#}"));
            let (imu, fixes, truth) =
                write_and_read_drive(dir.path(), &drive).unwrap_or_else(|e| panic!("{e:#}"));
            for (k, frac, outage_err, nees) in cases.iter_mut() {
                // `outages` is the same schedule (600 s, then every 1200 s).
                let args = NavArgs::simulated_drive(
                    dir.path(),
                    &fixes,
                    &truth,
                    hal_sim::nav::model::scaled_sd(
                        &sim.to_core().unwrap_or_else(|e| panic!("{e:#}")),
                        *k,
                    ),
                    &format!("{grade} x{k}"),
                );
                let run = run_with::<f64>(&args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
                let mut out = [0.0; 3];
                let mut n = 0.0;
                for e in run.epochs.iter().filter(|e| e.t >= 60.0) {
                    let i = truth.partition_point(|r| r.t < e.t - 1e-6);
                    let Some(r) = truth.get(i) else { continue };
                    let ne = hal_sim::nav_io::outages::north_east(
                        r.lat_deg, r.lon_deg, r.h, e.lat_deg, e.lon_deg,
                    );
                    let err = [ne[0], ne[1], e.h - r.h];
                    for j in 0..3 {
                        if err[j].abs() > 3.0 * e.sd_pos[j] {
                            out[j] += 1.0;
                        }
                    }
                    n += 1.0;
                }
                frac.push(out.map(|x| x / n));
                // The 9 navigation errors against the truth (the `--truth` statistics): NEES
                // and every axis's 3-sigma fraction, epochs with a known heading.
                let cmp = hal_sim::nav::truth::compare(&run.epochs, &truth, "truth.csv")
                    .unwrap_or_else(|e| panic!("{e:#}"))
                    .summary;
                let worst9 = cmp.worst_outside_3sigma();
                nees.push((
                    cmp.nees_mean,
                    cmp.nees_consistent,
                    cmp.nees_band99_effective,
                    worst9,
                ));
                // Horizontal error at the last IMU-rate truth sample of each outage.
                for (_, end) in &outages {
                    let Some(i) = run.epochs.iter().rposition(|e| e.t < *end) else {
                        continue;
                    };
                    let e = &run.epochs[i];
                    let Some(r) = truth.get(truth.partition_point(|r| r.t < e.t - 1e-6)) else {
                        continue;
                    };
                    let ne = hal_sim::nav_io::outages::north_east(
                        r.lat_deg, r.lon_deg, r.h, e.lat_deg, e.lon_deg,
                    );
                    outage_err.push(ne[0].hypot(ne[1]));
                }
            }
        }
        for (k, frac, outage_err, nees) in &cases {
            let mut worst_axis: Vec<f64> = frac
                .iter()
                .map(|f| f.iter().cloned().fold(0.0, f64::max))
                .collect();
            let med = quantile(&mut worst_axis.clone(), 0.5);
            let p95 = quantile(&mut worst_axis.clone(), 0.95);
            let worst = quantile(&mut worst_axis, 1.0);
            let rms =
                (outage_err.iter().map(|x| x * x).sum::<f64>() / outage_err.len() as f64).sqrt();
            println!(
                "{grade} noise x{k}: {} seeds x {hours} h; worst-axis fraction outside 3 sigma: median {:.2} %, p95 {:.2} %, worst {:.2} %; horizontal error at the end of {} 60-s outages: RMS {:.2} m",
                frac.len(), med * 100.0, p95 * 100.0, worst * 100.0, outage_err.len(), rms
            );
            let mut m: Vec<f64> = nees.iter().map(|x| x.0).collect();
            let mut w9: Vec<f64> = nees.iter().map(|x| x.3).collect();
            let consistent = nees.iter().filter(|x| x.1).count();
            let band = nees.first().map_or([f64::NAN; 2], |x| x.2);
            println!(
                "  9 errors (att, vel, pos) vs truth: mean NEES median {:.2}, p95 {:.2}, worst {:.2}, min {:.2} (9 if consistent); inside the effective-n 99 % band in {consistent}/{} seeds (first seed's band [{:.2}, {:.2}]); worst of the 9 axes outside 3 sigma: median {:.2} %, p95 {:.2} %, worst {:.2} %",
                quantile(&mut m.clone(), 0.5), quantile(&mut m.clone(), 0.95), quantile(&mut m.clone(), 1.0), quantile(&mut m, 0.0),
                nees.len(), band[0], band[1],
                quantile(&mut w9.clone(), 0.5) * 100.0, quantile(&mut w9.clone(), 0.95) * 100.0, quantile(&mut w9, 1.0) * 100.0
            );
        }
    }
}
