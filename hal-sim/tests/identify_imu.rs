//! `hal-sim identify --imu` / `--columns` (whole IMU in one pass) on the real ADIS16405
//! recording, and the round trip datasheet → model → simulated recording → identification.
//!
//! Real data: `<repo>/../shared/data/real` via `hal_sim::shared_data` (never copied into the
//! repository); a test that needs them fails under `CI=true` when they are missing, else skips.

use std::path::{Path, PathBuf};

use hal_sim::datasheet::{arw_deg_sqrt_h, Grade, FLICKER_FACTOR};
use hal_sim::datasheet_model::{build, DatasheetArgs};
use hal_sim::identify::imu::{run, ImuArgs, Unit};
use hal_sim::identify::{IdentifyArgs, SensorArg};
use hal_sim::series::{read_columns, ReadOptions};
use hal_sim::shared_data::{present, real_dir};

fn adis1() -> PathBuf {
    real_dir().join("adis16405-static/adis16405_rep1_static_100hz.csv.gz")
}
fn reference() -> PathBuf {
    real_dir().join("adis16405-static/reference_adev_rep1_from_avar_adis_av.csv")
}

/// `tau,adev,ci_lo,ci_hi` of an `adev.csv`.
fn read_adev(p: &Path) -> Vec<Vec<f64>> {
    read_columns(
        p,
        &["tau", "adev", "ci_lo", "ci_hi"],
        &ReadOptions::default().quiet(),
    )
    .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Bars of issue 15 on ADIS16405 replicate 1, all six axes in one run:
/// - one pass: the bytes read equal the file size (a second pass would double them) and the
///   rows read equal the samples of every axis;
/// - the ADEV of every axis equals the one-column `identify` of the same column (gyro z and
///   accel x are re-run one column at a time; exact, same code on the same numbers);
/// - Kalibr's `gyroscope_noise_density` lies within 5 % of the range of the three gyro axes'
///   white density read off the published ADEV, ADEV(τ)·sqrt(τ) at the τ nearest 1 s;
/// - `datasheet.md` sets the figures beside the ADIS16405 datasheet's typical values, naming
///   the source; `imu-model.toml` and `kalibr-imu.yaml` load back.
#[test]
fn adis16405_whole_imu_in_one_pass() {
    if !present(&[&adis1(), &reference()]) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("imu");
    let args = ImuArgs {
        series: adis1(),
        columns: None,
        rate: 100.0,
        gyro_unit: None,
        accel_unit: None,
        decimate: 1,
        out: out.clone(),
        quiet: true,
        reference: Some("adis16405".into()),
    };
    let t = std::time::Instant::now();
    let s = run(&args).unwrap_or_else(|e| panic!("identify --imu: {e:#}"));
    println!("identify --imu: {:.1} s", t.elapsed().as_secs_f64());
    print!("{}", hal_sim::identify::imu::report(&s));

    let size = std::fs::metadata(adis1()).expect("size").len();
    assert_eq!(s.read.bytes, size, "bytes read vs file size");
    assert_eq!(s.read.rows, 1_000_000);
    assert!(s.summaries.iter().all(|x| x.samples as u64 == s.read.rows));
    let cols: Vec<&str> = s.axes.iter().map(|a| a.column.as_str()).collect();
    assert_eq!(
        cols,
        [
            "gyro_x_dps",
            "gyro_y_dps",
            "gyro_z_dps",
            "acc_x_g",
            "acc_y_g",
            "acc_z_g"
        ]
    );
    assert!(s.axes.iter().all(|a| matches!(a.unit, Unit::Dps | Unit::G)));

    for (axis, col, scale) in [
        ("gyro_z", "gyro_z_dps", Unit::Dps.scale()),
        ("accel_x", "acc_x_g", Unit::G.scale()),
    ] {
        let one = dir.path().join(format!("one_{axis}"));
        hal_sim::identify::run(&IdentifyArgs {
            series: adis1(),
            column: col.into(),
            rate: 100.0,
            scale,
            decimate: 1,
            out: one.clone(),
            quiet: true,
            sensor: None,
        })
        .expect("one-column identify");
        let (a, b) = (
            read_adev(&out.join(axis).join("adev.csv")),
            read_adev(&one.join("adev.csv")),
        );
        assert_eq!(a[0].len(), b[0].len());
        let worst = a[1]
            .iter()
            .zip(&b[1])
            .map(|(x, y)| ((x - y) / y).abs())
            .fold(0.0, f64::max);
        println!("{axis}: worst relative ADEV difference one pass vs one column {worst:e}");
        assert!(worst <= 1e-12, "{axis}: {worst}");
    }

    // Published ADEV (deg/s): white density ADEV(τ)·sqrt(τ) at the reference τ nearest 1 s.
    let names = [
        "tau_s",
        "gyro_x_adev_dps",
        "gyro_y_adev_dps",
        "gyro_z_adev_dps",
    ];
    let r = read_columns(reference(), &names, &ReadOptions::default().quiet()).expect("ref");
    let i = (0..r[0].len())
        .min_by(|&a, &b| r[0][a].ln().abs().total_cmp(&r[0][b].ln().abs()))
        .expect("taus");
    let n_ref: Vec<f64> = (1..4)
        .map(|k| r[k][i] * r[0][i].sqrt() * Unit::Dps.scale())
        .collect();
    let (lo, hi) = (
        n_ref.iter().copied().fold(f64::INFINITY, f64::min),
        n_ref.iter().copied().fold(0.0, f64::max),
    );
    let g = s.kalibr.gyroscope_noise_density;
    println!(
        "kalibr gyroscope_noise_density {g:.4e} rad/s/sqrt(Hz); published ADEV at tau {} s gives {lo:.4e} .. {hi:.4e} ({:.3} .. {:.3} deg/sqrt(h))",
        r[0][i],
        arw_deg_sqrt_h(lo),
        arw_deg_sqrt_h(hi)
    );
    assert!(
        g >= 0.95 * lo && g <= 1.05 * hi,
        "gyroscope_noise_density {g} outside [{}, {}]",
        0.95 * lo,
        1.05 * hi
    );

    let md = std::fs::read_to_string(out.join("datasheet.md")).expect("datasheet.md");
    println!("{md}");
    assert!(md.contains("Against the ADIS16405 datasheet"), "{md}");
    assert!(md.contains("ADIS16405 data sheet Rev. B"), "{md}");
    assert!(
        md.contains("| gyro in-run bias stability | 2.520e1 deg/h |"),
        "{md}"
    );
    assert!(md.contains("deg/sqrt(h)") && md.contains("ug"));
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("datasheet.json")).expect("datasheet.json"),
    )
    .expect("json");
    assert_eq!(json["figures"].as_array().map(Vec::len), Some(6));
    assert_eq!(json["figures"][0]["random_walk"]["unit"], "deg/sqrt(h)");
    assert_eq!(json["read"]["bytes"].as_u64(), Some(size));

    let model = hal_sim::imu_model::load(&out.join("imu-model.toml")).expect("imu-model.toml");
    assert!(!model.gyro.z.is_empty() && !model.accel.x.is_empty());
    let k = hal_sim::kalibr::load(&out.join("kalibr-imu.yaml")).expect("kalibr");
    assert!((k.gyroscope_noise_density / g - 1.0).abs() < 1e-3);
    assert_eq!(k.update_rate, 100.0);
}

