//! `hal-sim nav --diagnose` on simulated drives (`hal_sim::nav::diagnose`): an accelerometer
//! bias that drifts (a random walk) hidden from a model that calls it constant, on a
//! manoeuvring course; the diagnosis must name it, and with it added the error against the
//! truth must fall. On a log without the hidden effect the diagnosis must find the model
//! adequate. With the walk on the vertical accelerometer only, the split of the named effect
//! over the axes (`diagnose::axes`) must place it there; with it the same on every axis, the
//! split must not be significant. A gyro drift that oscillates (an exponential-cosine hidden
//! from a model with a Gauss-Markov only) must be named as an exponential-cosine; one that
//! oscillates in place of the model's Gauss-Markov, as that Gauss-Markov replaced.
//!
//! The IMU (per axis), the MEMS preset's gyros and accelerometer white noise: gyro white
//! 0.15 deg/sqrt(h) + Gauss-Markov 10 deg/h over 300 s; accelerometer white 0.1 m/s/sqrt(h)
//! plus a random constant of 3 mg (turn-on bias), and, hidden,
//! a random walk whose 1-h drift is 2 mg (from zero). Course: the figure-eight of
//! `nav_blind_spots.rs` (IMU 50 Hz, GNSS 1 Hz, 60-s outages every 20 min from 10 min), 40 min.
//!
//! What the bounds rest on:
//! - the verdict's false-alarm rate is at most `ALPHA` = 1 % over the candidates (Wilks and
//!   Bonferroni, module docs of `diagnose`), so the null test fails on at most 1 % of seeds;
//! - the fitted random walk's `q` is checked within a factor of 10 of the truth only as a
//!   sanity bound (its Cramér-Rao coverage is `nav_blind_spots.rs`'s);
//! - a split of an effect the same on every axis, and the effect placed on an axis without it,
//!   are each false alarms in at most `ALPHA` of logs (Wilks: chi-square(2) and chi-square(1)
//!   0.99 quantiles, `diagnose::axes`).
//!
//! Benchmark (ignored): `NAVDIAG_SEEDS=10 NAVDIAG_FIRST_SEED=8801 NAVDIAG_DRIFT_MG=2 cargo test
//! --release -p hal-sim --test host nav_diagnose:: -- --ignored --nocapture` prints, per seed, the
//! verdict on the log with the hidden walk (its 1-h drift `NAVDIAG_DRIFT_MG`) and on the log
//! without it, the gains and the errors before and after; `NAVDIAG_AXES=z` (or `x`, `xz`, ...)
//! puts the walk on those accelerometer axes only, and the split of the named effect is
//! printed.

use hal_sim::nav::diagnose::{diagnose, run_diagnosed, NavDiagnosis, RunScores};
use hal_sim::nav::{run_with, NavArgs};
use hal_sim::nav_io::truth_csv::TruthRow;
use hal_sim::nav_io::{GnssFix, ImuSample};
use hal_sim::trajectory::errors::ImuErrorModel as SimModel;
use hal_sim::trajectory::gnss::GnssConfig;
use hal_sim::trajectory::profile::Profile;
use hal_sim::trajectory::write::{simulate_drive, write_and_read_drive};
use imu_ident::model::{Component, RandomConstant, RandomWalk};

const MG: f64 = 1e-3 * imu_ident::model::ins::G0;
const DT: f64 = 0.02;
const HOURS: f64 = 40.0 / 60.0;
/// The hidden walk: 2 mg of drift in 1 h.
const WALK_Q: f64 = 4.0 * MG * MG / 3600.0;

/// Every accelerometer axis.
const XYZ: [bool; 3] = [true; 3];

/// The accelerometers: white, the turn-on bias, and a walk of intensity `walk` when given.
fn sensors(walk: Option<f64>) -> SimModel {
    sensors_on(walk, XYZ)
}

/// [`sensors`] with the walk on the accelerometer axes `on` (x, y, z) only.
fn sensors_on(walk: Option<f64>, on: [bool; 3]) -> SimModel {
    // The MEMS preset's gyros and accelerometer white noise (its accelerometer Gauss-Markov
    // replaced by the turn-on bias).
    let mems = SimModel::mems();
    let accel = [
        mems.accel[0][0],
        Component::RandomConstant(RandomConstant { sigma: 3.0 * MG }),
    ];
    let mut m = SimModel::same_on_all_axes(&mems.gyro[0], &accel);
    if let Some(q) = walk {
        for (axis, on) in m.accel.iter_mut().zip(on) {
            if on {
                axis.push(Component::RandomWalk(RandomWalk { q, sigma0: 0.0 }));
            }
        }
    }
    m
}

