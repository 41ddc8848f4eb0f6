//! Unit tests of the window search's bookkeeping: the schedule while the window fills and the
//! diverse list of points to polish. The searches themselves are tested end to end in
//! `adapt::tests` and hal-sim's `global` tests.

use super::{WindowConfig, WindowSearch, CROWD, MAXP, TOP};
use crate::adapt::params::specs;
use crate::model::InsModel;

/// The `paper` model, its identified parameters, its point, and bounds that hold anything.
fn paper_at_truth() -> (
    InsModel<f64>,
    crate::adapt::params::Specs,
    [f64; MAXP],
    crate::adapt::guard::Bounds<f64>,
) {
    let base = InsModel::<f64>::paper();
    let s = specs(&base);
    let theta = crate::adapt::params::theta_of(&base, &s);
    let wide = crate::adapt::guard::Bounds {
        lo: [-1e9; MAXP],
        hi: [1e9; MAXP],
    };
    (base, s, theta, wide)
}

fn search(cfg: WindowConfig<f64>) -> WindowSearch<f64> {
    let mut w = WindowSearch::BLANK;
    w.init(cfg, &[0.0; MAXP]);
    w
}

/// While the window fills, searches come every `filling_every` blocks, and one is due when the
/// window first fills; then every `every`. After a change found, the windows since it double
/// as before, whatever `filling_every`.
#[test]
fn searches_come_sooner_while_the_window_fills() {
    let cfg = WindowConfig::<f64>::default_on();
    assert_eq!((cfg.first, cfg.every, cfg.window), (240, 240, 480));
    assert_eq!(cfg.filling_every, super::FILLING_EVERY);
    let mut w = search(cfg);
    let a = [0.0; MAXP];
    let next_after = |w: &mut WindowSearch<f64>, pushed: u32| {
        w.pushed = pushed;
        w.start(&a);
        w.phase = super::Phase::Idle;
        w.next_search
    };
    // (blocks pushed when a search starts, the next search's due block, why)
    let schedule = [
        (240, 360, "the 4-h search: the next 2 h later"),
        (300, 420, "2 h later, 1 h before the window fills"),
        (400, 480, "due when the window first fills"),
        (
            342,
            480,
            "not 462: a search then would still run when the window fills",
        ),
        (480, 720, "then the usual pace"),
    ];
    for (pushed, next, why) in schedule {
        assert_eq!(next_after(&mut w, pushed), next, "{why}");
    }
    // Off: the usual pace from the first search on.
    let mut off = search(WindowConfig {
        filling_every: 0,
        ..cfg
    });
    assert_eq!(next_after(&mut off, 240), 480);
    assert_eq!(next_after(&mut off, 400), 640);
    // After a change found at block 480 (dated there), the windows since it double (1 h, then
    // the time since it), not the filling pace.
    w.changed(0);
    assert_eq!((w.floor, w.changes), (480, 1));
    assert_eq!(next_after(&mut w, 540), 600);
    assert_eq!(next_after(&mut w, 600), 720);
}

