//! The global stage's structure test (issue 13, item 3; `docs/ADAPTATION.md` §7.6): a gyro drift
//! that is an exponential-cosine is found from the Gauss-Markov-only `paper` model, and `paper`
//! data do not make it switch.

use hal_sim::adaptive::{self, tilt_window};
use hal_sim::{replay, sim};
use imu_ident::adapt::AdaptConfig;
use imu_ident::model::{Component, ExpCosine, InsModel};

const HOURS: usize = 12;
const SEEDS: std::ops::Range<u64> = 1000..1006;

/// The global stage with the structure test on, at host pace (a search every 2 h, 1000 filter
/// steps per tick), as the issue-13 benches run it.
fn config() -> AdaptConfig<f64> {
    let mut cfg = AdaptConfig::global();
    cfg.global.structure = imu_ident::adapt::window::STRUCTURE_PENALTY;
    cfg.global.every = 120;
    cfg.global.budget = 1000;
    cfg
}

/// `paper` with the issue's gyro drift: an exponential-cosine of period 600 s, tau 1200 s and
/// 0.1 deg/h; and its `beta`.
fn issue_exp_cosine() -> (InsModel<f64>, f64) {
    let beta = 2.0 * std::f64::consts::PI / 600.0;
    let mut ec = InsModel::<f64>::paper();
    ec.gyro[0] = Component::ExpCosine(
        ExpCosine::new(0.1 * std::f64::consts::PI / 180.0 / 3600.0, 1200.0, beta)
            .unwrap_or_else(|e| panic!("{e:?}")),
    );
    (ec, beta)
}

/// On six `paper`-like logs whose gyro drift is an exponential-cosine (period 600 s, tau
/// 1200 s, 0.1 deg/h), at least three runs end with the gyro switched, the switched runs'
/// median `|beta error|` is within the issue's 10 % and none is beyond 25 %, and the median
/// tilt RMS over hours 8-12 is within 1.10x the oracle's. On six `paper` logs, none switches.
///
/// Why these bounds: the evidence is weak at this amplitude (`docs/ADAPTATION.md` §7.6).
/// - The structure statistic is the best alternative's log-likelihood gain over the best
///   Gauss-Markov fit, with no switching.
/// - On 80 `paper` logs over 12 h it reached at most 4.3 nats. The switch needs 4.5 (1.5 times
///   the penalty of 3 nats per parameter), so a `paper` log that switches fails the test.
/// - On exp-cosine logs at this pace, 14-17 of 20 runs per seed set ended switched (70-85 %),
///   and these six development seeds give six. Three of six is the floor: a test that never
///   switches fails it.
/// - `beta`: a wrong peak of the likelihood, or a neighbouring scanned period, is off by a
///   factor 1.5 or more; 25 % catches it. Per run, 10 % is not a bound the data support: the
///   offline maximum likelihood over hours 0-6 put 5 of 40 logs beyond it
///   (`examples/structure_bound.rs`), and since the early revisit of flat answers also runs
///   with the test on (2026-11-27), runs switch sooner, from shorter windows: the worst of 73
///   switched runs of `structure_bench` (seed sets 9300, 9500 and 76000, both paces) was
///   16.2 % off, and three of these six are 10-15 % off.
///   The median stays at the issue's 10 % (1.9-3.6 % on the seed sets; 8.6 % here).
#[test]
fn exp_cosine_gyro_drift_is_found_and_paper_does_not_switch() {
    let paper = InsModel::<f64>::paper();
    let (ec, beta) = issue_exp_cosine();
    let (t0, t1) = (8.0 * 3600.0, HOURS as f64 * 3600.0 + 1.0);
    let (mut found, mut ratios, mut errs) = (0, Vec::new(), Vec::new());
    for seed in SEEDS {
        let log = sim::simulate(&ec, HOURS * 3600, seed).unwrap_or_else(|e| panic!("{e:#}"));
        let oracle = replay::estimates::<f64>(&ec, &log).unwrap_or_else(|e| panic!("{e:#}"));
        let (orms, _) = tilt_window(&log, &oracle.0, t0, t1).unwrap_or_else(|| panic!("oracle"));
        let r = adaptive::run::<f64>(&paper, &log, config()).unwrap_or_else(|e| panic!("{e:#}"));
        let (rms, _) = tilt_window(&log, &r.estimates, t0, t1).unwrap_or_else(|| panic!("run"));
        ratios.push(rms / orms);
        let end = r.final_model.gyro.first().copied();
        eprintln!(
            "seed {seed}: tilt/oracle {:.3}, gyro at the end {end:?}",
            rms / orms
        );
        if let Some(Component::ExpCosine(e)) = end {
            let err = (e.beta / beta - 1.0).abs();
            eprintln!("seed {seed}: |beta error| {:.1} %", 100.0 * err);
            assert!(err <= 0.25, "seed {seed}: beta {} vs {beta}", e.beta);
            errs.push(err);
            found += 1;
        }
    }
    assert!(found >= 3, "only {found} of 6 runs switched the gyro");
    errs.sort_by(f64::total_cmp);
    let n = errs.len();
    let median_err = 0.5 * (errs[(n - 1) / 2] + errs[n / 2]);
    assert!(median_err <= 0.10, "median |beta error| {median_err:.3}");
    ratios.sort_by(f64::total_cmp);
    let median = 0.5 * (ratios[2] + ratios[3]);
    assert!(median <= 1.10, "median tilt/oracle {median:.3}");
    for seed in SEEDS {
        let log = sim::simulate(&paper, HOURS * 3600, seed).unwrap_or_else(|e| panic!("{e:#}"));
        let r = adaptive::run::<f64>(&paper, &log, config()).unwrap_or_else(|e| panic!("{e:#}"));
        let kinds: Vec<_> = r
            .final_model
            .accel
            .iter()
            .chain(r.final_model.gyro.iter())
            .map(|c| c.kind())
            .collect();
        assert!(
            r.params.iter().all(|p| p.kind == "gauss-markov"),
            "seed {seed}: a paper log switched the structure ({kinds:?})"
        );
    }
}

