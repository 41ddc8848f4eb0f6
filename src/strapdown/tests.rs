//! Tests of the high-rate algorithms on classic motions with closed-form truth, and of the
//! error handling and correction conventions. The long-trajectory tests against the exact
//! simulator are in hal-sim (`tests/strapdown_*.rs`).

extern crate std;
use super::*;
use nalgebra::Vector3;

/// 4-point Gauss-Legendre rule on `[a, b]` (exact for degree 7): the "exact" IMU increments.
fn gauss4(a: f64, b: f64, f: impl Fn(f64) -> Vector3<f64>) -> Vector3<f64> {
    const X: [f64; 4] = [
        -0.861_136_311_594_052_6,
        -0.339_981_043_584_856_3,
        0.339_981_043_584_856_3,
        0.861_136_311_594_052_6,
    ];
    const W: [f64; 4] = [
        0.347_854_845_137_453_9,
        0.652_145_154_862_546_1,
        0.652_145_154_862_546_1,
        0.347_854_845_137_453_9,
    ];
    let (c, h) = ((a + b) / 2.0, (b - a) / 2.0);
    X.iter()
        .zip(W.iter())
        .fold(Vector3::zeros(), |acc, (x, w)| acc + f(c + h * x) * (w * h))
}

/// Classic coning (Savage §7.1.1.1): the body axis x sweeps a cone of half-angle `beta` at
/// `omega` rad/s, `q(t) = (cos(beta/2), 0, sin(beta/2) cos(omega t), sin(beta/2) sin(omega t))`.
fn cone_q(beta: f64, omega: f64, t: f64) -> Quat<f64> {
    let s = (beta / 2.0).sin();
    Quat {
        w: (beta / 2.0).cos(),
        x: 0.0,
        y: s * (omega * t).cos(),
        z: s * (omega * t).sin(),
    }
}

/// Body rate of the coning motion, `omega = 2 vec(q* q')`.
fn cone_rate(beta: f64, omega: f64, t: f64) -> Vector3<f64> {
    let s = (beta / 2.0).sin();
    let qd = Quat {
        w: 0.0,
        x: 0.0,
        y: -s * omega * (omega * t).sin(),
        z: s * omega * (omega * t).cos(),
    };
    cone_q(beta, omega, t).conj().mul(&qd).vector() * 2.0
}

/// Attitude error [rad] after `secs` of coning integrated at `dt` with or without the correction.
fn coning_error(dt: f64, coning: bool, secs: f64) -> f64 {
    let (beta, omega) = (0.05, 2.0 * core::f64::consts::PI * 2.0);
    let corr = Corrections {
        coning,
        sculling: true,
    };
    let mut q = cone_q(beta, omega, 0.0);
    let mut prev: Option<Increment<f64>> = None;
    let n = (secs / dt).round() as usize;
    for k in 1..=n {
        let (a, b) = ((k - 1) as f64 * dt, k as f64 * dt);
        let inc = Increment {
            dtheta: gauss4(a, b, |t| cone_rate(beta, omega, t)),
            dv: Vector3::zeros(),
        };
        let (alpha, _) = body_increments(prev.as_ref(), &inc, corr);
        q = q.mul(&Quat::from_rotvec(&alpha)).normalized();
        prev = Some(inc);
    }
    let truth = cone_q(beta, omega, n as f64 * dt);
    truth.conj().mul(&q).rotvec().norm()
}

/// Errors at 100 and 200 Hz without and with a correction: asserts the uncorrected error is
/// second order (ratio ~4 on halving dt), the corrected one at least third (> 10, ~16 for
/// fourth), and the correction's gain at 100 Hz above 20 (~1/(omega dt)^2 ~ 60 expected).
fn assert_orders(name: &str, error: fn(f64, bool, f64) -> f64) {
    let secs = 10.0;
    let (u1, u2) = (error(0.01, false, secs), error(0.005, false, secs));
    let (c1, c2) = (error(0.01, true, secs), error(0.005, true, secs));
    std::println!("{name}: uncorrected {u1:.3e} -> {u2:.3e}, corrected {c1:.3e} -> {c2:.3e}");
    assert!(
        (3.5..4.5).contains(&(u1 / u2)),
        "{name} uncorrected order {}",
        u1 / u2
    );
    assert!(c1 / c2 > 10.0, "{name} corrected order {}", c1 / c2);
    assert!(u1 / c1 > 20.0, "{name} gain {}", u1 / c1);
}

