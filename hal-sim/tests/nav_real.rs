//! The real RTKLIB drive (`<repo>/../shared/data/real/rtklib-drive-0708`, never copied into the
//! repository) through `hal-sim nav` with the data's own outage test (15-s outages every 45 s
//! from 40 s after the first GNSS epoch while more than 30 s remain: 11 outages), three ways
//! (issue 16): the datasheet noise, the data's hand-inflated noise, and the noise identified on
//! the log by maximum likelihood (`--identify`). A test needing the data fails under `CI=true`
//! when they are missing, and otherwise prints why it skips.
//!
//! What is asserted:
//! - the datasheet model is inconsistent with these data: its mean per-axis NIS of the GNSS
//!   position is far above 1 (the datasheet noise is far too small for a roof-mounted MEMS IMU
//!   on a moving car);
//! - the identified model is consistent: every mean per-axis NIS of the position between 0.3
//!   and 3, of the velocity between 0.1 and 3 (over ~400 fused epochs a consistent filter gives
//!   1; one factor scales the three velocity sd of the RTK solution, whose vertical sd is
//!   looser than the horizontal ones, so a wide band is asserted, not a chi-square one);
//! - the identified model is no worse at the end of the outages than the hand-inflated one
//!   (measured 7.17 m against 8.05 m). The data's own filter, 7.15 m RMS, is the bar:
//!   this model sits at it within the spread of the start's arbitrary choices (11 levelling
//!   windows of 16-24 s: 6.95-7.18 m, median 7.05 m; 7.02 m before the start's fix was no
//!   longer fused twice; BENCHMARKS.md "The fix that places the run"), so the bar is asserted
//!   on the online identification (the test below: 5.05-6.93 m over the same windows);
//! - the non-holonomic constraint (`--nhc`, at the body origin 0.65 m below the IMU) with
//!   the identified model, at [`NHC_SD`] (the constraint's sd identified on this log), raises
//!   the GNSS innovation likelihood, is consistent (mean NIS of its two axes between 0.1 and
//!   3), and is better at the end of the outages than the same model without it and than the
//!   data's own filter (which has no constraint). Measured (BENCHMARKS.md): 4.56 m against
//!   7.17 m (4.38 m against 7.02 m before "The fix that places the run"); the bounds leave
//!   that margin to a different identification path (the search is flat along the bias
//!   walks).
//!
//! - the MCU's online identification, the bank of shadow filters (`--adapt --adapt-method
//!   bank`, decisions every 60 s from the datasheet model), is no worse at the end of the
//!   outages than the hand-inflated model, and the rule that a coordinate the window does not
//!   bound waits while a bounded one leaves the grid (`OnlineConfig::flat_waits`) is what
//!   brings it there: without it the flat coordinates climbed to their bound together with
//!   the bounded ones and the bank ended worse. Measured 7.12 m with the rule, 10.31 m
//!   without, 8.05 m hand-inflated (7.66, 10.33 and 7.99 m before "The fix that places the
//!   run", whose start sweep puts the bank at 6.71-9.70 m: under the hand-inflated model in
//!   6 of 11 starts); with the default exit test (`OnlineConfig::exit_z`; 7.81 m and 10.64 m
//!   before it; BENCHMARKS.md "Flat coordinates wait in the bank" and "Leaving the grid on
//!   evidence").
//!   With the non-holonomic constraint on both it is within the drive's bar, 7.15 m: 3.31 m
//!   against 6.68 m hand-inflated (2.73 m against 6.60 m before).
//!
//! - the drive streamed through the live loop (`imu_ident::nav::live`: the start and every
//!   fix decided by the core, as on a navigation computer), fixes early or late within the
//!   latency budget, is the host's run bit for bit (no outage schedule).
//!
//! The identification with the constraint's factor in the search (`--identify --nhc`, ~50 s)
//! is the ignored test `real_drive_identifies_the_constraint_sd`.

use hal_sim::nav::identify::Identified;
use hal_sim::nav::{identify, run_with, NavArgs};
use hal_sim::nav_io::{GnssFix, ImuSample};
use std::sync::OnceLock;

/// Standard deviation of the body lateral and vertical velocity of the drive's body origin
/// [m/s]: identified on this log by `hal-sim nav --identify --nhc SD` (the constraint's factor
/// as one more coordinate of the likelihood search): 0.056 from `SD = 0.1`, 0.053 from 0.3.
const NHC_SD: f64 = 0.05;

