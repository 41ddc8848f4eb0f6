//! Diagnosis on data with a hidden effect: the missing effect is named from the innovations
//! alone, adding it brings the tilt error back to the oracle's, and a model that lacks nothing
//! is called adequate.
//!
//! Bounds: the verdict uses BIC, so under the null a candidate with k parameters is accepted
//! only if 2 x gain > k ln n = 10.7 k at n = 43200; for a nested candidate 2 x gain is about
//! chi2(k), so the false-alarm chance per candidate is below P(chi2(1) > 10.7) = 1e-3, and
//! about 1 % over the 11 candidates and the 2 kind swaps of `paper` (a swap to an
//! exp-cosine is charged its three fitted parameters, like an addition; the Gauss-Markov it
//! replaces is the exp-cosine's infinite-period limit, so the swap is nested). The seeds are
//! fixed.

use hal_sim::log::LogRow;
use hal_sim::{compare, diagnose, hidden, scenario, sim};
use rand::SeedableRng;

fn nominal() -> imu_ident::model::InsModel<f64> {
    scenario::load("paper").unwrap().to_core().unwrap()
}

fn without_truth(log: &[LogRow]) -> Vec<LogRow> {
    log.iter().map(|r| LogRow { truth: None, ..*r }).collect()
}

/// A gyro rate random walk hidden in `paper` data is named, and adding it brings the tilt RMS
/// within 1.15x of the oracle's (issue 4 bar). The verdict is the same without truth columns.
#[test]
fn hidden_gyro_random_walk_is_named_and_fixed() {
    let base = nominal();
    let candidate = hidden::by_label("gyro/random-walk").unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(41);
    let truth = hidden::truth(&base, candidate, &mut rng).unwrap();
    let log = sim::simulate(&truth, 43_200, 41).unwrap();
    let d = diagnose::diagnose(&base, &without_truth(&log)).unwrap();
    assert_eq!(
        (d.verdict, d.sensor, d.effect),
        ("missing-effect", Some("gyro"), Some("random-walk")),
        "{}",
        d.explanation
    );
    assert!(d.evidence.log_likelihood_gain > d.evidence.penalty);
    assert!(
        !d.evidence.failed_lags.is_empty(),
        "the nominal model's innovations are not white"
    );
    let oracle = compare::evaluate("oracle", &truth, &log)
        .unwrap()
        .summary
        .tilt_rms
        .unwrap();
    let fixed = compare::evaluate("fixed", &d.suggested, &log)
        .unwrap()
        .summary
        .tilt_rms
        .unwrap();
    let nominal_rms = compare::evaluate("nominal", &base, &log)
        .unwrap()
        .summary
        .tilt_rms
        .unwrap();
    println!(
        "tilt RMS: nominal {:.2}x, fixed {:.2}x the oracle",
        nominal_rms / oracle,
        fixed / oracle
    );
    assert!(nominal_rms / oracle >= 1.2, "the hidden effect must matter");
    assert!(fixed / oracle <= 1.15);
}

/// Gyro white noise and an accelerometer random walk give the velocity the same dynamics: the
/// likelihoods tie (equal posterior weights), and the tie goes to the least expected tilt
/// regret (the gyro). Naming the accelerometer would leave a confident tilt whose error is many
/// times the oracle's; with the gyro the tilt RMS is back within 1.15x (issue 4 bar).
#[test]
fn gyro_white_noise_ties_with_an_accelerometer_random_walk_and_the_tie_is_safe() {
    let base = nominal();
    let candidate = hidden::by_label("gyro/white").unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(44);
    let truth = hidden::truth(&base, candidate, &mut rng).unwrap();
    let log = sim::simulate(&truth, 43_200, 44).unwrap();
    let d = diagnose::diagnose(&base, &without_truth(&log)).unwrap();
    assert_eq!(
        (d.sensor, d.effect, d.chosen_by),
        (Some("gyro"), Some("white"), diagnose::CHOSEN_BY_TIE),
        "{} (ties {:?})",
        d.explanation,
        d.indistinguishable_from
    );
    assert!(d
        .indistinguishable_from
        .iter()
        .any(|l| l == "accel/random-walk"));
    // The record explains the choice: the gyro's expected regret is the least.
    let tie = d.tie.as_ref().unwrap();
    let gyro = tie.labels.iter().position(|l| l == "gyro/white").unwrap();
    assert!(
        tie.expected_regret
            .iter()
            .enumerate()
            .all(|(i, r)| i == gyro || *r > tie.expected_regret[gyro]),
        "{tie:?}"
    );
    let rms = |m| {
        compare::evaluate("m", m, &log)
            .unwrap()
            .summary
            .tilt_rms
            .unwrap()
    };
    let (oracle, fixed) = (rms(&truth), rms(&d.suggested));
    assert!(
        fixed / oracle <= 1.15,
        "tilt RMS {:.2}x the oracle",
        fixed / oracle
    );
}