struct Drive {
    dir: tempfile::TempDir,
    args: NavArgs,
    imu: Vec<ImuSample>,
    fixes: Vec<GnssFix>,
    truth: Vec<TruthRow>,
}

/// A drive simulated with `sim` and the navigator's arguments with the model that calls the
/// bias constant (the truth when the drive has no walk).
fn drive(sim: &SimModel, seed: u64) -> Drive {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let profile = Profile::figure_eight_course(HOURS, 1.0).unwrap_or_else(|e| panic!("{e:#}"));
    let start = hal_sim::trajectory::write::course_start();
    let d = simulate_drive(&profile, start, DT, sim, GnssConfig::default(), seed)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let (imu, fixes, truth) =
        write_and_read_drive(dir.path(), &d).unwrap_or_else(|e| panic!("{e:#}"));
    let model = sensors(None).to_core().unwrap_or_else(|e| panic!("{e:#}"));
    let args = NavArgs::simulated_drive(dir.path(), &fixes, &truth, model, "bias called constant");
    Drive {
        dir,
        args,
        imu,
        fixes,
        truth,
    }
}

/// The diagnosis of the drive with the hidden walk, run through the command's path (the runs
/// before and after scored against the truth).
fn hidden_walk(seed: u64, q: f64, on: [bool; 3], per_axis: bool) -> NavDiagnosis {
    hidden_walk_and_truth(seed, q, on, per_axis, false).0
}

/// [`hidden_walk`], and with `oracle` the scores of the true model's run on the same log.
fn hidden_walk_and_truth(
    seed: u64,
    q: f64,
    on: [bool; 3],
    per_axis: bool,
    oracle: bool,
) -> (NavDiagnosis, Option<RunScores>) {
    let d = drive(&sensors_on(Some(q), on), seed);
    let out = d.dir.path().join("out");
    let truth = d.dir.path().join("truth.csv");
    let diag = run_diagnosed(&d.args, None, per_axis, Some(&d.truth), Some(&truth), &out)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let scores = oracle.then(|| {
        let mut a = d.args.clone();
        a.model = sensors_on(Some(q), on)
            .to_core()
            .unwrap_or_else(|e| panic!("{e:#}"));
        let mut run = run_with::<f64>(&a, &d.imu, &d.fixes).unwrap_or_else(|e| panic!("{e:#}"));
        hal_sim::nav::truth::attach(&mut run, &d.truth, &truth).unwrap_or_else(|e| panic!("{e:#}"));
        RunScores::of(&run, f64::NAN)
    });
    (diag, scores)
}

fn without_walk(seed: u64, per_axis: bool) -> NavDiagnosis {
    let d = drive(&sensors(None), seed);
    diagnose(&d.args, &d.imu, &d.fixes, per_axis).unwrap_or_else(|e| panic!("{e:#}"))
}

fn gains(d: &NavDiagnosis) -> String {
    d.candidates
        .iter()
        .filter_map(|c| {
            let split = c
                .split_gain_nats
                .zip(c.split_threshold_nats)
                .map_or(String::new(), |(g, t)| format!(" (split {g:.1}/{t:.1})"));
            Some(format!(
                "{} {:.1}/{:.1}{split}",
                c.label, c.gain_nats?, c.threshold_nats?
            ))
        })
        .collect::<Vec<_>>()
        .join(", ")
}

fn named_q(d: &NavDiagnosis) -> Option<f64> {
    let name = d.named.as_deref()?;
    d.candidates.iter().find(|c| c.label == name)?.component?.q
}

