//! Unit tests of the decision rule ([`super::newton`]) on exact quadratic log-likelihoods.

use super::coords::{coordinates, Coordinate, MAX_PARAMS};
use super::newton::{pairs, settled_off_centre, step, Marks, Quad};
use super::OnlineConfig;
use crate::model::{Component, GaussMarkov, WhiteNoise};
use crate::nav::ImuErrorModel;

/// One Gauss-Markov gyro component: coordinates sigma (0) and tau (1), one pair.
fn gm_model() -> ImuErrorModel<f64> {
    let mut m = ImuErrorModel::default();
    m.set_all_gyro(&[Component::GaussMarkov(GaussMarkov {
        sigma: 1e-4,
        tau: 600.0,
    })])
    .unwrap_or_else(|e| panic!("{e:?}"));
    m
}

/// The shadows' sums of `L(y) = -1/2 (y - top)^T H (y - top)` about `x = 0` with offset `d`:
/// `+d, -d` on each coordinate, the centre, then each pair at `(+d, +d)`.
fn sums(h: [[f64; 2]; 2], top: [f64; 2], d: f64) -> [f64; 6] {
    let l = |y: [f64; 2]| {
        let e = [y[0] - top[0], y[1] - top[1]];
        -0.5 * (e[0] * (h[0][0] * e[0] + h[0][1] * e[1]) + e[1] * (h[1][0] * e[0] + h[1][1] * e[1]))
    };
    [
        l([d, 0.0]),
        l([-d, 0.0]),
        l([0.0, d]),
        l([0.0, -d]),
        l([0.0, 0.0]),
        l([d, d]),
    ]
}

#[test]
fn a_coupled_pair_moves_to_the_vertex_of_an_exact_quadratic() {
    let m = gm_model();
    let c = coordinates(&m, false, true).unwrap_or_else(|e| panic!("{e:?}"));
    let pr = pairs(&c);
    assert_eq!((c.len(), pr.len()), (2, 1));
    // sigma and tau strongly coupled (correlation 0.9): each coordinate alone would move to
    // its conditional vertex, and together they would overshoot.
    let h = [[400.0, 360.0], [360.0, 400.0]];
    let top = [0.3, -0.2];
    let s = sums(h, top, 0.5);
    let mut m = Marks::NONE;
    let q = Quad::from_sums(0.5, 2, &pr, &s);
    let out = step(
        &OnlineConfig::DEFAULT,
        2,
        &c,
        &pr,
        &q,
        &[0.0; MAX_PARAMS],
        &mut m,
    );
    let sd = m.cr_sd;
    for i in 0..2 {
        assert!((out[i] - top[i]).abs() < 1e-9, "{out:?} against {top:?}");
    }
    // The Cramér-Rao sds reported are the coordinates' own parabolas', 1/sqrt(H_ii)...
    assert!((sd[0] - 0.05).abs() < 1e-12, "{sd:?}");
    // ... and with `hold_flat_taus` the marginal ones, sqrt((H^-1)_ii).
    let hold = OnlineConfig {
        hold_flat_taus: true,
        ..OnlineConfig::DEFAULT
    };
    let _ = step(&hold, 2, &c, &pr, &q, &[0.0; MAX_PARAMS], &mut m);
    let sd = m.cr_sd;
    assert!(
        (sd[0] - (400.0f64 / 30_400.0).sqrt()).abs() < 1e-12,
        "{sd:?}"
    );
}

/// Along a ridge (correlation 0.995) the tau's marginal Cramér-Rao sd exceeds
/// `IDENTIFIABLE_SD`: with `hold_flat_taus` the tau is held and flagged, and the sigma takes
/// its own parabola's step, `g_0 / H_00`, where the joint Newton step runs along the ridge.
#[test]
fn with_the_option_a_tau_the_data_do_not_bound_is_held() {
    let c = coordinates(&gm_model(), false, true).unwrap_or_else(|e| panic!("{e:?}"));
    let pr = pairs(&c);
    let h = [[400.0, 398.0], [398.0, 400.0]];
    let top = [0.3, 0.3];
    let q = Quad::from_sums(0.5, 2, &pr, &sums(h, top, 0.5));
    let mut m = Marks::NONE;
    // Without the exit test (`exit_z`): the sigma's own step, 0.6, is beyond the edge by
    // less than 2 of its marginal sds (0.5), so with the test it would stop at the edge.
    let hold = OnlineConfig {
        hold_flat_taus: true,
        exit_z: 0.0,
        ..OnlineConfig::DEFAULT
    };
    let out = step(&hold, 2, &c, &pr, &q, &[0.0; MAX_PARAMS], &mut m);
    let sd = m.cr_sd;
    let g0 = h[0][0] * top[0] + h[0][1] * top[1];
    assert!((out[0] - g0 / h[0][0]).abs() < 1e-9, "{out:?}");
    assert_eq!(out[1], 0.0, "the tau moved: {out:?}");
    assert!(sd[1] > super::IDENTIFIABLE_SD, "{sd:?}");
    // Without the option the pair takes its joint Newton step (to the vertex, within 2d).
    let cfg = OnlineConfig {
        exit_z: 0.0,
        ..OnlineConfig::DEFAULT
    };
    let out = step(&cfg, 2, &c, &pr, &q, &[0.0; MAX_PARAMS], &mut m);
    assert!((out[0] - top[0]).abs() < 1e-9, "{out:?}");
    assert!((out[1] - top[1]).abs() < 1e-9, "{out:?}");
}

