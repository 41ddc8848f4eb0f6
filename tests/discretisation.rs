//! Exact discretisation checked against an independent reference: Van Loan's 2n x 2n block
//! exponential (nalgebra's std `exp`, a different algorithm from the crate's series) evaluated
//! at a 1 ms step and composed 1000 times to reach dt = 1 s.

use imu_ident::model::discretise::discretise;
use imu_ident::model::{
    Component, ExpCosine, GaussMarkov, InsModel, RandomConstant, RandomWalk, StateMat, WhiteNoise,
    NX,
};
use nalgebra::SMatrix;

type M16 = SMatrix<f64, 16, 16>;

/// Van Loan: exp([[-A, Qc], [0, A^T]] h) = [[., Phi^-1 Qd], [0, Phi^T]].
fn van_loan(a: &StateMat<f64>, qc: &StateMat<f64>, h: f64) -> (StateMat<f64>, StateMat<f64>) {
    let mut m = M16::zeros();
    m.fixed_view_mut::<NX, NX>(0, 0).copy_from(&(-a * h));
    m.fixed_view_mut::<NX, NX>(0, NX).copy_from(&(qc * h));
    m.fixed_view_mut::<NX, NX>(NX, NX)
        .copy_from(&(a.transpose() * h));
    let e = m.exp();
    let phi: StateMat<f64> = e.fixed_view::<NX, NX>(NX, NX).transpose();
    let q = phi * e.fixed_view::<NX, NX>(0, NX);
    (phi, (q + q.transpose()) * 0.5)
}

/// 1000 Van Loan steps of 1 ms: Phi = Phi_h^1000, Q_{k+1} = Phi_h Q_k Phi_h^T + Q_h.
fn fine_step_reference(a: &StateMat<f64>, qc: &StateMat<f64>) -> (StateMat<f64>, StateMat<f64>) {
    let (ph, qh) = van_loan(a, qc, 1e-3);
    let (mut phi, mut q) = (StateMat::identity(), StateMat::zeros());
    for _ in 0..1000 {
        q = ph * q * ph.transpose() + qh;
        phi = ph * phi;
    }
    (phi, q)
}

/// Every kind at once: accel GM + white + random constant, gyro exp-cosine + random walk,
/// one coloured observation term: 2 + 1 + 1 + 2 + 1 + 1 = 8 = NX states.
fn full_model() -> InsModel<f64> {
    let mut m = InsModel::<f64>::paper();
    m.accel
        .push(Component::White(WhiteNoise::new(2e-4).unwrap()))
        .unwrap();
    m.accel
        .push(Component::RandomConstant(
            RandomConstant::new(5e-4).unwrap(),
        ))
        .unwrap();
    m.gyro.clear();
    m.gyro
        .push(Component::ExpCosine(
            ExpCosine::new(5e-7, 900.0, 2.0 * core::f64::consts::PI / 600.0).unwrap(),
        ))
        .unwrap();
    m.gyro
        .push(Component::RandomWalk(RandomWalk::new(1e-17, 1e-7).unwrap()))
        .unwrap();
    m.colored
        .push(GaussMarkov::new(0.02, 30.0).unwrap())
        .unwrap();
    m
}

/// Largest |X - Y| relative to the scale of the reference: for Phi the element-wise bound
/// `|dPhi_ij| <= tol * max(1, |Phi_ij|)`; for covariances `|dQ_ij| <= tol sqrt(Q_ii Q_jj)`.
fn check(model: &InsModel<f64>, tol: f64) {
    let scale = model.scaling().unwrap();
    let (c, d) = model.discretise(&scale).unwrap();
    let (phi_ref, q_ref) = fine_step_reference(&c.A, &c.Qc);
    for i in 0..NX {
        for j in 0..NX {
            let e = (d.Phi[(i, j)] - phi_ref[(i, j)]).abs();
            assert!(
                e <= tol * phi_ref[(i, j)].abs().max(1.0),
                "Phi[{i},{j}] off by {e:e}"
            );
            let s = (q_ref[(i, i)] * q_ref[(j, j)]).sqrt();
            let e = (d.Qd[(i, j)] - q_ref[(i, j)]).abs();
            assert!(
                e <= tol * s + 1e-300,
                "Qd[{i},{j}] = {:e} vs {:e}",
                d.Qd[(i, j)],
                q_ref[(i, j)]
            );
        }
    }
}