#[test]
fn a_drifting_accelerometer_bias_is_named_and_the_error_falls() {
    let d = hidden_walk(8701, WALK_Q, XYZ, false);
    eprintln!(
        "hidden walk: {} {:?}; {}; per axis {:?}",
        d.verdict,
        d.named,
        gains(&d),
        d.axes
    );
    assert_eq!(d.verdict, "missing-effect", "{}", gains(&d));
    assert_eq!(
        d.named.as_deref(),
        Some("accel/random-walk"),
        "{}",
        gains(&d)
    );
    let q = named_q(&d).unwrap_or(f64::NAN);
    assert!(
        (q / WALK_Q).log10().abs() < 1.0,
        "fitted q {q:.3e} against {WALK_Q:.3e}"
    );
    // The walk is the same on every axis: the split is a false alarm in at most ALPHA = 1 % of
    // logs (Wilks, chi-square(2); `diagnose::axes`).
    let split = d.axes.clone().unwrap_or_else(|| panic!("no split"));
    assert!(!split.significant, "{split:?}");
    assert_eq!(split.on_axes, XYZ);
    let (b, a) = (
        d.before.clone().unwrap_or_else(|| panic!("no run before")),
        d.after.clone().unwrap_or_else(|| panic!("no run after")),
    );
    eprintln!("before {b:?}\nafter {a:?}");
    // The model that calls the bias constant is overconfident; with the walk the filter is
    // consistent: its mean NEES inside the 99 % band of the effective number of independent
    // epochs, and on this seed at most 1 % of epochs outside 3 sigma on every axis (0.27 %
    // expected of a consistent filter; 1 % is issue 16's bar for the true-model filter, which
    // itself exceeds it on some seeds: BENCHMARKS.md "Naming a missing effect on the
    // strapdown navigator"). The horizontal RMS falls on this seed; over seeds it is the
    // true-model filter's, lower than the overconfident model's on most but not all.
    assert_eq!(b.truth_nees_consistent, Some(false), "{b:?}");
    assert_eq!(a.truth_nees_consistent, Some(true), "{a:?}");
    assert!(
        a.truth_outside_3sigma_max.is_some_and(|f| f <= 0.01),
        "{a:?}"
    );
    let h = |s: &hal_sim::nav::diagnose::RunScores| s.truth_rms_horizontal_m.unwrap_or(f64::NAN);
    assert!(h(&a) < h(&b), "horizontal RMS {} -> {}", h(&b), h(&a));
    assert!(a.loglik > b.loglik);
}

/// The walk on the vertical accelerometer only: named, split, and placed on z.
#[test]
fn a_drift_on_one_axis_is_placed_on_that_axis() {
    let d = hidden_walk(8701, WALK_Q, [false, false, true], false);
    eprintln!(
        "walk on z: {} {:?}; {}; per axis {:?}",
        d.verdict,
        d.named,
        gains(&d),
        d.axes
    );
    assert_eq!(
        d.named.as_deref(),
        Some("accel/random-walk"),
        "{}",
        gains(&d)
    );
    let split = d.axes.clone().unwrap_or_else(|| panic!("no split"));
    // The split must gain more than half the chi-square(2) 0.99 quantile over the tied fit,
    // and dropping the walk from y or z alone lose less than half the chi-square(1) 0.99
    // quantile (each an ALPHA = 1 % false alarm where the walk is absent), from x more.
    assert!(split.significant, "{split:?}");
    assert_eq!(split.on_axes, [false, false, true], "{split:?}");
    assert_eq!(d.named_on_axes().as_deref(), Some("accel/random-walk on z"));
    let qz = split.axes[2].q.unwrap_or(f64::NAN);
    assert!(
        (qz / WALK_Q).log10().abs() < 1.0,
        "fitted q on z {qz:.3e} against {WALK_Q:.3e}"
    );
    let a = d.after.clone().unwrap_or_else(|| panic!("no run after"));
    assert_eq!(a.truth_nees_consistent, Some(true), "{a:?}");
    assert!(
        a.truth_outside_3sigma_max.is_some_and(|f| f <= 0.01),
        "{a:?}"
    );
}

/// The walk on the forward accelerometer only, a case the tied candidates miss on this seed
/// (the walk's tied gain 4.0 nats against 4.8: tied, it lands on the vertical axis too):
/// with every candidate split over the axes (`--diagnose-axes`) it is named and placed on x.
#[test]
fn a_drift_on_a_horizontal_axis_is_named_with_split_candidates() {
    let d = hidden_walk(8701, WALK_Q, [true, false, false], true);
    eprintln!(
        "walk on x, split candidates: {} {:?}; {}; per axis {:?}",
        d.verdict,
        d.named,
        gains(&d),
        d.axes
    );
    // The split walk's gain must pass half the chi-square(3) 1 - 0.01 / m quantile (m = 15
    // tests: 7 additions, tied and split, and the gyro Gauss-Markov's replacement): a right model is called inadequate in at most 1 %
    // of logs.
    assert_eq!(
        d.named_on_axes().as_deref(),
        Some("accel/random-walk on x"),
        "{}",
        gains(&d)
    );
    let a = d.after.clone().unwrap_or_else(|| panic!("no run after"));
    let b = d.before.clone().unwrap_or_else(|| panic!("no run before"));
    assert!(a.loglik > b.loglik);
    assert!(
        a.truth_outside_3sigma_max < b.truth_outside_3sigma_max,
        "{b:?} -> {a:?}"
    );
}