/// The list of points to polish keeps at most `CROWD` points that share one component's
/// values, whatever the order in which the points arrive.
#[test]
fn the_points_to_polish_are_diverse() {
    let model = InsModel::<f64>::paper();
    let sp = specs(&model);
    assert_eq!(
        sp.len(),
        4,
        "paper: accelerometer (sigma, tau), gyro (sigma, tau)"
    );
    // Ten points with the same gyro (coordinates 2 and 3) and distinct accelerometers, better
    // than one point with another gyro.
    let alike: [([f64; MAXP], f64); 10] = core::array::from_fn(|i| {
        let mut t = [0.0; MAXP];
        t[0] = i as f64;
        t[1] = -(i as f64);
        t[2] = 1.0;
        t[3] = 2.0;
        (t, 100.0 - i as f64)
    });
    let mut other = [0.0; MAXP];
    other[0] = 20.0;
    other[2] = -1.0;
    for order in 0..2 {
        let mut w = search(WindowConfig::default_on());
        w.top_ll = [f64::NEG_INFINITY; TOP];
        if order == 0 {
            w.offer_diverse(50.0, &other, &sp);
        }
        // Worst first, so that better points crowd out entries already in the list.
        for (t, ll) in alike.iter().rev() {
            w.offer_diverse(*ll, t, &sp);
        }
        if order == 1 {
            w.offer_diverse(50.0, &other, &sp);
        }
        let kept: usize = w.top_ll.iter().filter(|l| l.is_finite()).count();
        assert_eq!(kept, CROWD + 1, "order {order}: {:?}", w.top_ll);
        for k in 0..CROWD {
            assert_eq!(w.top_ll[k], 100.0 - k as f64);
            assert_eq!(w.top[k], alike[k].0);
        }
        assert_eq!(w.top_ll[CROWD], 50.0);
        assert_eq!(w.top[CROWD], other);
    }
    // A plain offer keeps the best TOP whatever they share (`offer_diverse` thins after it).
    let mut w = search(WindowConfig::default_on());
    w.top_ll = [f64::NEG_INFINITY; TOP];
    for (t, ll) in alike.iter() {
        w.offer(*ll, t, 0.0);
    }
    assert!(w.top_ll.iter().all(|l| *l >= 100.0 - TOP as f64 + 1.0));
}

/// After the brief polishes the best point is refined first, and the most promising of the
/// others (likelihood plus the gain its next step is predicted to make) second: a point still
/// climbing steeply goes before converged points a little above it. The entries are seed
/// 92718's on its 8-h window (nats against the anchor, rounded; `docs/ADAPTATION.md` §7.11).
#[test]
fn the_second_refinement_goes_to_the_most_promising_point() {
    let ll_ahead = [
        (0.17, 0.0),
        (-3.5, 3.1),
        (-1.9, 1.9),
        (-6.3, 17.8),
        (-34.5, 21.4),
        (-2.9, 2.1),
    ];
    for climbing in [true, false] {
        let mut w = search(WindowConfig::default_on());
        for (k, (l, a)) in ll_ahead.iter().enumerate() {
            // Each entry tagged by its place in the unsorted list.
            w.top[k] = [k as f64; MAXP];
            w.top_ll[k] = *l;
            w.top_ahead[k] = if climbing { *a } else { 0.0 };
        }
        w.rank_for_refinement();
        let order: [f64; TOP] = core::array::from_fn(|k| w.top[k][0]);
        if climbing {
            // -6.3 + 17.8 = 11.5 is the most promising; the rest by likelihood.
            assert_eq!(order, [0.0, 3.0, 2.0, 5.0, 1.0, 4.0]);
        } else {
            assert_eq!(order, [0.0, 2.0, 5.0, 1.0, 3.0, 4.0]);
        }
        for k in 0..TOP {
            let i = order[k] as usize;
            assert_eq!(w.top_ll[k], ll_ahead[i].0);
        }
    }
}

/// The gain ahead is the quadratic model's for one damped, limited step: on a quadratic it is
/// the model's exact gain, and a nearly flat direction (a tiny information with a score left
/// in it) does not make it large, because the step is limited to half a grid spacing.
#[test]
fn the_gain_ahead_is_bounded_by_the_step_limit() {
    use crate::adapt::guard::Bounds;
    let p = 4;
    let wide = Bounds {
        lo: [-1e9; MAXP],
        hi: [1e9; MAXP],
    };
    let mut w = search(WindowConfig::default_on());
    w.lambda = 0.0;
    w.acc_theta = [0.0; MAXP];
    w.acc_fisher = [[0.0; MAXP]; MAXP];
    for i in 0..p {
        w.acc_fisher[i][i] = 2.0;
    }
    w.acc_score = [0.0; MAXP];
    for v in w.acc_score.iter_mut().take(p) {
        *v = 1.0;
    }
    // Newton's step 1/2 per coordinate (within the limit): gain g d - I d^2 / 2 = 1/4 each.
    let gain = w.step_gain(p, &wide);
    assert!((gain - 0.25 * p as f64).abs() < 1e-6, "{gain}");
    // One flat direction: the undamped Newton gain there would be g^2 / (2 I) = 5e5 nats.
    w.acc_fisher[3][3] = 1e-6;
    let limit = w.cfg.spacing * 0.5;
    let gain = w.step_gain(p, &wide);
    assert!(gain > 0.0 && gain <= p as f64 * limit, "{gain}");
}

