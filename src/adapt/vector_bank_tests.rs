//! The identification bank on an error model other than the one-channel INS: one first-order
//! Gauss-Markov state seen by two sensors with independent white noise (`N = 1`, `Z = 2`). The
//! bank knows the model only through [`IdentifiableModel`], fuses the two axes as sequential
//! scalar updates, and gates them together on the vector NIS.

use crate::adapt::bank::Bank;
use crate::adapt::identifiable::IdentifiableModel;
use crate::adapt::identifier::Identifier;
use crate::adapt::information::Information;
use crate::adapt::params::{ParamSpec, Specs, MAXP};
use crate::adapt::AdaptConfig;
use crate::model::{
    ComponentKind, ContinuousSystem, ErrorModel, ErrorSource, ModelError, Quantity, StateBlock,
};
extern crate std;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::vec::Vec;

/// `x' = -x / tau + w` (stationary sd `sigma`), observed as `z_i = x + v_i`, `v_i ~ N(0, r_i)`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TwoSensorMarkov {
    pub(crate) sigma: f64,
    pub(crate) tau: f64,
    pub(crate) r: [f64; 2],
}

impl ErrorModel<f64, 1, 2> for TwoSensorMarkov {
    fn dt(&self) -> f64 {
        1.0
    }

    fn scaling(&self) -> Result<[f64; 1], ModelError> {
        Ok([self.sigma])
    }

    fn system(&self, s: &[f64; 1]) -> Result<ContinuousSystem<f64, 1, 2>, ModelError> {
        let s2 = s[0] * s[0];
        Ok(ContinuousSystem {
            A: [[-1.0 / self.tau]],
            Qc: [[2.0 * self.sigma * self.sigma / self.tau / s2]],
            P0: [[self.sigma * self.sigma / s2]],
            H: [[s[0]], [s[0]]],
            R: self.r,
            n: 1,
        })
    }

    fn blocks(&self, f: &mut dyn FnMut(StateBlock)) {
        f(StateBlock {
            name: "markov",
            component: Some(ComponentKind::GaussMarkov),
            start: 0,
            width: 1,
        });
    }

    fn same_layout(&self, _: &Self) -> bool {
        true
    }
}

impl IdentifiableModel<f64, 1, 2> for TwoSensorMarkov {
    const BLANK: Self = Self {
        sigma: 0.0,
        tau: 0.0,
        r: [0.0; 2],
    };

    type Outputs = ();
    const NO_OUTPUTS: () = ();

    fn outputs(&self, _: &[f64; 1]) -> Result<(), ModelError> {
        Ok(())
    }

    fn with_parameters(&self, specs: &Specs, theta: &[f64; MAXP]) -> Option<Self> {
        let mut m = self.clone();
        set_each(&mut m, specs, theta, |m, s| match s.kind {
            Quantity::Sigma => Some(&mut m.sigma),
            Quantity::Tau => Some(&mut m.tau),
            _ => None,
        })?;
        Some(m)
    }

    fn identified(&self) -> Specs {
        specs()
    }

    fn parameters(&self, specs: &Specs) -> [f64; MAXP] {
        let mut theta = [0.0; MAXP];
        for (t, s) in theta.iter_mut().zip(specs.iter()) {
            *t = match s.kind {
                Quantity::Sigma => self.sigma.ln(),
                Quantity::Tau => self.tau.ln(),
                _ => 0.0,
            };
        }
        theta
    }
}

/// Writes `exp` of each spec's `theta` into the field of `m` that `slot` names; `None` at the
/// first value that is not positive and finite, or spec that `slot` does not name.
pub(super) fn set_each<M>(
    m: &mut M,
    specs: &Specs,
    theta: &[f64; MAXP],
    slot: for<'a> fn(&'a mut M, &ParamSpec) -> Option<&'a mut f64>,
) -> Option<()> {
    for (s, t) in specs.iter().zip(theta.iter()) {
        let v = t.exp();
        if !(v.is_finite() && v > 0.0) {
            return None;
        }
        *slot(m, s)? = v;
    }
    Some(())
}

pub(crate) const TRUTH: TwoSensorMarkov = TwoSensorMarkov {
    sigma: 0.5,
    tau: 20.0,
    r: [0.09, 0.36],
};