#[test]
fn coning_correction_raises_the_order() {
    // Uncorrected, the drift rate of a cone is ~ beta^2 omega (omega dt)^2 / 12 (second order
    // in dt); the previous-sample correction leaves a fourth-order residual (Savage eq.
    // 7.1.1.1-12 and §7.1.1.1.1).
    assert_orders("coning", coning_error);
}

/// Classic sculling: roll oscillation `A sin(omega t)` about x in phase with a specific force
/// `B sin(omega t)` along body y, in a non-rotating frame without gravity. The rectified
/// `z` velocity grows at `A B / 2` per second; the exact velocity is integrated with a fine
/// Gauss-Legendre rule.
fn sculling_error(dt: f64, sculling: bool, secs: f64) -> f64 {
    let (amp, b, omega) = (0.02, 1.0, 2.0 * core::f64::consts::PI * 2.0);
    let roll = |t: f64| amp * (omega * t).sin();
    let rate = |t: f64| Vector3::new(amp * omega * (omega * t).cos(), 0.0, 0.0);
    let force = |t: f64| Vector3::new(0.0, b * (omega * t).sin(), 0.0);
    let corr = Corrections {
        coning: true,
        sculling,
    };
    let mut q = Quat::identity();
    let mut v = Vector3::zeros();
    let mut exact = Vector3::zeros();
    let mut prev: Option<Increment<f64>> = None;
    let n = (secs / dt).round() as usize;
    for k in 1..=n {
        let (a, e) = ((k - 1) as f64 * dt, k as f64 * dt);
        let inc = Increment {
            dtheta: gauss4(a, e, rate),
            dv: gauss4(a, e, force),
        };
        let (alpha, dv_b) = body_increments(prev.as_ref(), &inc, corr);
        v += q.rotate(&dv_b);
        q = q.mul(&Quat::from_rotvec(&alpha)).normalized();
        prev = Some(inc);
        // Truth: int C(t) f^b(t) dt on 8 sub-intervals (error far below the algorithm's).
        for s in 0..8 {
            let (sa, sb) = (a + dt * s as f64 / 8.0, a + dt * (s + 1) as f64 / 8.0);
            exact += gauss4(sa, sb, |t| {
                Quat::from_rotvec(&Vector3::new(roll(t), 0.0, 0.0)).rotate(&force(t))
            });
        }
    }
    (v - exact).norm()
}

#[test]
fn sculling_correction_raises_the_order() {
    // Without the sculling term the rectified velocity is in error at second order in dt
    // (rate ~ A B (omega dt)^2 / 12, Savage §7.2.2.2.1); with it, fourth order.
    assert_orders("sculling", sculling_error);
}

fn start() -> Strapdown<f64> {
    let pos = Geodetic {
        lat: 0.8,
        lon: 0.2,
        h: 150.0,
    };
    Strapdown::new(
        pos,
        Vector3::new(10.0, -3.0, 0.5),
        Quat::from_euler(0.1, 0.05, 1.0),
    )
    .unwrap()
}

#[test]
fn correct_removes_computed_minus_true_errors() {
    let truth = start();
    let mut computed = truth.clone();
    let (phi, dv, dp) = (
        Vector3::new(1e-3, -2e-3, 5e-3),
        Vector3::new(0.1, 0.2, -0.3),
        Vector3::new(3.0, -4.0, 1.5),
    );
    // Build the computed solution from the truth and the errors (module docs convention):
    // C_hat = (I + [phi x]) C, v_hat = v + dv, p_hat = p + dp.
    computed
        .set_attitude(Quat::from_rotvec(&phi).mul(&truth.attitude()))
        .unwrap();
    computed.set_velocity(truth.velocity() + dv).unwrap();
    computed
        .correct(&Vector3::zeros(), &Vector3::zeros(), &-dp)
        .unwrap();
    let (p, ph) = (truth.position(), computed.position());
    // Position error resolved in NED metres has the sign of dp.
    let rn = earth::radius_north(p.lat) + p.h;
    assert!(((ph.lat - p.lat) * rn - dp.x).abs() < 1e-6);
    assert!(((p.h - ph.h) - dp.z).abs() < 1e-9);
    computed.correct(&phi, &dv, &dp).unwrap();
    let err = truth
        .attitude()
        .conj()
        .mul(&computed.attitude())
        .rotvec()
        .norm();
    assert!(err < 1e-15, "{err}");
    assert!((computed.velocity() - truth.velocity()).norm() < 1e-14);
    let pc = computed.position();
    assert!((pc.lat - p.lat).abs() < 1e-15 && (pc.lon - p.lon).abs() < 1e-15);
    assert!((pc.h - p.h).abs() < 1e-9);
}