/// A search that ran to an identified answer hands that answer and its polished list to the
/// next one as candidates: non-finite entries, points near the new anchor and repeats skipped;
/// nothing after an abandoned search, a change in service or a structure switch.
#[test]
fn the_last_search_s_points_are_candidates_of_the_next() {
    use super::Phase;
    use crate::adapt::guard::Bounds;
    let mut w = search(WindowConfig::default_on());
    let tol = w.cfg.spacing * 0.25;
    let at = |v: f64| [v; MAXP];
    let anchor = at(10.0);
    w.best = at(1.0);
    w.best_ll = 5.0;
    let list = [
        (at(2.0), 4.0),
        (at(1.0 + 0.5 * tol), 3.9),   // the answer's own neighbourhood
        (at(10.0 - 0.5 * tol), 3.0),  // near the new anchor
        (at(3.0), f64::NEG_INFINITY), // never evaluated
        (at(4.0), 1.0),
        (at(2.0 + 0.9 * tol), 0.5), // a repeat
    ];
    for (k, (t, l)) in list.iter().enumerate() {
        w.top[k] = *t;
        w.top_ll[k] = *l;
    }
    w.carry_list = true;
    w.pushed = 480;
    w.start(&anchor);
    assert_eq!(w.phase, Phase::Anchor);
    assert_eq!(w.carried_len, 3);
    let wide = Bounds {
        lo: [-1e9; MAXP],
        hi: [1e9; MAXP],
    };
    for (k, v) in [1.0, 2.0, 4.0].iter().enumerate() {
        assert_eq!(w.after_carried(k), Phase::Carried(k));
        w.phase = Phase::Carried(k);
        assert_eq!(w.next_point(4, &wide), Some((at(*v), false)));
    }
    assert_eq!(w.after_carried(3), Phase::Grid(0));
    // The search above was not run to its end: the next carries nothing.
    w.start(&anchor);
    assert_eq!((w.carried_len, w.after_carried(0)), (0, Phase::Grid(0)));
    // Nor after a change in service or a structure switch.
    for reset in 0..2 {
        w.carry_list = true;
        if reset == 0 {
            w.changed(0);
        } else {
            let s = specs(&InsModel::<f64>::paper());
            w.restructure(&s, &s, &anchor);
        }
        w.start(&anchor);
        assert_eq!(w.carried_len, 0, "reset {reset}");
    }
}

/// The tick on which the change monitor built its filter holds no construction of the search
/// (with the structure test's hourly searches, the two on one tick reached 641k Cortex-M4
/// instructions); the search's construction comes on the next tick.
#[test]
fn a_tick_the_monitor_built_on_holds_no_construction_of_the_search() {
    let (base, s, theta, wide) = paper_at_truth();
    let cfg = WindowConfig::<f64>::default_on();
    for built in [false, true] {
        let mut w = search(cfg);
        for k in 0..(cfg.block * 10) {
            w.push(&[1e-3 * f64::from(k % 7)], &base, &s);
        }
        w.start(&theta);
        w.monitor_built = built;
        assert!(w.work(&base, &s, &wide).is_none());
        // Without the monitor's filter, the anchor's filter is built on this tick and its
        // pass over the 10 blocks ends; with it, nothing is built.
        assert_eq!(w.evaluations(), u32::from(!built), "monitor built: {built}");
        assert!(!w.monitor_built);
        assert!(w.work(&base, &s, &wide).is_none());
        assert!(w.evaluations() >= 1);
    }
}