#[test]
fn a_flat_likelihood_holds_and_a_bound_clamps() {
    let m = gm_model();
    let c = coordinates(&m, false, true).unwrap_or_else(|e| panic!("{e:?}"));
    let pr = pairs(&c);
    let cfg = OnlineConfig::DEFAULT;
    // A maximum 0.4 decade away along a likelihood this flat gains under 1 nat: held.
    let flat = sums([[2.0, 0.0], [0.0, 2.0]], [0.4, 0.0], 0.5);
    let mut m = Marks::NONE;
    let q = Quad::from_sums(0.5, 2, &pr, &flat);
    let out = step(&cfg, 2, &c, &pr, &q, &[0.0; MAX_PARAMS], &mut m);
    assert_eq!(&out[..2], &[0.0, 0.0]);
    // A steep one far away: the step is at most 2d, and stops at the bound.
    let steep = sums([[100.0, 0.0], [0.0, 100.0]], [5.0, 0.0], 0.5);
    let q = Quad::from_sums(0.5, 2, &pr, &steep);
    let mut x = [0.0; MAX_PARAMS];
    let out = step(&cfg, 2, &c, &pr, &q, &x, &mut m);
    assert!((out[0] - 1.0).abs() < 1e-12, "{out:?}");
    x[0] = 1.6;
    let out = step(&cfg, 2, &c, &pr, &q, &x, &mut m);
    assert!((out[0] - 0.4).abs() < 1e-12, "{out:?}");
}

/// A navigator at rest with a white noise and a Gauss-Markov on every gyro axis.
fn navigator() -> crate::nav::Navigator<f64, 24> {
    use crate::model::WhiteNoise;
    let mut imu = gm_model();
    imu.set_all_gyro(&[
        Component::White(WhiteNoise { density: 1e-4 }),
        Component::GaussMarkov(GaussMarkov {
            sigma: 1e-4,
            tau: 600.0,
        }),
    ])
    .unwrap_or_else(|e| panic!("{e:?}"));
    crate::nav::navigator::tests::navigator_with(
        imu,
        crate::strapdown::Quat::identity(),
        nalgebra::Vector3::zeros(),
    )
}

/// On [`navigator`]'s bank: non-finite times decide nothing (and return: no loop over an
/// infinite gap), the bank has `2p + 1 + q` shadows, and a bad configuration is refused.
#[test]
fn a_bank_refuses_bad_settings_and_non_finite_times() {
    use super::OnlineIdent;
    use crate::model::ModelError;
    let nav = navigator();
    let mut id = OnlineIdent::<f64, 24, 8>::new(OnlineConfig::DEFAULT, &nav, 0.0)
        .unwrap_or_else(|e| panic!("{e:?}"));
    // Three coordinates (density, sigma, tau), one pair: 2 * 3 + 1 + 1 shadows.
    assert_eq!((id.coordinates().len(), id.window_sums().len()), (3, 8));
    assert!(id.decide(f64::NAN).is_none());
    assert!(id.decide(f64::INFINITY).is_none());
    // Before any fix, a due decision does nothing either.
    assert!(id.decide(1e9).is_none());
    assert_eq!(id.decisions(), 0);
    let too_small = OnlineIdent::<f64, 24, 7>::new(OnlineConfig::DEFAULT, &nav, 0.0);
    assert_eq!(too_small.err(), Some(ModelError::TooManyStates));
    let bad = OnlineConfig {
        min_offset: 1.0,
        ..OnlineConfig::DEFAULT
    };
    assert_eq!(
        OnlineIdent::<f64, 24, 8>::new(bad, &nav, 0.0).err(),
        Some(ModelError::BadSigma)
    );
    for exit_z in [-1.0, f64::NAN, f64::INFINITY] {
        let bad = OnlineConfig {
            exit_z,
            ..OnlineConfig::DEFAULT
        };
        assert_eq!(
            OnlineIdent::<f64, 24, 8>::new(bad, &nav, 0.0).err(),
            Some(ModelError::BadSigma)
        );
    }
}