#[test]
fn non_finite_inputs_are_refused_and_leave_the_state() {
    let mut s = start();
    let before = s.clone();
    let good = Increment {
        dtheta: Vector3::new(1e-4, 0.0, 0.0),
        dv: Vector3::new(0.0, 0.0, -0.098),
    };
    let mut bad = good;
    bad.dv.y = f64::NAN;
    assert_eq!(s.step(&bad, 0.01), Err(StrapdownError::NonFiniteInput));
    bad.dv.y = f64::INFINITY;
    assert_eq!(s.step(&bad, 0.01), Err(StrapdownError::NonFiniteInput));
    assert_eq!(s.step(&good, 0.0), Err(StrapdownError::BadDt));
    assert_eq!(s.step(&good, f64::NAN), Err(StrapdownError::BadDt));
    let huge = Increment {
        dtheta: Vector3::zeros(),
        dv: Vector3::new(f64::MAX, f64::MAX, f64::MAX),
    };
    assert_eq!(s.step(&huge, 1e-300), Err(StrapdownError::NonFiniteState));
    let nan = Vector3::new(f64::NAN, 0.0, 0.0);
    assert_eq!(
        s.correct(&nan, &Vector3::zeros(), &Vector3::zeros()),
        Err(StrapdownError::NonFiniteInput)
    );
    assert_eq!(s, before);
    let polar = Geodetic {
        lat: 1.5699,
        lon: 0.0,
        h: 0.0,
    };
    assert_eq!(
        Strapdown::new(polar, Vector3::<f32>::zeros(), Quat::identity()),
        Err(StrapdownError::Polar)
    );
    assert!(s.step(&good, 0.01).is_ok());
}

#[test]
fn rebasing_keeps_the_position() {
    // A long northward-eastward move crosses many rebases; the f64 position must follow the
    // integral of the velocity through the curvilinear rates (checked against an f64 Euler
    // integration of L' = v_N/(R_N+h), lambda' = v_E/((R_E+h) cos L), exact here since the
    // velocity is constant and the increments cancel gravity and Coriolis exactly).
    let mut s = start();
    s.set_attitude(Quat::identity()).unwrap();
    // Level motion: the test's increments use the start-of-interval gravity.
    s.set_velocity(Vector3::new(10.0, -3.0, 0.0)).unwrap();
    let v = s.velocity();
    let dt = 0.01;
    let mut lat = s.position().lat;
    let mut lon = s.position().lon;
    let mut h = s.position().h;
    for _ in 0..100_000 {
        let (l, hh) = s.lat_h();
        let w_ie = earth::earth_rate_ned(l);
        let w_en = earth::transport_rate_ned(&v, l, hh);
        let g = earth::gravity_ned(l, hh);
        // Specific force that keeps v constant: f^n = (2 w_ie + w_en) x v - g.
        let f = (w_ie * 2.0 + w_en).cross(&v) - g;
        let q = s.attitude();
        let inc = Increment {
            dtheta: q.dcm().transpose() * (w_ie + w_en) * dt,
            dv: q.dcm().transpose() * f * dt,
        };
        let r = earth::geodetic_rates(&v, lat, h);
        s.step(&inc, dt).unwrap();
        let r2 = earth::geodetic_rates(&v, lat + r.x * dt, h + r.z * dt);
        lat += (r.x + r2.x) / 2.0 * dt;
        lon += (r.y + r2.y) / 2.0 * dt;
        h += (r.z + r2.z) / 2.0 * dt;
    }
    let p = s.position();
    let rn = earth::radius_north(lat) + h;
    let re = (earth::radius_east(lat) + h) * lat.cos();
    let (en, ee, eh) = ((p.lat - lat) * rn, (p.lon - lon) * re, p.h - h);
    std::println!("rebase: 1000 s, errors {en:.2e} {ee:.2e} {eh:.2e} m");
    assert!(en.abs() < 1e-3 && ee.abs() < 1e-3 && eh.abs() < 1e-3);
}
