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

/// On six `paper`-like logs whose gyro drift is an exponential-cosine (period 600 s, tau
/// 1200 s, 0.1 deg/h), at least three runs end with the gyro switched, every switched run has
/// `beta` within 10 %, and the median tilt RMS over hours 8-12 is within 1.10x the oracle's.
/// On six `paper` logs, none switches.
///
/// Why these bounds: the evidence is weak at this amplitude (`docs/ADAPTATION.md` §7.6).
/// - The structure statistic is the best alternative's log-likelihood gain over the best
///   Gauss-Markov fit, with no switching.
/// - On 80 `paper` logs over 12 h it reached at most 4.3 nats. The switch needs 4.5 (1.5 times
///   the penalty of 3 nats per parameter), so a `paper` log that switches fails the test.
/// - On exp-cosine logs at this pace, 14-17 of 20 runs per seed set ended switched (70-85 %),
///   and these six development seeds give four. Three of six is the floor: a test that never
///   switches fails it, and so does a beta off by the scan's spacing (a factor 1.5).
#[test]
fn exp_cosine_gyro_drift_is_found_and_paper_does_not_switch() {
    let paper = InsModel::<f64>::paper();
    let beta = 2.0 * std::f64::consts::PI / 600.0;
    let mut ec = paper.clone();
    ec.gyro[0] = Component::ExpCosine(
        ExpCosine::new(0.1 * std::f64::consts::PI / 180.0 / 3600.0, 1200.0, beta)
            .unwrap_or_else(|e| panic!("{e:?}")),
    );
    let (t0, t1) = (8.0 * 3600.0, HOURS as f64 * 3600.0 + 1.0);
    let (mut found, mut ratios) = (0, Vec::new());
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
            assert!(
                (e.beta / beta - 1.0).abs() <= 0.10,
                "seed {seed}: beta {} vs {beta}",
                e.beta
            );
            found += 1;
        }
    }
    assert!(found >= 3, "only {found} of 6 runs switched the gyro");
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
