//! The core's online identification by a bank of shadow filters (`imu_ident::nav::online`,
//! `hal-sim nav --adapt --adapt-method bank`) on a 25-min simulated figure-eight drive (MEMS
//! IMU, 100 Hz, GNSS 1 Hz, seed 12).
//!
//! What is asserted, and why:
//! - **The shadows are exact.** A shadow under the running filter's own model is that filter:
//!   the same predictions (its navigation block less the drive the mechanisation already
//!   removed), the same fixes, the same corrections. With the gate off, the centre shadow's
//!   summed innovation log-likelihood equals the running filter's to rounding (1e-9
//!   relative), over every fix of the drive; the shadows at `+-d` differ from it.
//! - **It moves the right way from a wrong start.** Started with every standard deviation 10x
//!   too large (log10 factor +1 on the intensities, the truth at -1), the decisions at 10 and
//!   20 min lower every intensity coordinate by more than 0.3 decade: each decision moves
//!   only when its parabola promises at least `min_gain` = 1 nat over the centre (a
//!   likelihood ratio), so a move is the data's, not noise's, at that level.

use hal_sim::nav::adapt::{start_bank, AdaptConfig, AdaptMethod, TauMode};
use hal_sim::nav::drive::NavLoop;
use hal_sim::nav::model::scaled_sd;
use hal_sim::nav::setup::shifted_imu;
use hal_sim::nav::{run_with, NavArgs};
use hal_sim::nav_io::{read_gnss_csv, read_imu_csv, read_truth_csv};
use hal_sim::trajectory::errors::ImuErrorModel as SimModel;
use hal_sim::trajectory::write::simulate_drive_files;
use imu_ident::model::Quantity;
use imu_ident::nav::OnlineConfig;

