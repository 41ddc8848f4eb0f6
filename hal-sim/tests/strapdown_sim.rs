//! The drive simulator: sensor errors per axis, GNSS noise and outages, and the pinned CSV
//! formats (README, "Strapdown formats").

use hal_sim::trajectory::errors::ImuErrorModel;
use hal_sim::trajectory::gnss::GnssConfig;
use hal_sim::trajectory::write::{simulate_drive, write_drive};
use hal_sim::trajectory::{Profile, TruthGen};
use imu_ident::model::{Component, GaussMarkov, RandomConstant, WhiteNoise};
use imu_ident::strapdown::{earth, Geodetic};
use std::f64::consts::PI;

fn start() -> Geodetic {
    Geodetic {
        lat: 0.7,
        lon: -1.2,
        h: 50.0,
    }
}

fn course() -> Profile {
    Profile::new(0.0, 0.0, 0.0)
        .unwrap()
        .hold(100.0)
        .unwrap()
        .accelerate(15.0, 20.0)
        .unwrap()
        .turn(PI, 30.0)
        .unwrap()
        .hold(150.0)
        .unwrap()
}

#[test]
fn sensor_errors_and_gnss_have_their_statistics() {
    let dt = 0.01;
    let density = 1e-3; // rad/s/sqrt(Hz): sampled sd 1e-2 rad/s at 100 Hz
    let gyro = [
        Component::White(WhiteNoise { density }),
        Component::RandomConstant(RandomConstant { sigma: 1e-4 }),
    ];
    let accel = [Component::GaussMarkov(GaussMarkov {
        sigma: 1e-3,
        tau: 50.0,
    })];
    let model = ImuErrorModel::same_on_all_axes(&gyro, &accel);
    let gnss = GnssConfig {
        outages: vec![(120.0, 180.0)],
        ..GnssConfig::default()
    };
    let p = course();
    let drive = simulate_drive(&p, start(), dt, &model, gnss.clone(), 7).unwrap();
    let exact: Vec<_> = TruthGen::new(&p, start(), dt).unwrap().skip(1).collect();
    assert_eq!(drive.imu.len(), exact.len());
    assert_eq!(drive.truth.len(), exact.len() + 1);

    // Gyro: measured rate - exact rate - bias is the white draw, sd density / sqrt(dt). Over
    // n = 30000 draws the sample variance has relative sd sqrt(2/n) = 0.8 %: 5 sigma = 4 %.
    let n = exact.len() as f64;
    let mut ss = 0.0;
    for (row, (s, tr)) in drive
        .imu
        .iter()
        .zip(exact.iter().zip(drive.truth.iter().skip(1)))
    {
        let w = row.gx - s.inc.dtheta.x / dt - tr.bg_x;
        ss += w * w;
    }
    let var = ss / n;
    let expect = density * density / dt;
    assert!(
        (var / expect - 1.0).abs() < 5.0 * (2.0 / n).sqrt(),
        "{var} vs {expect}"
    );
    // The random constant is constant; the Gauss-Markov bias moves.
    let bg: Vec<f64> = drive.truth.iter().skip(1).map(|r| r.bg_y).collect();
    assert!(bg.iter().all(|b| *b == bg[0]) && bg[0] != 0.0);
    let ba: Vec<f64> = drive.truth.iter().skip(1).map(|r| r.ba_z).collect();
    assert!(ba.iter().any(|b| *b != ba[0]));

    // GNSS: 1 Hz, none in [120, 180), normalised position errors chi-square with 3 m dof:
    // mean square within 1 +- 5 sqrt(2 / (3 m)).
    assert!(drive.gnss.iter().all(|g| g.t < 120.0 || g.t >= 180.0));
    assert_eq!(drive.gnss.len(), 301 - 60);
    let mut chi = 0.0;
    for g in &drive.gnss {
        let k = (g.t / dt).round() as usize;
        let tr = &drive.truth[k];
        assert!((tr.t - g.t).abs() < 1e-9);
        let lat = tr.lat.to_radians();
        let rn = earth::radius_north(lat) + tr.h;
        let re = (earth::radius_east(lat) + tr.h) * lat.cos();
        let e = [
            (g.lat - tr.lat).to_radians() * rn / g.sd_n,
            (g.lon - tr.lon).to_radians() * re / g.sd_e,
            (tr.h - g.h) / g.sd_d,
        ];
        chi += e.iter().map(|x| x * x).sum::<f64>();
    }
    let m = 3.0 * drive.gnss.len() as f64;
    assert!(
        (chi / m - 1.0).abs() < 5.0 * (2.0 / m).sqrt(),
        "{}",
        chi / m
    );
}

