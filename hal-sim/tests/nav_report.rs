//! `hal-sim nav`'s outputs (issue 16) through the binary: `--truth` errors and their statistics
//! on a simulated drive, `report.html` with its figures and tables, and bad input refused with
//! the file, line and field named.
//!
//! Bounds (true noise model, `--yaw` from the truth, so every epoch counts):
//! - Mean NEES (9 dof per epoch). The epochs are correlated over tens to hundreds of seconds,
//!   so the band of the mean is that of `n_eff` independent epochs, `chi2(9 n_eff) / n_eff`,
//!   with `n_eff` the effective number of independent epochs the summary reports (from the
//!   NEES autocorrelation; ~50 for these 900 epochs). The test asks for the 99.9 % band (the
//!   summary's verdict uses 99 %): `[chi2_{9 n_eff}(0.0005), chi2_{9 n_eff}(0.9995)] / n_eff`.
//!   Measured (seed 7): mean 7.657, `n_eff` 49.9, 99 % band [7.529, 10.62].
//! - Fraction of epochs outside 3 sigma per axis (position, velocity, roll/pitch/yaw): 0.27 %
//!   expected. With ~50 independent blocks of ~18 epochs, P(two or more blocks outside) =
//!   1 - (1-p)^50 - 50 p (1-p)^49 = 0.8 % at p = 0.0027, so at 99 % at most one block: 18/900
//!   = 2 %. Measured: at most 0.44 %.
//! - Fraction of epochs whose NEES is outside its per-epoch 99 % band [1.735, 23.59]: 1 %
//!   expected; with 50 blocks, Binomial(50, 0.01) <= 3 with probability 99.8 %: 3 blocks of 18
//!   epochs = 6 %. Measured: 1.4 %.
//! - The same drive with every noise standard deviation 10x too small must be found
//!   inconsistent: mean NEES above its 99 % effective band.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn hal_sim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hal-sim"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("running hal-sim: {e}"))
}