/// The grid rule on [`navigator`]'s bank (coordinates density, sigma, tau; shadows `+d, -d`
/// on each, the centre, the pair at `(+d, +d)`), with sums of an exact quadratic written in:
/// an estimate inside the grid moves the running point and keeps the shadows and their sums;
/// one outside moves the shadows there and restarts the sums.
#[test]
fn an_estimate_inside_the_grid_keeps_the_window_and_one_outside_moves_it() {
    use super::OnlineIdent;
    let nav = navigator();
    // The estimate itself as the running model: a decision hands over a model only when the
    // estimate moved. Without the exit test (`exit_z`) until the end.
    let cfg = OnlineConfig {
        conservative: false,
        exit_z: 0.0,
        ..OnlineConfig::DEFAULT
    };
    let mut id = OnlineIdent::<f64, 24, 8>::new(cfg, &nav, 0.0).unwrap_or_else(|e| panic!("{e:?}"));
    let d = id.d;
    // L(y) = -w |y - top|^2 at each shadow's offset from the centre (curvature 2 w,
    // Cramér-Rao sd 1 / sqrt(2 w)); `fill` takes w = 50.
    let fill_w = |id: &mut OnlineIdent<f64, 24, 8>, top: [f64; 3], w: f64| {
        let l = |y: [f64; 3]| -w * (0..3).map(|i| (y[i] - top[i]).powi(2)).sum::<f64>();
        let at = [
            [d, 0.0, 0.0],
            [-d, 0.0, 0.0],
            [0.0, d, 0.0],
            [0.0, -d, 0.0],
            [0.0, 0.0, d],
            [0.0, 0.0, -d],
            [0.0; 3],
            [0.0, d, d],
        ];
        for (s, y) in id.sums.iter_mut().zip(at) {
            *s = l(y);
        }
        id.fixes = 100;
    };
    let fill = |id: &mut OnlineIdent<f64, 24, 8>, top: [f64; 3]| fill_w(id, top, 50.0);
    let top = [0.3, -0.2, 0.1];
    fill(&mut id, top);
    let before = id.window_sums().to_vec();
    assert!(id.decide(600.0).is_some(), "the running model moves");
    for (e, t) in id.log10_factors().iter().zip(top) {
        assert!((e - t).abs() < 1e-9, "estimate {e} against the vertex {t}");
    }
    assert_eq!(id.centre(), [0.0; 3], "the shadows stay");
    assert_eq!(
        id.window_sums(),
        before.as_slice(),
        "the sums keep accumulating"
    );
    assert_eq!((id.window_start(), id.fixes()), (0.0, 100));
    // The same data again: the estimate does not move, nothing to hand over.
    assert!(id.decide(1800.0).is_none());
    // A vertex beyond the grid: a step of 2d, the shadows move, the sums restart.
    fill(&mut id, [1.2, 0.0, 0.0]);
    assert!(id.decide(3000.0).is_some());
    assert_eq!(id.centre(), [2.0 * d, 0.0, 0.0]);
    assert_eq!(id.log10_factors(), id.centre());
    assert!(id.window_sums().iter().all(|s| *s == 0.0));
    assert_eq!((id.window_start(), id.fixes()), (3000.0, 0));

    // With the exit test, sd 0.2 decade (curvature 25): a vertex 0.3 beyond the edge (under
    // 2 sd) stops at the edge and keeps the window (2 sd = 0.4 is not under d / 2: not
    // settled). With sd 0.1 (curvature 100) the same vertex leaves the grid; and a vertex
    // 0.3 inside the edge, settled (2 sd = 0.2 < d / 2), is measured again about itself at
    // half the offset.
    let cfg = OnlineConfig { exit_z: 2.0, ..cfg };
    let mut id = OnlineIdent::<f64, 24, 8>::new(cfg, &nav, 0.0).unwrap_or_else(|e| panic!("{e:?}"));
    fill_w(&mut id, [d + 0.3, 0.0, 0.0], 12.5);
    assert!(id.decide(600.0).is_some());
    assert_eq!(id.log10_factors(), [d, 0.0, 0.0]);
    assert_eq!(id.centre(), [0.0; 3], "the shadows stay");
    assert_eq!(id.fixes(), 100, "the sums keep accumulating");
    let mut out = id.clone();
    fill(&mut out, [d + 0.3, 0.0, 0.0]);
    assert!(out.decide(1200.0).is_some());
    assert!(
        (out.centre()[0] - (d + 0.3)).abs() < 1e-12,
        "it leaves: {:?}",
        out.centre()
    );
    fill(&mut id, [0.3, 0.0, 0.0]);
    assert!(id.decide(1200.0).is_some());
    assert_eq!(id.centre(), [0.3, 0.0, 0.0]);
    assert_eq!(id.log10_factors(), id.centre());
    assert!(id.window_sums().iter().all(|s| *s == 0.0));
    assert_eq!(id.d, 0.5 * d);
}