/// Coloured observation noise (a different sensor, two parameters) is named too.
#[test]
fn hidden_colored_observation_noise_is_named() {
    let base = nominal();
    let candidate = hidden::by_label("observation/gauss-markov").unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
    let truth = hidden::truth(&base, candidate, &mut rng).unwrap();
    let log = sim::simulate(&truth, 43_200, 42).unwrap();
    let d = diagnose::diagnose(&base, &without_truth(&log)).unwrap();
    assert_eq!(
        (d.sensor, d.effect),
        (Some("observation"), Some("gauss-markov")),
        "{}",
        d.explanation
    );
}

/// With no hidden effect the model is adequate (false-alarm bound in the module comment).
#[test]
fn true_model_is_adequate() {
    let base = nominal();
    let log = sim::simulate(&base, 43_200, 43).unwrap();
    let d = diagnose::diagnose(&base, &log).unwrap();
    let best = d
        .evidence
        .candidates
        .first()
        .map(|c| (c.label.clone(), c.gain, c.penalty));
    assert_eq!(d.verdict, "adequate", "best candidate {best:?}");
    assert!(d.sensor.is_none() && d.suggested == base);
    // The kind swaps were on offer (the model has two Gauss-Markov components) and lost.
    assert!(
        d.evidence
            .candidates
            .iter()
            .filter(|c| c.label.contains("->"))
            .count()
            == 2
    );
}

/// `paper` with a gyro drift that is an exponential-cosine (period 600 s, tau 1200 s,
/// sigma 0.1 deg/h) instead of a Gauss-Markov.
const GYRO_EXP_COSINE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/paper-gyro-exp-cosine.toml"
);

/// Issue 13: a gyro drift that *is* an exponential-cosine, diagnosed from the Gauss-Markov-only
/// `paper` model, is named as a replacement of the gyro's Gauss-Markov (not as an addition,
/// and not on the accelerometer), its period is found within 10 %, the suggested model (and
/// its TOML) holds the exp-cosine in place of the Gauss-Markov, and its tilt RMS over hours
/// 8-12 is within 1.10x the true model's on the same log.
///
/// Bounds: 1.10x and 10 % are the bars. With the right structure the fitted model
/// differs from the truth only by parameter error: on 10 fresh seeds (`examples/replace_bench`,
/// BENCHMARKS.md "Replacing a component's kind") the tilt ratio was 0.92x to 1.03x and the
/// period within 10 % in 9 (the miss, 755 s, is that log's own likelihood maximum, 600 s being
/// 1.9 nats below it: the period's spread over 12 h is about 10 %, so this bar can fail on an
/// unlucky seed). This seed (not among the bench's) gives 601 s and 1.00x.
#[test]
fn gyro_exp_cosine_drift_is_named_as_a_replacement_and_fixed() {
    use imu_ident::model::{Component, ComponentKind};
    let base = nominal();
    let truth = scenario::load(GYRO_EXP_COSINE).unwrap().to_core().unwrap();
    let log = sim::simulate(&truth, 43_200, 9001).unwrap();
    let d = diagnose::diagnose(&base, &without_truth(&log)).unwrap();
    let top: Vec<_> = d
        .evidence
        .candidates
        .iter()
        .take(4)
        .map(|c| (c.label.clone(), c.score))
        .collect();
    assert_eq!(
        (
            d.verdict,
            d.sensor,
            d.effect,
            d.replaces.as_ref().map(|r| r.kind)
        ),
        (
            "wrong-kind",
            Some("gyro"),
            Some("exp-cosine"),
            Some("gauss-markov")
        ),
        "{} (best {top:?})",
        d.explanation
    );
    assert!(
        d.explanation
            .starts_with("replace gyro Gauss-Markov by exp-cosine (period "),
        "{}",
        d.explanation
    );
    let Some(Component::ExpCosine(ec)) = d.params.map(|p| p.0) else {
        panic!("params {:?}", d.params)
    };
    let period = 2.0 * std::f64::consts::PI / ec.beta;
    assert!((period / 600.0 - 1.0).abs() <= 0.10, "period {period:.1} s");
    // The suggested model is the replaced one, and so is the TOML the CLI writes.
    let kinds: Vec<_> = d.suggested.gyro.iter().map(|c| c.kind()).collect();
    assert_eq!(kinds, [ComponentKind::ExpCosine]);
    assert_eq!(d.suggested.accel, base.accel);
    let text = hal_sim::model_toml::to_string(&d.suggested).unwrap();
    let back = hal_sim::model_toml::parse(&text, "suggested").unwrap();
    assert_eq!(back.gyro.len(), 1, "{text}");
    assert_eq!(back.gyro[0].kind(), ComponentKind::ExpCosine, "{text}");
    let window = |m| {
        let (est, _) = hal_sim::replay::estimates::<f64>(m, &log).unwrap();
        hal_sim::adaptive::tilt_window(&log, &est, 8.0 * 3600.0, 12.0 * 3600.0 + 1.0)
            .unwrap()
            .0
    };
    let ratio = window(&d.suggested) / window(&truth);
    println!("period {period:.1} s; tilt RMS h8-12 {ratio:.3}x the true model's");
    assert!(ratio <= 1.10, "tilt RMS h8-12 {ratio:.3}x the true model's");
}

