//! Online identification in the strapdown INS/GNSS navigator (issue 16's bar "with online
//! identification from starts 10x too small, 10x too large and wrong in random directions per
//! axis: after 1 h, position and attitude RMS within 1.10x the true-model filter's, and <= 2 %
//! outside 3 sigma"), BENCHMARKS.md "Online identification in the navigator".
//!
//!   cargo run --release -p hal-sim --example nav_adapt_bench -- \
//!       grade=mems seeds=8 first=8001 starts=0.1,10,rand
//!
//! Other keys: `grade=tactical`, `hours=` (2), `rate=` (IMU Hz, 100), `score_from=` (3600 s),
//! `adapt_first=`, `every=`, `window=` (600, 1200, 7200 s), `method=bank` (the core's
//! shadow-filter bank, `nav --adapt-method bank`; with it `every=` defaults to 1200 s and
//! `offset=`, `min_offset=`, `min_gain=`, `memory=`, `bank_conservative=1` set its `OnlineConfig`), `per_axis=1` (`per_axis=2`: per axis, tied first, `--adapt-tied-first`), `taus=` (`held`,
//! `tested`, `free`; default the command's), `conservative=0`, `gnss_sd=0` (the window
//! search does not identify the GNSS standard deviations, `--adapt-gnss-sd false`; on by
//! default),
//! `gnss_stated=K` (the adaptive runs take the fixes' standard deviations as K times the true
//! noise, `--gnss-sd-factor K,K`; the true-model run has the truth), `truth_axes=K` (the true
//! model's intensities differ by axis: each axis's white density and sigmas scaled by its own
//! log-uniform factor in [1/K, K], drawn per seed; correlation times alike; default 1, the
//! grade's model on every axis); environment `AXES=1` prints every run's 9 per-axis 3-sigma
//! fractions; `TRACE=1` prints each decision (time, window start, fixes, estimate and
//! Cramér-Rao sds in log10 factors); `fixed_final=1` also runs, after each adaptive run, a
//! fixed filter at that run's final estimate over the whole log (no conservative raise), which
//! tells a wrong estimate from a costly path to it; `ml_ref=1` also runs, per seed, the
//! **ML reference**: the host's window search (`nav --adapt`, replay method, no conservative
//! raise) once at `score_from` over `[0, score_from]` from the true model (an offline
//! maximum-likelihood fit of the data the runs have when scoring starts), then a fixed filter
//! at its estimate over the whole log. Each run is then also judged against the larger of
//! 1.10x and 1.05x its seed's reference on both ratios and at most the larger of 2 % and its
//! fraction outside 3 sigma (issue 13's form of the bar: what the data up to the scoring
//! allow); the summary counts those, and gives the mean `log10` of each ratio over the
//! reference, a finer score than a count at a threshold for comparing two rules on the same
//! runs. The reference's line gives its factors on the truth and its log-likelihood of the
//! fixes over `[0, score_from]` less the true model's; `ml_from=K` starts its search from the
//! true model with every standard deviation times `K` (1 by default: from the truth), which
//! tells whether the search's answer depends on its start. `probe=F1,F2,..;G1,..` runs, per
//! seed and in place of the runs, fixed filters at the true model moved by each list of
//! `log10` factors (the tied coordinates in the bank's order: per sensor, gyro then
//! accelerometer, each component's quantities) and prints their ratios and log-likelihoods
//! against the true-model filter's: what an error in one coordinate costs.
//!
//! Per seed: a figure-eight drive (`Profile::figure_eight_course`, 100 Hz, GNSS 1 Hz with 60-s
//! outages every 20 min from 10 min, withheld by the run); the true-model filter; then one
//! `nav --adapt` run per start. A start `k` scales every standard deviation (white density,
//! Gauss-Markov sigma; random-walk q by k^2) by `k`; `k:l` also every correlation time by
//! `l`, and `taul` the correlation times alone; `rand` draws a factor log-uniformly in
//! [0.1, 10] independently for every standard deviation and correlation time on every axis
//! (seeded by the seed and the start's place in the list; `randK` is the draw of place K, to
//! pair runs with another list). Scored over t >= `score_from` [s] (3600):
//! horizontal position RMS, attitude RMS (root of the mean of the three angles' squares),
//! each over the true-model filter's, and the worst of the 9 navigation errors' 3-sigma
//! fractions. Prints one line per run and the medians, 95th percentiles and worst cases.