/// The shadows that differ from the centre in an intensity share its discretisation
/// (`shared.rs`): `Phi` and `Qd0 + alpha Qd(B)` give the same prediction as each shadow's
/// own full discretisation, to rounding; a correlation time's shadows (another `A`) are not
/// shared. Model: gyro white + Gauss-Markov, accelerometer white + random walk (a `q`
/// coordinate, linear in `Qc` rather than quadratic) + random constant (states without noise).
#[test]
fn shadows_that_differ_in_an_intensity_share_the_centres_discretisation() {
    use super::shared::Centre;
    use super::OnlineIdent;
    use crate::model::{RandomConstant, RandomWalk, WhiteNoise};
    use crate::nav::navigator::NavObserver;
    let mut imu = navigator().model().imu.clone();
    imu.set_all_accel(&[
        Component::White(WhiteNoise { density: 1e-3 }),
        Component::RandomWalk(RandomWalk {
            q: 1e-9,
            sigma0: 1e-3,
        }),
        Component::RandomConstant(RandomConstant { sigma: 1e-2 }),
    ])
    .unwrap_or_else(|e| panic!("{e:?}"));
    let nav = crate::nav::navigator::tests::navigator_with::<24>(
        imu,
        crate::strapdown::Quat::identity(),
        nalgebra::Vector3::zeros(),
    );
    let id = OnlineIdent::<f64, 24, 16>::new(OnlineConfig::DEFAULT, &nav, 0.0)
        .unwrap_or_else(|e| panic!("{e:?}"));
    let p = id.coords.len();
    // Coordinates: gyro density, sigma, tau; accelerometer density, q (a random constant's
    // sigma is not identified online); one pair.
    assert_eq!((p, id.shadows.len()), (5, 12), "{:?}", id.coords);
    // A turning step: the navigation block of A is not trivial.
    let mut model = nav.model().clone();
    model.point.mean_w_b = nalgebra::Vector3::new(0.01, -0.02, 0.3);
    let mut scale = [1.0; 24];
    for (i, s) in scale.iter_mut().enumerate() {
        *s = 10f64.powi(-(i as i32 % 5));
    }
    let x: [f64; 24] = core::array::from_fn(|i| 1e-3 * (i as f64 - 7.0));
    let p0 = nav.kalman().P;
    // Shared (the observer hook) against every shadow in full.
    let mut shared = id.clone();
    shared.propagated(&model, &scale, &x, &p0);
    let mut full = id.clone();
    for sh in full.shadows.iter_mut() {
        sh.propagate(&model, &scale, &x, &p0)
            .unwrap_or_else(|e| panic!("{e:?}"));
    }
    assert_eq!(shared.faults(), 0);
    for (k, (a, b)) in shared.shadows.iter().zip(full.shadows.iter()).enumerate() {
        let big = b.kf.P.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff =
            a.kf.P
                .iter()
                .flatten()
                .zip(b.kf.P.iter().flatten())
                .fold(0.0f64, |m, (u, v)| m.max((u - v).abs()));
        assert!(
            diff <= 1e-12 * big,
            "shadow {k}: P differs by {diff:e} of {big:e}"
        );
        assert_eq!(a.kf.x, b.kf.x, "shadow {k}: x");
    }
    // Which coordinates shared: every intensity, no correlation time.
    let mut bank = id.clone();
    let (coords, rest) = bank.shadows.split_at_mut(2 * p);
    let c = Centre::propagate(&mut rest[0], &model, &scale, &x, &p0).expect("the centre");
    for (i, two) in coords.chunks_exact_mut(2).enumerate() {
        let [plus, minus] = two else { unreachable!() };
        let is_tau = id.coords[i].quantity == crate::model::Quantity::Tau;
        let got = c.shared_qd(plus, minus, &model, &scale).is_some();
        assert_eq!(got, !is_tau, "coordinate {i}: {:?}", id.coords[i]);
    }
}