/// Rounding in 1000 composed steps is ~1e3 * eps = 2e-13; 1e-10 leaves margin but would catch
/// any truncation or Euler-like error (an Euler step errs by ~(A dt)^2/2 ~ 1e-3 here).
#[test]
fn paper_model_matches_fine_step_van_loan() {
    check(&InsModel::paper(), 1e-10);
}

#[test]
fn every_component_kind_matches_fine_step_van_loan() {
    let m = full_model();
    assert_eq!(m.states().unwrap(), NX);
    check(&m, 1e-10);
}

/// A stiff case that needs scaling and squaring: ||A dt|| = 50 from a 0.02 s Gauss-Markov.
#[test]
fn stiff_component_needs_squaring_and_still_matches() {
    let mut m = InsModel::<f64>::paper();
    m.accel[0] = Component::GaussMarkov(GaussMarkov::new(1e-3, 0.02).unwrap());
    check(&m, 1e-9);
}

/// The closed forms of each component agree with the general series.
#[test]
fn component_closed_forms_match_the_series() {
    let dt = 1.0;
    let gm = GaussMarkov::new(3.0f64, 40.0).unwrap();
    let (mut a, mut q) = (StateMat::zeros(), StateMat::zeros());
    a[(0, 0)] = -gm.alpha();
    q[(0, 0)] = gm.qc();
    let d = discretise(&a, &q, dt).unwrap();
    let (phi, qd) = gm.discretise(dt);
    assert!((d.Phi[(0, 0)] - phi).abs() < 1e-15);
    assert!((d.Qd[(0, 0)] - qd).abs() < 1e-14 * qd);

    let ec = ExpCosine::new(2.0f64, 30.0, 0.3).unwrap();
    let b = Component::ExpCosine(ec).block();
    let (mut a, mut q) = (StateMat::zeros(), StateMat::zeros());
    a.fixed_view_mut::<2, 2>(0, 0).copy_from(&b.a);
    q.fixed_view_mut::<2, 2>(0, 0).copy_from(&b.qc);
    let d = discretise(&a, &q, dt).unwrap();
    // The filter's realisation is a damped rotation (`model::exp_cosine` docs): its closed
    // form is `Phi = exp(-alpha dt) R(beta dt)`, `Qd = sigma^2 (1 - exp(-2 alpha dt)) I`.
    let (e, (s, c)) = ((-ec.alpha() * dt).exp(), (ec.beta * dt).sin_cos());
    let phi = nalgebra::Matrix2::new(c, -s, s, c) * e;
    let qd = nalgebra::Matrix2::identity() * (ec.sigma * ec.sigma * (1.0 - e * e));
    for i in 0..2 {
        for j in 0..2 {
            assert!((d.Phi[(i, j)] - phi[(i, j)]).abs() < 1e-13, "Phi[{i},{j}]");
            assert!(
                (d.Qd[(i, j)] - qd[(i, j)]).abs() < 1e-12 * qd.norm(),
                "Qd[{i},{j}]"
            );
        }
    }
}

/// Single-precision discretisation against double: the series runs to 8 terms in f32; each
/// entry should be within a few f32 ulps of its scale (1e-5 relative leaves ~100 ulps).
#[test]
fn f32_discretisation_matches_f64() {
    let m = full_model();
    let s = m.scaling().unwrap();
    let (_, d64) = m.discretise(&s).unwrap();
    let m32 = m.cast::<f32>();
    let (_, d32) = m32.discretise(&s.map(|v| v as f32)).unwrap();
    for i in 0..NX {
        for j in 0..NX {
            let e = (d32.Phi[(i, j)] as f64 - d64.Phi[(i, j)]).abs();
            assert!(e <= 1e-5 * d64.Phi[(i, j)].abs().max(1.0), "Phi[{i},{j}]");
            let sc = (d64.Qd[(i, i)] * d64.Qd[(j, j)]).sqrt();
            let e = (d32.Qd[(i, j)] as f64 - d64.Qd[(i, j)]).abs();
            assert!(
                e <= 1e-5 * sc + 1e-30,
                "Qd[{i},{j}] {} vs {}",
                d32.Qd[(i, j)],
                d64.Qd[(i, j)]
            );
        }
    }
}