#[path = "bench_args/mod.rs"]
mod bench_args;

use bench_args::nav::score;
use bench_args::{arg, arg_or, pct};
use hal_sim::nav::adapt::{AdaptConfig, AdaptMethod, TauMode};
use hal_sim::nav::{run_with, NavArgs};
use hal_sim::trajectory::errors::ImuErrorModel as SimModel;
use hal_sim::trajectory::gnss::GnssConfig;
use hal_sim::trajectory::profile::Profile;
use hal_sim::trajectory::write::{simulate_drive, write_and_read_drive};
use imu_ident::model::Quantity;
use imu_ident::nav::ImuErrorModel;
use rand::{Rng, SeedableRng};

/// `m` with every identified quantity of every axis scaled by its own log-uniform factor in
/// [0.1, 10] (standard deviations and correlation times; `q` by the factor squared).
fn random(m: &ImuErrorModel<f64>, rng: &mut impl Rng) -> ImuErrorModel<f64> {
    let mut out = m.clone();
    for axis in out.gyro.iter_mut().chain(out.accel.iter_mut()) {
        for c in axis.iter_mut() {
            for &q in c.kind().identified() {
                let k = 10f64.powf(rng.gen_range(-1.0..=1.0));
                if let Some(v) = c.get(q) {
                    c.set(q, if q == Quantity::Q { v * k * k } else { v * k });
                }
            }
        }
    }
    out
}

/// `m` with every correlation time times `k`.
fn scaled_taus(m: &ImuErrorModel<f64>, k: f64) -> ImuErrorModel<f64> {
    let mut out = m.clone();
    for axis in out.gyro.iter_mut().chain(out.accel.iter_mut()) {
        for c in axis.iter_mut() {
            if let Some(v) = c.get(Quantity::Tau) {
                c.set(Quantity::Tau, v * k);
            }
        }
    }
    out
}

/// The innovation log-likelihood of the fixes over `t <= to` [nats].
fn loglik(run: &hal_sim::nav::NavRun, to: f64) -> f64 {
    run.epochs
        .iter()
        .filter(|e| e.t <= to)
        .map(|e| e.loglik)
        .sum()
}