/// A factor on the fixes' variances moves by the variance-scale model (`newton.rs`): on that
/// model's own log-likelihood, `-n/2 (2 a u + K exp(-2 a u))`, the shadows at `+-d` give back
/// its maximum `ln K / (2 a)` (at most `2 d` away) and its Cramér-Rao sd `1 / (a sqrt(2 n))`
/// to rounding, also at a half-decade offset where a parabola's vertex is 0.1 decade off; data
/// unlike the model
/// (a likelihood falling on both sides but convex) fall back to the parabola.
#[test]
fn a_variance_factor_moves_to_the_maximum_of_its_model() {
    use super::newton::variance_scale;
    let a = core::f64::consts::LN_10;
    let (n, top) = (1800.0, -0.45);
    let k = libm::exp(2.0 * a * top);
    let l = |u: f64| -0.5 * n * (2.0 * a * u + k * libm::exp(-2.0 * a * u));
    for d in [0.5, 0.25, 0.0625] {
        let (p, m, c) = (l(d), l(-d), l(0.0));
        let (g, cv) = ((p - m) / (2.0 * d), -(p + m - 2.0 * c) / (d * d));
        let (s, gain, sd) = variance_scale(g, cv, d).unwrap_or_else(|| panic!("d {d}"));
        // At most 2d, as any coordinate's step.
        let want = top.max(-2.0 * d).min(2.0 * d);
        assert!((s - want).abs() < 1e-9, "d {d}: {s} against {want}");
        assert!(
            (gain - (l(want) - c)).abs() < 1e-6 * gain.abs(),
            "d {d}: gain {gain}"
        );
        assert!(
            (sd - 1.0 / (a * (2.0 * n).sqrt())).abs() < 1e-12,
            "d {d}: sd {sd}"
        );
        if d == 0.5 {
            assert!(
                (g / cv - top).abs() > 0.1,
                "the parabola's vertex {}",
                g / cv
            );
        }
    }
    // Sums that rise on both sides of the centre: no variance scale fits.
    assert!(variance_scale(0.0, -10.0, 0.25).is_none());
}

/// White noise on the gyros and on the accelerometers: two intensity coordinates, no pair.
fn two_white() -> ImuErrorModel<f64> {
    let mut m = ImuErrorModel::default();
    let white = |density| [Component::White(WhiteNoise { density })];
    m.set_all_gyro(&white(1e-3))
        .unwrap_or_else(|e| panic!("{e:?}"));
    m.set_all_accel(&white(1e-2))
        .unwrap_or_else(|e| panic!("{e:?}"));
    m
}

/// `OnlineConfig::flat_waits`: coordinate 0 has an exact parabola with its vertex at `top`
/// (curvature 100 nats/decade^2); coordinate 1 rises linearly, 40 nats/decade, and is slightly
/// convex, so it is not bounded and would step `2 d` up its slope. It waits while coordinate
/// 0 leaves the grid (`top` beyond `d`), and steps when coordinate 0 settles inside it.
#[test]
fn a_flat_coordinate_waits_while_a_bounded_one_leaves_the_grid() {
    let c = coordinates(&two_white(), false, true).unwrap_or_else(|e| panic!("{e:?}"));
    assert_eq!((c.len(), pairs(&c).len()), (2, 0));
    let d = 0.5;
    let sums = |top: f64| {
        let bounded = |y: f64| -50.0 * (y - top) * (y - top) + 50.0 * top * top;
        let flat = |y: f64| 40.0 * y + 2.0 * y * y;
        [bounded(d), bounded(-d), flat(d), flat(-d), 0.0]
    };
    let run = |cfg: &OnlineConfig, top: f64| {
        let q = Quad::from_sums(d, 2, &[], &sums(top));
        let mut m = Marks::NONE;
        let out = step(cfg, 2, &c, &[], &q, &[0.0; MAX_PARAMS], &mut m);
        let sd = m.cr_sd;
        // The flat coordinate is flagged either way: not concave, no Cramér-Rao interval.
        assert!(sd[1].is_infinite() && (sd[0] - 0.1).abs() < 1e-12, "{sd:?}");
        [out[0], out[1]]
    };
    let on = OnlineConfig::DEFAULT;
    assert!(on.flat_waits);
    let off = OnlineConfig {
        flat_waits: false,
        ..on
    };
    // The bounded coordinate leaves the grid (0.8 > d): the flat one waits with the rule.
    let [s0, s1] = run(&on, 0.8);
    assert!((s0 - 0.8).abs() < 1e-9 && s1 == 0.0, "{s0} {s1}");
    let [s0, s1] = run(&off, 0.8);
    assert!(
        (s0 - 0.8).abs() < 1e-9 && (s1 - 2.0 * d).abs() < 1e-12,
        "{s0} {s1}"
    );
    // It settles inside the grid (0.3 <= d): the flat one steps `2 d` up its slope either way.
    for cfg in [&on, &off] {
        let [s0, s1] = run(cfg, 0.3);
        assert!(
            (s0 - 0.3).abs() < 1e-9 && (s1 - 2.0 * d).abs() < 1e-12,
            "{s0} {s1}"
        );
    }
}