#[test]
fn a_right_model_is_adequate() {
    let d = without_walk(8701, false);
    eprintln!("no walk: {} {:?}; {}", d.verdict, d.named, gains(&d));
    assert_eq!(d.verdict, "adequate", "{}", gains(&d));
}

fn env<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

#[test]
#[ignore = "benchmark: NAVDIAG_SEEDS seeds from NAVDIAG_FIRST_SEED, about 2 min per seed"]
fn diagnosis_over_seeds() {
    let n: u64 = env("NAVDIAG_SEEDS", 10);
    let first: u64 = env("NAVDIAG_FIRST_SEED", 8801);
    // The walk's 1-h drift [mg].
    let drift: f64 = env("NAVDIAG_DRIFT_MG", 2.0);
    let q = drift * drift * MG * MG / 3600.0;
    // The accelerometer axes with the walk, e.g. `x` or `xz` (all three by default).
    let axes: String = env("NAVDIAG_AXES", "xyz".to_string());
    let on = [axes.contains('x'), axes.contains('y'), axes.contains('z')];
    // NAVDIAG_PER_AXIS=1: every candidate split over the axes too (`--diagnose-axes`).
    let per_axis = env("NAVDIAG_PER_AXIS", 0) == 1;
    let (mut named, mut adequate, mut placed) = (0, 0, 0);
    for seed in first..first + n {
        // NAVDIAG_ORACLE=1 also runs the true model on the log with the walk.
        let (h, oracle) =
            hidden_walk_and_truth(seed, q, on, per_axis, env("NAVDIAG_ORACLE", 0) == 1);
        if let Some(o) = &oracle {
            println!(
                "seed {seed}: true model: horizontal RMS {:.2} m, attitude RMS {:?} deg, worst axis outside 3 sigma {:.2} %, mean NEES {:.2}",
                o.truth_rms_horizontal_m.unwrap_or(f64::NAN),
                o.truth_rms_att_deg,
                100.0 * o.truth_outside_3sigma_max.unwrap_or(f64::NAN),
                o.truth_nees_mean.unwrap_or(f64::NAN)
            );
        }
        // NAVDIAG_NULL=0 skips the log without the walk (the same for every drift).
        let z = (env("NAVDIAG_NULL", 1) == 1).then(|| without_walk(seed, per_axis));
        let (b, a) = (h.before.clone(), h.after.clone());
        let hz = |s: &Option<hal_sim::nav::diagnose::RunScores>| {
            s.as_ref()
                .and_then(|s| s.truth_rms_horizontal_m)
                .unwrap_or(f64::NAN)
        };
        let out3 = |s: &Option<hal_sim::nav::diagnose::RunScores>| {
            100.0
                * s.as_ref()
                    .and_then(|s| s.truth_outside_3sigma_max)
                    .unwrap_or(f64::NAN)
        };
        let nees = |s: &Option<hal_sim::nav::diagnose::RunScores>| {
            s.as_ref()
                .and_then(|s| s.truth_nees_mean)
                .unwrap_or(f64::NAN)
        };
        let ok = h.named.as_deref() == Some("accel/random-walk");
        named += usize::from(ok);
        adequate += usize::from(z.as_ref().is_some_and(|z| z.verdict == "adequate"));
        placed += usize::from(ok && h.axes.as_ref().is_some_and(|a| a.on_axes == on));
        if let Some(a) = &h.axes {
            let qs = a.axes.map(|j| j.q.unwrap_or(f64::NAN) / q);
            println!(
                "seed {seed}: per axis q/q_true {:.2} {:.2} {:.2}, gain {:.1} nats (threshold {:.1}), drop losses {:?}, on {:?}, {} runs",
                qs[0],
                qs[1],
                qs[2],
                a.gain_nats,
                a.threshold_nats,
                a.drop_loss_nats,
                a.on_axes,
                a.evaluations
            );
        }
        let named_fit = h
            .named
            .as_deref()
            .and_then(|n| h.candidates.iter().find(|c| c.label == n))
            .and_then(|c| c.component)
            .map(|j| format!("{j:?}"))
            .unwrap_or_default();
        println!(
            "seed {seed}: hidden walk -> {} {:?} {named_fit} q/q_true {:.2}, horizontal RMS {:.2} -> {:.2} m, \
             attitude RMS {:?} -> {:?} deg, worst axis outside 3 sigma {:.2} -> {:.2} %, \
             mean NEES {:.1} -> {:.2} [{}]; \
             no walk -> {} {:?} [{}]",
            h.verdict,
            h.named,
            named_q(&h).unwrap_or(f64::NAN) / q,
            hz(&b),
            hz(&a),
            b.as_ref().and_then(|s| s.truth_rms_att_deg),
            a.as_ref().and_then(|s| s.truth_rms_att_deg),
            out3(&b),
            out3(&a),
            nees(&b),
            nees(&a),
            gains(&h),
            z.as_ref().map_or("-", |z| z.verdict),
            z.as_ref().and_then(|z| z.named.clone()),
            z.as_ref().map(gains).unwrap_or_default()
        );
    }
    let null = if env("NAVDIAG_NULL", 1) == 1 {
        format!("; the right model adequate in {adequate} of {n}")
    } else {
        String::new()
    };
    println!("named the walk in {named} of {n}, placed on its axes in {placed} of {n}{null}");
}