/// The CLI writes diagnosis.json with the documented fields, a suggested model that parses,
/// and a self-contained report with embedded SVG plots.
#[test]
fn diagnose_cli_writes_json_model_and_report() {
    let dir = tempfile::tempdir().unwrap();
    let base = nominal();
    let candidate = hidden::by_label("gyro/random-walk").unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(44);
    let truth = hidden::truth(&base, candidate, &mut rng).unwrap();
    let log = sim::simulate(&truth, 6 * 3600, 44).unwrap();
    let log_path = dir.path().join("log.csv");
    hal_sim::log::write(&log_path, &log).unwrap();
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/paper.toml");
    let out = dir.path().join("diag");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_hal-sim"))
        .args(["diagnose", "--log"])
        .arg(&log_path)
        .args(["--model", model, "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("diagnosis.json")).unwrap())
            .unwrap();
    for field in ["verdict", "sensor", "effect", "params", "evidence"] {
        assert!(!j[field].is_null(), "diagnosis.json lacks {field}: {j}");
    }
    for field in [
        "log_likelihood_gain",
        "penalty",
        "failed_lags",
        "failed_windows",
    ] {
        assert!(!j["evidence"][field].is_null(), "evidence lacks {field}");
    }
    // The levelling limit is stated with a threshold estimated from this log (a few times
    // g sigma_delta0 = 9.8e-4 m/s^2 for `paper`).
    let bias_limit = j["limits"]
        .as_array()
        .and_then(|l| {
            l.iter()
                .find(|l| l["candidates"][0] == "accel/random-constant")
        })
        .unwrap_or_else(|| panic!("no accelerometer-bias limit: {}", j["limits"]));
    let threshold = bias_limit["threshold"].as_f64().unwrap();
    assert!((1e-3..2e-2).contains(&threshold), "{bias_limit}");
    let suggested = hal_sim::model_toml::load(&out.join("suggested-model.toml")).unwrap();
    assert_eq!(suggested.gyro.len(), 2);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("<svg") && html.contains("Diagnosis") && !html.contains("src=\"http"));
    assert!(html.contains("What these data cannot show"));
}

/// The ACF of the estimated sensor errors of the true model lies inside the model's Monte Carlo
/// 99 % band at nearly every lag (pointwise band, strongly correlated lags: allow 10 %). The
/// 0.1x model's estimates also sit inside *their own* model's band — the self-confirmation trap
/// of METHOD.md §4 made visible (measured: 0 of 150 gyro lags outside) — while its innovations
/// fail the whiteness test: that is why the verdict rests on innovations and likelihood.
#[test]
fn estimate_acf_self_confirms_but_innovations_do_not() {
    let base = nominal();
    let log = sim::simulate(&base, 43_200, 45).unwrap();
    let run = compare::evaluate("oracle", &base, &log).unwrap();
    assert_eq!(run.estimate_acf.len(), 2);
    for a in &run.estimate_acf {
        let frac = a.outside.len() as f64 / (a.lags.len() - 1) as f64;
        println!("oracle {}: {:.1} % of lags outside", a.sensor, 100.0 * frac);
        assert!(frac <= 0.10, "{}: {frac}", a.sensor);
    }
    assert!(run.whiteness.p_value > 1e-3, "oracle innovations are white");
    let wrong = hal_sim::mismatch::scaled(&base, 0.1, 0.1);
    let run = compare::evaluate("0.1x", &wrong, &log).unwrap();
    let gyro = run
        .estimate_acf
        .iter()
        .find(|a| a.sensor == "gyro")
        .unwrap();
    println!(
        "0.1x gyro: {} of {} lags outside; Ljung-Box p {:e}",
        gyro.outside.len(),
        gyro.lags.len() - 1,
        run.whiteness.p_value
    );
    assert!(
        run.whiteness.p_value < 1e-6,
        "the innovations reveal the mismatch"
    );
}