/// A flat coordinate (coordinate 1: `a y + y^2`, convex) steps `2 d` up its slope only when
/// its shadow on that side measured `FLAT_EVIDENCE` (1.92 nats) over the centre. At `a = 2` the
/// shadow at `+d` measured 1.25 nats: held, although the parabola's promise at `2 d`
/// (`2 g d - 2 c d^2` = 3 nats) passes `min_gain`. At `a = 4` it measured 2.25: it steps.
#[test]
fn a_flat_coordinate_moves_only_on_what_its_shadow_measured() {
    let c = coordinates(&two_white(), false, true).unwrap_or_else(|e| panic!("{e:?}"));
    let d = 0.5;
    let run = |a: f64| {
        let flat = |y: f64| a * y + y * y;
        let q = Quad::from_sums(d, 2, &[], &[0.0, 0.0, flat(d), flat(-d), 0.0]);
        let mut m = Marks::NONE;
        let out = default_step(&c, &q, &mut m);
        let sd = m.cr_sd;
        assert!(sd[1].is_infinite(), "{sd:?}");
        out
    };
    assert_eq!(run(2.0), [0.0, 0.0]);
    assert_eq!(run(-2.0), [0.0, 0.0]);
    let [s0, s1] = run(4.0);
    assert!(s0 == 0.0 && (s1 - 2.0 * d).abs() < 1e-12, "{s0} {s1}");
    // Down the slope alike: the shadow at `-d` measured `-a d + d^2` = 2.25 nats.
    let [s0, s1] = run(-4.0);
    assert!(s0 == 0.0 && (s1 + 2.0 * d).abs() < 1e-12, "{s0} {s1}");
}

/// After a bounded coordinate left the grid, a flat coordinate needs `AFTER_A_LEAVE` (3.84
/// nats) at the next decision: coordinate 0 is an exact parabola of curvature 100
/// nats/decade^2 with its vertex at `top`, coordinate 1 the flat `a y + y^2` of the test
/// above. At the first decision coordinate 0 leaves (`top` = 0.8, 3 sds past the edge), which
/// the marks record, and the flat one waits (`flat_waits`). At the next, with coordinate 0
/// settled (`top` = 0), the flat one measured 2.25 nats (`a = 4`): under the test, it stays;
/// with 4.25 (`a = 8`) it steps. That decision, at which nothing left, clears the record,
/// and at the one after 2.25 nats suffice again.
#[test]
fn a_flat_coordinate_needs_more_evidence_on_the_window_after_a_leave() {
    let c = coordinates(&two_white(), false, true).unwrap_or_else(|e| panic!("{e:?}"));
    let d = 0.5;
    let run = |top: f64, a: f64, m: &mut Marks| {
        let bounded = |y: f64| -50.0 * (y - top) * (y - top) + 50.0 * top * top;
        let flat = |y: f64| a * y + y * y;
        let sums = [bounded(d), bounded(-d), flat(d), flat(-d), 0.0];
        default_step(&c, &Quad::from_sums(d, 2, &[], &sums), m)
    };
    let near = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9;
    for (a, steps) in [(4.0, false), (8.0, true)] {
        let mut m = Marks::NONE;
        let out = run(0.8, a, &mut m);
        assert!(near(out, [0.8, 0.0]) && m.left, "{out:?}");
        let out = run(0.0, a, &mut m);
        let s1 = if steps { 2.0 * d } else { 0.0 };
        assert!(near(out, [0.0, s1]) && !m.left, "{a}: {out:?}");
        // Nothing left at that decision: the ordinary test (1.92 nats) at the next.
        let out = run(0.0, a, &mut m);
        assert!(near(out, [0.0, 2.0 * d]) && !m.left, "{a}: {out:?}");
    }
}

/// `step` with the default configuration on two coordinates at the centre, no pairs: the two
/// steps.
fn default_step(c: &[Coordinate], q: &Quad, m: &mut Marks) -> [f64; 2] {
    let out = step(&OnlineConfig::DEFAULT, 2, c, &[], q, &[0.0; MAX_PARAMS], m);
    [out[0], out[1]]
}

