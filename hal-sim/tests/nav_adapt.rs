//! Online identification in the strapdown navigator (`hal-sim nav --adapt`, issue 16): one
//! 25-min figure-eight drive (MEMS IMU `ImuErrorModel::mems`, 100 Hz, GNSS 1 Hz), the filter
//! started with every noise standard deviation 10x too large; one search at 20 min over the
//! window from the start.
//!
//! What is asserted, and why the bounds:
//! - The search reaches the likelihood's maximum region: the highest window log-likelihood it
//!   found is at least the true model's on the same data, less 1 nat (the pattern search stops
//!   at a step of 0.125 decade; near the maximum a step that small changes the likelihood by
//!   well under a nat on these coordinates).
//! - The truth is inside the likelihood-ratio confidence region of that maximum:
//!   2 (L_max - L_true) <= chi-square(4 dof, 0.999) = 18.47 (Wilks; four coordinates: the
//!   white density and the Gauss-Markov sigma of each sensor type, tied over the axes; the
//!   correlation times are held here, `TauMode::Held`).
//! - The model taken is within its conservative allowance of the maximum: at most
//!   `FLAT_NATS` per coordinate below it.
//! - The wrong start is rejected: 2 (L_taken - L_start) > 18.47.
//! - The Cramér-Rao intervals at the maximum (the inverse observed information by finite
//!   differences) bound every coordinate, and each holds the truth within 3.29 sd (99.9 %
//!   two-sided, Wald).
//! - Causality: the same run on the log cut 100 s after the search gives the same search,
//!   bit for bit (the search reads nothing after its time).
//!
//! The correlation times under test (`TauMode::Tested`), the same drive and search:
//! - from the 10x start, whose correlation times are right, the search holds them: twice the
//!   gain of freeing them is chi-square(2) under the held values (Wilks), so the test moves
//!   them with probability 1 % (`TAU_TEST_LEVEL`); on this fixed seed it does not;
//! - from the true intensities with both correlation times 10x too short (30 s for 300 s), the
//!   test rejects them and the search lengthens both.

use hal_sim::nav::adapt::{AdaptConfig, AdaptMethod, TauMode, FLAT_NATS};
use hal_sim::nav::model::scaled_sd;
use hal_sim::nav::{run_with, NavArgs};
use hal_sim::nav_io::{GnssFix, ImuSample};
use hal_sim::trajectory::errors::ImuErrorModel as SimModel;
use hal_sim::trajectory::gnss::GnssConfig;
use hal_sim::trajectory::profile::Profile;
use hal_sim::trajectory::write::{simulate_drive, write_and_read_drive};
use imu_ident::model::Quantity;
use imu_ident::nav::ImuErrorModel;

/// chi-square quantile, 4 degrees of freedom, 0.999.
const CHI2_4_999: f64 = 18.467;