fn specs() -> Specs {
    let spec = |kind| ParamSpec {
        sensor: ErrorSource::Gyro,
        index: 0,
        kind,
    };
    let mut s = Specs::new();
    s.push(spec(Quantity::Sigma)).unwrap();
    s.push(spec(Quantity::Tau)).unwrap();
    s
}

type TwoAxisBank = Bank<f64, TwoSensorMarkov, 1, 2>;

/// `theta` of `m` for [`specs`].
fn theta_of(m: &TwoSensorMarkov) -> [f64; MAXP] {
    m.parameters(&specs())
}

/// A bank for `m`, perturbed by `+-h`, at `m`'s own parameters.
fn bank_at(m: &TwoSensorMarkov, h: f64) -> TwoAxisBank {
    let mut bank = TwoAxisBank::new(m, &specs(), h).unwrap();
    bank.set_theta(&theta_of(m)).unwrap();
    bank
}

/// The gate: the 99.9 % quantile of chi-square with `m` degrees of freedom (1 or 2).
fn gate(m: usize) -> f64 {
    if m == 1 {
        10.83
    } else {
        13.82
    }
}

/// `steps` observations of the truth: the exact AR(1) of the Gauss-Markov state at `dt = 1`.
pub(crate) fn observations(seed: u64, steps: usize) -> Vec<[f64; 2]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = Normal::new(0.0, 1.0).unwrap();
    let phi = (-1.0 / TRUTH.tau).exp();
    let q = TRUTH.sigma * (1.0 - phi * phi).sqrt();
    let mut x = TRUTH.sigma * n.sample(&mut rng);
    (0..steps)
        .map(|_| {
            x = phi * x + q * n.sample(&mut rng);
            [
                x + TRUTH.r[0].sqrt() * n.sample(&mut rng),
                x + TRUTH.r[1].sqrt() * n.sample(&mut rng),
            ]
        })
        .collect()
}

/// Score and Fisher information of the whole record at `theta` (one bank pass).
fn information(model: &TwoSensorMarkov, theta: &[f64; MAXP], z: &[[f64; 2]]) -> Information<f64> {
    let mut bank = TwoAxisBank::new(model, &specs(), 0.01).unwrap();
    bank.set_theta(theta).unwrap();
    let mut info = Information::default();
    for zk in z {
        assert!(bank.step_axes(zk, &mut info, None).accumulated);
    }
    info
}

/// `I^-1 g` and `I^-1` of a two-parameter information.
fn newton(info: &Information<f64>) -> ([f64; 2], [[f64; 2]; 2]) {
    let f = info.fisher;
    let det = f[0][0] * f[1][1] - f[0][1] * f[1][0];
    let inv = [
        [f[1][1] / det, -f[0][1] / det],
        [-f[1][0] / det, f[0][0] / det],
    ];
    let g = info.score;
    let step = [
        inv[0][0] * g[0] + inv[0][1] * g[1],
        inv[1][0] * g[0] + inv[1][1] * g[1],
    ];
    (step, inv)
}