#[test]
fn bad_models_are_errors_not_panics() {
    let mut m = InsModel::<f64>::paper();
    m.dt = f64::NAN;
    assert!(m.scaling().is_err());
    let mut m = InsModel::<f64>::paper();
    m.accel[0] = Component::GaussMarkov(GaussMarkov {
        sigma: 1e-3,
        tau: -1.0,
    });
    assert!(m.layout().is_err());
    let mut m = full_model();
    m.accel.pop();
    m.accel
        .push(Component::ExpCosine(
            ExpCosine::new(1e-3, 10.0, 0.1).unwrap(),
        ))
        .unwrap();
    assert_eq!(
        m.layout().unwrap_err(),
        imu_ident::model::ModelError::TooManyStates
    );
    let mut a = StateMat::<f64>::zeros();
    a[(0, 0)] = f64::INFINITY;
    assert!(discretise(&a, &StateMat::zeros(), 1.0).is_err());
}

/// A strapdown error model in motion with every component kind on the sensors: gyros a
/// Gauss-Markov (x), an exponential-cosine (y) and a random walk (z), accelerometers a
/// Gauss-Markov with a random constant (x), white noise with an exp-cosine (y) and a random
/// walk (z): 9 navigation states + 1 + 2 + 1 + 2 + 2 + 1 = 18 states, turning at 0.2 rad/s
/// with 2 m/s^2 of lateral specific force.
fn strapdown_model() -> imu_ident::nav::StrapdownErrorModel<f64> {
    use imu_ident::nav::{ImuErrorModel, NavInit, NavPoint, StrapdownErrorModel, NAV_Z};
    use imu_ident::strapdown::Quat;
    use nalgebra::Vector3;
    let deg_h = core::f64::consts::PI / 180.0 / 3600.0;
    let ec = |s: f64| {
        Component::ExpCosine(
            ExpCosine::new(s, 1200.0, 2.0 * core::f64::consts::PI / 600.0).unwrap(),
        )
    };
    let mut imu = ImuErrorModel::<f64>::EMPTY;
    let comps: [&[Component<f64>]; 6] = [
        &[Component::GaussMarkov(
            GaussMarkov::new(10.0 * deg_h, 300.0).unwrap(),
        )],
        &[ec(10.0 * deg_h)],
        &[Component::RandomWalk(RandomWalk::new(1e-12, 1e-5).unwrap())],
        &[
            Component::GaussMarkov(GaussMarkov::new(1e-3, 60.0).unwrap()),
            Component::RandomConstant(RandomConstant::new(5e-3).unwrap()),
        ],
        &[Component::White(WhiteNoise::new(2e-3).unwrap()), ec(1e-3)],
        &[Component::RandomWalk(RandomWalk::new(1e-8, 1e-3).unwrap())],
    ];
    for (axis, cs) in imu.gyro.iter_mut().chain(imu.accel.iter_mut()).zip(comps) {
        for c in cs {
            axis.push(*c).unwrap();
        }
    }
    let mut point = NavPoint::at_rest(0.7, 300.0);
    point.v = Vector3::new(18.0, -7.0, 0.4);
    point.c_bn = Quat::from_euler(0.05, -0.02, 2.3).dcm();
    point.f_n = Vector3::new(1.2, -1.6, -9.81);
    point.w_b = Vector3::new(0.01, -0.02, 0.2);
    point.mean_w_b = point.w_b;
    point.mean_f_b = point.c_bn.transpose() * point.f_n;
    StrapdownErrorModel {
        imu,
        init: NavInit {
            sd_att: Vector3::repeat(0.01),
            sd_vel: 0.1,
            sd_pos: 1.0,
        },
        lever_arm: Vector3::new(0.3, 0.0, -0.8),
        obs_sd: [1.0; NAV_Z],
        point,
        dt: 1.0,
        scale_factor_sd: None,
    }
}