/// The drive with an exponential-cosine on every axis of `sensor` ("gyro" or "accel"; none
/// otherwise) hidden
/// from the model: sigma `sigma` (rad/s or m/s^2), envelope `tau` [s], period `period` [s];
/// with `replaces`, in place of the sensor's last component (the gyro's Gauss-Markov), which
/// the model keeps. Diagnosed through the command's path (the runs before and after scored
/// against the truth).
fn hidden_exp_cosine(
    seed: u64,
    sensor: &str,
    sigma: f64,
    tau: f64,
    period: f64,
    replaces: bool,
) -> NavDiagnosis {
    let mut sim = sensors(None);
    let ec = Component::ExpCosine(imu_ident::model::ExpCosine {
        sigma,
        tau,
        beta: 2.0 * std::f64::consts::PI / period,
    });
    let axes = match sensor {
        "gyro" => sim.gyro.iter_mut(),
        "accel" => sim.accel.iter_mut(),
        _ => [].iter_mut(),
    };
    for axis in axes {
        if replaces {
            axis.pop();
        }
        axis.push(ec);
    }
    let d = drive(&sim, seed);
    let out = d.dir.path().join("out");
    let truth = d.dir.path().join("truth.csv");
    run_diagnosed(&d.args, None, false, Some(&d.truth), Some(&truth), &out)
        .unwrap_or_else(|e| panic!("{e:#}"))
}

const DEG_H: f64 = std::f64::consts::PI / 180.0 / 3600.0;

/// The other direction: the drive's gyro drift is the Gauss-Markov (10 deg/h over 300 s), the
/// model's an exponential-cosine of the same sigma with envelope `tau` and period `period`.
/// Diagnosed through the command's path.
fn modelled_as_exp_cosine(seed: u64, tau: f64, period: f64) -> NavDiagnosis {
    let mut d = drive(&sensors(None), seed);
    let ec = Component::ExpCosine(imu_ident::model::ExpCosine {
        sigma: 10.0 * DEG_H,
        tau,
        beta: 2.0 * std::f64::consts::PI / period,
    });
    for axis in d.args.model.gyro.iter_mut() {
        axis.pop();
        axis.push(ec)
            .unwrap_or_else(|_| panic!("an axis with room"));
    }
    let out = d.dir.path().join("out");
    let truth = d.dir.path().join("truth.csv");
    run_diagnosed(&d.args, None, false, Some(&d.truth), Some(&truth), &out)
        .unwrap_or_else(|e| panic!("{e:#}"))
}