/// Only oscillations are offered (`structure::MIN_QUALITY`): every exponential-cosine the test
/// reports has `beta tau >= pi`, on a `paper` log and on a log of the issue's oscillation
/// (`beta tau = 4 pi`), where one must be offered.
///
/// Fresh seed 74015 (firmware pace, no switching): before the bound, the first search on its
/// `paper` log offered an accelerometer exponential-cosine with `beta tau = 1.68`, 4.1 nats
/// above the Gauss-Markov fit: a shape, not an oscillation, and the largest null statistic of
/// 40 logs at hour 6 (BENCHMARKS.md "Structure online, 2026-11-27"). The test fails on that
/// code; it asserts a bound, not a statistic.
#[test]
fn a_non_oscillating_exp_cosine_is_not_offered() {
    use imu_ident::adapt::identifiable::IdentifiableModel;
    use imu_ident::adapt::params::{apply, specs};
    use imu_ident::model::{ErrorSource, Quantity};
    let paper = InsModel::<f64>::paper();
    let mut ec = paper.clone();
    ec.gyro[0] = Component::ExpCosine(
        ExpCosine::new(
            0.1 * std::f64::consts::PI / 180.0 / 3600.0,
            1200.0,
            2.0 * std::f64::consts::PI / 600.0,
        )
        .unwrap_or_else(|e| panic!("{e:?}")),
    );
    let mut cfg = AdaptConfig::<f64>::global();
    // The test runs, but no gain can pay this penalty: the model stays Gauss-Markov.
    cfg.global.structure = 1e9;
    // The `beta tau` of every alternative offered on `truth`'s log of `hours`.
    let offered = |truth: &InsModel<f64>, hours: usize| -> Vec<f64> {
        let log = sim::simulate(truth, hours * 3600, 74015).unwrap_or_else(|e| panic!("{e:#}"));
        let mut f = imu_ident::adapt::AdaptiveFilter::new(paper.clone(), cfg)
            .unwrap_or_else(|e| panic!("{e:?}"));
        let (mut last, mut out) = (0, Vec::new());
        for row in &log {
            f.step(row.z);
            let g = f.last_global();
            if g.evaluations == last {
                continue;
            }
            last = g.evaluations;
            let Some(s) = g.switch.get().filter(|s| s.extra > 0) else {
                continue;
            };
            let alt = paper
                .swapped(&s.site, 1.0)
                .unwrap_or_else(|| panic!("{:?}", s.site));
            let m = apply(&alt, &specs(&alt), &s.theta).unwrap_or_else(|| panic!("theta"));
            let list = if s.site.sensor == ErrorSource::Accel {
                &m.accel
            } else {
                &m.gyro
            };
            let c = list[usize::from(s.site.index)];
            let q = c.get(Quantity::Beta).unwrap() * c.get(Quantity::Tau).unwrap();
            eprintln!("offered {:?}: beta tau {q:.2}, gain {:.2}", s.site, s.gain);
            out.push(q);
        }
        out
    };
    let null = offered(&paper, 6);
    let oscillation = offered(&ec, HOURS);
    // The documented bound (`structure::MIN_QUALITY`), not the constant: lowered, it fails here.
    for q in null.iter().chain(&oscillation) {
        assert!(*q >= std::f64::consts::PI * (1.0 - 1e-9), "beta tau {q}");
    }
    assert!(
        !oscillation.is_empty(),
        "nothing offered on the oscillation's log"
    );
}

