//! File formats and the CLI: exact column names, round trips, and errors that name the file,
//! the line and the field.

use hal_sim::{log, model_toml};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_hal-sim"))
}

#[test]
fn model_toml_round_trips_every_kind() {
    let text = r#"
dt = 1.0
[observation]
sigma_v = 0.03
[[observation.colored]]
sigma = 0.01
tau = 20.0
[[accel]]
kind = "gauss-markov"
sigma = 1e-3
tau = 100.0
[[accel]]
kind = "white"
density = 1e-4
[[gyro]]
kind = "exp-cosine"
sigma = 5e-7
tau = 900.0
beta = 0.0105
[[gyro]]
kind = "random-walk"
q = 1e-18
[[gyro]]
kind = "random-constant"
sigma = 1e-7
"#;
    let m = model_toml::parse(text, "t.toml").unwrap();
    assert_eq!((m.accel.len(), m.gyro.len(), m.colored.len()), (2, 3, 1));
    let again = model_toml::parse(&model_toml::to_string(&m).unwrap(), "again").unwrap();
    assert_eq!(m, again);
}

#[test]
fn model_errors_name_file_and_field() {
    let bad_kind =
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[gyro]]\nkind = \"pink\"\nsigma = 1.0\n";
    let e = format!("{:#}", model_toml::parse(bad_kind, "m.toml").unwrap_err());
    assert!(e.contains("m.toml") && e.contains("pink"), "{e}");
    let bad_value = "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[accel]]\nkind = \"gauss-markov\"\nsigma = 1e-3\ntau = -5.0\n";
    let e = format!("{:#}", model_toml::parse(bad_value, "m.toml").unwrap_err());
    assert!(
        e.contains("m.toml") && e.contains("accel[0]") && e.contains("tau"),
        "{e}"
    );
    let typo = "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[accel]]\nkind = \"gauss-markov\"\nsigma = 1e-3\ntua = 5.0\n";
    let e = format!("{:#}", model_toml::parse(typo, "m.toml").unwrap_err());
    assert!(
        e.contains("line 4") && e.contains("unknown field `tua`"),
        "{e}"
    );
}

#[test]
fn log_errors_name_file_line_and_column() {
    let text = "t,z,extra\n1,0.1,x\n2,abc,y\n";
    let e = format!(
        "{:#}",
        log::read_from(text.as_bytes(), "l.csv").unwrap_err()
    );
    assert!(
        e.contains("l.csv line 3, column z") && e.contains("abc"),
        "{e}"
    );
    let e = format!(
        "{:#}",
        log::read_from("time,z\n1,2\n".as_bytes(), "l.csv").unwrap_err()
    );
    assert!(e.contains("no column 't'") && e.contains("time,z"), "{e}");
    // Missing observations are NaN, not errors; other columns are ignored.
    let rows = log::read_from("z,t,other\n,1,a\nNaN,2,b\n0.5,3,c\n".as_bytes(), "l.csv").unwrap();
    assert!(rows[0].z.is_nan() && rows[1].z.is_nan() && rows[2].z == 0.5 && rows[2].t == 3.0);
}

#[test]
fn simulate_and_run_write_the_documented_files() {
    let dir = tempfile::tempdir().unwrap();
    let log_path = dir.path().join("log.csv");
    let st = bin()
        .args([
            "simulate",
            "--scenario",
            "paper",
            "--hours",
            "0.5",
            "--seed",
            "3",
            "--out",
        ])
        .arg(&log_path)
        .status()
        .unwrap();
    assert!(st.success());
    let text = std::fs::read_to_string(&log_path).unwrap();
    assert_eq!(
        text.lines().next().unwrap(),
        "t,z,true_dv,true_delta,true_da,true_dw"
    );
    assert_eq!(text.lines().count(), 1801);

    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/paper.toml");
    let out = dir.path().join("run");
    let o = bin()
        .args(["run", "--log"])
        .arg(&log_path)
        .args(["--model", model, "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let est = std::fs::read_to_string(out.join("estimates.csv")).unwrap();
    assert_eq!(
        est.lines().next().unwrap(),
        "t,dv_hat,delta_hat,da_hat,dw_hat,sigma_dv,sigma_delta,sigma_da,sigma_dw,innovation,innovation_var,nis,flags"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["steps"], 1800);
    assert!(summary["nis_mean"].as_f64().unwrap() > 0.0);
    assert!(
        summary["tilt_rms"].as_f64().is_some() && summary["tilt_outside_3sigma"].as_f64().is_some()
    );
}

#[test]
fn cli_reports_bad_input_with_nonzero_exit() {
    let dir = tempfile::tempdir().unwrap();
    let log_path = dir.path().join("bad.csv");
    std::fs::write(&log_path, "t,z\n1,0.1\n2,oops\n").unwrap();
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/paper.toml");
    let out = dir.path().join("run");
    let o = bin()
        .args(["run", "--log"])
        .arg(&log_path)
        .args(["--model", model, "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bad.csv line 3, column z"), "{err}");
    assert!(
        !out.join("estimates.csv").exists(),
        "no partial output on error"
    );
}

/// Gaps are bridged by ticks without an observation (written and counted as missing); rows
/// whose time goes back are skipped and counted.
#[test]
fn gaps_and_backward_time_are_flagged() {
    let model = model_toml::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/paper.toml"
    )))
    .unwrap();
    let rows = log::read_from(
        "t,z\n1,0.01\n2,0.0\n10,0.02\n9,0.0\n11,NaN\n12,0.0\n".as_bytes(),
        "g.csv",
    )
    .unwrap();
    let (est, counts) = hal_sim::replay::estimates::<f64>(&model, &rows).unwrap();
    // Ticks: 1, 2, bridged 3..=9 (7), 10, 11 (NaN), 12; the row at 9 is skipped.
    assert_eq!(
        (
            counts.steps,
            counts.rows,
            counts.bridged,
            counts.gaps,
            counts.skipped_time,
            counts.missing
        ),
        (12, 5, 7, 1, 1, 8)
    );
    assert_eq!(est.len(), 12);
    let bridged: Vec<f64> = est.iter().filter(|e| e.is_bridged()).map(|e| e.t).collect();
    assert_eq!(bridged, (3..=9).map(f64::from).collect::<Vec<_>>());
    assert!(est
        .iter()
        .filter(|e| e.is_bridged())
        .all(|e| e.nis.is_nan()));
}
