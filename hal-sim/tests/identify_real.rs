//! `identify` on the real static recordings in `<repo>/../shared/data/real` (never copied
//! into the repository: ADIS16405 data are CC BY-NC-SA). A test needing the data fails when
//! `CI=true` and the data are missing, and otherwise prints why it skips.
//!
//! Bars (issue 6): the ADEV `identify` writes equals the published `avar` table within 0.1 %;
//! the fitted gyro models lie inside the reference's 95 % CI at ≥ 90 % of its taus; an
//! exponential cosine is found on ADIS gyro z (period ≈ 0.05 s) and on the PSINS gyro
//! (0.4-0.5 s); replicates 1 and 2 agree within their intervals or the difference is named.

use std::path::{Path, PathBuf};

use hal_sim::identify::{run, IdentifyArgs, IdentifySummary, SensorArg};
use hal_sim::series::{read_columns, ReadOptions};

/// deg/s → rad/s, so that the model TOML is in SI units.
const DEG: f64 = std::f64::consts::PI / 180.0;
/// PSINS gyro: 1 count = 0.1 arcsec per 10 ms sample = 4.8481368e-5 rad/s (dataset README).
const PSINS_GYRO: f64 = 4.848_136_8e-5;

use hal_sim::shared_data::real_dir;
fn adis(rep: u32) -> PathBuf {
    real_dir().join(format!(
        "adis16405-static/adis16405_rep{rep}_static_100hz.csv.gz"
    ))
}
fn reference() -> PathBuf {
    real_dir().join("adis16405-static/reference_adev_rep1_from_avar_adis_av.csv")
}
fn psins() -> PathBuf {
    real_dir().join("psins-lasergyro-vehicle/lasergyro_static_vehicle_100hz_counts.csv")
}

use hal_sim::shared_data::present as data_present;

fn identify(series: &Path, column: &str, scale: f64, out: &Path) -> IdentifySummary {
    let args = IdentifyArgs {
        series: series.to_path_buf(),
        column: column.into(),
        rate: 100.0,
        scale,
        decimate: 1,
        out: out.to_path_buf(),
        quiet: true,
        sensor: None,
    };
    let t = std::time::Instant::now();
    let s = run(&args).unwrap_or_else(|e| panic!("identify {column}: {e:#}"));
    println!(
        "{column}: {} components, chi2 {:.1}, inside own CI {:.0} %, white {:?}, {:.1} s",
        s.components.len(),
        s.chi2,
        100.0 * s.inside_ci,
        s.white_density,
        t.elapsed().as_secs_f64()
    );
    for c in &s.components {
        println!(
            "   {:<22} amp {:.4e} {:?} tc {:?} {:?} period {:?}",
            c.label, c.amplitude, c.amplitude_ci, c.tc, c.tc_ci, c.period
        );
    }
    s
}

/// `tau,adev,ci_lo,ci_hi` of an `adev.csv`.
fn read_adev_csv(p: &Path) -> Vec<[f64; 4]> {
    let cols = read_columns(
        p,
        &["tau", "adev", "ci_lo", "ci_hi"],
        &ReadOptions::default().quiet(),
    )
    .expect("adev.csv");
    (0..cols[0].len())
        .map(|i| [cols[0][i], cols[1][i], cols[2][i], cols[3][i]])
        .collect()
}

/// Reference columns `tau_s, <axis>_{adev,lci,uci}_<unit>`.
fn reference_axis(axis: &str, unit: &str) -> Vec<[f64; 4]> {
    let names = [
        "tau_s".to_string(),
        format!("{axis}_adev_{unit}"),
        format!("{axis}_lci_{unit}"),
        format!("{axis}_uci_{unit}"),
    ];
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let c = read_columns(reference(), &refs, &ReadOptions::default().quiet()).expect("reference");
    (0..c[0].len())
        .map(|i| [c[0][i], c[1][i], c[2][i], c[3][i]])
        .collect()
}

/// Bar 1. `identify` computes the standard overlapping estimator on the octave grid; the
/// reference uses `avar`'s variant (one difference fewer, same divisor), which differs by
/// O(m/n) ≤ 2^18/10^6 · … ≈ 3e-6 relative (tests/allan_reference.rs), far inside 0.1 %. The
/// reference taus (m = 2 … 2^18) are a subset of the octave grid (m = 1 … 2^18).
#[test]
fn adev_csv_written_by_identify_matches_avar_reference() {
    if !data_present(&[&adis(1), &reference()]) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    for (col, axis, unit, scale) in [
        ("gyro_z_dps", "gyro_z", "dps", 1.0),
        ("acc_x_g", "acc_x", "g", 1.0),
    ] {
        let out = dir.path().join(axis);
        identify(&adis(1), col, scale, &out);
        let ours = read_adev_csv(&out.join("adev.csv"));
        let refr = reference_axis(axis, unit);
        assert_eq!(refr.len(), 18);
        let mut worst = 0.0_f64;
        for r in &refr {
            let o = ours
                .iter()
                .find(|o| ((o[0] - r[0]) / r[0]).abs() < 1e-9)
                .unwrap_or_else(|| panic!("{axis}: tau {} missing from adev.csv", r[0]));
            let e = ((o[1] - r[1]) / r[1]).abs();
            assert!(e < 1e-3, "{axis} tau {}: {} vs {}", r[0], o[1], r[1]);
            worst = worst.max(e);
        }
        println!("{axis}: worst relative ADEV difference to avar reference {worst:.2e}");
    }
}