/// Round trip datasheet → `model from-datasheet` → six simulated axes → `identify --imu`:
/// the ARW / VRW and the bias instability come back inside their intervals.
///
/// Why the bound is sound: 12 figures are checked (6 axes × {random walk, B}), each against a
/// 95 % interval: (a) the fitted white level's Gauss-Newton interval (docs/IDENTIFY.md; it
/// ignores the correlation of overlapping ADEV points, so it is, if anything, too narrow),
/// (b) the Allan chi-square interval (conservative edf, SP 1065) of the ADEV point where the
/// measured curve is lowest; that point is chosen among the ≤ 3 octave points of the flat
/// bottom, so (b) is a choice among 3. Bonferroni over 12 · 3 = 36 intervals: each is widened
/// in log from z = 1.96 to z = 2.99 (two-sided 1 − 0.05/36), so that, if the intervals hold
/// their level, the whole test fails with probability ≤ 5 % for a random seed. The seed is
/// fixed (the test is deterministic); the bound says the fixed seed was not chosen to pass.
/// The true value compared at the chosen τ is the model's own ADEV there (theory), which is
/// the 0.664 B of the datasheet at τ_B and within a few % of it on the flat bottom; that
/// offset is printed and added to the bound.
#[test]
fn from_datasheet_round_trip_recovers_the_figures() {
    let ds = DatasheetArgs {
        arw: Some(0.3),
        vrw: Some(0.05),
        gyro_bias_instability: Some(10.0),
        accel_bias_instability: Some(50.0),
        // A rate random walk that lifts the ADEV back to 0.664 B near 200 s: without it the
        // model's ADEV would fall again beyond the Gauss-Markov peak (no floor, docs/IDENTIFY.md).
        gyro_rrw: Some(40.0),
        accel_rrw: Some(7.0),
        bias_tau: Some(20.0),
        grade: Some(Grade::Tactical),
        rate: Some(100.0),
        ..DatasheetArgs::default()
    };
    let built = build(&ds).expect("from-datasheet");
    assert!(built.warnings.is_empty(), "{:?}", built.warnings);
    assert!(built.bias_gm.iter().all(|g| g.is_some_and(|g| g.exact)));
    let dir = tempfile::tempdir().expect("tempdir");
    let n = 400_000; // 4000 s: 200 averaging times of tau_B = 20 s
    let cols = hal_sim::imu_sim::simulate(&built.model, n, 2024).expect("simulate");
    let csv = dir.path().join("sim.csv");
    hal_sim::imu_sim::write_csv(&csv, &cols).expect("write csv");
    let s = run(&ImuArgs {
        series: csv,
        columns: None,
        rate: 100.0,
        gyro_unit: None,
        accel_unit: None,
        decimate: 1,
        out: dir.path().join("id"),
        quiet: true,
        reference: None,
    })
    .expect("identify --imu");
    print!("{}", hal_sim::identify::imu::report(&s));

    let widen = 2.99 / 1.96;
    let inside = |truth: f64, v: f64, ci: [f64; 2], slack: f64| {
        let (l, h) = ((v / ci[0]).ln() * widen, (ci[1] / v).ln() * widen);
        let r = (truth / v).ln();
        r >= -l - slack && r <= h + slack
    };
    for (f, sum) in s.figures.iter().zip(&s.summaries) {
        let gyro = sum.sensor == SensorArg::Gyro;
        let (rw_true, b_true) = if gyro { (0.3, 10.0) } else { (0.05, 50.0) };
        // The fit's interval when it has one, else the IEEE reading at tau ~ 1 s with its
        // Allan interval (the Gauss-Newton covariance is singular when two short terms trade off).
        let rw = match f.random_walk.ci95 {
            Some(_) => &f.random_walk,
            None => &f.random_walk_at_1s,
        };
        let ci = rw.ci95.expect("random-walk interval");
        println!(
            "{}: random walk {} (true {rw_true}), B {} (true {b_true}) at tau {} s",
            f.axis,
            rw.text(),
            f.bias_instability.text(),
            f.adev_min_tau
        );
        assert!(
            inside(rw_true, rw.value, ci, 0.0),
            "{}: random walk",
            f.axis
        );
        // The model's ADEV at the chosen tau over its minimum 0.664 B: the flat-bottom offset.
        let m = built
            .model
            .channel(if gyro { "gyro" } else { "accel" }, 'x');
        let core = m.expect("channel").to_core().expect("core");
        let comps = if gyro { core.gyro } else { core.accel };
        let avar = |tau: f64| -> f64 {
            comps
                .iter()
                .map(|c| match c {
                    imu_ident::model::Component::White(w) => w.density.powi(2) / tau,
                    imu_ident::model::Component::GaussMarkov(g) => {
                        hal_sim::allan::theory::avar_gauss_markov(g.sigma, g.tau, tau)
                    }
                    imu_ident::model::Component::RandomWalk(r) => r.q * tau / 3.0,
                    _ => 0.0,
                })
                .sum()
        };
        let b_si = avar(20.0).sqrt() / FLICKER_FACTOR;
        let offset = (avar(f.adev_min_tau).sqrt() / avar(20.0).sqrt()).ln();
        println!("   flat-bottom offset {:.2} %", 100.0 * offset);
        let bi = &f.bias_instability;
        let ci = bi.ci95.expect("B interval");
        // b_true in datasheet units equals b_si converted: checked once here.
        let conv = if gyro {
            hal_sim::datasheet::deg_h(b_si)
        } else {
            hal_sim::datasheet::micro_g(b_si)
        };
        assert!((conv / b_true - 1.0).abs() < 1e-3, "{}: {conv}", f.axis);
        assert!(
            inside(b_true, bi.value, ci, offset),
            "{}: bias instability",
            f.axis
        );
        let rrw_true = if gyro { 40.0 } else { 7.0 };
        match &f.rate_random_walk {
            Some(r) => {
                println!("   rate random walk {} (true {rrw_true})", r.text());
                let ci = r.ci95.expect("rrw interval");
                assert!(
                    inside(rrw_true, r.value, ci, 0.0),
                    "{}: rate random walk",
                    f.axis
                );
            }
            None => panic!("{}: no rate random walk fitted", f.axis),
        }
    }
}

