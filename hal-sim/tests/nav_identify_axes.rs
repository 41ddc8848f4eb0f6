//! `hal-sim nav --identify --identify-axes` on simulated drives (`hal_sim::nav::identify`):
//! the model's factors identified tied over the three axes of each sensor, then untied and
//! tested. When the true sensor's axes differ (here the accelerometer bias walk: its 1-h drift
//! 3 mg on x, 1 mg on y, 0.3 mg on z, where the datasheet-style model says 1 mg on every axis),
//! the per-axis answer must be kept and must order the axes as the truth does; when they are
//! alike (1 mg on every axis, the model right), the tied answer must be kept.
//!
//! The IMU (per axis): the MEMS preset's gyros (white 0.15 deg/sqrt(h) + Gauss-Markov
//! 10 deg/h over 300 s) and accelerometer white noise (0.1 m/s/sqrt(h)), a 3-mg random constant
//! (turn-on bias) and the walk. Course: the figure-eight of `nav_diagnose.rs` (IMU 50 Hz, GNSS
//! 1 Hz, 60-s outages every 20 min from 10 min), 40 min.
//!
//! What the bounds rest on: the tied fit is the per-axis fit with equal factors, so under a
//! model whose axes are alike twice the gain is chi-square with two degrees of freedom per
//! factor the model carries (Wilks; here 6: gyro white, accelerometer white and walk), and the
//! test keeps the per-axis answer on at most 1 % of such logs (`identify::AxesFit`). The
//! per-axis walk factors are checked only for their order (x above z: the truth's 10x in
//! standard deviation), a sanity bound, not a Cramér-Rao one.
//!
//! Benchmark (ignored): `IDAXES_SEEDS=10 IDAXES_FIRST_SEED=9501 cargo test --release -p hal-sim
//! --test host nav_identify_axes:: -- --ignored --nocapture` prints, per seed, on the log
//! whose axes differ and on the log whose axes are alike: the gain against the threshold, the
//! per-axis walk factors, and the scores (outage-end RMS, horizontal RMS against the truth, worst
//! fraction outside 3 sigma, mean NEES) of the tied answer, the per-axis answer and the true
//! model.

use hal_sim::nav::diagnose::RunScores;
use hal_sim::nav::identify::{identify_axes, loglik, Axes, Identified, Uncertainty};
use hal_sim::nav::{run_with, truth, NavArgs};
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

/// The walk's 1-h drift [mg] on x, y, z when the axes differ.
const DIFFER: [f64; 3] = [3.0, 1.0, 0.3];
/// The same when they are alike (and the model's on every axis).
const ALIKE: [f64; 3] = [1.0; 3];

/// The IMU with the accelerometer walk's 1-h drift `drift_mg` per axis.
fn sensors(drift_mg: [f64; 3]) -> SimModel {
    let mems = SimModel::mems();
    let accel = [
        mems.accel[0][0],
        Component::RandomConstant(RandomConstant { sigma: 3.0 * MG }),
    ];
    let mut m = SimModel::same_on_all_axes(&mems.gyro[0], &accel);
    for (axis, d) in m.accel.iter_mut().zip(drift_mg) {
        // A 1-h drift of d: q = d^2 / 3600 s.
        let q = (d * MG).powi(2) / 3600.0;
        axis.push(Component::RandomWalk(RandomWalk { q, sigma0: 0.0 }));
    }
    m
}

struct Drive {
    dir: tempfile::TempDir,
    imu: Vec<ImuSample>,
    fixes: Vec<GnssFix>,
    truth: Vec<TruthRow>,
}

impl Drive {
    /// The navigator's arguments on this drive with `model`.
    fn args(&self, model: &SimModel, name: &str) -> NavArgs {
        let m = model.to_core().unwrap_or_else(|e| panic!("{e:#}"));
        NavArgs::simulated_drive(self.dir.path(), &self.fixes, &self.truth, m, name)
    }