/// Bar 2. The fitted model's theoretical ADEV (sampled-process expectation at m = τ·100)
/// against the reference's 95 % interval at its 18 taus: ≥ 90 % means ≥ 17 of 18 inside.
#[test]
fn gyro_models_lie_inside_the_reference_ci() {
    if !data_present(&[&adis(1), &reference()]) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    for axis in ["gyro_x", "gyro_y", "gyro_z"] {
        // Fitted in deg/s so that it compares with the reference directly.
        let s = identify(
            &adis(1),
            &format!("{axis}_dps"),
            1.0,
            &dir.path().join(axis),
        );
        let terms = terms_of(&s);
        let refr = reference_axis(axis, "dps");
        let mut inside = 0;
        for r in &refr {
            let m = (r[0] * 100.0).round() as usize;
            let model = hal_sim::identify::model_adev(&terms, m, 0.01);
            let ok = model >= r[2] && model <= r[3];
            inside += usize::from(ok);
            println!(
                "   tau {:>9.2}  ref {:.5e} [{:.5e}, {:.5e}]  model {:.5e} {}",
                r[0],
                r[1],
                r[2],
                r[3],
                model,
                if ok { "in" } else { "OUT" }
            );
        }
        let share = inside as f64 / refr.len() as f64;
        println!(
            "{axis}: model inside reference CI at {inside}/{} taus",
            refr.len()
        );
        assert!(share >= 0.9, "{axis}: only {inside}/{} inside", refr.len());
    }
}

/// The fitted terms back from the summary (amplitudes are √var).
fn terms_of(s: &IdentifySummary) -> Vec<hal_sim::identify::fit::Term> {
    s.components
        .iter()
        .map(|c| hal_sim::identify::fit::Term {
            kind: c.kind,
            var: c.amplitude * c.amplitude,
            tc: c.tc.unwrap_or(1.0),
            period: c.period.unwrap_or(0.0),
        })
        .collect()
}

/// Bar 3. ADIS gyro z: a 20 Hz line, period 5 samples = 0.05 s (dataset README: ACF period
/// 5 samples, PSD peak at 19.8-20 Hz, i.e. 0.0500-0.0505 s); bound ±5 %. PSINS: the README
/// reads a damped cosine of period 0.4-0.5 s on the gyros, strongest on z (ρ(0.2 s) = −0.54)
/// and x (−0.31); bound [0.35, 0.55] s.
#[test]
fn exp_cosine_found_on_adis_gyro_z_and_psins_gyros() {
    if !data_present(&[&adis(1), &psins()]) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let s = identify(&adis(1), "gyro_z_dps", DEG, &dir.path().join("adis_z"));
    let ec = s.exp_cosine().expect("ADIS gyro z: no exp-cosine selected");
    let p = ec.period.expect("period");
    println!("ADIS gyro z exp-cosine period {p:.5} s");
    // The model TOML must load as `hal-sim run` loads it, with the exp-cosine in it.
    let model = hal_sim::model_toml::load(&dir.path().join("adis_z/model.toml"))
        .unwrap_or_else(|e| panic!("model.toml does not load: {e:#}"));
    assert!(model
        .gyro
        .iter()
        .any(|c| matches!(c, imu_ident::model::Component::ExpCosine(_))));
    assert!((model.dt - 0.01).abs() < 1e-15);
    assert!((p / 0.05 - 1.0).abs() < 0.05, "ADIS gyro z period {p}");
    for col in ["dtheta_z_cnt", "dtheta_x_cnt"] {
        let s = identify(&psins(), col, PSINS_GYRO, &dir.path().join(col));
        let acf_p = s.acf.exp_cos.map(|f| f.period);
        let ec = s.exp_cosine().and_then(|c| c.period);
        println!("PSINS {col}: ACF period {acf_p:?}, selected exp-cosine period {ec:?}");
        let p = ec.unwrap_or_else(|| panic!("PSINS {col}: no exp-cosine selected"));
        assert!((0.35..=0.55).contains(&p), "PSINS {col} period {p}");
    }
}

