//! The present solution of a live run with a latency budget (`imu_ident::nav::predictor`,
//! `hal_sim::present`): fixes delivered 0.25 s late, a 0.3-s budget, the run 0.3 s behind the
//! newest sample and the output predictor at it. BENCHMARKS.md "The present solution".

use hal_sim::nav::NavArgs;
use hal_sim::nav_io::{read_gnss_csv, read_imu_csv, read_truth_csv};
use hal_sim::present::{present_run, simulated_drive, PresentRun};

/// Every prediction compared with the run at its time is the run's, bit for bit.
fn assert_bit_for_bit(r: &PresentRun) {
    assert_eq!(
        r.differ, 0,
        "{} of {} predictions differ",
        r.differ, r.compared
    );
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    (s / n.max(1) as f64).sqrt()
}

/// The predictor's work is bounded by its design: each sample once as it arrives, and after
/// each change of the run's solution at most the delay line again (`latency` at 100 Hz, plus
/// the sample the run has not yet passed).
fn assert_cost_bounded(r: &PresentRun, latency: f64) {
    let line = (latency * 100.0).ceil() as u64 + 1;
    let bound = r.samples as u64 + r.changes * line;
    assert!(
        r.predicted <= bound,
        "{} samples mechanised, bound {bound} ({} samples, {} changes)",
        r.predicted,
        r.samples,
        r.changes
    );
}

/// A simulated 10-min drive (seed 65800): the predicted solution at each sample's time is the
/// one the run reaches there, bit for bit, wherever no filter step or fix came between (more
/// than half the samples at 1-Hz fixes and steps with a 0.3-s budget). Against the truth at
/// the newest sample's time its horizontal, velocity and attitude RMS are within 5 % of the
/// run's at its own time: the present cannot know the fixes of its last 0.3 s, which the run
/// at that time has fused (0.4, 2.4 and 0.9 % on 2026-12-01). The run's solution read as the
/// present is off by its speed times the budget: more than 5x the present's horizontal RMS
/// (19x on 2026-12-01).
#[test]
fn the_present_solution_is_the_run_carried_to_the_newest_sample() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = simulated_drive(dir.path(), 1.0 / 6.0, 65_800, false, true)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let imu = read_imu_csv(&args.imu).unwrap_or_else(|e| panic!("{e:#}"));
    let fixes = read_gnss_csv(&args.gnss).unwrap_or_else(|e| panic!("{e:#}"));
    let truth = read_truth_csv(&dir.path().join("truth.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    let r = present_run(&args, &imu, &fixes, Some(&truth), (0.25, 0.3, 120.0))
        .unwrap_or_else(|e| panic!("{e:#}"));
    assert_bit_for_bit(&r);
    assert!(
        2 * r.compared > r.samples,
        "{} of {} compared",
        r.compared,
        r.samples
    );
    assert!(
        2 * r.errors.len() > r.samples,
        "{} of {} scored",
        r.errors.len(),
        r.samples
    );
    let h = |k: usize| rms(r.errors.iter().map(|e| e[k].horizontal));
    let (present, stale, run) = (h(0), h(1), h(2));
    eprintln!(
        "horizontal RMS: present {present:.4} m, stale {stale:.4} m, run at its own time \
         {run:.4} m; {} predictions bit for bit; {:.3} samples mechanised per sample",
        r.compared,
        r.predicted as f64 / r.samples as f64
    );
    assert!(
        stale > 5.0 * present,
        "stale {stale} m against the present {present} m"
    );
    let q = |k: usize, w: usize| {
        rms(r.errors.iter().map(|e| {
            let s = &e[k];
            [s.horizontal, s.velocity, s.attitude][w]
        }))
    };
    for (w, name) in ["horizontal", "velocity", "attitude"].iter().enumerate() {
        let ratio = q(0, w) / q(2, w);
        eprintln!("{name}: present / run at its own time {ratio:.4}");
        assert!(
            ratio <= 1.05,
            "{name}: present {} against {}",
            q(0, w),
            q(2, w)
        );
    }
    assert_cost_bounded(&r, 0.3);
}

/// The real drive (4-Hz RTK fixes 0.2 s late, a 0.25-s budget, no outage): no truth at the
/// IMU's rate, so the present solution read at a sample's time is compared with the run's when
/// it reaches that time. RMS distance below a tenth of the stale solution's (0.09 against
/// 2.26 m on 2026-12-01); predictions with no change between are the run's bit for bit.
#[test]
fn real_drive_present_solution_stays_with_the_run() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let Some((args, imu, fixes)) =
        hal_sim::nav::real::drive_0708(dir.path()).unwrap_or_else(|e| panic!("{e:#}"))
    else {
        return;
    };
    let args = NavArgs {
        outages: None,
        ..args
    };
    let r = present_run(&args, &imu, &fixes, None, (0.2, 0.25, 120.0))
        .unwrap_or_else(|e| panic!("{e:#}"));
    assert_bit_for_bit(&r);
    assert!(
        r.compared > 0 && r.to_run.len() > 30_000,
        "{}",
        r.to_run.len()
    );
    let (present, stale) = (
        rms(r.to_run.iter().map(|d| d[0])),
        rms(r.to_run.iter().map(|d| d[1])),
    );
    eprintln!("from the run's solution: present RMS {present:.4} m, stale {stale:.4} m");
    assert!(
        10.0 * present < stale,
        "present {present} m, stale {stale} m"
    );
    assert_cost_bounded(&r, 0.25);
}