/// Gauss-Newton on the bank's score and Fisher information, from a start wrong in both
/// parameters, in opposite directions: both starts reach the same maximum-likelihood point (up to
/// the start's initial covariance, below), and
/// it lies within 4 Cramér-Rao standard deviations of the truth in each coordinate (the ML
/// estimate is asymptotically normal with covariance `I^-1`; `P(|N(0,1)| > 4) = 6e-5`). At the
/// truth itself the score is consistent with zero: `g^T I^-1 g` is chi-square with 2 degrees of
/// freedom, below 13.8 with probability 0.999.
#[test]
fn a_two_axis_bank_finds_the_maximum_likelihood_from_either_side() {
    let z = observations(20_261_130, 20_000);
    let truth = [TRUTH.sigma.ln(), TRUTH.tau.ln()];
    let info = information(&TRUTH, &theta_of(&TRUTH), &z);
    let (step, _) = newton(&info);
    let chi2 = step[0] * info.score[0] + step[1] * info.score[1];
    assert!(chi2 < 13.8, "score at the truth: g^T I^-1 g = {chi2}");
    assert_eq!(info.steps, 2 * 20_000, "one term per axis and step");

    let mut ends = Vec::new();
    for factors in [[3.0, 0.25], [1.0 / 3.0, 4.0]] {
        let start = TwoSensorMarkov {
            sigma: TRUTH.sigma * factors[0],
            tau: TRUTH.tau * factors[1],
            ..TRUTH
        };
        let mut theta = theta_of(&start);
        let mut last = (f64::INFINITY, [[0.0; 2]; 2]);
        for _ in 0..12 {
            let info = information(&start, &theta, &z);
            let (step, inv) = newton(&info);
            // Damped to a factor e per iteration far from the optimum; full steps near it.
            let norm = step[0].abs().max(step[1].abs()).max(1.0);
            theta[0] += step[0] / norm;
            theta[1] += step[1] / norm;
            last = (step[0].abs().max(step[1].abs()), inv);
        }
        assert!(
            last.0 < 1e-6,
            "Gauss-Newton converged: last step {}",
            last.0
        );
        for i in 0..2 {
            let sd = last.1[i][i].sqrt();
            assert!(
                (theta[i] - truth[i]).abs() < 4.0 * sd,
                "coordinate {i}: {} against {} (CR sd {sd})",
                theta[i],
                truth[i]
            );
        }
        ends.push((
            [theta[0], theta[1]],
            [last.1[0][0].sqrt(), last.1[1][1].sqrt()],
        ));
    }
    // The members start from the start model's initial covariance, so the two maxima differ by
    // that prior's weight, one state's worth of information against 40 000 terms: a few
    // hundredths of a Cramér-Rao sd, against the sd itself for a start-dependent answer.
    let ((a, sd), (b, _)) = (ends[0], ends[1]);
    for i in 0..2 {
        assert!(
            (a[i] - b[i]).abs() < 0.05 * sd[i],
            "{a:?} vs {b:?}, sd {sd:?}"
        );
    }
}

/// Observation values for the fuzz tests: mostly ordinary, with NaN, +-Inf, 1e30, `-f64::MAX`,
/// subnormals and zeros.
pub(crate) fn hostile_values() -> impl proptest::strategy::Strategy<Value = f64> + Clone {
    use proptest::prelude::*;
    prop_oneof![
        6 => -3.0..3.0f64,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(1e30),
        1 => Just(-f64::MAX),
        1 => Just(f64::MIN_POSITIVE / 4.0),
        1 => Just(0.0),
    ]
}

/// The vector gate withholds a whole observation when one axis is an outlier (as the strapdown
/// filter's `fuse` does): no member uses either axis, nothing is accumulated, and the members
/// only predict. An observation with one axis missing adds that step's one finite axis.
#[test]
fn a_two_axis_bank_gates_the_whole_observation_and_uses_a_partial_one() {
    let z = observations(7, 200);
    let mut bank = bank_at(&TRUTH, 0.05);
    let mut info = Information::default();
    for zk in &z {
        let out = bank.step_axes(zk, &mut info, Some(&gate));
        assert!(out.gated.iter().all(Option::is_none));
    }
    let steps = info.steps;

    // Axis 0 sits 40 of its own sds off; axis 1 is clean.
    let mut predicted = bank.clone();
    let nan = [f64::NAN; 2];
    predicted.step_axes(&nan, &mut Information::default(), None);
    let outlier = [z[199][0] + 40.0 * TRUTH.r[0].sqrt(), z[199][1]];
    let out = bank.step_axes(&outlier, &mut info, Some(&gate));
    assert!(out.gated.iter().all(Option::is_some), "{out:?}");
    assert!(out.centre.iter().all(Option::is_none));
    assert!(!out.accumulated);
    assert_eq!(info.steps, steps);
    assert_eq!(bank.centre(), predicted.centre());
    assert_eq!(bank, predicted);

    let out = bank.step_axes(&[f64::NAN, z[0][1]], &mut info, Some(&gate));
    assert!(out.accumulated);
    assert!(out.centre[0].is_none() && out.centre[1].is_some());
    assert_eq!(info.steps, steps + 1);
}