/// The test drive (`simulate_drive_files`: the figure-eight course, MEMS IMU at 100 Hz, GNSS
/// 1 Hz): its directory, the yaw at the start, and the samples and fixes.
fn drive() -> (
    tempfile::TempDir,
    f64,
    Vec<hal_sim::nav_io::ImuSample>,
    Vec<hal_sim::nav_io::GnssFix>,
) {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    simulate_drive_files(25.0 / 60.0, 100.0, 12, (vec![], [0.0; 3]), dir.path())
        .unwrap_or_else(|e| panic!("{e:#}"));
    let read = |name: &str| dir.path().join(name);
    let imu = read_imu_csv(&read("imu.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    let fixes = read_gnss_csv(&read("gnss.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    let truth = read_truth_csv(&read("truth.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    let yaw = truth[0].rpy_deg[2];
    (dir, yaw, imu, fixes)
}

fn args(dir: &tempfile::TempDir, yaw: f64, scale: f64, adapt: AdaptConfig) -> NavArgs {
    let truth = SimModel::mems()
        .to_core()
        .unwrap_or_else(|e| panic!("{e:#}"));
    NavArgs {
        adapt: Some(adapt),
        ..NavArgs::simulated(
            dir.path().join("imu.csv"),
            dir.path().join("gnss.csv"),
            scaled_sd(&truth, scale),
            "test",
            yaw,
        )
    }
}

/// The bank with decisions at `first` and every `every` seconds after it, without the GNSS
/// factors (they have their own test).
fn bank(first: f64, every: f64) -> AdaptConfig {
    AdaptConfig {
        method: AdaptMethod::Bank,
        taus: TauMode::Free,
        gnss_sd: false,
        bank: OnlineConfig {
            first,
            every,
            ..OnlineConfig::DEFAULT
        },
        ..AdaptConfig::DEFAULT
    }
}

/// The right IMU model, the receiver's stated standard deviations 4x its true noise
/// (`--gnss-sd-factor 4,4`), and `adapt` with the GNSS factors identified.
fn misstated_gnss(dir: &tempfile::TempDir, yaw: f64, adapt: AdaptConfig) -> NavArgs {
    let adapt = AdaptConfig {
        gnss_sd: true,
        ..adapt
    };
    NavArgs {
        gnss_sd_factor: [4.0, 4.0],
        ..args(dir, yaw, 1.0, adapt)
    }
}

#[test]
fn the_centre_shadow_reproduces_the_running_filter() {
    let (dir, yaw, imu, fixes) = drive();
    for gnss_sd in [false, true] {
        centre_against_running(&dir, yaw, &imu, &fixes, gnss_sd);
    }
}

/// [`the_centre_shadow_reproduces_the_running_filter`] with or without the GNSS factors (their
/// shadows differ from the centre in the fixes' variances only, by `10^(+-2d)`).
fn centre_against_running(
    dir: &tempfile::TempDir,
    yaw: f64,
    imu: &[hal_sim::nav_io::ImuSample],
    fixes: &[hal_sim::nav_io::GnssFix],
    gnss_sd: bool,
) {
    // No decision within the drive: every shadow keeps its model, the sums cover every fix.
    let mut a = args(
        dir,
        yaw,
        1.0,
        AdaptConfig {
            gnss_sd,
            ..bank(1e6, 1e6)
        },
    );
    a.gate = None;
    let shifted = shifted_imu(&a, imu);
    let (mut lp, _) =
        NavLoop::<f64>::start(&a, &shifted, fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let t0 = lp.time(&shifted);
    let online = a.online().expect("the bank's settings");
    start_bank(online, None, lp.nav_mut(), t0).unwrap_or_else(|e| panic!("{e:#}"));
    let mut epochs = Vec::new();
    lp.advance(
        &shifted,
        fixes,
        f64::INFINITY,
        &mut epochs,
        "imu.csv",
        &|| {},
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    let id = lp.nav().observer().ident.as_ref().expect("the bank");
    let p = id.log10_factors().len();
    assert_eq!(p, id.coordinates().len() + if gnss_sd { 2 } else { 0 });
    let sums = id.window_sums();
    let centre = sums[2 * p];
    assert!(lp.fused > 1000, "{} fixes", lp.fused);
    assert_eq!(id.fixes() as usize, lp.fused);
    assert!(
        (centre - lp.loglik).abs() <= 1e-9 * lp.loglik.abs(),
        "centre {centre} against the running filter {}",
        lp.loglik
    );
    for (k, s) in sums.iter().enumerate().take(2 * p) {
        assert!(
            (s - centre).abs() > 1e-3,
            "shadow {k}: {s} = centre {centre}"
        );
    }
    assert_eq!(id.faults(), 0);
}

#[test]
fn from_ten_times_too_large_the_bank_lowers_every_intensity() {
    let (dir, yaw, imu, fixes) = drive();
    let a = args(&dir, yaw, 10.0, bank(600.0, 600.0));
    let run = run_with::<f64>(&a, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let log = run.adapt.as_ref().expect("an adapt log");
    assert!(log.searches.len() >= 2, "{:?}", log.searches);
    let last = log.searches.last().expect("a decision");
    let mut intensities = 0;
    for (c, x) in log.coordinates.iter().zip(&last.log10_factors) {
        assert!(
            x.abs() <= 2.0 + 1e-12,
            "{} outside the bound: {x}",
            c.label()
        );
        if c.quantity != Quantity::Tau.name() {
            intensities += 1;
            assert!(*x < -0.3, "{} at {x:+.2} decades (truth -1)", c.label());
        }
    }
    assert_eq!(intensities, 4, "{:?}", log.coordinates);
    assert!(last.cr_sd_log10.iter().any(|sd| sd.is_finite()));
}

/// The GNSS factors in the bank (`OnlineConfig::gnss_sd`, `--adapt-gnss-sd true`): the IMU
/// model right, the receiver's stated standard deviations 4x its true noise
/// (`--gnss-sd-factor 4,4`); decisions at 10 and 20 min. Both factors should come out at
/// log10(1/4) = -0.602, and the running filter should take them.
///
/// Bound: within 3.29 Cramér-Rao sd (99.9 %, two-sided, Wald) plus 0.01 decade of -0.602.
/// The factors move by the variance-scale model's maximum (`newton.rs`), exact when the fixes'
/// noise dominates their innovation variance; the 0.01 decade allows for the filter's own
/// share of it, which the model's sd (`1 / (ln 10 sqrt(2 n))`, ~0.007 decade with 600 fixes of
/// three axes) leaves out. A parabola through the shadows at half a decade put the factor at
/// -0.716 (measured), and a bank without the coordinates is 0.6 decade off: both fail.
#[test]
fn the_bank_finds_a_misstated_gnss_noise() {
    let (dir, yaw, imu, fixes) = drive();
    let a = misstated_gnss(&dir, yaw, bank(600.0, 600.0));
    let run = run_with::<f64>(&a, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let log = run.adapt.as_ref().expect("an adapt log");
    let names: Vec<&str> = log.coordinates.iter().map(|c| c.quantity).collect();
    let p = names.len();
    assert_eq!(&names[p - 2..], ["position_sd", "velocity_sd"], "{names:?}");
    let last = log.searches.last().expect("a decision");
    for s in &log.searches {
        println!(
            "decision at {:.0} s (window from {:.0} s, {} fixes): factors {:.3?}, sd {:.3?}",
            s.t, s.window_start, s.fixes, s.log10_factors, s.cr_sd_log10
        );
    }
    let want = 0.25f64.log10();
    for i in [p - 2, p - 1] {
        let (x, sd) = (last.log10_factors[i], last.cr_sd_log10[i]);
        assert!(sd.is_finite() && sd > 0.0, "{}: sd {sd}", names[i]);
        assert!(
            (x - want).abs() <= 3.29 * sd + 0.01,
            "{}: {x:+.4} +- {sd:.4}, want {want:+.4}",
            names[i]
        );
    }
    // The record gives the factors on top of the stated 4.
    let end = log.gnss_sd_factor_end();
    for (i, f) in end.iter().enumerate() {
        let x = last.log10_factors[p - 2 + i];
        assert!((f - 4.0 * 10f64.powf(x)).abs() < 1e-9, "{end:?}");
    }
    // The running filter took them at the first decision: the position NIS of the fixes
    // after it is a right R's. Each fix's sum of the three per-axis NIS has mean 3 and
    // variance about 6 (chi-square(3) for independent axes): the mean over n fixes within
    // 3.29 sd of 3. With the stated R it would be about 3/16.
    let first = log.searches.first().map_or(f64::INFINITY, |s| s.t);
    assert_right_position_nis(&run, first);
}

/// The mean position NIS of the fixes fused after `from` [s] is a right R's (the bound above).
fn assert_right_position_nis(run: &hal_sim::nav::NavRun, from: f64) {
    let after: Vec<f64> = run
        .epochs
        .iter()
        .filter(|e| e.t > from && e.fused)
        .map(|e| e.nis_axis[..3].iter().sum::<f64>())
        .collect();
    let n = after.len() as f64;
    let mean = after.iter().sum::<f64>() / n;
    println!("{n} fixes after {from:.0} s, mean position NIS {mean:.3}");
    assert!(n >= 30.0, "{n} fixes");
    assert!((mean - 3.0).abs() <= 3.29 * (6.0 / n).sqrt(), "{mean}");
}

/// `--adapt-tied-first` (`hal_sim::nav::adapt::switch_if_settled`): the tied bank until its
/// first decision that keeps its window, then a per-axis bank from its point. Same drive and
/// misstated GNSS noise as above, decisions every 5 min.
///
/// Asserted:
/// - **It switches**, and the record is one history in the per-axis coordinates: every
///   IMU coordinate on one axis, every decision with a factor for each, the tied bank's with
///   the three axes of a quantity equal, and decisions on both sides of the switch.
/// - **The GNSS factors carry over.** The per-axis bank starts from the navigator's factors
///   (the core's GNSS reference), so after its decisions the running filter still has the
///   right `R`: the mean position NIS of the fixes after the per-axis bank's first decision
///   within 3.29 sd of 3 (the bound of the test above). A bank that restarted its factors at
///   the stated 4x would leave it near 3/16. The record's last factors are on the run's start
///   and agree with the filter's end factors.
#[test]
fn tied_first_switches_to_per_axis_and_keeps_the_gnss_factors() {
    let (dir, yaw, imu, fixes) = drive();
    let tied_first = AdaptConfig {
        per_axis: true,
        tied_first: true,
        ..bank(300.0, 300.0)
    };
    let a = misstated_gnss(&dir, yaw, tied_first);
    let run = run_with::<f64>(&a, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let log = run.adapt.as_ref().expect("an adapt log");
    for s in &log.searches {
        println!(
            "decision at {:.0} s (window from {:.0} s): factors {:.2?}",
            s.t, s.window_start, s.log10_factors
        );
    }
    let switched = log.tied_until.expect("the per-axis bank took over");
    println!("per axis from {switched:.0} s");
    let p = log.coordinates.len();
    let imu_coords = &log.coordinates[..p - 2];
    assert!(
        imu_coords.iter().all(|c| c.axes.len() == 1),
        "{imu_coords:?}"
    );
    assert!(log.searches.iter().all(|s| s.log10_factors.len() == p));
    let (tied, per_axis): (Vec<_>, Vec<_>) = log.searches.iter().partition(|s| s.t <= switched);
    assert!(
        !tied.is_empty() && !per_axis.is_empty(),
        "{:?}",
        log.searches
    );
    for s in &tied {
        for (i, c) in imu_coords.iter().enumerate() {
            for (j, d) in imu_coords.iter().enumerate() {
                let same =
                    c.sensor == d.sensor && c.component == d.component && c.quantity == d.quantity;
                if same {
                    let (x, y) = (s.log10_factors[i], s.log10_factors[j]);
                    assert!(
                        (x - y).abs() < 1e-9,
                        "{} {x} against {} {y}",
                        c.label(),
                        d.label()
                    );
                }
            }
        }
    }
    let last = log.searches.last().expect("a decision");
    let end = log.gnss_sd_factor_end();
    for (i, f) in end.iter().enumerate() {
        let x = last.log10_factors[p - 2 + i];
        assert!((f - 4.0 * 10f64.powf(x)).abs() < 1e-9, "{end:?}");
        assert!(
            (x - 0.25f64.log10()).abs() < 0.1,
            "GNSS factor {i}: {x:+.3}"
        );
    }
    let first = per_axis.first().map_or(f64::INFINITY, |s| s.t);
    assert_right_position_nis(&run, first);
}
