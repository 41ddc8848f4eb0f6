//! The strapdown INS/GNSS navigator on the trajectory simulator (issue 16): a 20-min
//! figure-eight course with a MEMS IMU (`ImuErrorModel::mems`), 1-Hz GNSS and one 60-s outage,
//! through `hal-sim nav`'s run with the true noise model, with it 10x too small, and in `f32`.
//!
//! Bounds: with the true model each position error is N(0, sd^2) where the filter says sd, so
//! the fraction outside 3 sd is 0.27 %; the per-axis fractions over ~1200 correlated epochs
//! are bounded here at 2 % (the correlation time of the errors, tens of seconds, leaves ~40
//! independent samples, whose binomial 99.9 % bound at p = 0.0027 is ~2/40 = 5 %; 2 % is kept
//! as the floor the issue asks for: 1 % is measured, see the printout). With the noise 10x
//! too small the filter must be visibly overconfident (the paper's divergence): more than
//! 10 % outside 3 sd. The f32 core must agree with the f64 core within 0.05 sd.

use hal_sim::nav::{run_with, NavArgs};
use hal_sim::nav_io::{read_gnss_csv, read_imu_csv, read_truth_csv, TruthRow};

struct Errors {
    /// Fraction of epochs outside 3 sd, per axis N, E, D.
    outside: [f64; 3],
    /// Horizontal RMS [m].
    rms_h: f64,
    /// Solution per epoch (N, E offsets from the truth [m]) and sd.
    err: Vec<[f64; 3]>,
    sd: Vec<[f64; 3]>,
}

fn errors(run: &hal_sim::nav::NavRun, truth: &[TruthRow], skip: f64) -> Errors {
    let t0 = run.epochs[0].t;
    let mut out = Errors {
        outside: [0.0; 3],
        rms_h: 0.0,
        err: vec![],
        sd: vec![],
    };
    let mut n = 0.0;
    for e in run.epochs.iter().filter(|e| e.t >= t0 + skip) {
        let k = truth.partition_point(|r| r.t < e.t - 1e-6);
        let Some(r) = truth.get(k) else { continue };
        assert!(
            (r.t - e.t).abs() < 1e-3,
            "truth row at {} for epoch {}",
            r.t,
            e.t
        );
        let ne =
            hal_sim::nav_io::outages::north_east(r.lat_deg, r.lon_deg, r.h, e.lat_deg, e.lon_deg);
        let err = [ne[0], ne[1], e.h - r.h];
        for ((o, x), s) in out.outside.iter_mut().zip(err.iter()).zip(e.sd_pos.iter()) {
            if x.abs() > 3.0 * s {
                *o += 1.0;
            }
        }
        out.rms_h += ne[0] * ne[0] + ne[1] * ne[1];
        out.err.push(err);
        out.sd.push(e.sd_pos);
        n += 1.0;
    }
    for o in out.outside.iter_mut() {
        *o /= n;
    }
    out.rms_h = (out.rms_h / n).sqrt();
    out
}

#[test]
fn navigator_is_consistent_on_a_simulated_drive() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    hal_sim::trajectory::write::simulate_drive_files(
        1.0 / 3.0,
        100.0,
        7,
        (vec![(600.0, 660.0)], [0.0; 3]),
        dir.path(),
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    let imu = read_imu_csv(&dir.path().join("imu.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    let fixes = read_gnss_csv(&dir.path().join("gnss.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    let truth = read_truth_csv(&dir.path().join("truth.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    let model = hal_sim::trajectory::errors::ImuErrorModel::mems()
        .to_core()
        .unwrap_or_else(|e| panic!("{e:#}"));
    let args = NavArgs {
        ..NavArgs::simulated(
            dir.path().join("imu.csv"),
            dir.path().join("gnss.csv"),
            model.clone(),
            "mems (true)",
            truth[0].rpy_deg[2],
        )
    };
    let run = run_with::<f64>(&args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let e = errors(&run, &truth, 60.0);
    println!(
        "true model: outside 3 sd N/E/D = {:?}, horizontal RMS {:.2} m, mean NIS {:?}",
        e.outside, e.rms_h, run.summary.mean_nis_axis
    );
    for (i, f) in e.outside.iter().enumerate() {
        assert!(
            *f <= 0.02,
            "axis {i}: {:.2} % outside 3 sd with the true model",
            f * 100.0
        );
    }

    let small = NavArgs {
        model: hal_sim::nav::model::scaled_sd(&model, 0.1),
        ..args.clone()
    };
    let run_s = run_with::<f64>(&small, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let es = errors(&run_s, &truth, 60.0);
    println!(
        "noise 10x too small: outside 3 sd N/E/D = {:?}, horizontal RMS {:.2} m",
        es.outside, es.rms_h
    );
    assert!(
        es.outside.iter().cloned().fold(0.0, f64::max) >= 0.10,
        "no divergence with 10x too small noise"
    );

    let single = NavArgs {
        single: true,
        ..args.clone()
    };
    let run32 = run_with::<f32>(&single, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let e32 = errors(&run32, &truth, 60.0);
    let worst = e
        .err
        .iter()
        .zip(e32.err.iter())
        .zip(e.sd.iter())
        .map(|((a, b), s)| {
            (0..3)
                .map(|i| (a[i] - b[i]).abs() / s[i])
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    println!("f32 against f64: worst position difference {worst:.2e} sd");
    assert!(worst <= 0.05, "f32 differs from f64 by {worst} sd");
}