/// A gyro drift that oscillates (a heater cycling: an exp-cosine of 10 deg/h, period 900 s,
/// envelope 1200 s, on every gyro axis) next to the Gauss-Markov the model has: named as an
/// exp-cosine, not as a second Gauss-Markov or a walk, and with it the filter is consistent.
/// The period is not one of the candidate table's starting periods (120, 600, 3000 s).
#[test]
fn an_oscillating_gyro_drift_is_named_an_exp_cosine() {
    let d = hidden_exp_cosine(8701, "gyro", 10.0 * DEG_H, 1200.0, 900.0, false);
    eprintln!(
        "gyro exp-cosine: {} {:?}; {}",
        d.verdict,
        d.named,
        gains(&d)
    );
    // Significant: above half the chi-square(3) 1 - 0.01 / m quantile (m = 8: 7 additions
    // and the gyro Gauss-Markov's replacement; a right model is called inadequate in at most
    // 1 % of logs), with a larger excess than the replacement. Named over the Gauss-Markov
    // and the walk it contains as limits only when it gains more than half the chi-square(1)
    // or chi-square(2) 0.99 quantile over them (`diagnose` item 4).
    assert_eq!(d.named.as_deref(), Some("gyro/exp-cosine"), "{}", gains(&d));
    // The period of 900 s: 40 min hold 2.7 periods but two envelopes, so the period is set
    // by the data and tau is not.
    assert_fitted_and_consistent(&d, "gyro/exp-cosine", 900.0);
}

/// The exp-cosine fitted as `label` (sigma 10 deg/h): its period within 25 % of `period` (the
/// search's finest step is a factor e^0.25 = 1.28) and sigma within 2x (sanity bounds); with
/// the named change the likelihood rises and the filter is consistent: mean NEES in its 99 %
/// band, at most 1 % of epochs outside 3 sigma on every axis (0.27 % expected; issue 16's bar).
fn assert_fitted_and_consistent(d: &NavDiagnosis, label: &str, period: f64) {
    let c = d
        .candidates
        .iter()
        .find(|c| c.label == label)
        .and_then(|c| c.component)
        .unwrap_or_else(|| panic!("{label} not fitted"));
    let fitted = c.period.unwrap_or(f64::NAN);
    assert!((fitted / period - 1.0).abs() < 0.25, "{c:?}");
    let sigma = c.sigma.unwrap_or(f64::NAN) / (10.0 * DEG_H);
    assert!(sigma.log2().abs() < 1.0, "{c:?}");
    let (b, a) = (
        d.before.clone().unwrap_or_else(|| panic!("no run before")),
        d.after.clone().unwrap_or_else(|| panic!("no run after")),
    );
    eprintln!("before {b:?}\nafter {a:?}");
    assert!(a.loglik > b.loglik);
    assert_eq!(a.truth_nees_consistent, Some(true), "{a:?}");
    assert!(
        a.truth_outside_3sigma_max.is_some_and(|f| f <= 0.01),
        "{a:?}"
    );
}

/// A gyro drift that *is* an oscillation (issue 13's hidden structure: an exp-cosine of
/// period 600 s, envelope 1200 s, in place of the Gauss-Markov on every gyro axis), modelled as
/// a Gauss-Markov: named as the replacement `gyro/gauss-markov->exp-cosine` ("wrong-kind"),
/// not as an exp-cosine added on top of the wrong component, and with it the filter is
/// consistent.
#[test]
fn a_gyro_drift_of_the_wrong_kind_is_named_a_replacement() {
    let d = hidden_exp_cosine(8701, "gyro", 10.0 * DEG_H, 1200.0, 600.0, true);
    eprintln!(
        "gyro drift of the wrong kind: {} {:?}; {}",
        d.verdict,
        d.named,
        gains(&d)
    );
    // Significant: above half the chi-square(3) 1 - 0.01 / m quantile (m = 8: the seven
    // additions and this replacement; a right model is called inadequate in at most 1 % of
    // logs), and the largest excess (`diagnose` item 8).
    assert_eq!(d.verdict, "wrong-kind", "{}", gains(&d));
    assert_eq!(
        d.named.as_deref(),
        Some("gyro/gauss-markov->exp-cosine"),
        "{}",
        gains(&d)
    );
    // Not tied with the addition (which keeps the Gauss-Markov): more than 3.3 nats apart.
    assert_eq!(d.tied_with, None, "{}", gains(&d));
    // The diagnosed model has the exp-cosine where the Gauss-Markov was, on every axis.
    for axis in &d.model.gyro {
        assert!(
            matches!(
                axis.as_slice(),
                [Component::White(_), Component::ExpCosine(_)]
            ),
            "{axis:?}"
        );
    }
    // 40 min hold four periods of 600 s.
    assert_fitted_and_consistent(&d, "gyro/gauss-markov->exp-cosine", 600.0);
}