fn ok(args: &[&str]) -> Output {
    let o = hal_sim(args);
    assert!(
        o.status.success(),
        "hal-sim {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn fails(args: &[&str]) -> String {
    let o = hal_sim(args);
    assert!(!o.status.success(), "hal-sim {args:?} should have failed");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The simulator's MEMS model (`trajectory::errors::ImuErrorModel::mems`) with its standard
/// deviations times `k`, in the `[[gyro.all]]` shorthand.
fn mems_toml(k: f64) -> String {
    let deg = std::f64::consts::PI / 180.0;
    format!(
        "dt = 1.0e-2\n\
         [[gyro.all]]\nkind = \"white\"\ndensity = {:e}\n\
         [[gyro.all]]\nkind = \"gauss-markov\"\nsigma = {:e}\ntau = 300.0\n\
         [[accel.all]]\nkind = \"white\"\ndensity = {:e}\n\
         [[accel.all]]\nkind = \"gauss-markov\"\nsigma = {:e}\ntau = 300.0\n",
        k * 0.15 * deg / 60.0,
        k * 10.0 * deg / 3600.0,
        k * 0.1 / 60.0,
        k * 0.5e-3 * imu_ident::model::ins::G0,
    )
}

fn simulate(dir: &Path, hours: f64) -> PathBuf {
    let sim = dir.join("sim");
    hal_sim::trajectory::write::simulate_drive_files(
        hours,
        100.0,
        7,
        (vec![(600.0, 660.0)], [0.0; 3]),
        &sim,
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    sim
}

fn first_yaw(sim: &Path) -> String {
    let truth =
        hal_sim::nav_io::read_truth_csv(&sim.join("truth.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    format!("{}", truth[0].rpy_deg[2])
}

fn summary(out: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(out.join("summary.json")).unwrap_or_else(|e| panic!("{e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}"))
}

fn f(v: &serde_json::Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn nav_with_truth(sim: &Path, model: &Path, out: &Path, yaw: &str) {
    let p = |x: &Path| x.display().to_string();
    let (imu, gnss, truth) = (
        p(&sim.join("imu.csv")),
        p(&sim.join("gnss.csv")),
        p(&sim.join("truth.csv")),
    );
    let (model, out) = (p(model), p(out));
    ok(&[
        "nav",
        "--imu",
        &imu,
        "--gnss",
        &gnss,
        "--model",
        &model,
        "--truth",
        &truth,
        "--yaw",
        yaw,
        "--align",
        "50",
        "--no-static-gyro-bias",
        "--sd-att",
        "1,1,1",
        "--sd-pos",
        "3",
        "--out",
        &out,
    ]);
}

#[test]
fn truth_errors_are_consistent_on_a_simulated_drive() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let sim = simulate(dir.path(), 1.0 / 3.0);
    let yaw = first_yaw(&sim);
    let model = dir.path().join("mems.toml");
    std::fs::write(&model, mems_toml(1.0)).unwrap_or_else(|e| panic!("{e}"));
    let out = dir.path().join("out");
    nav_with_truth(&sim, &model, &out, &yaw);

    let s = summary(&out);
    let t = &s["truth"];
    println!(
        "truth statistics: {}",
        serde_json::to_string_pretty(t).unwrap_or_default()
    );
    let epochs = t["epochs"].as_u64().unwrap_or(0) as usize;
    assert_eq!(
        Some(epochs as u64),
        s["epochs"].as_u64(),
        "every epoch counts"
    );
    assert!(epochs > 800, "{epochs} epochs");

    // errors.csv: one row per epoch, every documented column.
    let text = std::fs::read_to_string(out.join("errors.csv")).unwrap_or_else(|e| panic!("{e}"));
    let header = text.lines().next().unwrap_or("");
    for c in [
        "t",
        "withheld",
        "fused",
        "heading_known",
        "err_n",
        "err_e",
        "err_d",
        "err_vn",
        "err_ve",
        "err_vd",
        "err_roll",
        "err_pitch",
        "err_yaw",
        "sd_n",
        "sd_e",
        "sd_d",
        "sd_vn",
        "sd_ve",
        "sd_vd",
        "sd_roll",
        "sd_pitch",
        "sd_yaw",
        "phi_n",
        "phi_e",
        "phi_d",
        "nees",
        "err_bg_x",
        "err_bg_y",
        "err_bg_z",
        "err_ba_x",
        "err_ba_y",
        "err_ba_z",
    ] {
        assert!(
            header.split(',').any(|h| h == c),
            "errors.csv: no {c} in {header}"
        );
    }
    assert_eq!(text.lines().count(), epochs + 1);

    // Mean NEES inside the 99.9 % band of n_eff independent epochs.
    let mean = f(&t["nees_mean"]);
    let n_eff = f(&t["nees_n_effective"]);
    assert!((10.0..=epochs as f64).contains(&n_eff), "n_eff {n_eff}");
    let q = |p: f64| hal_sim::allan::chi2_quantile(p, 9.0 * n_eff).unwrap_or(f64::NAN) / n_eff;
    let (lo, hi) = (q(0.0005), q(0.9995));
    println!("mean NEES {mean:.3}, n_eff {n_eff:.1}, 99.9 % band [{lo:.3}, {hi:.3}]");
    assert!(
        lo <= mean && mean <= hi,
        "mean NEES {mean} outside [{lo}, {hi}]"
    );
    assert_eq!(t["nees_consistent"], serde_json::Value::Bool(true));
    let epoch_band = &t["nees_band99_epoch"];
    assert!((f(&epoch_band[0]) - 1.735).abs() < 1e-3 && (f(&epoch_band[1]) - 23.589).abs() < 1e-3);
    let outside_band = f(&t["nees_outside_epoch_band"]);
    assert!(
        outside_band <= 0.06,
        "{outside_band} of the NEES outside the per-epoch band"
    );

    // 3-sigma fractions per axis.
    for key in [
        "outside_3sigma_pos",
        "outside_3sigma_vel",
        "outside_3sigma_att",
    ] {
        for (i, v) in t[key].as_array().into_iter().flatten().enumerate() {
            assert!(f(v) <= 0.02, "{key}[{i}] = {} > 2 %", f(v));
        }
    }
    // Errors of the order of the GNSS noise (sd 1.5 m horizontal, 0.05 m/s).
    assert!(f(&t["rms_horizontal_m"]) < 1.5, "{}", t["rms_horizontal_m"]);

    // The noise 10x too small: overconfident, mean NEES above the band.
    let small = dir.path().join("small.toml");
    std::fs::write(&small, mems_toml(0.1)).unwrap_or_else(|e| panic!("{e}"));
    let out_s = dir.path().join("out-small");
    nav_with_truth(&sim, &small, &out_s, &yaw);
    let ts = &summary(&out_s)["truth"];
    let (mean_s, hi_s) = (f(&ts["nees_mean"]), f(&ts["nees_band99_effective"][1]));
    println!("noise 10x too small: mean NEES {mean_s:.3}, upper band {hi_s:.3}");
    assert!(
        mean_s > hi_s,
        "10x too small noise not detected: {mean_s} <= {hi_s}"
    );
    assert_eq!(ts["nees_consistent"], serde_json::Value::Bool(false));

    // The report shows the truth statistics and the error figures.
    let html = std::fs::read_to_string(out.join("report.html")).unwrap_or_else(|e| panic!("{e}"));
    for needle in [
        "Errors against the truth",
        "Position error north (solution - truth) against ±3 sigma",
        "Velocity error down (solution - truth)",
        "Attitude error yaw (solution - truth)",
        "NEES (9 dof)",
        "Estimated gyro error, body z",
    ] {
        assert!(html.contains(needle), "report.html: no {needle:?}");
    }
}

#[test]
fn report_has_the_track_innovations_outages_and_identified_factors() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    // Three minutes: --identify runs the filter some fifty times.
    let sim = simulate(dir.path(), 0.05);
    let model = dir.path().join("mems.toml");
    std::fs::write(&model, mems_toml(1.0)).unwrap_or_else(|e| panic!("{e}"));
    let out = dir.path().join("out");
    let p = |x: &Path| x.display().to_string();
    let (imu, gnss, model, out_s) = (
        p(&sim.join("imu.csv")),
        p(&sim.join("gnss.csv")),
        p(&model),
        p(&out),
    );
    ok(&[
        "nav",
        "--imu",
        &imu,
        "--gnss",
        &gnss,
        "--model",
        &model,
        "--yaw",
        &first_yaw(&sim),
        "--align",
        "50",
        "--outages",
        "40,15,45,30",
        "--identify",
        "--out",
        &out_s,
    ]);
    for f in [
        "estimates.csv",
        "solution.pos",
        "summary.json",
        "outages.json",
        "identified.json",
        "identified-model.toml",
        "report.html",
    ] {
        assert!(out.join(f).is_file(), "no {f}");
    }
    assert!(
        !out.join("errors.csv").exists(),
        "errors.csv without --truth"
    );
    assert!(summary(&out).get("truth").is_none());
    let html = std::fs::read_to_string(out.join("report.html")).unwrap_or_else(|e| panic!("{e}"));
    let svgs = html.matches("<svg").count();
    // Track, 3 innovations, 2 sigma charts, 6 sensor errors.
    assert!(svgs >= 12, "{svgs} figures");
    assert!(
        html.matches("<polygon").count() >= 9,
        "no shaded ±3 sigma bands"
    );
    for needle in [
        "Track: GNSS fixes and the solution (outages highlighted)",
        "GNSS fixes withheld (outages)",
        "solution during outages",
        "GNSS position innovation north (pre-fit) against ±3 sqrt(S)",
        "Velocity error 1-sigma",
        "Attitude error (phi) 1-sigma",
        "Estimated accelerometer error, body x",
        "Horizontal error at the end of each outage",
        "Identified noise model",
        "gnss_vel_sd",
    ] {
        assert!(html.contains(needle), "report.html: no {needle:?}");
    }
    // One table row per scored outage.
    let outages: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("outages.json")).unwrap_or_else(|e| panic!("{e}")),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let scored = outages["outages"].as_array().map_or(0, Vec::len);
    assert!(scored >= 2, "{scored} outages scored");
    let table = html
        .split("Horizontal error at the end of each outage")
        .nth(1)
        .and_then(|s| s.split("</table>").next())
        .unwrap_or("");
    assert_eq!(
        table.matches("<tr>").count(),
        scored + 1,
        "outage table rows"
    );
    // The identified filter rerun from its files (model TOML + identified-options.txt) is the
    // same filter: the same innovation log-likelihood as the identified run, to rounding.
    let opts = std::fs::read_to_string(out.join("identified-options.txt"))
        .unwrap_or_else(|e| panic!("{e}"));
    let out2 = dir.path().join("rerun");
    let id_model = p(&out.join("identified-model.toml"));
    let out2_s = p(&out2);
    let yaw = first_yaw(&sim);
    let mut args = vec![
        "nav",
        "--imu",
        &imu,
        "--gnss",
        &gnss,
        "--model",
        &id_model,
        "--yaw",
        &yaw,
        "--align",
        "50",
        "--outages",
        "40,15,45,30",
        "--out",
        &out2_s,
    ];
    args.extend(opts.split_whitespace());
    ok(&args);
    let (l1, l2) = (f(&summary(&out)["loglik"]), f(&summary(&out2)["loglik"]));
    assert!(
        (l1 - l2).abs() <= 1e-9 * l1.abs().max(1.0),
        "identified run loglik {l1} vs rerun from its files {l2} ({opts})"
    );
}

#[test]
fn bad_input_names_the_file_line_and_field() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let d = dir.path();
    let gnss = d.join("gnss.csv");
    std::fs::write(&gnss, "t,lat,lon,h\n0,45,7,300\n1,45,7,300\n")
        .unwrap_or_else(|e| panic!("{e}"));
    let imu_ok = "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,-9.8\n0.01,0,0,0,0,0,-9.8\n";
    let truth_ok = "t,lat,lon,h,vn,ve,vd,roll,pitch,yaw\n0,45,7,300,0,0,0,0,0,0\n";
    let cases: [(&str, String, &str, String, &[&str]); 4] = [
        // A missing column: named with line 1 (the header).
        (
            "no-gz.csv",
            "t,gx,gy,ax,ay,az\n0,0,0,0,0,-9.8\n".to_string(),
            "truth.csv",
            truth_ok.to_string(),
            &["no-gz.csv line 1", "'gz'"],
        ),
        // IMU time going back at the fourth data row (line 5).
        (
            "back.csv",
            format!("{imu_ok}0.02,0,0,0,0,0,-9.8\n0.015,0,0,0,0,0,-9.8\n"),
            "truth.csv",
            truth_ok.to_string(),
            &["back.csv line 5, column t", "does not increase"],
        ),
        // A cell that is not a number.
        (
            "cell.csv",
            format!("{imu_ok}0.02,0,0,x9,0,0,-9.8\n"),
            "truth.csv",
            truth_ok.to_string(),
            &["cell.csv line 4, column gz", "x9"],
        ),
        // A truth file without a yaw column: refused before the run.
        (
            "imu.csv",
            imu_ok.to_string(),
            "no-yaw.csv",
            "t,lat,lon,h,vn,ve,vd,roll,pitch\n0,45,7,300,0,0,0,0,0\n".to_string(),
            &["no-yaw.csv line 1", "'yaw'"],
        ),
    ];
    for (imu_name, imu_text, truth_name, truth_text, want) in cases {
        let imu = d.join(imu_name);
        let truth = d.join(truth_name);
        std::fs::write(&imu, imu_text).unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(&truth, truth_text).unwrap_or_else(|e| panic!("{e}"));
        let p = |x: &Path| x.display().to_string();
        let e = fails(&[
            "nav",
            "--imu",
            &p(&imu),
            "--gnss",
            &p(&gnss),
            "--model",
            "drive-datasheet",
            "--truth",
            &p(&truth),
            "--out",
            &p(&d.join("out")),
        ]);
        for w in want {
            assert!(e.contains(w), "{imu_name}/{truth_name}: no {w:?} in {e}");
        }
    }
}

/// `hal-sim nav` on inputs that do not exist, with `extra` options: its error message (the
/// options are refused before anything is read or written).
fn refused_nav(extra: &[&str]) -> String {
    let mut args = vec![
        "nav",
        "--imu",
        "missing-imu.csv",
        "--gnss",
        "missing-gnss.csv",
        "--model",
        "drive-datasheet",
        "--out",
        "never-written",
    ];
    args.extend_from_slice(extra);
    fails(&args)
}

/// `--adapt --qemu-elf` needs the bank (`--adapt-method bank`): the firmware cannot run the
/// host's window replay, and says so before reading anything.
#[test]
fn the_firmware_comparison_of_an_online_run_needs_the_bank() {
    let e = refused_nav(&["--adapt", "--qemu-elf", "missing.elf"]);
    assert!(e.contains("--adapt-method bank"), "{e}");
    assert!(!Path::new("never-written").exists());
}

/// `--adapt-memory` is the bank's: with the host's window replay it is refused, not ignored,
/// before anything is read; a memory that is not positive is refused too.
#[test]
fn a_window_memory_needs_the_bank_and_positive_seconds() {
    let memory = |method, memory| {
        refused_nav(&[
            "--adapt",
            "--adapt-method",
            method,
            "--adapt-memory",
            memory,
        ])
    };
    let e = memory("replay", "1800");
    assert!(
        e.contains("--adapt-memory") && e.contains("--adapt-method bank"),
        "{e}"
    );
    let e = memory("bank", "0");
    assert!(
        e.contains("--adapt-memory") && e.contains("positive"),
        "{e}"
    );
    assert!(!Path::new("never-written").exists());
}

/// `--adapt-exit-z` (the bank's test for leaving the grid): refused with the window replay
/// unless at its default, and refused when negative or not finite.
#[test]
fn an_exit_test_needs_the_bank_and_a_finite_z() {
    let exit = |method, z: &str| {
        let z = format!("--adapt-exit-z={z}");
        refused_nav(&["--adapt", "--adapt-method", method, &z])
    };
    let e = exit("replay", "3");
    assert!(
        e.contains("--adapt-exit-z") && e.contains("--adapt-method bank"),
        "{e}"
    );
    for z in ["-1", "inf", "NaN"] {
        let e = exit("bank", z);
        assert!(
            e.contains("--adapt-exit-z") && e.contains(">= 0"),
            "{z}: {e}"
        );
    }
    assert!(!Path::new("never-written").exists());
}