/// Any observation sequence (NaN, +-Inf, 1e30, `f64::MAX`, subnormals, an axis missing, outliers
/// on one axis) and any requested parameters (absurd ones included, whose discretisation fails
/// and is rolled back), with and without the gate: no panic, the centre's covariance stays
/// positive definite, and the accumulated score and information stay finite.
#[test]
fn a_two_axis_bank_survives_any_input() {
    use proptest::prelude::*;
    use proptest::test_runner::{Config, TestRunner};
    let value = hostile_values();
    let row = (value.clone(), value);
    // Log-parameters up to e^800: beyond e^709 the value overflows and the move is rolled back.
    let log = prop_oneof![3 => -60.0..60.0f64, 1 => -800.0..800.0f64];
    let moves = proptest::collection::vec((0usize..300, log.clone(), log), 0..6);
    let case = (proptest::collection::vec(row, 1..300), moves, any::<bool>());
    let failed_moves = std::cell::Cell::new(0);
    let mut runner = TestRunner::new(Config {
        cases: 64,
        ..Config::default()
    });
    runner
        .run(&case, |(rows, moves, gated)| {
            let mut bank = bank_at(&TRUTH, 0.05);
            let theta = theta_of(&TRUTH);
            let mut info = Information::default();
            let mut failed = 0;
            for (k, (a, b)) in rows.iter().enumerate() {
                for &(_, s, t) in moves.iter().filter(|m| m.0 == k) {
                    let mut th = theta;
                    th[0] = s;
                    th[1] = t;
                    bank.request_theta(&th);
                }
                let g: Option<&dyn Fn(usize) -> f64> = if gated { Some(&gate) } else { None };
                failed += usize::from(bank.step_axes(&[*a, *b], &mut info, g).failed);
                let c = &bank.centre().kf;
                prop_assert!(crate::linalg::is_positive_definite(&c.P, bank.active()));
                prop_assert!(c.x.iter().all(|v| v.is_finite()));
                prop_assert!(bank.theta().iter().all(|v| v.is_finite()));
            }
            prop_assert!(info.score.iter().all(|v| v.is_finite()));
            prop_assert!(info.fisher.iter().flatten().all(|v| v.is_finite()));
            failed_moves.set(failed_moves.get() + failed);
            Ok(())
        })
        .unwrap();
    // The rollback path was exercised (a test of it that never ran would prove nothing).
    assert!(failed_moves.get() > 0);
}

/// The probes of the one-channel loop run on the two-axis model too: started with the
/// correlation time 4x too long, the best probe (a grid of `tau x 2^{+-1, +-2}` with sigma moved
/// the other way by half as many octaves) has a shorter correlation time than the centre, and
/// beats it by more than a likelihood-ratio test of 2 parameters at 5 % would need: twice the
/// gain above 5.99, the 95 % point of chi-square(2).
#[test]
fn the_probes_run_on_a_two_axis_model() {
    use crate::adapt::guard::Bounds;
    use crate::adapt::probes::Probes;
    let z = observations(11, 6_000);
    let start = TwoSensorMarkov {
        tau: 4.0 * TRUTH.tau,
        ..TRUTH
    };
    let sp = specs();
    let theta = theta_of(&start);
    let mut bank = bank_at(&start, 0.05);
    let mut probes = Probes::<f64, 1>::new(&sp, 2.0, bank.p0());
    assert_eq!(probes.len(), 4);
    let mut lo = [-50.0; MAXP];
    let mut hi = [50.0; MAXP];
    lo[1] = 0.0;
    hi[1] = 20.0;
    probes.anchor(&theta, &Bounds { lo, hi }, 2);
    let mut info = Information::default();
    for zk in &z {
        let out = bank.step_axes(zk, &mut info, None);
        let (scale, rows) = (*bank.scale_array(), bank.rows());
        let centre = (bank.centre(), &out.centre);
        probes
            .step(zk, centre, rows, &start, &sp, &scale, 60)
            .unwrap();
    }
    let best = probes.best().unwrap();
    assert!(best.theta[1] < theta[1], "{:?}", best.theta);
    assert!(2.0 * best.gain > 5.99, "gain {}", best.gain);
}

/// The starts of the online identification: factors on the truth's (sigma, tau).
const STARTS: [[f64; 2]; 8] = [
    [10.0, 1.0],
    [0.1, 1.0],
    [1.0, 10.0],
    [1.0, 0.1],
    [3.0, 0.25],
    [1.0 / 3.0, 4.0],
    [3.0, 4.0],
    [1.0 / 3.0, 0.25],
];