#[test]
fn drive_files_have_the_pinned_columns() {
    let p = Profile::new(0.0, 0.0, 0.0).unwrap().hold(3.0).unwrap();
    let drive = simulate_drive(
        &p,
        start(),
        0.01,
        &ImuErrorModel::default(),
        GnssConfig::default(),
        1,
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    write_drive(dir.path(), &drive).unwrap();
    let header = |f: &str| {
        let text = std::fs::read_to_string(dir.path().join(f)).unwrap();
        text.lines().next().unwrap().to_string()
    };
    assert_eq!(header("imu.csv"), "t,gx,gy,gz,ax,ay,az");
    assert_eq!(
        header("truth.csv"),
        "t,lat,lon,h,vn,ve,vd,roll,pitch,yaw,bg_x,bg_y,bg_z,ba_x,ba_y,ba_z"
    );
    assert_eq!(
        header("gnss.csv"),
        "t,lat,lon,h,vn,ve,vd,sd_n,sd_e,sd_d,sd_vn,sd_ve,sd_vd"
    );
    // At rest and level, the specific force is the reaction to normal gravity, az = -gamma.
    let mut rd = csv::Reader::from_path(dir.path().join("imu.csv")).unwrap();
    let rows: Vec<Vec<f64>> = rd
        .records()
        .map(|r| r.unwrap().iter().map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 300);
    let g = earth::normal_gravity(start().lat, start().h);
    assert!(rows
        .iter()
        .all(|r| (r[6] + g).abs() < 1e-9 && r[4].abs() < 1e-9));
    assert_eq!(drive.gnss.len(), 4);
}

#[test]
fn error_free_imu_csv_through_the_mechanisation_reproduces_the_truth_csv() {
    // The IMU CSV convention (mean rates over (t - dt, t]) is what Increment::from_rates takes:
    // an error-free drive written and read back must reproduce the truth as well as the exact
    // increments do (strapdown_truth.rs: third-order drift, ~1e-5 m over these 5 minutes).
    use imu_ident::strapdown::{Increment, Quat, Strapdown};
    use nalgebra::Vector3;
    let dt = 0.01;
    let drive = simulate_drive(
        &course(),
        start(),
        dt,
        &ImuErrorModel::default(),
        GnssConfig::default(),
        3,
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    write_drive(dir.path(), &drive).unwrap();
    let read = |f: &str| -> Vec<Vec<f64>> {
        csv::Reader::from_path(dir.path().join(f))
            .unwrap()
            .records()
            .map(|r| r.unwrap().iter().map(|x| x.parse().unwrap()).collect())
            .collect()
    };
    let (imu, truth) = (read("imu.csv"), read("truth.csv"));
    let t0 = &truth[0];
    let pos = |r: &[f64]| Geodetic {
        lat: r[1].to_radians(),
        lon: r[2].to_radians(),
        h: r[3],
    };
    let q0 = Quat::from_euler(t0[7].to_radians(), t0[8].to_radians(), t0[9].to_radians());
    let mut ins = Strapdown::new(pos(t0), Vector3::new(t0[4], t0[5], t0[6]), q0).unwrap();
    for r in &imu {
        let inc = Increment::from_rates(
            &Vector3::new(r[1], r[2], r[3]),
            &Vector3::new(r[4], r[5], r[6]),
            dt,
        );
        ins.step(&inc, dt).unwrap();
    }
    let (p, last) = (ins.position(), pos(truth.last().unwrap()));
    let rn = earth::radius_north(last.lat) + last.h;
    let err = ((p.lat - last.lat) * rn).hypot((p.lon - last.lon) * rn * last.lat.cos());
    println!(
        "CSV round trip, 300 s: {err:.3e} m horizontal, {:.3e} m vertical",
        p.h - last.h
    );
    assert!(err < 1e-3 && (p.h - last.h).abs() < 1e-3);
}

/// The antenna at a lever arm (`GnssConfig::lever_arm`), without noise: every fix lies at the
/// arm's length from the truth's IMU position (0.854 m for `(0.3, 0, -0.8)`; to a micrometre,
/// the local radii's first order over a metre), above it by the arm's down component rotated
/// by the truth's attitude (level before the turn: 0.8 m exactly, to 1e-9 m), and moves at the
/// IMU's velocity plus `C (w x l)`, whose length is that of `w x l` with `w` the body rate of
/// the error-free IMU's CSV (to 1e-9 m/s; over 0.02 m/s in the 30-s half turn). At the IMU
/// (no arm) the fixes are the truth's position and velocity, as before the arm.
#[test]
fn gnss_fixes_are_at_the_antenna() {
    let dt = 0.01;
    let model = ImuErrorModel::same_on_all_axes(&[], &[]);
    let quiet = GnssConfig {
        sd_pos: [0.0; 3],
        sd_vel: [0.0; 3],
        ..GnssConfig::default()
    };
    let arm = [0.3, 0.0, -0.8];
    let with_arm = GnssConfig {
        lever_arm: arm,
        ..quiet.clone()
    };
    let p = course();
    let at_imu = simulate_drive(&p, start(), dt, &model, quiet, 7).unwrap();
    let drive = simulate_drive(&p, start(), dt, &model, with_arm, 7).unwrap();
    assert_eq!(drive.gnss.len(), at_imu.gnss.len());
    let length = (0.3f64 * 0.3 + 0.8 * 0.8).sqrt();
    let mut turning = 0;
    for (g, g0) in drive.gnss.iter().zip(&at_imu.gnss) {
        let k = (g.t / dt).round() as usize;
        let tr = &drive.truth[k];
        // At the IMU: the truth itself (equal values; a zero may change its sign).
        let at = [g0.lat, g0.lon, g0.h, g0.vn, g0.ve, g0.vd];
        assert_eq!(at, [tr.lat, tr.lon, tr.h, tr.vn, tr.ve, tr.vd], "t {}", g.t);
        let lat = tr.lat.to_radians();
        let rn = earth::radius_north(lat) + tr.h;
        let re = (earth::radius_east(lat) + tr.h) * lat.cos();
        let d = [
            (g.lat - tr.lat).to_radians() * rn,
            (g.lon - tr.lon).to_radians() * re,
            tr.h - g.h,
        ];
        let r = d.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!((r - length).abs() < 1e-6, "t {}: {r} m from the IMU", g.t);
        let dv = [g.vn - tr.vn, g.ve - tr.ve, g.vd - tr.vd];
        let speed = dv.iter().map(|x| x * x).sum::<f64>().sqrt();
        if g.t < 100.0 {
            assert!((d[2] + 0.8).abs() < 1e-9, "t {}: down {}", g.t, d[2]);
        }
        let Some(imu) = k.checked_sub(1).and_then(|i| drive.imu.get(i)) else {
            continue;
        };
        let w = nalgebra::Vector3::new(imu.gx, imu.gy, imu.gz);
        let want = w.cross(&nalgebra::Vector3::from(arm)).norm();
        assert!(
            (speed - want).abs() < 1e-9,
            "t {}: {speed} against {want} m/s",
            g.t
        );
        turning += usize::from(want > 0.02);
    }
    assert!(turning >= 25, "{turning} fixes in the turn");
}