/// The balanced series on a moving strapdown model (mixed units: 9.8 m/s^2 per rad against
/// 1/R) against nalgebra's 2N Van Loan at 1 ms composed 1000 times. Same bounds as `check`.
#[test]
fn strapdown_model_matches_fine_step_van_loan() {
    use imu_ident::model::discretise::discretise_block;
    use imu_ident::model::error_model::ErrorModel;
    use nalgebra::DMatrix;
    const N: usize = 24;
    let model = strapdown_model();
    let n = model.states();
    assert_eq!(n, 18);
    let scale: [f64; N] = ErrorModel::<f64, N, 6>::scaling(&model).unwrap();
    let sys = ErrorModel::<f64, N, 6>::system(&model, &scale).unwrap();
    let (phi, qd) = discretise_block(&sys.A, &sys.Qc, 1.0, n).unwrap();
    // Reference: exp([[-A, Qc], [0, A^T]] h) at h = 1 ms, composed.
    let a = DMatrix::from_fn(n, n, |i, j| sys.A[i][j]);
    let qc = DMatrix::from_fn(n, n, |i, j| sys.Qc[i][j]);
    let h = 1e-3;
    let mut m = DMatrix::<f64>::zeros(2 * n, 2 * n);
    m.view_mut((0, 0), (n, n)).copy_from(&(-&a * h));
    m.view_mut((0, n), (n, n)).copy_from(&(&qc * h));
    m.view_mut((n, n), (n, n)).copy_from(&(a.transpose() * h));
    let e = m.exp();
    let ph = e.view((n, n), (n, n)).transpose();
    let qh = &ph * e.view((0, n), (n, n));
    let qh = (&qh + qh.transpose()) * 0.5;
    let (mut phi_ref, mut q_ref) = (DMatrix::<f64>::identity(n, n), DMatrix::<f64>::zeros(n, n));
    for _ in 0..1000 {
        q_ref = &ph * &q_ref * ph.transpose() + &qh;
        phi_ref = &ph * &phi_ref;
    }
    let tol = 1e-10;
    for i in 0..n {
        for j in 0..n {
            let e = (phi[i][j] - phi_ref[(i, j)]).abs();
            assert!(
                e <= tol * phi_ref[(i, j)].abs().max(1.0),
                "Phi[{i},{j}] off by {e:e}"
            );
            let s = (q_ref[(i, i)] * q_ref[(j, j)]).sqrt();
            let e = (qd[i][j] - q_ref[(i, j)]).abs();
            assert!(
                e <= tol * s + 1e-300,
                "Qd[{i},{j}] = {:e} vs {:e}",
                qd[i][j],
                q_ref[(i, j)]
            );
        }
    }
}

/// Why the strapdown model is cheap: balanced, it needs no squaring at 1 s and few terms (the
/// unbalanced 1-norm, 0.7 at 1 s, took 2 squarings and 14 dense terms before the balancing).
#[test]
fn strapdown_model_needs_no_squaring() {
    use imu_ident::model::discretise::Expm;
    use imu_ident::model::error_model::ErrorModel;
    const N: usize = 24;
    let model = strapdown_model();
    let scale: [f64; N] = ErrorModel::<f64, N, 6>::scaling(&model).unwrap();
    let sys = ErrorModel::<f64, N, 6>::system(&model, &scale).unwrap();
    let e = Expm::new(&sys.A, 1.0, sys.n).unwrap();
    assert_eq!(e.squarings(), 0);
    let (p, q) = e.orders();
    assert!(p <= 12 && q <= 20, "orders {p}, {q}");
}