/// Units and columns: a name without a known suffix asks for --gyro-unit; a gyro unit on an
/// accelerometer column is refused; the Kalibr file of from-datasheet round-trips.
#[test]
fn units_columns_and_kalibr_input() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join("x.csv");
    std::fs::write(&p, "gx,gy,gz,ax,ay,az\n1,2,3,4,5,6\n").expect("write");
    let mut a = ImuArgs {
        series: p,
        columns: Some(
            ["gx", "gy", "gz", "ax", "ay", "az"]
                .map(String::from)
                .to_vec(),
        ),
        rate: 100.0,
        gyro_unit: None,
        accel_unit: None,
        decimate: 1,
        out: dir.path().join("o"),
        quiet: true,
        reference: None,
    };
    let e = format!("{:#}", run(&a).unwrap_err());
    assert!(e.contains("column gx") && e.contains("--gyro-unit"), "{e}");
    a.gyro_unit = Some(Unit::Rads);
    a.accel_unit = Some(Unit::Dps);
    let e = format!("{:#}", run(&a).unwrap_err());
    assert!(
        e.contains("column ax") && e.contains("not a accelerometer unit"),
        "{e}"
    );
    a.columns = None;
    let e = format!("{:#}", run(&a).unwrap_err());
    assert!(e.contains("no column for gyro_x"), "{e}");

    let k = dir.path().join("k.yaml");
    std::fs::write(
        &k,
        "rostopic: /imu0\nupdate_rate: 200.0\naccelerometer_noise_density: 2.0e-3\n\
         accelerometer_random_walk: 3.0e-3\ngyroscope_noise_density: 1.6968e-04\n\
         gyroscope_random_walk: 1.9393e-05\n",
    )
    .expect("write");
    let m = build(&DatasheetArgs {
        kalibr: Some(k),
        ..DatasheetArgs::default()
    })
    .expect("from kalibr");
    assert!((m.model.dt - 0.005).abs() < 1e-15);
    let comps = &m.model.gyro.y;
    use imu_ident::model::{Component, RandomWalk, WhiteNoise};
    assert!(comps.iter().any(|c| matches!(c.0,
        Component::White(WhiteNoise { density }) if (density - 1.6968e-4).abs() < 1e-12)));
    assert!(comps.iter().any(|c| matches!(c.0,
        Component::RandomWalk(RandomWalk { q, .. }) if (q.sqrt() - 1.9393e-5).abs() < 1e-12)));
}
