//! Issue-4 figures: each candidate effect hidden in `paper`-like data (magnitudes and time
//! scales drawn by `hal_sim::hidden`, seeds 5000.. never used in development), 12 h each; the
//! nominal `paper` model is diagnosed from the innovations only.
//!
//! `cargo run --release -p hal-sim --example diagnose_bench [-- SEEDS [FIRST]]` (default 20 seeds,
//! from the first library entry)

use hal_sim::candidates::LIBRARY;
use hal_sim::{compare, diagnose, hidden, scenario, sim};
use rand::SeedableRng;

fn median(v: Vec<f64>) -> f64 {
    hal_sim::shared_data::median(&v)
}

fn main() -> anyhow::Result<()> {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    // Optional: first library index to run (to resume a long run); the adequate case runs last.
    let first: usize = std::env::args()
        .nth(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let nominal = scenario::load("paper")?.to_core()?;
    println!("| hidden effect | named correctly | named or tied | ignoring it (tilt RMS / oracle, median) | after adding the named effect (median) | worst after |");
    println!("|---|---|---|---|---|---|");
    let cases: Vec<Option<usize>> = (first..LIBRARY.len()).map(Some).chain([None]).collect();
    for case in cases {
        let (mut correct, mut tied) = (0, 0);
        let (mut before, mut after) = (vec![], vec![]);
        for k in 0..seeds {
            let seed = 5000 + 100 * case.map_or(99, |c| c as u64) + k;
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let truth = match case {
                Some(c) => hidden::truth(&nominal, LIBRARY[c], &mut rng).expect("fits"),
                None => nominal.clone(),
            };
            let log = sim::simulate(&truth, 43_200, seed)?;
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
            let oracle = compare::evaluate("oracle", &truth, &log)?
                .summary
                .tilt_rms
                .unwrap_or(f64::NAN);
            let nom = compare::evaluate("nominal", &nominal, &log)?
                .summary
                .tilt_rms
                .unwrap_or(f64::NAN);
            let fix = compare::evaluate("fixed", &d.suggested, &log)?
                .summary
                .tilt_rms
                .unwrap_or(f64::NAN);
            before.push(nom / oracle);
            after.push(fix / oracle);
            eprintln!(
                "{:?} seed {seed}: named {named:?} ties {:?} before {:.2} after {:.2}",
                want,
                d.indistinguishable_from,
                nom / oracle,
                fix / oracle
            );
        }
        let label = case.map_or("none (adequate model)".into(), |c| LIBRARY[c].label());
        let worst = after.iter().copied().fold(f64::NAN, f64::max);
        println!(
            "| {label} | {correct}/{seeds} | {tied}/{seeds} | {:.2} | {:.2} | {:.2} |",
            median(before),
            median(after),
            worst
        );
    }
    Ok(())
}