/// The test drive (25-min figure-eight, MEMS IMU, seed 11): samples, fixes, truth, directory.
fn drive() -> (
    Vec<ImuSample>,
    Vec<GnssFix>,
    Vec<hal_sim::nav_io::TruthRow>,
    tempfile::TempDir,
) {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let profile =
        Profile::figure_eight_course(25.0 / 60.0, 1.0).unwrap_or_else(|e| panic!("{e:#}"));
    let start = hal_sim::trajectory::write::course_start();
    let drive = simulate_drive(
        &profile,
        start,
        0.01,
        &SimModel::mems(),
        GnssConfig::default(),
        11,
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    let (imu, fixes, truth) =
        write_and_read_drive(dir.path(), &drive).unwrap_or_else(|e| panic!("{e:#}"));
    (imu, fixes, truth, dir)
}

/// The run of the test drive (`dir`, `truth` from [`drive`]) with `model` and `adapt`.
fn nav_args(
    dir: &tempfile::TempDir,
    truth: &[hal_sim::nav_io::TruthRow],
    model: ImuErrorModel<f64>,
    adapt: Option<AdaptConfig>,
) -> NavArgs {
    NavArgs {
        adapt,
        ..NavArgs::simulated(
            dir.path().join("imu.csv"),
            dir.path().join("gnss.csv"),
            model,
            "test",
            truth[0].rpy_deg[2],
        )
    }
}

/// One search at 20 min over the window from the start.
const ONE_SEARCH: AdaptConfig = AdaptConfig {
    first: 1200.0,
    every: 1e6,
    window: 1e6,
    per_axis: false,
    tied_first: false,
    taus: TauMode::Held,
    conservative: true,
    method: AdaptMethod::Replay,
    bank: imu_ident::nav::OnlineConfig::DEFAULT,
    gnss_sd: false,
};

#[test]
fn online_search_finds_the_likelihood_maximum_from_a_wrong_start_and_reads_no_future() {
    let (imu, fixes, truth, dir) = drive();
    let truth_model = SimModel::mems()
        .to_core()
        .unwrap_or_else(|e| panic!("{e:#}"));
    let args = |model, adapt| nav_args(&dir, &truth, model, adapt);
    let adapted = args(scaled_sd(&truth_model, 10.0), Some(ONE_SEARCH));
    let run = run_with::<f64>(&adapted, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let log = run.adapt.as_ref().expect("an adapt log");
    assert_eq!(log.searches.len(), 1, "{:?}", log.searches);
    let s = &log.searches[0];
    // The run starts at the end of the levelling window; the first window starts there.
    let t_run = run.epochs[0].t;
    assert!(
        s.window_start <= t_run && s.window_start > t_run - 1.0,
        "{} vs {t_run}",
        s.window_start
    );

    // The likelihood of a fixed model on the search's window: a run on the log cut at the
    // search's time, ungated (as the search's replays are).
    let t_search = s.t;
    let cut = |t: f64| -> (Vec<ImuSample>, Vec<GnssFix>) {
        (
            imu.iter().filter(|x| x.t <= t).copied().collect(),
            fixes.iter().filter(|f| f.t <= t).copied().collect(),
        )
    };
    let (imu_w, fixes_w) = cut(t_search);
    let window_loglik = |model| {
        let mut a = args(model, None);
        a.gate = None;
        run_with::<f64>(&a, &imu_w, &fixes_w)
            .unwrap_or_else(|e| panic!("{e:#}"))
            .summary
            .loglik
    };
    let l_true = window_loglik(truth_model.clone());
    let l_start = window_loglik(scaled_sd(&truth_model, 10.0));
    println!(
        "search at {} s over {} fixes, {} replays: L_start {:.2} (search's own {:.2}), L_max {:.2}, L_taken {:.2}, L_true {:.2}; log10 factors {:?}",
        s.t, s.fixes, s.evaluations, l_start, s.loglik_before, s.loglik_max, s.loglik, l_true, s.log10_factors
    );
    assert!(
        (s.loglik_before - l_start).abs() < 1e-6,
        "the search's window is the run's"
    );
    assert_eq!(log.coordinates.len(), 4);
    assert!(
        s.loglik_max >= l_true - 1.0,
        "L_max {} < L_true {} - 1",
        s.loglik_max,
        l_true
    );
    assert!(
        2.0 * (s.loglik_max - l_true) <= CHI2_4_999,
        "truth outside the LR region"
    );
    assert!(s.loglik >= s.loglik_max - FLAT_NATS * 4.0 - 1e-9);
    assert!(
        2.0 * (s.loglik - l_start) > CHI2_4_999,
        "the 10x start was not rejected"
    );
    // The Cramér-Rao intervals at the maximum: every coordinate bounded, and the truth (log10
    // factor -1 on each: the start is 10x) within 3.29 sd of the maximum (99.9 % two-sided
    // per coordinate, Wald).
    println!(
        "maximum {:?}, Cramér-Rao sd {:?}, identifiable {:?}",
        s.ml_log10_factors, s.cr_sd_log10, s.identifiable
    );
    for (i, (m, sd)) in s.ml_log10_factors.iter().zip(&s.cr_sd_log10).enumerate() {
        assert!(sd.is_finite() && *sd > 0.0, "coordinate {i}: sd {sd}");
        assert!((m + 1.0).abs() <= 3.29 * sd, "coordinate {i}: {m} +- {sd}");
    }

    // The outputs: adapt.csv (one row per search, the coordinates' values), adapt.json, the
    // model TOML (read back as the final model) and the report's section.
    let out = dir.path().join("out");
    hal_sim::nav::records::write_outputs(&out, &run, None, None, &[])
        .unwrap_or_else(|e| panic!("{e:#}"));
    let csv = std::fs::read_to_string(out.join("adapt.csv")).unwrap_or_else(|e| panic!("{e}"));
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 2, "{csv}");
    assert!(
        lines[0].ends_with(
            "gyro_xyz_0_density,gyro_xyz_1_sigma,accel_xyz_0_density,accel_xyz_1_sigma,\
             gyro_xyz_0_density_sd_log10,gyro_xyz_1_sigma_sd_log10,\
             accel_xyz_0_density_sd_log10,accel_xyz_1_sigma_sd_log10"
        ),
        "{}",
        lines[0]
    );
    let back = hal_sim::nav::model::load(&out.join("adapt-model.toml").display().to_string())
        .unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(back, log.model);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap_or_else(|e| panic!("{e}"));
    assert!(html.contains("Online identification"));

    // Causality: the log cut 100 s after the search gives the same search.
    let (imu_c, fixes_c) = cut(t_search + 100.0);
    let run_c = run_with::<f64>(&adapted, &imu_c, &fixes_c).unwrap_or_else(|e| panic!("{e:#}"));
    let c = &run_c.adapt.as_ref().expect("an adapt log").searches[0];
    assert_eq!(c.loglik.to_bits(), s.loglik.to_bits());
    assert_eq!(c.log10_factors, s.log10_factors);
    assert_eq!(c.evaluations, s.evaluations);
}

/// `m` with every correlation time multiplied by `k`.
fn scaled_taus(m: &ImuErrorModel<f64>, k: f64) -> ImuErrorModel<f64> {
    let mut out = m.clone();
    for c in out.gyro.iter_mut().chain(out.accel.iter_mut()).flatten() {
        if let Some(tau) = c.get(Quantity::Tau) {
            c.set(Quantity::Tau, tau * k);
        }
    }
    out
}

#[test]
fn tested_correlation_times_are_held_when_right_and_moved_when_rejected() {
    let (imu, fixes, truth, dir) = drive();
    let truth_model = SimModel::mems()
        .to_core()
        .unwrap_or_else(|e| panic!("{e:#}"));
    let search = |model: ImuErrorModel<f64>| {
        let tested = AdaptConfig {
            taus: TauMode::Tested,
            ..ONE_SEARCH
        };
        let args = nav_args(&dir, &truth, model, Some(tested));
        let run = run_with::<f64>(&args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
        let log = run.adapt.expect("an adapt log");
        let names: Vec<&str> = log.coordinates.iter().map(|c| c.quantity).collect();
        assert_eq!(
            names,
            ["density", "sigma", "tau", "density", "sigma", "tau"],
            "gyro then accel: white, then Gauss-Markov"
        );
        let s = log.searches[0].clone();
        println!("{:?}", s);
        s
    };
    // chi-square(2) 0.99 quantile 9.2103, halved: the gain that rejects the held taus.
    let right = search(scaled_sd(&truth_model, 10.0));
    let t = right.tau_test.expect("tested");
    assert!((t.threshold - 9.2103 / 2.0).abs() < 1e-3, "{t:?}");
    assert!(t.gain >= 0.0, "the free search starts at the held optimum");
    assert!(!t.moved, "right correlation times moved: {t:?}");
    assert_eq!((right.log10_factors[2], right.log10_factors[5]), (0.0, 0.0));

    let short = search(scaled_taus(&truth_model, 0.1));
    let t = short.tau_test.expect("tested");
    assert!(t.moved, "correlation times 10x short held: {t:?}");
    assert!(
        short.log10_factors[2] > 0.0 && short.log10_factors[5] > 0.0,
        "{:?}",
        short.log10_factors
    );
}

/// The GNSS noise online (`AdaptConfig::gnss_sd`, `--adapt-gnss-sd true`): the same drive and
/// search, the IMU model right, but the receiver's stated standard deviations 4x its true
/// noise (`--gnss-sd-factor 4,4`). The search has two more coordinates, the factors on the
/// fixes' position and velocity standard deviations, and should find 1/4 for both.
///
/// Bounds: the maximum's log10 factor within 3.29 Cramér-Rao sd (99.9 % two-sided, Wald) plus
/// half the search's last step (1/16 decade: the pattern search stops on a grid of 1/8 decade)
/// of log10(1/4). With ~1 200 fixes of three axes each the Cramér-Rao sd is a few thousandths
/// of a decade, so the bound is about 0.08 decade, a factor 1.2: a search that did not move
/// the factors (0.6 decade off) fails it. The model taken runs the rest of the drive: its
/// position NIS over the fixes after the search is that of a right R (mean 3 per fix, three
/// axes), where the stated R would give about 3/16.
#[test]
fn online_search_finds_a_misstated_gnss_noise() {
    let (imu, fixes, truth, dir) = drive();
    let truth_model = SimModel::mems()
        .to_core()
        .unwrap_or_else(|e| panic!("{e:#}"));
    let cfg = AdaptConfig {
        gnss_sd: true,
        ..ONE_SEARCH
    };
    let args = NavArgs {
        gnss_sd_factor: [4.0, 4.0],
        ..nav_args(&dir, &truth, truth_model, Some(cfg))
    };
    let run = run_with::<f64>(&args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let log = run.adapt.as_ref().expect("an adapt log");
    let names: Vec<(&str, &str)> = log
        .coordinates
        .iter()
        .map(|c| (c.sensor, c.quantity))
        .collect();
    assert_eq!(
        names,
        [
            ("gyro", "density"),
            ("gyro", "sigma"),
            ("accel", "density"),
            ("accel", "sigma"),
            ("gnss", "position_sd"),
            ("gnss", "velocity_sd")
        ]
    );
    let s = &log.searches[0];
    println!(
        "maximum {:?}, Cramér-Rao sd {:?}, taken {:?}",
        s.ml_log10_factors, s.cr_sd_log10, s.log10_factors
    );
    let want = 0.25f64.log10();
    for i in [4, 5] {
        let (m, sd) = (s.ml_log10_factors[i], s.cr_sd_log10[i]);
        assert!(sd.is_finite() && sd > 0.0, "coordinate {i}: sd {sd}");
        assert!(
            (m - want).abs() <= 3.29 * sd + 0.0625,
            "coordinate {i}: {m} +- {sd}, want {want}"
        );
    }
    // The rest of the drive runs with the factors found: adapt.csv gives them on top of the
    // stated 4, and the position NIS after the search is a right R's.
    let out = dir.path().join("out");
    hal_sim::nav::records::write_outputs(&out, &run, None, None, &[])
        .unwrap_or_else(|e| panic!("{e:#}"));
    let csv = std::fs::read_to_string(out.join("adapt.csv")).unwrap_or_else(|e| panic!("{e}"));
    let mut rd = csv::Reader::from_reader(csv.as_bytes());
    let head = rd.headers().unwrap_or_else(|e| panic!("{e}")).clone();
    let row = rd
        .records()
        .next()
        .expect("one search")
        .unwrap_or_else(|e| panic!("{e}"));
    for (col, i) in [("gnss_xyz_0_position_sd", 4), ("gnss_xyz_0_velocity_sd", 5)] {
        let k = head.iter().position(|h| h == col).expect(col);
        let v: f64 = row[k].parse().unwrap_or_else(|e| panic!("{col}: {e}"));
        assert!(
            (v - 4.0 * 10f64.powf(s.log10_factors[i])).abs() < 1e-9,
            "{col} {v}"
        );
    }
    // adapt-model.toml names the factors the run ended with, as the option that reruns them.
    let toml =
        std::fs::read_to_string(out.join("adapt-model.toml")).unwrap_or_else(|e| panic!("{e}"));
    let opt = toml
        .lines()
        .find_map(|l| l.split("--gnss-sd-factor ").nth(1))
        .unwrap_or_else(|| panic!("no --gnss-sd-factor in {toml}"));
    let end: Vec<f64> = opt
        .split(',')
        .map(|v| v.trim().parse().unwrap_or_else(|e| panic!("{opt}: {e}")))
        .collect();
    assert_eq!(end, log.gnss_sd_factor_end());
    assert_eq!(
        end,
        [4, 5].map(|i| 4.0 * 10f64.powf(s.log10_factors[i])),
        "{opt}"
    );
    let after: Vec<f64> = run
        .epochs
        .iter()
        .filter(|e| e.t > s.t && e.fused)
        .map(|e| e.nis_axis[..3].iter().sum::<f64>())
        .collect();
    let mean = after.iter().sum::<f64>() / after.len() as f64;
    println!(
        "{} fixes after the search, mean position NIS {mean:.3}",
        after.len()
    );
    // Each fix's sum of the three per-axis NIS has mean 3 and variance about 6 (chi-square(3)
    // when the axes are independent): the mean over n fixes within 3.29 sd of 3.
    let n = after.len() as f64;
    assert!(n >= 30.0, "{n} fixes");
    assert!((mean - 3.0).abs() <= 3.29 * (6.0 / n).sqrt(), "{mean}");
}