/// `OnlineConfig::exit_z`: coordinate 0 has an exact parabola of curvature 100 nats/decade^2
/// (Cramér-Rao sd 0.1 decade) with its vertex at `top`; the grid's offset is `d = 0.5`. With
/// `exit_z = 2` it leaves the grid only when `top` is beyond the edge by 2 sd (0.2 decade):
/// at 0.8 it does, at 0.6 and -0.6 it stops at the edge, which keeps the window. The flat
/// coordinate 1 then does not wait (nothing leaves the grid). Without the test every vertex
/// beyond the edge is taken.
#[test]
fn a_bounded_coordinate_leaves_the_grid_only_when_its_vertex_is_significantly_beyond() {
    let c = coordinates(&two_white(), false, true).unwrap_or_else(|e| panic!("{e:?}"));
    let d = 0.5;
    let run = |cfg: &OnlineConfig, top: f64| {
        let bounded = |y: f64| -50.0 * (y - top) * (y - top) + 50.0 * top * top;
        let flat = |y: f64| 40.0 * y + 2.0 * y * y;
        let sums = [bounded(d), bounded(-d), flat(d), flat(-d), 0.0];
        let q = Quad::from_sums(d, 2, &[], &sums);
        let mut m = Marks::NONE;
        let out = step(cfg, 2, &c, &[], &q, &[0.0; MAX_PARAMS], &mut m);
        let sd = m.cr_sd;
        assert!((sd[0] - 0.1).abs() < 1e-12, "{sd:?}");
        [out[0], out[1]]
    };
    let test = OnlineConfig {
        exit_z: 2.0,
        ..OnlineConfig::DEFAULT
    };
    let none = OnlineConfig {
        exit_z: 0.0,
        ..test
    };
    let [s0, s1] = run(&test, 0.8);
    assert!((s0 - 0.8).abs() < 1e-9 && s1 == 0.0, "{s0} {s1}");
    for top in [0.6, -0.6] {
        let [s0, s1] = run(&test, top);
        assert!(
            (s0 - d * top.signum()).abs() < 1e-12 && (s1 - 2.0 * d).abs() < 1e-12,
            "{top}: {s0} {s1}"
        );
        let [s0, s1] = run(&none, top);
        assert!((s0 - top).abs() < 1e-9 && s1 == 0.0, "{top}: {s0} {s1}");
    }
}

/// `OnlineConfig::exit_z`, a vertex far past the edge: coordinate 0's exact parabola has a
/// curvature of 11.1 nats/decade^2 (Cramér-Rao sd 0.3 decade) and `d = 0.5`. With its vertex at
/// 2.0, the step limited to `2 d` is 0.5 past the edge, under 2 sd: it stops at the edge, but
/// the vertex is 1.5 past it, 5 sd, so the coordinate is pressed; pressed at the next decision
/// again, the limited step leaves the grid. A vertex at 0.9 (0.4 past the edge, under 2 sd) is
/// not pressed and stays at the edge.
#[test]
fn a_coordinate_pressed_on_the_edge_at_two_decisions_leaves_the_grid() {
    let c = coordinates(&two_white(), false, true).unwrap_or_else(|e| panic!("{e:?}"));
    let d = 0.5;
    let curv = 1.0 / 0.09;
    let run = |top: f64, pressed: &mut [bool; MAX_PARAMS]| {
        let bounded = |y: f64| -0.5 * curv * ((y - top) * (y - top) - top * top);
        let flat = |y: f64| 40.0 * y + 2.0 * y * y;
        let sums = [bounded(d), bounded(-d), flat(d), flat(-d), 0.0];
        let q = Quad::from_sums(d, 2, &[], &sums);
        let mut m = Marks {
            pressed: *pressed,
            ..Marks::NONE
        };
        let out = default_step(&c, &q, &mut m);
        *pressed = m.pressed;
        let sd = m.cr_sd;
        assert!((sd[0] - 0.3).abs() < 1e-12, "{sd:?}");
        out
    };
    let mut pressed = [false; MAX_PARAMS];
    // First decision: at the edge, pressed; the flat coordinate steps (nothing leaves).
    let [s0, s1] = run(2.0, &mut pressed);
    assert!(s0 == d && (s1 - 2.0 * d).abs() < 1e-12, "{s0} {s1}");
    assert!(pressed[0] && !pressed[1]);
    // Second: it leaves by `2 d`, and the flat coordinate waits.
    let [s0, s1] = run(2.0, &mut pressed);
    assert!((s0 - 2.0 * d).abs() < 1e-12 && s1 == 0.0, "{s0} {s1}");
    // Not pressed: the edge at every decision.
    let mut pressed = [false; MAX_PARAMS];
    for _ in 0..3 {
        let [s0, _] = run(0.9, &mut pressed);
        assert!(s0 == d && !pressed[0], "{s0} {pressed:?}");
    }
    // Pressed once, then not: the record clears.
    let mut pressed = [false; MAX_PARAMS];
    let _ = run(2.0, &mut pressed);
    let _ = run(0.9, &mut pressed);
    let [s0, _] = run(2.0, &mut pressed);
    assert!(s0 == d && pressed[0], "{s0}");
}