fn main() {
    let grade = arg("grade").unwrap_or_else(|| "mems".into());
    let seeds: u64 = arg_or("seeds", 3);
    let first: u64 = arg_or("first", 8001);
    let hours: f64 = arg_or("hours", 2.0);
    let rate: f64 = arg_or("rate", 100.0);
    let from: f64 = arg_or("score_from", 3600.0);
    let starts: Vec<String> = arg("starts")
        .unwrap_or_else(|| "0.1,10,rand".into())
        .split(',')
        .map(str::to_string)
        .collect();
    let bank = arg("method").as_deref() == Some("bank");
    let d = AdaptConfig::DEFAULT;
    let cfg = AdaptConfig {
        first: arg_or("adapt_first", if bank { d.bank.first } else { d.first }),
        every: arg_or("every", if bank { d.bank.every } else { d.every }),
        window: arg_or("window", 7200.0),
        per_axis: arg_or("per_axis", 0) != 0,
        tied_first: arg_or("per_axis", 0) == 2,
        taus: match arg("taus").as_deref() {
            None => AdaptConfig::default().taus,
            Some("0" | "held") => TauMode::Held,
            Some("1" | "free") => TauMode::Free,
            Some("tested") => TauMode::Tested,
            Some(t) => panic!("taus={t}: held, tested or free"),
        },
        conservative: arg_or("conservative", 1) != 0,
        method: if bank {
            AdaptMethod::Bank
        } else {
            AdaptMethod::Replay
        },
        bank: imu_ident::nav::OnlineConfig {
            first: arg_or("adapt_first", d.bank.first),
            every: arg_or("every", d.bank.every),
            offset: arg_or("offset", d.bank.offset),
            min_offset: arg_or("min_offset", d.bank.min_offset),
            min_gain: arg_or("min_gain", d.bank.min_gain),
            memory: arg_or("memory", d.bank.memory),
            conservative: arg_or("bank_conservative", u8::from(d.bank.conservative)) != 0,
            flat_waits: arg_or("flat_waits", u8::from(d.bank.flat_waits)) != 0,
            exit_z: arg_or("exit_z", d.bank.exit_z),
            ..d.bank
        },
        gnss_sd: arg_or("gnss_sd", u8::from(d.gnss_sd)) != 0,
    };
    // The receiver's stated standard deviations are this factor times the true noise in the
    // adaptive runs (`--gnss-sd-factor`; the true-model run has the truth).
    let gnss_stated: f64 = arg_or("gnss_stated", 1.0);
    let sim = match grade.as_str() {
        "mems" => SimModel::mems(),
        "tactical" => SimModel::tactical(),
        g => panic!("grade={g}: mems or tactical"),
    };
    let truth_axes: f64 = arg_or("truth_axes", 1.0);
    let probe = arg("probe");
    println!("# {grade}, {seeds} seeds from {first}, {hours} h at {rate} Hz, scored from {from} s; truth_axes {truth_axes}; {cfg:?}");
    // Per start: ratios (horizontal, attitude), worst 3-sigma fractions.
    let mut ratios: Vec<Vec<[f64; 2]>> = vec![vec![]; starts.len()];
    let mut out3: Vec<Vec<f64>> = vec![vec![]; starts.len()];
    let mut true_out3 = vec![];
    let ml_ref = arg_or("ml_ref", 0) != 0;
    let ml_from: f64 = arg_or("ml_from", 1.0);
    // Per run: within the larger of 1.10x and 1.05x its seed's ML reference on both ratios,
    // and at most the larger of 2 % and the reference's fraction outside 3 sigma.
    let mut within_ref = 0usize;
    let mut refs: Vec<[f64; 3]> = vec![];
    // Per run: log10 of each ratio over the seed's reference (a continuous score, finer than
    // a count of passes at a threshold).
    let mut excess: Vec<[f64; 2]> = vec![];
    for seed in first..first + seeds {
        let sim = if truth_axes > 1.0 {
            // Every axis's intensities by its own log-uniform factor in [1/k, k]: a true model
            // whose axes differ.
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed * 1000 + 777);
            let e = truth_axes.log10();
            sim.scaled_axes(|| 10f64.powf(rng.gen_range(-e..=e)))
        } else {
            sim.clone()
        };
        let truth_model = sim.to_core().unwrap_or_else(|e| panic!("{e:#}"));
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let profile = Profile::figure_eight_course(hours, 1.0).unwrap_or_else(|e| panic!("{e:#}"));
        let start = hal_sim::trajectory::write::course_start();
        let drive = simulate_drive(
            &profile,
            start,
            1.0 / rate,
            &sim,
            GnssConfig::default(),
            seed,
        )
        .unwrap_or_else(|e| panic!("{e:#}"));
        let (imu, fixes, truth) =
            write_and_read_drive(dir.path(), &drive).unwrap_or_else(|e| panic!("{e:#}"));
        let base = |model: ImuErrorModel<f64>, name: &str| {
            NavArgs::simulated_drive(dir.path(), &fixes, &truth, model, name)
        };
        // A fixed filter over the whole log at `est` (log10 factors on `start`, tied; no
        // raise): its score, and its innovation log-likelihood of the fixes over [0, from].
        let fixed_at = |start: &ImuErrorModel<f64>, est: &[f64], name: &str| {
            use imu_ident::nav::online::coords;
            // The estimate's own coordinates (`coordinates` under `cfg`): per axis with
            // `per_axis=1` (tied, a start whose axes differ would be replaced by its geometric
            // mean, and 20 factors applied to 8 coordinates), the taus unless held.
            let c = coords::coordinates(start, cfg.per_axis, cfg.taus != TauMode::Held)
                .unwrap_or_else(|e| panic!("{e:?}"));
            let fixed = coords::apply(&coords::tie(start, &c), &c, est);
            let args = NavArgs {
                gnss_sd_factor: [gnss_stated; 2],
                ..base(fixed, name)
            };
            let run = run_with::<f64>(&args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
            (
                score(&run, &truth, from),
                [loglik(&run, from), loglik(&run, f64::INFINITY)],
            )
        };
        // `probe=`: fixed filters at the truth moved by the given log10 factors, one list per
        // `;`, scored against the true-model filter (how much each coordinate's error costs).
        if let Some(spec) = &probe {
            let oracle = run_with::<f64>(&base(truth_model.clone(), "true"), &imu, &fixes)
                .unwrap_or_else(|e| panic!("{e:#}"));
            let o = score(&oracle, &truth, from);
            for v in spec.split(';') {
                let est: Vec<f64> = v
                    .split(',')
                    .map(|x| {
                        x.trim()
                            .parse()
                            .unwrap_or_else(|e| panic!("probe {v}: {e}"))
                    })
                    .collect();
                let (r, ll) = fixed_at(&truth_model, &est, "probe");
                println!(
                    "seed {seed} probe {v}: horizontal {:.3}x, attitude {:.3}x, worst outside 3 sigma {:.2} %; log-likelihood over [0, {from}] {:+.1}, over the log {:+.1} nats on the true model's",
                    r.0 / o.0, r.1 / o.1, r.2 * 100.0, ll[0] - loglik(&oracle, from),
                    ll[1] - loglik(&oracle, f64::INFINITY)
                );
            }
            continue;
        }
        let t = std::time::Instant::now();
        let oracle = run_with::<f64>(&base(truth_model.clone(), "true"), &imu, &fixes)
            .unwrap_or_else(|e| panic!("{e:#}"));
        let o = score(&oracle, &truth, from);
        true_out3.push(o.2);
        println!(
            "seed {seed} true: horizontal {:.3} m, attitude {:.4} deg, worst outside 3 sigma {:.2} % ({:.1} s)",
            o.0, o.1, o.2 * 100.0, t.elapsed().as_secs_f64()
        );
        // The seed's ML reference (`ml_ref=1`): the window search over [0, from] from the
        // truth, then a fixed filter at its estimate.
        let reference = ml_ref.then(|| {
            let t = std::time::Instant::now();
            let fit = AdaptConfig {
                first: from,
                every: f64::MAX,
                window: from,
                conservative: false,
                method: AdaptMethod::Replay,
                ..cfg
            };
            let fit_start = hal_sim::nav::model::scaled_sd(&truth_model, ml_from);
            let args = NavArgs {
                adapt: Some(fit),
                gnss_sd_factor: [gnss_stated; 2],
                ..base(fit_start.clone(), "ml")
            };
            let run = run_with::<f64>(&args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
            let log = run.adapt.as_ref().expect("adapt log");
            let est = log.searches.last().map_or_else(Vec::new, |l| l.log10_factors.clone());
            let (r, ll) = fixed_at(&fit_start, &est, "ml");
            let ratio = [r.0 / o.0, r.1 / o.1, r.2];
            // Its factors on the truth (a standard deviation's start was `ml_from` times it).
            let coords = imu_ident::nav::online::coords::coordinates(
                &fit_start,
                cfg.per_axis,
                cfg.taus != TauMode::Held,
            )
            .unwrap_or_else(|e| panic!("{e:?}"));
            let on_truth = est.iter().enumerate().map(|(i, x)| {
                let sd = coords.get(i).is_some_and(|c| c.quantity != Quantity::Tau);
                x + if sd { ml_from.log10() } else { 0.0 }
            });
            println!(
                "seed {seed} ML reference: horizontal {:.3}x, attitude {:.3}x, worst outside 3 sigma {:.2} %; log10 factors on the truth {:?}; log-likelihood over [0, {from}] {:+.1} nats on the true model's ({:.1} s)",
                ratio[0], ratio[1], r.2 * 100.0,
                on_truth.map(|x| (x * 100.0).round() / 100.0).collect::<Vec<_>>(),
                ll[0] - loglik(&oracle, from),
                t.elapsed().as_secs_f64()
            );
            refs.push(ratio);
            ratio
        });
        for (si, s) in starts.iter().enumerate() {
            let model = match s.strip_prefix("rand") {
                Some(draw) => {
                    // `randK` is draw K; a plain `rand` is the draw of its place in the list.
                    let k: u64 = draw.parse().unwrap_or(si as u64);
                    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed * 1000 + k);
                    random(&truth_model, &mut rng)
                }
                None => {
                    // `K`: every standard deviation times K; `K:L` also every correlation time
                    // times L; `tauL` the correlation times alone (`1:L`).
                    let (k, l) = match s.strip_prefix("tau") {
                        Some(l) => ("1", l),
                        None => s.split_once(':').unwrap_or((s.as_str(), "1")),
                    };
                    let num =
                        |v: &str| -> f64 { v.parse().unwrap_or_else(|e| panic!("start {s}: {e}")) };
                    scaled_taus(
                        &hal_sim::nav::model::scaled_sd(&truth_model, num(k)),
                        num(l),
                    )
                }
            };
            let t = std::time::Instant::now();
            let args = NavArgs {
                adapt: Some(cfg),
                gnss_sd_factor: [gnss_stated; 2],
                ..base(model, s)
            };
            let run = run_with::<f64>(&args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
            let r = score(&run, &truth, from);
            let ratio = [r.0 / o.0, r.1 / o.1];
            ratios[si].push(ratio);
            out3[si].push(r.2);
            if let Some(m) = reference {
                let bar = |i: usize| (1.05 * m[i]).max(1.10);
                if ratio[0] <= bar(0) && ratio[1] <= bar(1) && r.2 <= m[2].max(0.02) {
                    within_ref += 1;
                }
                excess.push([(ratio[0] / m[0]).log10(), (ratio[1] / m[1]).log10()]);
            }
            let log = run.adapt.as_ref().expect("adapt log");
            let last = log.searches.last();
            println!(
                "seed {seed} start {s}: horizontal {:.3}x, attitude {:.3}x, worst outside 3 sigma {:.2} %; {} searches ({} moved the correlation times under test), {} replays, final log10 factors {:?} ({:.1} s)",
                ratio[0], ratio[1], r.2 * 100.0, log.searches.len(),
                log.searches.iter().filter(|s| s.tau_test.is_some_and(|t| t.moved)).count(),
                log.searches.iter().map(|s| s.evaluations).sum::<usize>(),
                last.map(|l| l.log10_factors.iter().map(|x| (x * 100.0).round() / 100.0).collect::<Vec<_>>()),
                t.elapsed().as_secs_f64()
            );
            if std::env::var("TRACE").is_ok() {
                let r2 = |v: &[f64]| {
                    v.iter()
                        .map(|x| (x * 100.0).round() / 100.0)
                        .collect::<Vec<_>>()
                };
                for d in &log.searches {
                    println!(
                        "  t {:.0} from {:.0} fixes {} est {:?} sd {:?}",
                        d.t,
                        d.window_start,
                        d.fixes,
                        r2(&d.log10_factors),
                        r2(&d.cr_sd_log10)
                    );
                }
            }
            // `fixed_final=1`: the same log through a fixed filter at the run's final
            // estimate (no raise): tells a wrong estimate from the path to it.
            if arg_or("fixed_final", 0) != 0 {
                if let Some(l) = last {
                    let (r, ll) = fixed_at(&args.model, &l.log10_factors, s);
                    println!(
                        "seed {seed} start {s} fixed at final: horizontal {:.3}x, attitude {:.3}x, worst outside 3 sigma {:.2} %; log-likelihood over the log {:+.1} nats on the true model's",
                        r.0 / o.0, r.1 / o.1, r.2 * 100.0, ll[1] - loglik(&oracle, f64::INFINITY)
                    );
                }
            }
        }
    }
    println!(
        "# true model: worst outside 3 sigma median {:.2} %, worst {:.2} %",
        pct(&mut true_out3.clone(), 0.5) * 100.0,
        pct(&mut true_out3, 1.0) * 100.0
    );
    let mut all_h = vec![];
    let mut all_a = vec![];
    let mut all_o = vec![];
    for (si, s) in starts.iter().enumerate() {
        let mut h: Vec<f64> = ratios[si].iter().map(|r| r[0]).collect();
        let mut a: Vec<f64> = ratios[si].iter().map(|r| r[1]).collect();
        all_h.extend(&h);
        all_a.extend(&a);
        all_o.extend(&out3[si]);
        println!(
            "# start {s}: horizontal ratio median {:.3}, p95 {:.3}, worst {:.3}; attitude ratio median {:.3}, p95 {:.3}, worst {:.3}; outside 3 sigma median {:.2} %, worst {:.2} %",
            pct(&mut h.clone(), 0.5), pct(&mut h.clone(), 0.95), pct(&mut h, 1.0),
            pct(&mut a.clone(), 0.5), pct(&mut a.clone(), 0.95), pct(&mut a, 1.0),
            pct(&mut out3[si].clone(), 0.5) * 100.0, pct(&mut out3[si], 1.0) * 100.0
        );
    }
    let within = ratios
        .iter()
        .flatten()
        .filter(|r| r[0] <= 1.10 && r[1] <= 1.10)
        .count();
    let all_len = all_h.len();
    println!(
        "# all {} runs: horizontal median {:.3}, p95 {:.3}, worst {:.3}; attitude median {:.3}, p95 {:.3}, worst {:.3}; both within 1.10x: {within}; outside 3 sigma median {:.2} %, p95 {:.2} %, worst {:.2} %",
        all_h.len(),
        pct(&mut all_h.clone(), 0.5), pct(&mut all_h.clone(), 0.95), pct(&mut all_h, 1.0),
        pct(&mut all_a.clone(), 0.5), pct(&mut all_a.clone(), 0.95), pct(&mut all_a, 1.0),
        pct(&mut all_o.clone(), 0.5) * 100.0, pct(&mut all_o.clone(), 0.95) * 100.0, pct(&mut all_o, 1.0) * 100.0
    );
    if ml_ref {
        let mut h: Vec<f64> = refs.iter().map(|r| r[0]).collect();
        let mut a: Vec<f64> = refs.iter().map(|r| r[1]).collect();
        let both = refs.iter().filter(|r| r[0] <= 1.10 && r[1] <= 1.10).count();
        println!(
            "# ML reference over {} seeds: horizontal median {:.3}, worst {:.3}; attitude median {:.3}, worst {:.3}; both within 1.10x: {both}; runs within max(1.10, 1.05 x reference) on both and outside 3 sigma at most max(2 %, the reference's): {within_ref} of {}",
            refs.len(),
            pct(&mut h.clone(), 0.5), pct(&mut h, 1.0),
            pct(&mut a.clone(), 0.5), pct(&mut a, 1.0),
            all_len
        );
        // Mean and standard error of the log10 excess over the reference, in millidecades.
        let mean_se = |k: usize| {
            let v: Vec<f64> = excess.iter().map(|e| 1e3 * e[k]).collect();
            let n = v.len().max(1) as f64;
            let m = v.iter().sum::<f64>() / n;
            let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
            (m, (var / n).sqrt())
        };
        let ((hm, hs), (am, as_)) = (mean_se(0), mean_se(1));
        println!(
            "# log10 of the ratios over the seed's reference [millidecades, 1 = 0.23 %], mean +- standard error: horizontal {hm:.1} +- {hs:.1}, attitude {am:.1} +- {as_:.1}"
        );
    }
}