/// Bar 4. Replicates 1 and 2, gyro x, y, z: the angle random walk must agree within the
/// 95 % two-sample bound (x, y) or within the difference of the measured curves themselves
/// (z, see below); the exp-cosine centre frequencies within the line's half-width. Every
/// other parameter is compared in BENCHMARKS.md.
#[test]
fn replicates_agree_within_their_intervals() {
    if !data_present(&[&adis(1), &adis(2)]) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    for axis in ["gyro_x", "gyro_y", "gyro_z"] {
        let col = format!("{axis}_dps");
        let a = identify(&adis(1), &col, DEG, &dir.path().join(format!("{axis}_1")));
        let b = identify(&adis(2), &col, DEG, &dir.path().join(format!("{axis}_2")));
        // The long-τ white density (ARW): white and filtered-white trade off against each
        // other, their sum is what the data determine.
        let (wa, wb) = (
            a.white_density.expect("rep1 white"),
            b.white_density.expect("rep2 white"),
        );
        println!("{axis}: ARW rep1 {wa:?} rep2 {wb:?}");
        // Two independent estimates agree at 95 % when |a − b| ≤ 1.96 √(s_a² + s_b²), s from
        // the half-widths of their (log-symmetric, hence nearly symmetric) intervals.
        let sd = |w: [f64; 3]| (w[2] - w[1]) / (2.0 * 1.96);
        let diff = (wa[0] - wb[0]).abs();
        let bound = 1.96 * (sd(wa).powi(2) + sd(wb).powi(2)).sqrt();
        let rel = diff / (0.5 * (wa[0] + wb[0]));
        println!(
            "{axis}: ARW difference {:.2} % , 95 % two-sample bound {:.2} %",
            100.0 * rel,
            100.0 * bound / (0.5 * (wa[0] + wb[0]))
        );
        if axis == "gyro_z" {
            // Explained in BENCHMARKS.md: the measured gyro-z ADEV curves of the two runs
            // differ by 0.9-1.3 % at τ = 0.01-0.16 s, five times their ±0.2-0.4 % intervals,
            // so the runs differ, not the fit. Bound: the model's ARW may differ between the
            // runs by no more than the measured ADEV does where the ARW is read, on the −½
            // slope at τ ∈ [0.5, 6] s.
            let (ra, rb) = (
                read_adev_csv(&dir.path().join(format!("{axis}_1/adev.csv"))),
                read_adev_csv(&dir.path().join(format!("{axis}_2/adev.csv"))),
            );
            let data_rel = ra
                .iter()
                .zip(&rb)
                .filter(|(x, _)| (0.5..=6.0).contains(&x[0]))
                .map(|(x, y)| (x[1] - y[1]).abs() / (0.5 * (x[1] + y[1])))
                .fold(0.0, f64::max);
            println!(
                "{axis}: measured ADEV differs by up to {:.2} % on [0.5, 6] s",
                100.0 * data_rel
            );
            assert!(
                rel <= data_rel,
                "{axis}: ARW differs by {:.2} %, data by {:.2} %",
                100.0 * rel,
                100.0 * data_rel
            );
        } else {
            assert!(
                diff <= bound,
                "{axis}: ARW {} vs {} (bound {bound})",
                wa[0],
                wb[0]
            );
        }
        if let (Some(ea), Some(eb)) = (a.exp_cosine(), b.exp_cosine()) {
            let (pa, pb) = (ea.period.unwrap_or(0.0), eb.period.unwrap_or(0.0));
            // A line of envelope 1/α has half-width at half maximum α/(2π) Hz (Lorentzian);
            // two runs' centre frequencies must agree within it.
            let hwhm = 1.0 / (2.0 * std::f64::consts::PI * ea.tc.unwrap_or(f64::INFINITY));
            let df = (1.0 / pa - 1.0 / pb).abs();
            println!(
                "{axis}: exp-cosine period rep1 {pa:.5} s rep2 {pb:.5} s, |df| {df:.3} Hz, HWHM {hwhm:.3} Hz"
            );
            assert!(df < hwhm, "{axis}: periods {pa} {pb}");
        }
    }
}

/// Bad input: the error names the file, the line and the column; nothing panics.
#[test]
fn bad_input_errors_name_file_line_and_column() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join("bad.csv");
    let mut text = String::from("gyro_x\n");
    for i in 0..100 {
        text += &format!("{}\n", (i % 7) as f64 * 0.1);
    }
    text += "oops\n";
    std::fs::write(&p, text).expect("write");
    let mut args = IdentifyArgs {
        series: p.clone(),
        column: "gyro_x".into(),
        rate: 100.0,
        scale: 1.0,
        decimate: 1,
        out: dir.path().join("out"),
        quiet: true,
        sensor: None,
    };
    let msg = format!("{:#}", run(&args).unwrap_err());
    assert!(msg.contains("bad.csv line 102, column gyro_x"), "{msg}");
    args.column = "temperature".into();
    let msg = format!("{:#}", run(&args).unwrap_err());
    assert!(msg.contains("--sensor"), "{msg}");
    args.sensor = Some(SensorArg::Gyro);
    let msg = format!("{:#}", run(&args).unwrap_err());
    assert!(msg.contains("no column named 'temperature'"), "{msg}");
    args.rate = f64::NAN;
    assert!(run(&args).is_err());
}