/// Benchmark: `NAVDIAG_EC=gyro` (or `accel`, or `none` for the right model: the null),
/// `NAVDIAG_EC_SIGMA` (deg/h or mg),
/// `NAVDIAG_EC_TAU`, `NAVDIAG_EC_PERIOD` [s], `NAVDIAG_SEEDS`, `NAVDIAG_FIRST_SEED`;
/// `NAVDIAG_EC_REPLACES=1` puts the exp-cosine in place of the gyro's Gauss-Markov (the model
/// keeps the Gauss-Markov; the replacement is the right answer); `NAVDIAG_EC_MODEL=1` the
/// other direction, the drive's Gauss-Markov modelled as an exp-cosine of `NAVDIAG_EC_TAU`
/// and `NAVDIAG_EC_PERIOD` ([`modelled_as_exp_cosine`]).
#[test]
#[ignore = "benchmark: the hidden exp-cosine over seeds, about 3 min per seed"]
fn exp_cosine_over_seeds() {
    let sensor: String = env("NAVDIAG_EC", "gyro".to_string());
    let n: u64 = env("NAVDIAG_SEEDS", 10);
    let first: u64 = env("NAVDIAG_FIRST_SEED", 8801);
    let unit = if sensor == "gyro" { DEG_H } else { MG };
    let sigma = env("NAVDIAG_EC_SIGMA", 10.0) * unit;
    let (tau, period) = (
        env("NAVDIAG_EC_TAU", 1200.0),
        env("NAVDIAG_EC_PERIOD", 900.0),
    );
    let replaces = env("NAVDIAG_EC_REPLACES", 0) == 1;
    let modelled = env("NAVDIAG_EC_MODEL", 0) == 1;
    let label = if modelled {
        "gyro/exp-cosine->gauss-markov".to_string()
    } else if replaces {
        format!("{sensor}/gauss-markov->exp-cosine")
    } else {
        format!("{sensor}/exp-cosine")
    };
    let (mut named, mut adequate) = (0, 0);
    for seed in first..first + n {
        let d = if modelled {
            modelled_as_exp_cosine(seed, tau, period)
        } else {
            hidden_exp_cosine(seed, &sensor, sigma, tau, period, replaces)
        };
        named += usize::from(d.named.as_deref() == Some(label.as_str()));
        adequate += usize::from(d.verdict == "adequate");
        let fit = d
            .candidates
            .iter()
            .find(|c| c.label == label)
            .and_then(|c| c.component);
        let f = |s: &Option<RunScores>, g: fn(&RunScores) -> Option<f64>| {
            s.as_ref().and_then(g).unwrap_or(f64::NAN)
        };
        let (b, a) = (&d.before, &d.after);
        println!(
            "seed {seed}: {} {:?}; fitted sigma/true {:.2}, tau {:.0} s, period {:.0} s; \
             outage RMS {:.2} -> {:.2} m, horizontal RMS {:.2} -> {:.2} m, worst axis outside 3 sigma \
             {:.2} -> {:.2} %, NEES consistent {:?} -> {:?} [{}]",
            d.verdict,
            d.named,
            fit.and_then(|c| c.sigma).unwrap_or(f64::NAN) / sigma,
            fit.and_then(|c| c.tau).unwrap_or(f64::NAN),
            fit.and_then(|c| c.period).unwrap_or(f64::NAN),
            f(b, |s| s.outage_rms_m),
            f(a, |s| s.outage_rms_m),
            f(b, |s| s.truth_rms_horizontal_m),
            f(a, |s| s.truth_rms_horizontal_m),
            100.0 * f(b, |s| s.truth_outside_3sigma_max),
            100.0 * f(a, |s| s.truth_outside_3sigma_max),
            b.as_ref().and_then(|s| s.truth_nees_consistent),
            a.as_ref().and_then(|s| s.truth_nees_consistent),
            gains(&d)
        );
    }
    println!("named {label} in {named} of {n}, adequate in {adequate} of {n}");
}