type TwoAxisIdentifier = Identifier<f64, TwoSensorMarkov, 1, 2>;

/// The truth with `factors` on (sigma, tau).
fn start_at(factors: [f64; 2]) -> TwoSensorMarkov {
    TwoSensorMarkov {
        sigma: TRUTH.sigma * factors[0],
        tau: TRUTH.tau * factors[1],
        ..TRUTH
    }
}

/// An identifier from `start`, run over `z` (no move may be rejected).
fn identify(start: TwoSensorMarkov, cfg: AdaptConfig<f64>, z: &[[f64; 2]]) -> TwoAxisIdentifier {
    let mut f = TwoAxisIdentifier::new(start, cfg).unwrap();
    assert_eq!(
        f.flat(),
        0b11,
        "nothing is identified before the first block"
    );
    for zk in z {
        assert!(!f.step_axes(zk, None).rejected, "a move was rejected");
    }
    f
}

/// The online identification ([`Identifier`]) on the two-axis model, from eight starts: each
/// parameter alone 10x and 0.1x, and both wrong (3x or 1/3 with 4x or 1/4) in all four pairs of
/// directions. The window is 10 blocks (`f = exp(-500 / 5000)`), and the hysteresis is off, so
/// each run follows the window's maximum-likelihood point. After 40 000 steps (80 blocks; the
/// information of the path is weighted by `f^80 = 3e-4`), a run that converged has no
/// [`Identifier::flat`] bit and is within 4 windowed Cramér-Rao sd of the truth in each
/// coordinate. The window's estimate is asymptotically normal with the sandwich covariance of
/// [`Identifier::windowed_sd`], and `P(|N(0,1)| > 4) = 6e-5`.
/// - **The recursion alone** (no probes). Seven runs converge and agree within 0.2 windowed sd
///   (measured: at most 0.05 on the 7 seeds tuned on, 0.08 on 7 fresh ones): the start does
///   not matter. An answer that depended on
///   the start would differ by about an sd. With the default hysteresis (steps under one
///   standard error are not taken) they stop up to 1.5 sd apart ([`hysteresis_spread`];
///   `docs/ADAPTATION.md` §2.7). The recursion is local: started with sigma 10x, it climbs to
///   the random-walk ridge (`tau -> 5000 s`, `sigma^2 / tau` about right), where the likelihood
///   is flat, and it stays there on every seed tried. The test asserts that this run says so:
///   both coordinates flagged.
/// - **With the probes** (grid factor 3, epochs of 3600 steps, moves held while searching):
///   all eight converge, the sigma-10x start too, and they agree within 1 windowed sd
///   (measured: at most 0.50 on 7 seeds, 0.61 on 7 fresh ones; the search phase leaves the
///   recursion fewer blocks to forget its path).
#[test]
fn the_identifier_converges_online_or_flags_its_ridge() {
    let z = observations(20_261_201, 40_000);
    let truth = [TRUTH.sigma.ln(), TRUTH.tau.ln()];
    for (probe_factor, agree) in [(0.0, 0.2), (3.0, 1.0)] {
        let cfg = AdaptConfig {
            block: 500,
            window: 5000.0,
            hysteresis: 0.0,
            probe_factor,
            ..AdaptConfig::default()
        };
        let mut ends = Vec::new();
        for factors in STARTS {
            let f = identify(start_at(factors), cfg, &z);
            assert!(f.updates() > 0 && f.steps() == 40_000);
            if factors == [10.0, 1.0] && probe_factor == 0.0 {
                assert_eq!(
                    f.flat(),
                    0b11,
                    "the ridge is flagged: {:?}",
                    f.windowed_sd()
                );
                continue;
            }
            let sd = f.windowed_sd().unwrap();
            let th = *f.theta();
            assert_eq!(
                f.flat(),
                0,
                "start {factors:?}, probes {probe_factor}: sd {sd:?}"
            );
            for i in 0..2 {
                assert!(
                    (th[i] - truth[i]).abs() < 4.0 * sd[i],
                    "start {factors:?}, probes {probe_factor}, coordinate {i}: {} against {} \
                     (sd {})",
                    th[i],
                    truth[i],
                    sd[i]
                );
            }
            ends.push((th, sd));
        }
        let (first, sd) = ends[0];
        for (th, _) in &ends {
            for i in 0..2 {
                let d = (th[i] - first[i]).abs() / sd[i];
                assert!(
                    d < agree,
                    "probes {probe_factor}: ends {th:?} and {first:?}: {d} sd"
                );
            }
        }
    }
}

