//! Issue-13 figures for the "replace a component's kind" candidate: a `paper` log whose gyro
//! drift IS an exponential-cosine (`tests/data/paper-gyro-exp-cosine.toml`: period 600 s,
//! tau 1200 s, sigma 0.1 deg/h), 12 h, diagnosed from the Gauss-Markov-only `paper` model; and
//! plain `paper` logs, where a replacement named as the verdict is a false alarm.
//!
//! Per seed (stderr): the verdict, the fitted period, the best addition's score against the
//! verdict's, and the tilt RMS over hours 8-12 of the suggested model over the true model's
//! (same log). Summary (stdout): verdicts right, period within 10 %, tilt ratio median and
//! worst, false replacements on `paper`.
//!
//! `cargo run --release -p hal-sim --example replace_bench [-- SEEDS [FIRST_SEED]]`: default
//! 10 seeds from 9100 (exp-cosine logs; the `paper` logs use FIRST_SEED + 100 ..). The test
//! (`tests/diagnose.rs`) uses seed 9001, outside these.

use hal_sim::adaptive::tilt_window;
use hal_sim::diagnose::{diagnose, Diagnosis};
use hal_sim::log::LogRow;
use hal_sim::{replay, scenario, shared_data::median, sim};
use imu_ident::model::{Component, InsModel};

/// The scenario whose gyro drift is an exponential-cosine.
const SCENARIO: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/paper-gyro-exp-cosine.toml"
);
/// Hours 8-12: the window of the bars (the filter has settled).
const WINDOW: (f64, f64) = (8.0 * 3600.0, 12.0 * 3600.0 + 1.0);

fn tilt(m: &InsModel<f64>, log: &[LogRow]) -> anyhow::Result<f64> {
    let (est, _) = replay::estimates::<f64>(m, log)?;
    tilt_window(log, &est, WINDOW.0, WINDOW.1)
        .map(|t| t.0)
        .ok_or_else(|| anyhow::anyhow!("no truth in the window"))
}

/// The verdict's fitted period [s], when it is an exponential-cosine.
fn period(d: &Diagnosis) -> Option<f64> {
    match d.params.map(|p| p.0) {
        Some(Component::ExpCosine(e)) => Some(2.0 * std::f64::consts::PI / e.beta),
        _ => None,
    }
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let seeds: u64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(10);
    let first: u64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(9100);
    let nominal = scenario::load("paper")?.to_core()?;
    let truth = scenario::load(SCENARIO)?.to_core()?;
    let (mut right, mut period_ok, mut ratios, mut before) = (0, 0, vec![], vec![]);
    for seed in first..first + seeds {
        let log = sim::simulate(&truth, 43_200, seed)?;
        let d = diagnose(&nominal, &log)?;
        let replace = d.replaces.as_ref().map(|r| r.kind);
        let ok = d.verdict == "wrong-kind"
            && d.sensor == Some("gyro")
            && replace == Some("gauss-markov")
            && d.effect == Some("exp-cosine");
        let per = period(&d);
        let per_ok = ok && per.is_some_and(|p| (p / 600.0 - 1.0).abs() <= 0.10);
        right += ok as usize;
        period_ok += per_ok as usize;
        let oracle = tilt(&truth, &log)?;
        let ratio = tilt(&d.suggested, &log)? / oracle;
        let nom = tilt(&nominal, &log)? / oracle;
        ratios.push(ratio);
        before.push(nom);
        // The best addition, to see by how much the replacement beat it.
        let best_add = d
            .evidence
            .candidates
            .iter()
            .find(|c| !c.label.contains("->"))
            .map(|c| format!("{} {:.1}", c.label, c.score));
        let top = d.evidence.candidates.first().map(|c| c.score);
        eprintln!(
            "seed {seed}: {} {:?}/{:?} (replaces {replace:?}, {}) period {:?} score {top:?}, best addition {best_add:?}; tilt h8-12 nominal {nom:.2}x, fixed {ratio:.2}x",
            d.verdict,
            d.sensor,
            d.effect,
            d.chosen_by,
            per.map(|p| p.round())
        );
    }
    let worst = ratios.iter().copied().fold(f64::NAN, f64::max);
    println!(
        "gyro exp-cosine, seeds {first}..{}: verdict gyro/gauss-markov->exp-cosine {right}/{seeds}, period within 10 % {period_ok}/{seeds}; tilt RMS h8-12 / true model: nominal median {:.2}, fixed median {:.2}, worst {:.2}",
        first + seeds - 1,
        median(&before),
        median(&ratios),
        worst
    );
    let mut false_replace = 0;
    for seed in first + 100..first + 100 + seeds {
        let log = sim::simulate(&nominal, 43_200, seed)?;
        let d = diagnose(&nominal, &log)?;
        false_replace += (d.verdict == "wrong-kind") as usize;
        let top = d
            .evidence
            .candidates
            .first()
            .map(|c| format!("{} {:.1}", c.label, c.score));
        eprintln!(
            "paper seed {seed}: {} {:?}/{:?}; best {top:?}",
            d.verdict, d.sensor, d.effect
        );
    }
    println!(
        "paper, seeds {}..{}: replacement as the verdict {false_replace}/{seeds}",
        first + 100,
        first + 100 + seeds - 1
    );
    Ok(())
}