/// `OnlineConfig::exit_z`: an estimate inside the grid is measured again about itself (half
/// the offset) when it has settled more than `d / 2` off the centre on a coordinate whose sd,
/// times `exit_z`, is under `d / 2`; not when it is near the centre, not when that sd is
/// large, not at the smallest offset and not without the test.
#[test]
fn an_estimate_settled_off_the_centre_is_measured_again_about_itself() {
    let cfg = OnlineConfig {
        exit_z: 2.0,
        ..OnlineConfig::DEFAULT
    };
    let (d, x) = (0.5, [0.0; MAX_PARAMS]);
    let mut est = [0.0; MAX_PARAMS];
    let mut sd = [f64::INFINITY; MAX_PARAMS];
    est[1] = 0.3;
    sd[1] = 0.1;
    assert!(settled_off_centre(&cfg, d, 2, &est, &x, &sd));
    // Only the leading p coordinates count.
    assert!(!settled_off_centre(&cfg, d, 1, &est, &x, &sd));
    // Near the centre (0.2 <= d / 2), or an sd too large (2 x 0.13 > d / 2): it stays.
    est[1] = 0.2;
    assert!(!settled_off_centre(&cfg, d, 2, &est, &x, &sd));
    est[1] = -0.3;
    sd[1] = 0.13;
    assert!(!settled_off_centre(&cfg, d, 2, &est, &x, &sd));
    sd[1] = 0.1;
    assert!(settled_off_centre(&cfg, d, 2, &est, &x, &sd));
    assert!(!settled_off_centre(&cfg, cfg.min_offset, 2, &est, &x, &sd));
    let none = OnlineConfig { exit_z: 0.0, ..cfg };
    assert!(!settled_off_centre(&none, d, 2, &est, &x, &sd));
}

/// A pair's Newton step with one quantity stopped at the edge (`exit_z`): the other takes the
/// quadratic's maximum given it, not its share of the joint step. Exact quadratic with
/// `H = [[400, 360], [360, 400]]` and vertex `(0.2, 0.6)`, offset `d = 0.5`: the tau's step
/// 0.6 is beyond the edge by 0.1, under 2 marginal sds (`2 sqrt(400 / 30 400)` = 0.23), so
/// it stops at 0.5; the sigma's maximum given tau = 0.5 is
/// `0.2 + 360 (0.6 - 0.5) / 400` = 0.29 (its share of the joint step was 0.2). That move is
/// the sigma's own, so its exit test takes its conditional sd, `1 / sqrt(H_00)`.
#[test]
fn a_pair_with_one_quantity_at_the_edge_moves_the_other_to_its_maximum_given_that_one() {
    let c = coordinates(&gm_model(), false, true).unwrap_or_else(|e| panic!("{e:?}"));
    let pr = pairs(&c);
    let (h, d) = ([[400.0, 360.0], [360.0, 400.0]], 0.5);
    // The step from the exact quadratic with its vertex at `top`.
    let decide = |cfg: &OnlineConfig, top: [f64; 2]| {
        let q = Quad::from_sums(d, 2, &pr, &sums(h, top, d));
        let mut m = Marks::NONE;
        let out = step(cfg, 2, &c, &pr, &q, &[0.0; MAX_PARAMS], &mut m);
        [out[0], out[1]]
    };
    let near = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9;
    let cfg = OnlineConfig::DEFAULT;
    let out = decide(&cfg, [0.2, 0.6]);
    assert!(near(out, [0.29, d]), "{out:?}");
    // Given the tau at the edge, the sigma's move is along its own coordinate, whose
    // Cramér-Rao sd is its conditional one, `1 / sqrt(400)` = 0.05 (its marginal one is
    // 0.115). Vertex `(0.45, 0.7)`: the tau stops at 0.5 (beyond by 0.2, under 0.23); the
    // sigma's maximum given it, `0.45 + 0.9 (0.7 - 0.5)` = 0.63, is beyond the edge by 0.13,
    // over 2 conditional sds: it leaves the grid.
    let out = decide(&cfg, [0.45, 0.7]);
    assert!(near(out, [0.63, d]), "{out:?}");
    // A partner whose share the bound cut to nothing moves too. Sigma at the bound
    // (`x_0` = 2) with `H_01` = -360 and vertex `(0.05, 0.7)`: its share, 0.05, is cut to 0;
    // the tau stops at 0.5; the sigma's maximum given it is `0.05 - 0.9 (0.7 - 0.5)` = -0.13.
    let hn = [[400.0, -360.0], [-360.0, 400.0]];
    let q = Quad::from_sums(d, 2, &pr, &sums(hn, [0.05, 0.7], d));
    let mut x = [0.0; MAX_PARAMS];
    x[0] = cfg.bound;
    let mut m = Marks::NONE;
    let out = step(&cfg, 2, &c, &pr, &q, &x, &mut m);
    assert!(near([out[0], out[1]], [-0.13, d]), "{out:?}");
    // Without the exit test both reach the vertex.
    let none = OnlineConfig { exit_z: 0.0, ..cfg };
    let out = decide(&none, [0.2, 0.6]);
    assert!(near(out, [0.2, 0.6]), "{out:?}");
    // A vertex beyond the edge by more than 2 sds leaves: the joint step stands.
    let out = decide(&cfg, [0.2, 0.9]);
    assert!(near(out, [0.2, 0.9]), "{out:?}");
}