/// Measurement, not a check (`cargo test --release --lib hysteresis_spread -- --ignored
/// --nocapture`): how far apart the starts of
/// [`the_identifier_converges_online_or_flags_its_ridge`] end, in windowed sd, on seeds 1-7
/// (`FIRST_SEED=k`: seeds `k` to `k + 6`):
/// the recursion alone (the seven starts other than sigma 10x, and how often that one ends
/// flagged) and with the probes (all eight),
/// with the hysteresis off and at its default (steps under one standard error not taken), with
/// the default 4-h window and with the 10-block one of the test, after 40 000 and 160 000 steps.
#[test]
#[ignore]
fn hysteresis_spread() {
    let runs = [
        (5000.0, 0.0, 40_000),
        (5000.0, 1.0, 40_000),
        (14_400.0, 0.0, 40_000),
        (14_400.0, 1.0, 40_000),
        (14_400.0, 0.0, 160_000),
        (14_400.0, 1.0, 160_000),
    ];
    let first: u64 = std::env::var("FIRST_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    for probe_factor in [0.0, 3.0] {
        let starts = if probe_factor > 1.0 {
            &STARTS[..]
        } else {
            &STARTS[1..]
        };
        for (window, hysteresis, steps) in runs {
            let cfg = AdaptConfig {
                block: 500,
                window,
                hysteresis,
                probe_factor,
                ..AdaptConfig::default()
            };
            let (mut worst, mut far): (f64, f64) = (0.0, 0.0);
            let (mut flagged, mut runs) = (0, 0);
            // The sigma-10x start: flagged, converged, neither.
            let mut ridge = [0; 3];
            for seed in first..first + 7 {
                let z = observations(seed, steps);
                if probe_factor <= 1.0 {
                    // The sigma-10x start, left out of the spread: does it end flagged?
                    let f = identify(start_at(STARTS[0]), cfg, &z);
                    let sd = f.windowed_sd().unwrap_or([f64::INFINITY; MAXP]);
                    let th = f.theta();
                    let near = (th[0] - TRUTH.sigma.ln()).abs() < 4.0 * sd[0]
                        && (th[1] - TRUTH.tau.ln()).abs() < 4.0 * sd[1];
                    if f.flat() != 0 {
                        ridge[0] += 1;
                    } else if near {
                        ridge[1] += 1;
                    } else {
                        ridge[2] += 1;
                        std::println!(
                            "  sigma 10x, seed {seed}: theta {:?}, sd {:?}",
                            &th[..2],
                            &sd[..2]
                        );
                    }
                }
                let mut ends = Vec::new();
                for factors in starts {
                    let f = identify(start_at(*factors), cfg, &z);
                    runs += 1;
                    flagged += usize::from(f.flat() != 0);
                    let sd = f.windowed_sd().unwrap();
                    let th = *f.theta();
                    far = far.max((th[0] - TRUTH.sigma.ln()).abs() / sd[0]);
                    far = far.max((th[1] - TRUTH.tau.ln()).abs() / sd[1]);
                    ends.push((th, sd));
                }
                for (a, sd) in &ends {
                    for (b, _) in &ends {
                        for i in 0..2 {
                            worst = worst.max((a[i] - b[i]).abs() / sd[i]);
                        }
                    }
                }
            }
            std::println!(
                "probes {probe_factor}, window {window} s, hysteresis {hysteresis}, {steps} \
                 steps: widest spread {worst:.3} windowed sd, farthest from the truth \
                 {far:.2} sd; {flagged} of {runs} runs flagged{}",
                if probe_factor <= 1.0 {
                    std::format!(
                        "; sigma 10x on 7 seeds: {} flagged, {} converged, {} neither",
                        ridge[0],
                        ridge[1],
                        ridge[2]
                    )
                } else {
                    std::string::String::new()
                }
            );
        }
    }
}