/// After a settled answer whose best alternative beat it (a positive gain, below the switch's
/// threshold; `test_first`, set when a search ends), with the test on, the next search tests
/// structure first, from its anchor: it
/// ends there when the best alternative already wins, and goes on to the model's search
/// otherwise, without testing again at its end. Off, after an unsettled answer or one no
/// alternative beat, or after a change in service or a switch, the test comes after the
/// search as before.
#[test]
fn after_a_settled_answer_the_structure_test_comes_first() {
    use super::{Phase, Switch};
    use crate::adapt::identifiable::IdentifiableModel;
    let (base, s, theta, wide) = paper_at_truth();
    // The anchor's pass finished, at log-likelihood 0.
    let anchor_done = |w: &mut WindowSearch<f64>| {
        w.pushed = 300;
        w.start(&theta);
        w.block_s = 60.0;
        w.pass.theta = theta;
        w.pass.ll = 0.0;
        w.complete(&base, &s, &wide)
    };
    let mut w = search(WindowConfig::with_structure());
    // The first search: the model's search first.
    assert!(anchor_done(&mut w).is_none());
    assert!(!w.early && !w.tested);
    assert!(matches!(w.phase, Phase::Grid(0) | Phase::Carried(0)));
    let winner = Switch {
        site: base.site(1).unwrap(),
        theta,
        gain: 5.0,
        extra: 1,
        valid: true,
    };
    // A search that ends settled (1 nat above its anchor), its structure test run and its best
    // alternative `gain` nats above its answer.
    let finish = |w: &mut WindowSearch<f64>, gain: f64| {
        w.phase = Phase::Refine(super::FINAL - 1);
        w.tested = true;
        w.switch = winner;
        (w.best_ll, w.acc_ll, w.switch_ll) = (1.0, 1.0, 1.0 + gain);
        w.iterations = super::MAX_ITERATIONS;
        w.complete(&base, &s, &wide)
    };
    // After a settled answer no alternative beat: the model's search first.
    assert!(finish(&mut w, -0.5).is_some());
    assert!(!w.test_first);
    assert!(anchor_done(&mut w).is_none());
    assert!(!w.early && matches!(w.phase, Phase::Grid(0) | Phase::Carried(0)));
    // After a settled answer an alternative beat (below the switch's threshold): the
    // alternative's scan (the accelerometer's component first).
    assert!(finish(&mut w, 1.0).is_some());
    assert!(w.test_first);
    assert!(anchor_done(&mut w).is_none());
    assert!(w.early && w.tested);
    assert_eq!(w.phase, Phase::AltScan(0));
    assert_eq!(w.alt.site, base.site(0).unwrap());
    // The test ends with an alternative 5 nats up (one more parameter at 3 nats: it wins
    // beyond 4.5) and a model that moved 1 nat: the search ends, with the switch.
    w.switch = winner;
    w.switch_ll = 6.0;
    w.best_ll = 1.0;
    assert_eq!(w.structure_done(&s), Phase::Idle);
    assert!(!w.early);
    // At 4 nats it does not win: the model's search goes on, with the nested polish's point
    // (here the anchor moved by 1 nat) in its list.
    w.early = true;
    w.switch_ll = 5.0;
    w.best = [1.0; MAXP];
    assert!(matches!(
        w.structure_done(&s),
        Phase::Grid(0) | Phase::Carried(0)
    ));
    assert!(w.top.contains(&[1.0; MAXP]));
    // ... and its refinements end the search without a second test.
    w.phase = Phase::Refine(super::FINAL - 1);
    w.acc_ll = f64::INFINITY;
    w.iterations = super::MAX_ITERATIONS;
    assert!(w.complete(&base, &s, &wide).is_some());
    assert_eq!(w.phase, Phase::Idle);
    // A settled answer is required of the model too: a search that then moved by more than
    // `SETTLED` keeps no switch.
    w.test_first = true;
    assert!(anchor_done(&mut w).is_none());
    assert!(w.early);
    w.switch = winner;
    w.switch_ll = 20.0;
    w.best_ll = super::structure::SETTLED + 1.0;
    assert!(matches!(
        w.structure_done(&s),
        Phase::Grid(0) | Phase::Carried(0)
    ));
    w.phase = Phase::Refine(super::FINAL - 1);
    w.acc_ll = f64::INFINITY;
    w.iterations = super::MAX_ITERATIONS;
    let found = w.complete(&base, &s, &wide).unwrap();
    assert!(found.switch.get().is_none() && !w.test_first);
    // Not after a change in service or a switch, nor with the test off.
    for reset in 0..3 {
        let mut w = search(if reset == 2 {
            WindowConfig::default_on()
        } else {
            WindowConfig::with_structure()
        });
        w.test_first = true;
        match reset {
            0 => w.changed(0),
            1 => w.restructure(&s, &s, &theta),
            _ => {}
        }
        assert!(anchor_done(&mut w).is_none());
        assert!(!w.early, "reset {reset}");
        assert!(matches!(w.phase, Phase::Grid(0) | Phase::Carried(0)));
    }
}