/// The offline identification of the drive from the datasheet model (`--identify`), which two
/// tests read: computed once per test binary (about 25 s in the test profile; CI time,
/// BENCHMARKS.md "CI time: the real drive identified once"). Every test reads the same log
/// with the same options (`drive`), so the answer does not depend on which test asks first.
fn identified(args: &NavArgs, samples: &[ImuSample], fixes: &[GnssFix]) -> &'static Identified {
    static ID: OnceLock<Identified> = OnceLock::new();
    ID.get_or_init(|| identify::identify(args, samples, fixes).unwrap_or_else(|e| panic!("{e:#}")))
}

/// The drive imported into `dir`, read: (args with the datasheet model and the outage test,
/// IMU samples, fixes), or `None` (printed) when the data are missing.
fn drive(dir: &std::path::Path) -> Option<hal_sim::nav::real::Drive> {
    hal_sim::nav::real::drive_0708(dir).unwrap_or_else(|e| panic!("{e:#}"))
}

#[test]
fn real_drive_identified_model_is_consistent_and_no_worse_than_hand_inflated() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let Some((args, samples, fixes)) = drive(dir.path()) else {
        return;
    };
    let datasheet = run_with::<f64>(&args, &samples, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let inflated = run_with::<f64>(&hand_inflated(&args), &samples, &fixes)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let id = identified(&args, &samples, &fixes);
    let id_args = NavArgs {
        model: id.model.clone(),
        gnss_sd_factor: [id.factors[4], id.factors[5]],
        imu_time_shift: id.imu_time_shift,
        ..args.clone()
    };
    let identified =
        run_with::<f64>(&id_args, &samples, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let nhc_args = NavArgs {
        nhc: Some(NHC_SD),
        ..id_args.clone()
    };
    let nhc = run_with::<f64>(&nhc_args, &samples, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let rms = |r: &hal_sim::nav::NavRun| r.summary.outage_rms_m.unwrap_or(f64::NAN);
    let c = nhc
        .summary
        .nhc
        .unwrap_or_else(|| panic!("no constraint summary"));
    println!(
        "identified model with the non-holonomic constraint (sd {NHC_SD} m/s at {:?} m): RMS {:.2} m, \
         median {:.2} m, max {:.2} m, loglik {:.1} (without: {:.1}); constraint: {} updates, {} in \
         outages, {} gated, mean NIS {:?}, RMS innovation {:?} m/s",
        c.lever,
        rms(&nhc),
        nhc.summary.outage_median_m.unwrap_or(f64::NAN),
        nhc.summary.outage_max_m.unwrap_or(f64::NAN),
        nhc.summary.loglik,
        identified.summary.loglik,
        c.updates,
        c.in_outages,
        c.gated,
        c.mean_nis_axis,
        c.rms_innovation
    );
    println!(
        "real drive, horizontal error at the end of 11 15-s outages, RMS: identified {:.2} m \
         (factors {:?}, IMU time shift {:+.4} s, {} runs), hand-inflated {:.2} m, datasheet {:.2} m; \
         the data's own filter: 7.15 m",
        rms(&identified),
        id.factors,
        id.imu_time_shift,
        id.evaluations,
        rms(&inflated),
        rms(&datasheet)
    );
    println!(
        "mean NIS per axis: datasheet {:?}, identified {:?}",
        datasheet.summary.mean_nis_axis, identified.summary.mean_nis_axis
    );
    for r in [&datasheet, &inflated, &identified] {
        assert_eq!(r.summary.outages_scored, Some(11));
    }
    assert!(
        datasheet.summary.mean_nis_axis[0] > 10.0,
        "the datasheet model should be visibly inconsistent: {:?}",
        datasheet.summary.mean_nis_axis
    );
    for (i, v) in identified.summary.mean_nis_axis.iter().enumerate() {
        let low = if i < 3 { 0.3 } else { 0.1 };
        assert!(
            (low..=3.0).contains(v),
            "identified model, axis {i}: mean NIS {v}"
        );
    }
    assert!(id.loglik > id.loglik_start);
    assert!(
        rms(&identified) <= rms(&inflated),
        "identified {} m worse than hand-inflated {} m",
        rms(&identified),
        rms(&inflated)
    );
    // The constraint.
    assert_eq!(nhc.summary.outages_scored, Some(11));
    assert_eq!(c.lever, [0.0, 0.0, 0.65]);
    assert!(
        c.in_outages > 100,
        "the constraint must act during the outages: {c:?}"
    );
    for v in c.mean_nis_axis {
        assert!((0.1..=3.0).contains(&v), "constraint mean NIS {v}: {c:?}");
    }
    assert!(
        nhc.summary.loglik > identified.summary.loglik,
        "the constraint should improve the prediction of the fixes: loglik {} <= {}",
        nhc.summary.loglik,
        identified.summary.loglik
    );
    assert!(
        rms(&nhc) < rms(&identified) && rms(&nhc) < 7.15,
        "with the constraint {} m, without {} m, the data's own filter 7.15 m",
        rms(&nhc),
        rms(&identified)
    );
}

/// `--identify --nhc 0.3`: the constraint's sd is one more coordinate of the likelihood search.
/// Asserted: it lands near the value the other starts found (0.05 m/s, within a factor 3: the
/// search's finest step is 1/8 decade and the likelihood is flat along the bias walks) and the
/// run beats the identification without the constraint (7.02 m, BENCHMARKS.md; asserted
/// against the grid answer's 6.88 m, measured 4.36 m). About 50 s.
#[test]
#[ignore = "about 50 s in release: cargo test --release -p hal-sim --test host nav_real:: -- --ignored"]
fn real_drive_identifies_the_constraint_sd() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let Some((args, samples, fixes)) = drive(dir.path()) else {
        return;
    };
    let args = NavArgs {
        nhc: Some(0.3),
        ..args
    };
    let id = identify::identify(&args, &samples, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let sd = id.nhc_sd.unwrap_or(f64::NAN);
    let run = run_with::<f64>(
        &NavArgs {
            model: id.model.clone(),
            gnss_sd_factor: [id.factors[4], id.factors[5]],
            imu_time_shift: id.imu_time_shift,
            nhc: id.nhc_sd,
            ..args.clone()
        },
        &samples,
        &fixes,
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    let rms = run.summary.outage_rms_m.unwrap_or(f64::NAN);
    println!(
        "identified with the constraint: sd {sd:.4} m/s, factors {:?}, shift {:+.4} s, {} runs; \
         outage RMS {rms:.2} m",
        id.factors, id.imu_time_shift, id.evaluations
    );
    assert!((NHC_SD / 3.0..=NHC_SD * 3.0).contains(&sd), "sd {sd}");
    assert!(rms < 6.88, "outage RMS {rms} m");
}

/// Online, causal (`--adapt --adapt-every 60,60 --adapt-gnss-sd true`, from the data's
/// hand-inflated model): the window search also identifies the GNSS position and velocity
/// standard deviations. Asserted:
/// - its final factors on them agree with the offline identification on the whole log
///   (`--identify`, the same likelihood) to within 3.29 of the last search's Cramér-Rao sd
///   (99.9 %, Wald) plus the 1/8-decade grid both searches stop on;
/// - at the end of the outages it is no worse than the hand-inflated model it started from,
///   nor than the data's own filter, 7.15 m RMS (the bar). Measured 5.86 m (5.70 m
///   before the start's fix was no longer fused twice; over 11 levelling windows of 16-24 s
///   5.05-6.93 m, median 6.15 m, each below the hand-inflated model's 7.99-8.69 m:
///   BENCHMARKS.md "The fix that places the run"; 6.18 m before "The fix at its own time");
///   without the GNSS coordinates 8.29 m.
///
/// About 2 min in release (23 s in the test profile, the offline identification read from
/// [`identified`]); in CI since 2026-12-02, the bar on this drive.
#[test]
fn real_drive_online_with_the_gnss_noise_beats_the_hand_inflated_model() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let Some((args, samples, fixes)) = drive(dir.path()) else {
        return;
    };
    let inflated = hand_inflated(&args);
    let fixed = run_with::<f64>(&inflated, &samples, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let cfg = hal_sim::nav::adapt::AdaptConfig {
        first: 60.0,
        every: 60.0,
        gnss_sd: true,
        ..hal_sim::nav::adapt::AdaptConfig::DEFAULT
    };
    let online = run_with::<f64>(
        &NavArgs {
            adapt: Some(cfg),
            ..inflated.clone()
        },
        &samples,
        &fixes,
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    let id = identified(&args, &samples, &fixes);
    let log = online.adapt.as_ref().expect("an adapt log");
    let last = log.searches.last().expect("searches");
    let rms = |r: &hal_sim::nav::NavRun| r.summary.outage_rms_m.unwrap_or(f64::NAN);
    println!(
        "online with the GNSS noise: {} searches, final log10 factors {:?} (Cramér-Rao sd {:?}); \
         outage RMS {:.2} m; hand-inflated {:.2} m; offline GNSS factors {:?}",
        log.searches.len(),
        last.log10_factors,
        last.cr_sd_log10,
        rms(&online),
        rms(&fixed),
        &id.factors[4..]
    );
    for (c, (x, sd)) in log
        .coordinates
        .iter()
        .zip(last.log10_factors.iter().zip(&last.cr_sd_log10))
    {
        if let Some(i) = c.gnss_sd() {
            let offline = id.factors[4 + i].log10();
            assert!(
                (x - offline).abs() <= 3.29 * sd + 0.125,
                "{}: online {x} +- {sd}, offline {offline}",
                c.quantity
            );
        }
    }
    assert!(rms(&online) <= rms(&fixed), "online {} m", rms(&online));
    assert!(rms(&online) <= 7.15, "online {} m", rms(&online));
}

/// `args` with the data's hand-inflated noise model.
fn hand_inflated(args: &NavArgs) -> NavArgs {
    NavArgs {
        model: hal_sim::nav::model::load("drive-inflated").unwrap_or_else(|e| panic!("{e:#}")),
        model_name: "drive-inflated".into(),
        ..args.clone()
    }
}

/// The bank on the drive (module docs): decisions every 60 s from the datasheet model, with
/// and without `OnlineConfig::flat_waits`, against the hand-inflated fixed model; then with
/// the non-holonomic constraint at [`NHC_SD`] on every run, where the bank with the rule is
/// within the drive's bar, 7.15 m, and no worse than the hand-inflated model with the same
/// constraint (measured 3.31 m against 6.68 m; BENCHMARKS.md "Flat coordinates wait in the
/// bank"). Five runs of a second or two each.
#[test]
fn real_drive_bank_with_flat_coordinates_waiting_is_no_worse_than_hand_inflated() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let Some((args, samples, fixes)) = drive(dir.path()) else {
        return;
    };
    let inflated = hand_inflated(&args);
    let rms = |r: &hal_sim::nav::NavRun| r.summary.outage_rms_m.unwrap_or(f64::NAN);
    let fixed =
        rms(&run_with::<f64>(&inflated, &samples, &fixes).unwrap_or_else(|e| panic!("{e:#}")));
    let bank = |flat_waits: bool, nhc: Option<f64>| {
        let d = hal_sim::nav::adapt::AdaptConfig::DEFAULT;
        let cfg = hal_sim::nav::adapt::AdaptConfig {
            first: 60.0,
            every: 60.0,
            method: hal_sim::nav::adapt::AdaptMethod::Bank,
            bank: imu_ident::nav::OnlineConfig {
                first: 60.0,
                every: 60.0,
                flat_waits,
                ..d.bank
            },
            gnss_sd: true,
            ..d
        };
        let run = run_with::<f64>(
            &NavArgs {
                adapt: Some(cfg),
                nhc,
                ..args.clone()
            },
            &samples,
            &fixes,
        )
        .unwrap_or_else(|e| panic!("{e:#}"));
        let decisions = run.adapt.as_ref().map_or(0, |l| l.searches.len());
        (rms(&run), decisions)
    };
    let (with, n_with) = bank(true, None);
    let (without, n_without) = bank(false, None);
    println!(
        "bank from the datasheet model, every 60 s: {with:.2} m with flat coordinates waiting \
         ({n_with} decisions), {without:.2} m without ({n_without}); hand-inflated {fixed:.2} m"
    );
    assert!(
        n_with >= 8 && n_without >= 8,
        "{n_with} {n_without} decisions"
    );
    assert!(with <= fixed, "bank {with} m, hand-inflated {fixed} m");
    assert!(
        without > with,
        "without the rule {without} m, with it {with} m"
    );
    // With the constraint on both.
    let fixed_nhc = NavArgs {
        nhc: Some(NHC_SD),
        ..inflated
    };
    let fixed_nhc =
        rms(&run_with::<f64>(&fixed_nhc, &samples, &fixes).unwrap_or_else(|e| panic!("{e:#}")));
    let (with_nhc, _) = bank(true, Some(NHC_SD));
    println!("with the constraint: bank {with_nhc:.2} m, hand-inflated {fixed_nhc:.2} m");
    assert!(
        with_nhc <= fixed_nhc && with_nhc <= 7.15,
        "bank {with_nhc} m, hand-inflated {fixed_nhc} m, with the constraint"
    );
}

/// The drive streamed through the live loop (`imu_ident::nav::live`) as a navigation computer
/// receives it: 100-Hz samples and 4-Hz fixes interleaved, the fixes 0.1 s early, then 0.2 s
/// late within a 0.25-s latency budget. The live loop levels, places the run and decides every
/// fix itself; the run is the host's, bit for bit (no outage schedule: a live run withholds
/// nothing).
#[test]
fn real_drive_streamed_live_is_the_host_run_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let Some((args, _, _)) = drive(dir.path()) else {
        return;
    };
    let args = NavArgs {
        outages: None,
        ..args
    };
    for (delay, latency) in [(-0.1, 0.0), (0.2, 0.25)] {
        let live = crate::nav_live::live_is_the_replay(&args, delay, latency);
        assert!(live.epochs.len() > 2000, "{} epochs", live.epochs.len());
    }
}