/// The prediction's part of the strapdown system (`ErrorModel::dynamics`, `dynamics_into`,
/// built without `P0`, `H`, `R`: BENCHMARKS.md "The filter step in place") is the full system's `A`, `Qc`, `n`, bit for bit, every entry of the caller's
/// arrays written (zero outside the block), with and without scale-factor states (24 states,
/// the capacity). The full system's `P0`, built apart since, holds each block's initial
/// covariance: the navigation errors' deviations, each component's stationary covariance, the
/// scale factors' deviations, zero elsewhere. A model too large for `N` is an error that
/// leaves the caller's arrays alone.
#[test]
fn the_prediction_takes_the_full_systems_dynamics() {
    use imu_ident::model::error_model::ErrorModel;
    const N: usize = 24;
    for sf in [None, Some([3e-4, 1e-3])] {
        let mut model = strapdown_model();
        model.scale_factor_sd = sf;
        let scale: [f64; N] = ErrorModel::<f64, N, 6>::scaling(&model).unwrap();
        let sys = ErrorModel::<f64, N, 6>::system(&model, &scale).unwrap();
        let mut a = [[f64::NAN; N]; N];
        let mut qc = [[f64::NAN; N]; N];
        let n = model.dynamics_into(&scale, &mut a, &mut qc).unwrap();
        assert_eq!(n, if sf.is_some() { 24 } else { 18 });
        assert_eq!(n, sys.n);
        let bits = |m: &[[f64; N]; N]| m.map(|r| r.map(f64::to_bits));
        assert_eq!(bits(&a), bits(&sys.A));
        assert_eq!(bits(&qc), bits(&sys.Qc));
        let (a2, qc2, n2) = ErrorModel::<f64, N, 6>::dynamics(&model, &scale).unwrap();
        assert_eq!((bits(&a2), bits(&qc2), n2), (bits(&a), bits(&qc), n));
        // P0 in physical units, P0'_ij s_i s_j, against each block's own covariance.
        let mut want = [[0.0; N]; N];
        for i in 0..3 {
            want[i][i] = 0.01 * 0.01;
            want[3 + i][3 + i] = 0.1 * 0.1;
            want[6 + i][6 + i] = 1.0;
        }
        model.for_each_component(&mut |_, _, k, c| {
            let b = c.block();
            for i in 0..b.states {
                for j in 0..b.states {
                    want[k + i][k + j] = b.p0[(i, j)];
                }
            }
        });
        if let Some(sd) = sf {
            for j in 0..3 {
                want[18 + j][18 + j] = sd[0] * sd[0];
                want[21 + j][21 + j] = sd[1] * sd[1];
            }
        }
        for i in 0..N {
            for j in 0..N {
                let got = sys.P0[i][j] * scale[i] * scale[j];
                let tol = 1e-15 * want[i][j].abs();
                assert!(
                    (got - want[i][j]).abs() <= tol,
                    "P0[{i},{j}] {got:e} vs {:e}",
                    want[i][j]
                );
            }
        }
    }
    let model = strapdown_model();
    let scale = [1.0f64; 12];
    let (mut a, mut qc) = ([[7.0f64; 12]; 12], [[7.0f64; 12]; 12]);
    assert!(model.dynamics_into(&scale, &mut a, &mut qc).is_err());
    assert!(a.iter().chain(qc.iter()).flatten().all(|v| *v == 7.0));
}

/// The navigation errors' variances carried ahead of the filter (`nav::navigator::spread`:
/// the second-order transition, its noise integrated exactly) against the exact
/// discretisation, `diag(Phi P Phi^T + Qd)`, on the turning 18-state model with a covariance
/// of a filter in its steady state with fixes every second (correlated attitude, velocity,
/// position and sensor errors). The truncation is the transition's third-order term, so it
/// grows as `dt^3`: in position, 2.8e-6, 2.5e-5 and 5.2e-5 of a standard deviation at 0.5, 1
/// and 1.25 s (measured 2026-12-02; asserted `1e-4 (dt / 1.25 s)^3`). 1.25 s is more than a
/// live run carries (a step and its budget). The first-order transition fails it from 0.1 s
/// on (1.3e-4 at 0.25 s). At `dt = 0` it is the covariance's diagonal, bit for bit.
#[test]
fn the_carried_variances_match_the_exact_discretisation() {
    use imu_ident::model::discretise::discretise_block_into;
    use imu_ident::model::error_model::ErrorModel;
    use imu_ident::nav::navigator::spread::carried_variances;
    const N: usize = 24;
    let model = strapdown_model();
    let scale: [f64; N] = ErrorModel::<f64, N, 6>::scaling(&model).unwrap();
    let sys = ErrorModel::<f64, N, 6>::system(&model, &scale).unwrap();
    let propagated = |p: &[[f64; N]; N], dt: f64| {
        let (mut phi, mut qd) = ([[0.0; N]; N], [[0.0; N]; N]);
        discretise_block_into(&sys.A, &sys.Qc, dt, sys.n, &mut phi, &mut qd).unwrap();
        let (phi_m, p_m) = (
            SMatrix::<f64, N, N>::from_fn(|i, j| phi[i][j]),
            SMatrix::<f64, N, N>::from_fn(|i, j| p[i][j]),
        );
        let out = phi_m * p_m * phi_m.transpose() + SMatrix::<f64, N, N>::from_fn(|i, j| qd[i][j]);
        core::array::from_fn::<[f64; N], N, _>(|i| core::array::from_fn(|j| out[(i, j)]))
    };
    // A filter in its steady state: 1-s steps, each ending with a fix of position (0.5 m)
    // and velocity (0.05 m/s) on every axis, in the scaled states (`x_si = s x`).
    let mut p = propagated(&sys.P0, 300.0);
    let r = [0.25, 0.25, 0.25, 0.0025, 0.0025, 0.0025];
    for _ in 0..120 {
        p = propagated(&p, 1.0);
        let mut pm = SMatrix::<f64, N, N>::from_fn(|i, j| p[i][j]);
        for (k, rk) in r.iter().enumerate() {
            let i = if k < 3 { 6 + k } else { k };
            let h = SMatrix::<f64, 1, N>::from_fn(|_, j| if j == i { scale[i] } else { 0.0 });
            let a = pm * h.transpose();
            let s_inv = 1.0 / ((h * a)[(0, 0)] + rk);
            pm -= a * a.transpose() * s_inv;
        }
        p = core::array::from_fn(|i| core::array::from_fn(|j| 0.5 * (pm[(i, j)] + pm[(j, i)])));
    }
    let at_zero = carried_variances(&sys.A, &sys.Qc, &p, sys.n, 0.0);
    for (i, v) in at_zero.iter().enumerate() {
        assert_eq!(v.to_bits(), p[i][i].to_bits(), "state {i} at dt = 0");
    }
    let mut worst = 0.0f64;
    for dt in [0.01, 0.1, 0.25, 0.5, 1.0, 1.25] {
        let exact = propagated(&p, dt);
        let got = carried_variances(&sys.A, &sys.Qc, &p, sys.n, dt);
        for (i, v) in got.iter().enumerate() {
            let rel = (v.sqrt() - exact[i][i].sqrt()).abs() / exact[i][i].sqrt();
            worst = worst.max(rel);
            let bound = 1e-4 * (dt / 1.25f64).powi(3) + 1e-8;
            assert!(
                rel <= bound,
                "state {i}, dt {dt}: {v:e} against {:e}",
                exact[i][i]
            );
        }
        // The carried spread grows: the solution drifts with no fix between.
        assert!(got[6] > p[6][6] && got[3] > p[3][3], "dt {dt}");
    }
    eprintln!("carried sd against the exact discretisation: worst relative {worst:.2e}");
}