/// The prior (`prior.rs`): weights `1 / (prior ln 10)^2` on every searched coordinate but an
/// exponential-cosine's `beta`; its gradient and information are those of its log-density
/// (central differences, exact for a quadratic); off, it adds exactly nothing.
#[test]
fn the_prior_is_a_normal_about_the_start_model_without_beta() {
    let paper = InsModel::<f64>::paper();
    use crate::adapt::identifiable::IdentifiableModel;
    let site = paper.site(1).unwrap();
    let ec = paper.swapped(&site, 0.01).unwrap();
    let s = specs(&ec);
    let beta = s
        .iter()
        .position(|x| x.kind == crate::model::Quantity::Beta)
        .unwrap();
    let cfg = WindowConfig::default_on();
    assert_eq!(cfg.prior, super::PRIOR_DECADES);
    let mut w = search(WindowConfig { prior: 2.0, ..cfg });
    w.centre = [0.5; MAXP];
    w.set_prior(&s);
    let weight = 1.0 / (2.0 * core::f64::consts::LN_10).powi(2);
    for i in 0..MAXP {
        let want = if i < s.len() && i != beta {
            weight
        } else {
            0.0
        };
        assert_eq!(w.prior.weight[i], want, "coordinate {i}");
    }
    let theta: [f64; MAXP] = core::array::from_fn(|i| 0.1 * i as f64 - 0.3);
    let (mut g, mut f) = ([0.0; MAXP], [[0.0; MAXP]; MAXP]);
    w.prior.add(&theta, &mut g, &mut f);
    for i in 0..MAXP {
        let (mut up, mut dn) = (theta, theta);
        up[i] += 1e-3;
        dn[i] -= 1e-3;
        let fd = (w.prior.log(&up) - w.prior.log(&dn)) / 2e-3;
        assert!((g[i] - fd).abs() < 1e-9, "gradient {i}: {} vs {fd}", g[i]);
        let curv = (w.prior.log(&up) - 2.0 * w.prior.log(&theta) + w.prior.log(&dn)) / 1e-6;
        assert!((f[i][i] + curv).abs() < 1e-6, "information {i}");
    }
    // Off: nothing, bit for bit.
    let mut off = search(WindowConfig { prior: 0.0, ..cfg });
    off.centre = [0.5; MAXP];
    off.set_prior(&s);
    assert_eq!(off.prior.log(&theta), 0.0);
    let (g0, f0) = ([0.25; MAXP], [[0.75; MAXP]; MAXP]);
    let (mut g1, mut f1) = (g0, f0);
    off.prior.add(&theta, &mut g1, &mut f1);
    assert_eq!((g1, f1), (g0, f0));
}
