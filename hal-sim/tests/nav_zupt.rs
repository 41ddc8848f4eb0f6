//! Zero-velocity updates (`hal-sim nav --zupt`, `imu_ident::nav::rest`) on a simulated
//! stop-and-go drive with the MEMS IMU (`ImuErrorModel::mems`, the true model): at rest 60 s,
//! away to 10 m/s, a right turn, braking to a 300-s stop, away again. GNSS is withheld over
//! [240 s, 600 s): the last 10 s of cruising, the braking, the whole stop, the start and 30 s
//! of cruising.
//!
//! What must hold, with the bounds' reasons:
//! - The detector fires at every step of the stop and nowhere else in the outage: the
//!   updates made while GNSS was withheld are the stop's 300 steps, minus at most the one
//!   step that straddles each end (298-300).
//! - With the updates the filter stays consistent: at the outage's last epoch each horizontal
//!   position error is within 3 of its sd (0.27 % per axis for a consistent filter), and the
//!   velocity error at the stop's last epoch within 3 of its sd.
//! - The updates bound the velocity at rest: its sd at the stop's end is below 0.05 m/s (the
//!   update's 0.02 m/s per step, with the process noise of one step), against more than
//!   1 m/s without them.
//! - They shrink the error the outage leaves: the horizontal position sd at the outage's end
//!   is below a third of the free-inertial run's, and the actual error too (the free run's
//!   error is the drift of 330 s of MEMS dead reckoning, the updated run's that of ~60 s).

use hal_sim::nav::{run_with, NavArgs, NavRun};
use hal_sim::nav_io::outages::{north_east, OutageSpec};
use hal_sim::nav_io::truth_csv::TruthRow;
use hal_sim::nav_io::{read_gnss_csv, read_imu_csv, read_truth_csv};
use hal_sim::trajectory::errors::ImuErrorModel as SimModel;
use hal_sim::trajectory::gnss::GnssConfig;
use hal_sim::trajectory::profile::Profile;
use hal_sim::trajectory::write::{simulate_drive, write_drive};
use imu_ident::nav::Zupt;

const OUTAGE: (f64, f64) = (240.0, 600.0);
const STOP: (f64, f64) = (260.0, 560.0);

/// Horizontal position error [m] and sd at the last epoch before `t`, and the velocity error
/// [m/s] and sd (north, east) there.
fn at(run: &NavRun, truth: &[TruthRow], t: f64) -> ([f64; 2], [f64; 2], [f64; 2], [f64; 2]) {
    let e = run
        .epochs
        .iter()
        .rev()
        .find(|e| e.t < t)
        .unwrap_or_else(|| panic!("no epoch before {t}"));
    let k = truth.partition_point(|r| r.t < e.t - 1e-6);
    let r = &truth[k.min(truth.len() - 1)];
    assert!((r.t - e.t).abs() < 1e-3, "truth at {} for {}", r.t, e.t);
    let ne = north_east(r.lat_deg, r.lon_deg, r.h, e.lat_deg, e.lon_deg);
    (
        ne,
        [e.sd_pos[0], e.sd_pos[1]],
        [e.vel[0] - r.vel_ned[0], e.vel[1] - r.vel_ned[1]],
        [e.sd_vel[0], e.sd_vel[1]],
    )
}

#[test]
fn zero_velocity_updates_hold_a_stop_in_an_outage() {
    let profile = Profile::stop_and_go(STOP.1 - STOP.0).unwrap_or_else(|e| panic!("{e:#}"));
    let sim = SimModel::mems();
    let start = hal_sim::trajectory::write::course_start();
    let drive = simulate_drive(&profile, start, 0.01, &sim, GnssConfig::default(), 11)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    write_drive(dir.path(), &drive).unwrap_or_else(|e| panic!("{e:#}"));
    let imu = read_imu_csv(&dir.path().join("imu.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    let fixes = read_gnss_csv(&dir.path().join("gnss.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    let truth = read_truth_csv(&dir.path().join("truth.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    let t_first = fixes.first().map_or(0.0, |f| f.t);
    let free = NavArgs {
        outages: Some(OutageSpec {
            start: OUTAGE.0 - t_first,
            len: OUTAGE.1 - OUTAGE.0,
            period: 1e6,
            margin: 10.0,
        }),
        ..NavArgs::simulated(
            dir.path().join("imu.csv"),
            dir.path().join("gnss.csv"),
            sim.to_core().unwrap_or_else(|e| panic!("{e:#}")),
            "mems (true)",
            truth[0].rpy_deg[2],
        )
    };
    let zupt = NavArgs {
        zupt: Some(Zupt {
            sd: 0.02,
            gyro_max: 0.15,
            accel_max: 0.6,
            speed_max: 0.5,
        }),
        ..free.clone()
    };
    let run_free = run_with::<f64>(&free, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let run = run_with::<f64>(&zupt, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let s = run
        .summary
        .zupt
        .unwrap_or_else(|| panic!("no zero-velocity summary"));
    println!("{s:?}");
    assert!(
        (298..=300).contains(&s.in_outages),
        "{} updates in the outage, the stop has 300 steps",
        s.in_outages
    );

    let (_, _, dv, sdv) = at(&run, &truth, STOP.1);
    let (_, _, _, sdv_free) = at(&run_free, &truth, STOP.1);
    println!("stop's end: velocity error {dv:.3?} m/s, sd {sdv:.3?} (free: sd {sdv_free:.3?})");
    for i in 0..2 {
        assert!(
            dv[i].abs() <= 3.0 * sdv[i],
            "velocity axis {i}: {dv:?} against sd {sdv:?}"
        );
        assert!(sdv[i] < 0.05, "velocity sd at rest {sdv:?}");
        assert!(sdv_free[i] > 1.0, "free-inertial velocity sd {sdv_free:?}");
    }

    let (dp, sdp, _, _) = at(&run, &truth, OUTAGE.1);
    let (dp_free, sdp_free, _, _) = at(&run_free, &truth, OUTAGE.1);
    let h = |v: [f64; 2]| v[0].hypot(v[1]);
    println!(
        "outage's end: horizontal error {:.2} m (sd {sdp:.2?}) with the updates, {:.2} m (sd {sdp_free:.2?}) without",
        h(dp),
        h(dp_free)
    );
    for i in 0..2 {
        assert!(
            dp[i].abs() <= 3.0 * sdp[i],
            "position axis {i}: {dp:?} against sd {sdp:?}"
        );
    }
    assert!(
        h(sdp) < h(sdp_free) / 3.0,
        "sd {sdp:?} against {sdp_free:?}"
    );
    assert!(h(dp) < h(dp_free) / 3.0, "error {dp:?} against {dp_free:?}");
}