/// With the structure test on, an answer the window does not identify is still searched again
/// sooner (`WindowConfig::flat_every`, `docs/ADAPTATION.md` §7.8).
///
/// Development seed 9106 of `examples/anystart_bench.rs`, started with the gyro's sigma at
/// 0.1x, firmware pace: when the structure test turned that early search off, tilt RMS over
/// hours 8-12 was 8.08x the oracle's; with it, at most 1.01x over all 33 starts of the seed.
/// The bound is the any-start bar's 1.05x of the larger of the oracle and the ML reference
/// (1.000x the oracle on this seed).
#[test]
fn structure_test_keeps_the_early_search_of_a_flat_answer() {
    let paper = InsModel::<f64>::paper();
    let log = sim::simulate(&paper, HOURS * 3600, 9106).unwrap_or_else(|e| panic!("{e:#}"));
    let mut start = paper.clone();
    if let Component::GaussMarkov(g) = &mut start.gyro[0] {
        g.sigma *= 0.1;
    }
    let mut cfg = AdaptConfig::<f64>::global();
    cfg.global = imu_ident::adapt::window::WindowConfig::with_structure();
    let (t0, t1) = (8.0 * 3600.0, HOURS as f64 * 3600.0 + 1.0);
    let oracle = replay::estimates::<f64>(&paper, &log).unwrap_or_else(|e| panic!("{e:#}"));
    let (orms, _) = tilt_window(&log, &oracle.0, t0, t1).unwrap_or_else(|| panic!("oracle"));
    let r = adaptive::run::<f64>(&start, &log, cfg).unwrap_or_else(|e| panic!("{e:#}"));
    let (rms, _) = tilt_window(&log, &r.estimates, t0, t1).unwrap_or_else(|| panic!("run"));
    eprintln!("tilt/oracle {:.3}", rms / orms);
    assert!(rms / orms <= 1.05, "tilt/oracle {:.3}", rms / orms);
}

/// After a settled answer that an alternative structure beat (below the switch's threshold),
/// the next search tests structure first, from its anchor, and decides within an hour of its
/// window rather than after the model's search (`docs/ADAPTATION.md` §7.15). Development seed
/// 94802 of `examples/structure_bench.rs` (the issue's exponential-cosine gyro, firmware
/// pace): the 5.1-h search's window (hours 0-5.1) holds a 4.9-nat alternative; tested after
/// that search, the switch came at 6.53 h, past the issue's 6 h; tested first, at 5.87 h. The
/// log is cut at 7 h: every decision is causal.
#[test]
fn after_a_settled_answer_the_switch_comes_within_6_h() {
    let paper = InsModel::<f64>::paper();
    let (ec, _) = issue_exp_cosine();
    let log = sim::simulate(&ec, 7 * 3600, 94802).unwrap_or_else(|e| panic!("{e:#}"));
    let mut cfg = AdaptConfig::<f64>::global();
    cfg.global = imu_ident::adapt::window::WindowConfig::with_structure();
    let r = adaptive::run::<f64>(&paper, &log, cfg).unwrap_or_else(|e| panic!("{e:#}"));
    let switched = r
        .params
        .iter()
        .find(|p| p.sensor == "gyro" && p.kind == "exp-cosine")
        .map(|p| p.t / 3600.0);
    eprintln!("gyro exp-cosine from {switched:?} h");
    assert!(
        switched.is_some_and(|h| h <= 6.0),
        "gyro switched at {switched:?} h"
    );
}