/// `hal-sim nav --present DELAY,LATENCY` (`hal_sim::present::write_present`): `present.csv`
/// is read back by the truth CSV's reader, one row per sample once running, the last at the
/// last sample; `present.json` holds the figures the bench prints; a negative budget is refused
/// with the option's name, before anything is written.
#[test]
fn nav_present_writes_the_present_solution_in_the_truth_format() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = simulated_drive(dir.path(), 1.0 / 12.0, 65_801, true, false)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let out = dir.path().join("out");
    std::fs::create_dir_all(&out).unwrap_or_else(|e| panic!("{e}"));
    let truth = read_truth_csv(&dir.path().join("truth.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    let err = hal_sim::present::write_present(&args, None, (0.2, -1.0), &out)
        .err()
        .map(|e| format!("{e:#}"));
    assert!(
        err.as_deref().is_some_and(|e| e.contains("--present")),
        "{err:?}"
    );
    assert!(!out.join("present.csv").exists());
    let line = hal_sim::present::write_present(&args, Some(&truth), (0.2, 0.25), &out)
        .unwrap_or_else(|e| panic!("{e:#}"));
    eprintln!("{line}");
    let rows = read_truth_csv(&out.join("present.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("present.json")).unwrap_or_else(|e| panic!("{e}")),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let imu = read_imu_csv(&args.imu).unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(json["rows"].as_u64(), Some(rows.len() as u64));
    assert_eq!(json["differ"].as_u64(), Some(0));
    // One row per sample from the start: after the 50-s levelling window (5000 samples) and
    // the wait for the next 1-Hz fix, delivered 0.2 s late (at most 121 more).
    let after = imu.len() - rows.len();
    assert!(
        (5000..=5121).contains(&after),
        "{} rows, {} samples",
        rows.len(),
        imu.len()
    );
    assert_eq!(rows.last().map(|r| r.t), imu.last().map(|s| s.t));
    assert!(rows.windows(2).all(|w| w[1].t > w[0].t));
    let present = json["errors_against_truth"]["present"]["horizontal_m"]["rms"].as_f64();
    let stale = json["errors_against_truth"]["stale"]["horizontal_m"]["rms"].as_f64();
    assert!(
        matches!((present, stale), (Some(p), Some(s)) if 5.0 * p < s),
        "{present:?} {stale:?}"
    );
}