    /// The scores of a run of `args` against the truth.
    fn scores(&self, args: &NavArgs) -> RunScores {
        let mut run =
            run_with::<f64>(args, &self.imu, &self.fixes).unwrap_or_else(|e| panic!("{e:#}"));
        let path = self.dir.path().join("truth.csv");
        truth::attach(&mut run, &self.truth, &path).unwrap_or_else(|e| panic!("{e:#}"));
        let ll = loglik(args, &self.imu, &self.fixes).unwrap_or_else(|e| panic!("{e:#}"));
        RunScores::of(&run, ll)
    }
}

/// A drive simulated with the walk `drift_mg`.
fn drive(drift_mg: [f64; 3], seed: u64) -> Drive {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let profile = Profile::figure_eight_course(HOURS, 1.0).unwrap_or_else(|e| panic!("{e:#}"));
    let start = hal_sim::trajectory::write::course_start();
    let d = simulate_drive(
        &profile,
        start,
        DT,
        &sensors(drift_mg),
        GnssConfig::default(),
        seed,
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    let (imu, fixes, truth) =
        write_and_read_drive(dir.path(), &d).unwrap_or_else(|e| panic!("{e:#}"));
    Drive {
        dir,
        imu,
        fixes,
        truth,
    }
}

/// The identification with the per-axis stage, from the model that says 1 mg on every axis.
fn identified(d: &Drive) -> (NavArgs, Identified) {
    let args = d.args(&sensors(ALIKE), "walk 1 mg/h on every axis");
    let id =
        identify_axes(&args, &d.imu, &d.fixes, Axes::Tested).unwrap_or_else(|e| panic!("{e:#}"));
    (args, id)
}

#[test]
fn a_sensor_whose_axes_differ_is_identified_per_axis() {
    let d = drive(DIFFER, 9401);
    let (_, id) = identified(&d);
    let axes = id.axes.as_ref().expect("the per-axis stage ran");
    println!("{}", id.summary_line());
    assert_eq!(axes.df, 6, "gyro white, accelerometer white and walk");
    assert!(
        axes.significant,
        "gain {:.1} nats, threshold {:.1}",
        axes.gain_nats, axes.threshold_nats
    );
    // The accelerometer walk (row 3): x above z, as the truth's 10x.
    let walk = axes.factors[3];
    assert!(walk[0] > walk[2], "walk factors x, y, z {walk:?}");
    // Its Cramér-Rao interval on x covers the truth (3.29 sd: 99.9 % two-sided).
    let (z, u) = walk_z_score(&id, "accel_bias_walk_x", DIFFER[0]);
    assert!(u.identifiable && z.abs() < 3.29, "{u:?}: z {z:.2}");
    // Its 95 % likelihood interval, measured by runs, is closed, holds the answer, and has
    // the Cramér-Rao interval's size within a factor of two on each side (the walk's
    // likelihood is nearly quadratic here: BENCHMARKS.md "Likelihood intervals").
    let (v, sd) = (u.interval_95, u.cr_sd.unwrap_or(f64::NAN));
    let half = 1.96 * sd;
    assert!(
        !v.lo_open
            && !v.hi_open
            && (0.5 * half..2.0 * half).contains(&(u.value - v.lo))
            && (0.5 * half..2.0 * half).contains(&(v.hi - u.value)),
        "{u:?}"
    );
}

/// The z-score of the identified log10 factor `name` against the truth's factor `truth_mg`
/// (the walk's drift over the model's 1 mg), and its record.
fn walk_z_score(id: &Identified, name: &str, truth_mg: f64) -> (f64, Uncertainty) {
    let u = id
        .uncertainty
        .iter()
        .find(|u| u.name == name)
        .unwrap_or_else(|| panic!("{name} in {:?}", id.uncertainty))
        .clone();
    let z = (u.value - truth_mg.log10()) / u.cr_sd.unwrap_or(f64::INFINITY);
    (z, u)
}

/// The 95 % likelihood interval of `u` and whether it holds the truth `truth_mg` (`IN95` or
/// `OUT95`, for the bench's tally), with the most a run rose above the answer.
fn interval_verdict(u: &Uncertainty, truth_mg: f64) -> String {
    let v = u.interval_95;
    let t = truth_mg.log10();
    format!(
        "LI [{:+.3}, {:+.3}] {} above {:.2}",
        v.lo,
        v.hi,
        if (v.lo..=v.hi).contains(&t) {
            "IN95"
        } else {
            "OUT95"
        },
        v.above_nats
    )
}

#[test]
fn a_sensor_whose_axes_are_alike_keeps_the_tied_answer() {
    let d = drive(ALIKE, 9401);
    let (_, id) = identified(&d);
    let axes = id.axes.as_ref().expect("the per-axis stage ran");
    println!("{}", id.summary_line());
    assert!(
        !axes.significant,
        "gain {:.1} nats over the threshold {:.1} (a 1 % false alarm)",
        axes.gain_nats, axes.threshold_nats
    );
}

fn env_or(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn line(name: &str, s: &RunScores) -> String {
    format!(
        "{name}: outage-end RMS {:.2} m, horizontal {:.3} m, worst outside 3 sigma {:.2} %, NEES {:.1}",
        s.outage_rms_m.unwrap_or(f64::NAN),
        s.truth_rms_horizontal_m.unwrap_or(f64::NAN),
        100.0 * s.truth_outside_3sigma_max.unwrap_or(f64::NAN),
        s.truth_nees_mean.unwrap_or(f64::NAN)
    )
}

#[test]
#[ignore = "benchmark: IDAXES_SEEDS, IDAXES_FIRST_SEED (BENCHMARKS.md)"]
fn bench_identify_axes() {
    let seeds = env_or("IDAXES_SEEDS", 4);
    let first = env_or("IDAXES_FIRST_SEED", 9501);
    for seed in first..first + seeds {
        for (name, drift) in [("differ", DIFFER), ("alike", ALIKE)] {
            let t = std::time::Instant::now();
            let d = drive(drift, seed);
            let (args, id) = identified(&d);
            let Some(axes) = id.axes.as_ref() else {
                panic!("the per-axis stage ran")
            };
            // The tied answer: `id` unless the per-axis one was kept (then the same search
            // without the per-axis stage).
            let tied = if axes.significant {
                hal_sim::nav::identify::identify(&args, &d.imu, &d.fixes)
                    .unwrap_or_else(|e| panic!("{e:#}"))
            } else {
                id.clone()
            };
            println!(
                "seed {seed} {name}: gain {:.1} nats against {:.1}: {}; walk factors x/y/z {:.2?} (true {:.2?}), white gyro {:.2?}, accel {:.2?}; {} + {} runs ({:.0} s)",
                axes.gain_nats,
                axes.threshold_nats,
                if axes.significant { "per axis" } else { "tied" },
                axes.factors[3],
                drift,
                axes.factors[0],
                axes.factors[1],
                id.evaluations - axes.evaluations,
                axes.evaluations,
                t.elapsed().as_secs_f64()
            );
            // The walk's Cramér-Rao z-scores against the truth, in the answer kept.
            let z: Vec<String> = if axes.significant {
                ["x", "y", "z"]
                    .iter()
                    .zip(drift)
                    .map(|(a, t)| {
                        let (z, u) = walk_z_score(&id, &format!("accel_bias_walk_{a}"), t);
                        format!(
                            "{a} {:+.2} sd {:?} z {z:+.2} {}",
                            u.value,
                            u.cr_sd,
                            interval_verdict(&u, t)
                        )
                    })
                    .collect()
            } else {
                let (z, u) = walk_z_score(&id, "accel_bias_walk", drift[0]);
                vec![format!(
                    "tied {:+.2} sd {:?} z {z:+.2} {}",
                    u.value,
                    u.cr_sd,
                    interval_verdict(&u, drift[0])
                )]
            };
            println!(
                "  walk, Cramér-Rao: {} (Newton step {:?} nats)",
                z.join("; "),
                id.newton_nats
            );
            println!("  {}", line("tied", &d.scores(&tied.apply(&args))));
            println!("  {}", line("per axis", &d.scores(&axes.apply(&args))));
            println!(
                "  {}",
                line("true", &d.scores(&d.args(&sensors(drift), "true")))
            );
        }
    }
}