/// Benchmark (ignored; BENCHMARKS.md "The discretisation's series without temporaries"): the
/// moving 18-state strapdown model discretised `DISC_REPS` times (20 000 by default) at steps
/// of 1.00-1.06 s, in `f64` and `f32`; prints the time per call (min, median, p95) and a hash
/// of the first seven results' bits, which a change meant to be exact must leave alone.
/// `cargo test --release --test discretisation discretisation_cost -- --ignored --nocapture`
#[test]
#[ignore = "benchmark: prints the time per discretisation"]
fn discretisation_cost() {
    fn run<T: imu_ident::Real>(label: &str, reps: usize) {
        use imu_ident::model::discretise::discretise_block;
        use imu_ident::model::error_model::ErrorModel;
        const N: usize = 24;
        let model = strapdown_model();
        let scale: [f64; N] = ErrorModel::<f64, N, 6>::scaling(&model).unwrap();
        let sys = ErrorModel::<f64, N, 6>::system(&model, &scale).unwrap();
        let a: [[T; N]; N] = sys.A.map(|r| r.map(T::lit));
        let q: [[T; N]; N] = sys.Qc.map(|r| r.map(T::lit));
        // FNV-1a over the bits of the first seven results.
        let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
        let mut times = Vec::with_capacity(reps);
        for k in 0..reps {
            let dt = T::lit(1.0 + (k % 7) as f64 * 0.01);
            let start = std::time::Instant::now();
            let (phi, qd) = discretise_block(&a, &q, dt, sys.n).unwrap();
            times.push(start.elapsed().as_secs_f64() * 1e6);
            if k < 7 {
                for v in phi.iter().chain(qd.iter()).flatten() {
                    hash = (hash ^ v.as_f64().to_bits()).wrapping_mul(0x0100_0000_01b3);
                }
            }
        }
        times.sort_by(f64::total_cmp);
        let at = |f: f64| times[((reps - 1) as f64 * f) as usize];
        println!(
            "{label}: n {}, {reps} calls: min {:.1} us, median {:.1} us, p95 {:.1} us; hash {hash:016x}",
            sys.n,
            at(0.0),
            at(0.5),
            at(0.95)
        );
    }
    let reps = std::env::var("DISC_REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20_000usize)
        .max(1);
    run::<f64>("f64", reps);
    run::<f32>("f32", reps);
}
