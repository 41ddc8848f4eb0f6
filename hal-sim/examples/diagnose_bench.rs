//! Issue-4 figures: each candidate effect hidden in `paper`-like data (magnitudes and time
//! scales drawn by `hal_sim::hidden`, seeds 5000.. never used in development), 12 h each; the
//! nominal `paper` model is diagnosed from the innovations only.
//!
//! The issue asks for effects at a *realistic magnitude*: one where ignoring the effect costs at
//! least 1.2x the oracle's tilt RMS. A drawn effect is a random process, so one seed's
//! realisation can be far weaker than its parameters (a random constant drawn near zero costs
//! nothing). Each case therefore draws seeds in order and keeps the first `SEEDS` whose cost
//! (nominal tilt RMS / oracle tilt RMS, from the truth columns, which only this selection uses)
//! is at least 1.2; the number of draws is printed. The diagnosis itself never sees the truth.
//!
//! `cargo run --release -p hal-sim --example diagnose_bench [-- SEEDS [CASES]]`: default 20
//! seeds; CASES is a comma-separated list of library labels and `none` (default: all, and the
//! adequate model last).

use hal_sim::candidates::LIBRARY;
use hal_sim::{compare, diagnose, hidden, scenario, sim};
use rand::SeedableRng;

/// The realistic magnitude: ignoring the effect costs at least this tilt RMS ratio.
const REALISTIC_COST: f64 = 1.2;
/// Draws per case at most (seeds `5000 + 100 case + k`, k below this).
const MAX_DRAWS: u64 = 100;

fn median(v: Vec<f64>) -> f64 {
    hal_sim::shared_data::median(&v)
}

fn main() -> anyhow::Result<()> {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let all: Vec<Option<usize>> = (0..LIBRARY.len()).map(Some).chain([None]).collect();
    let cases: Vec<Option<usize>> = match std::env::args().nth(2) {
        None => all,
        Some(list) => list
            .split(',')
            .map(|l| match l {
                "none" => Ok(None),
                _ => LIBRARY
                    .iter()
                    .position(|c| c.label() == l)
                    .map(Some)
                    .ok_or_else(|| anyhow::anyhow!("unknown case {l:?}")),
            })
            .collect::<anyhow::Result<_>>()?,
    };
    let nominal = scenario::load("paper")?.to_core()?;
    println!("| hidden effect | draws (kept / drawn) | named correctly | named or tied | ignoring it (tilt RMS / oracle, median) | after adding the named effect (median) | worst after |");
    println!("|---|---|---|---|---|---|---|");
    for case in cases {
        let (mut correct, mut tied, mut drawn) = (0, 0, 0);
        let (mut before, mut after, mut outside) = (vec![], vec![], vec![]);
        for k in 0..MAX_DRAWS {
            if before.len() as u64 == seeds {
                break;
            }
            drawn += 1;
            let seed = 5000 + 100 * case.map_or(99, |c| c as u64) + k;
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let truth = match case {
                Some(c) => hidden::truth(&nominal, LIBRARY[c], &mut rng).expect("fits"),
                None => nominal.clone(),
            };
            let log = sim::simulate(&truth, 43_200, seed)?;
            let summary = |name: &str, m| -> anyhow::Result<(f64, f64)> {
                let s = compare::evaluate(name, m, &log)?.summary;
                Ok((
                    s.tilt_rms.unwrap_or(f64::NAN),
                    s.tilt_outside_3sigma.unwrap_or(f64::NAN),
                ))
            };
            let tilt = |name: &str, m| -> anyhow::Result<f64> { Ok(summary(name, m)?.0) };
            let oracle = tilt("oracle", &truth)?;
            let nom = tilt("nominal", &nominal)?;
            let cost = nom / oracle;
            if case.is_some() && cost < REALISTIC_COST {
                eprintln!("seed {seed}: cost {cost:.2} below {REALISTIC_COST}, not kept");
                continue;
            }
            let d = diagnose::diagnose(&nominal, &log)?;
            let named = d.sensor.zip(d.effect).map(|(s, e)| format!("{s}/{e}"));
            let want = case.map(|c| LIBRARY[c].label());
            let ok = named == want;
            correct += ok as usize;
            tied += (ok
                || want
                    .as_ref()
                    .is_some_and(|w| d.indistinguishable_from.contains(w)))
                as usize;
            let (fix, fix_out) = summary("fixed", &d.suggested)?;
            before.push(cost);
            after.push(fix / oracle);
            outside.push(fix_out);
            eprintln!(
                "{:?} seed {seed}: named {named:?} ({}) ties {:?} before {:.2} after {:.2} (outside 3 sigma {:.3})",
                want,
                d.chosen_by,
                d.indistinguishable_from,
                cost,
                fix / oracle,
                fix_out
            );
            for l in d
                .limits
                .iter()
                .filter(|l| want.as_ref().is_some_and(|w| l.candidates.contains(w)))
            {
                if let (Some(e), Some(t)) = (l.estimate, l.threshold) {
                    eprintln!(
                        "  limit: estimate {e:.3e}, nameable above {t:.3e}: {}",
                        if e.abs() > t { "above" } else { "below" }
                    );
                }
            }
            if let Some(t) = &d.tie {
                eprintln!(
                    "  tie {:?} weights {:.3?} expected regret {:.2?} regret {:.2?}",
                    t.labels, t.weights, t.expected_regret, t.regret
                );
            }
        }
        let kept = before.len();
        let label = case.map_or("none (adequate model)".into(), |c| LIBRARY[c].label());
        let worst = after.iter().copied().fold(f64::NAN, f64::max);
        println!(
            "| {label} | {kept} / {drawn} | {correct}/{kept} | {tied}/{kept} | {:.2} | {:.2} | {:.2} |",
            median(before),
            median(after),
            worst
        );
        // Consistency of the suggested model: the fraction of ticks whose tilt error is outside
        // its own 3 sigma (0.27 % for a consistent Gaussian filter).
        eprintln!(
            "{label}: tilt outside 3 sigma after, median {:.3}, worst {:.3}",
            median(outside.clone()),
            outside.iter().copied().fold(f64::NAN, f64::max)
        );
    }
    Ok(())
}
