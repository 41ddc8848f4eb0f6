//! Unit tests of the navigator's pseudo-observations and their rejection counters.

use super::*;
use crate::nav::{ImuErrorModel, NavInit};
use crate::strapdown::{Geodetic, Quat};

/// A navigator with the noise model `imu` at `att`, `v`, at rest on the model's linearisation
/// point (also the online identification's tests, `nav::online::tests`).
pub(crate) fn navigator_with<const N: usize>(
    imu: ImuErrorModel<f64>,
    att: Quat<f64>,
    v: Vector3<f64>,
) -> Navigator<f64, N> {
    let pos = Geodetic {
        lat: 0.6,
        lon: 2.0,
        h: 100.0,
    };
    let ins = Strapdown::new(pos, v, att).unwrap_or_else(|e| panic!("{e:?}"));
    let model = StrapdownErrorModel {
        imu,
        init: NavInit {
            sd_att: Vector3::repeat(0.01),
            sd_vel: 0.1,
            sd_pos: 1.0,
        },
        lever_arm: Vector3::zeros(),
        obs_sd: [1.0; NAV_Z],
        point: NavPoint::at_rest(0.6, 100.0),
        dt: 1.0,
        scale_factor_sd: None,
    };
    Navigator::new(ins, 0.0, model, NavConfig::default()).unwrap_or_else(|e| panic!("{e:?}"))
}

/// A navigator with no sensor states at `att`, `v`, with the step's mean rate `w`.
fn navigator(att: Quat<f64>, v: Vector3<f64>, w: Vector3<f64>) -> Navigator<f64, 9> {
    let mut nav = navigator_with(ImuErrorModel::default(), att, v);
    nav.model.point.mean_w_b = w;
    nav
}

/// The rows of `nhc_observation` against the predicted measurement of a perturbed state:
/// the computed state is the true one with the errors `phi`, `dv` put in through
/// `Strapdown::correct` (which removes them, so `-phi`, `-dv` put them in), the filter's
/// own definition of the error state. `z(computed) - z(true)` must equal `H x` to first
/// order: with errors of 1e-4 rad and 1e-3 m/s, the second-order residual is below
/// `|phi| |dv| + |phi|^2 |v|` ~ 1e-6 m/s, a sign error would leave ~1e-3 m/s.
#[test]
fn nhc_rows_match_a_perturbed_state_to_first_order() {
    let l = Vector3::new(0.3, -0.2, 0.65);
    let w = Vector3::new(0.05, -0.03, 0.4);
    let cases = [
        (
            Quat::from_euler(0.1, -0.05, 0.7),
            Vector3::new(8.0, 5.0, -0.3),
        ),
        (
            Quat::from_euler(-0.3, 0.2, -2.5),
            Vector3::new(-12.0, 3.0, 0.5),
        ),
        (
            Quat::from_euler(0.0, 0.0, 1.2),
            Vector3::new(2.0, -9.0, 0.0),
        ),
    ];
    let errs = [
        (Vector3::new(1e-4, 0.0, 0.0), Vector3::zeros()),
        (Vector3::new(0.0, 1e-4, 0.0), Vector3::zeros()),
        (Vector3::new(0.0, 0.0, 1e-4), Vector3::zeros()),
        (Vector3::zeros(), Vector3::new(1e-3, 0.0, 0.0)),
        (Vector3::zeros(), Vector3::new(0.0, 1e-3, 0.0)),
        (Vector3::zeros(), Vector3::new(0.0, 0.0, 1e-3)),
        (
            Vector3::new(-7e-5, 5e-5, 1e-4),
            Vector3::new(4e-4, -8e-4, 6e-4),
        ),
    ];
    for (att, v) in cases {
        let truth = navigator(att, v, w);
        let (z0, h) = truth.nhc_observation(&l);
        for (phi, dv) in errs {
            let mut computed = truth.clone();
            computed
                .ins
                .correct(&-phi, &-dv, &Vector3::zeros())
                .unwrap_or_else(|e| panic!("{e:?}"));
            let (z1, _) = computed.nhc_observation(&l);
            // H in scaled states: x_scaled = x / scale.
            let mut x = [0.0; 9];
            for i in 0..3 {
                x[nav_idx::ATT + i] = phi[i] / truth.scale[nav_idx::ATT + i];
                x[nav_idx::VEL + i] = dv[i] / truth.scale[nav_idx::VEL + i];
            }
            for k in 0..NHC_Z {
                let hx: f64 = h[k].iter().zip(x.iter()).map(|(a, b)| a * b).sum();
                let dz = z1[k] - z0[k];
                assert!(
                    (dz - hx).abs() < 2e-6 && (hx.abs() > 1e-5 || dz.abs() < 1e-5),
                    "axis {k}, phi {phi:?}, dv {dv:?}: z difference {dz:e}, H x {hx:e}"
                );
            }
        }
    }
}

/// With the vehicle moving along its body x axis and no lever arm the constraint holds
/// (`z = 0`); a vehicle moving sideways is gated, counted apart from the GNSS fixes.
#[test]
fn nhc_zero_for_forward_motion_and_gated_counter_is_separate() {
    let yaw = 0.9f64;
    let v = Vector3::new(yaw.cos(), yaw.sin(), 0.0) * 10.0;
    let mut nav = navigator(Quat::from_euler(0.0, 0.0, yaw), v, Vector3::zeros());
    let (z, _) = nav.nhc_observation(&Vector3::zeros());
    assert!(z.iter().all(|v| v.abs() < 1e-9), "{z:?}");
    let fused = nav
        .nhc(0.1, &Vector3::zeros())
        .unwrap_or_else(|e| panic!("{e:?}"));
    assert_eq!(fused.dof, NHC_Z);
    assert!(!fused.gated);
    assert!(nav.nhc(-1.0, &Vector3::zeros()).is_err());
    assert!(nav.nhc(f64::NAN, &Vector3::zeros()).is_err());
    // A grossly violated constraint is gated and counted apart from the GNSS count.
    nav.ins
        .set_velocity(Vector3::new(-v.y, v.x, 0.0))
        .unwrap_or_else(|e| panic!("{e:?}"));
    let f = nav
        .nhc(0.01, &Vector3::zeros())
        .unwrap_or_else(|e| panic!("{e:?}"));
    assert!(f.gated);
    assert_eq!((nav.rejected_nhc, nav.rejected), (1, 0));
}

/// A zero-velocity update while the solution moves fast is gated and counted apart from
/// the GNSS and constraint counts; one at rest is accepted and resets its own count only.
#[test]
fn zupt_gated_counter_is_separate() {
    let v = Vector3::new(10.0, 0.0, 0.0);
    let mut nav = navigator(Quat::from_euler(0.0, 0.0, 0.0), v, Vector3::zeros());
    nav.rejected = 2;
    let f = nav.zupt(0.01).unwrap_or_else(|e| panic!("{e:?}"));
    assert!(f.gated);
    assert_eq!(
        (nav.rejected_zupt, nav.rejected, nav.rejected_nhc),
        (1, 2, 0)
    );
    nav.ins
        .set_velocity(Vector3::new(0.001, 0.0, 0.0))
        .unwrap_or_else(|e| panic!("{e:?}"));
    let f = nav.zupt(0.01).unwrap_or_else(|e| panic!("{e:?}"));
    assert!(!f.gated);
    assert_eq!((nav.rejected_zupt, nav.rejected), (0, 2));
}

/// Counts the running filter's propagations.
struct Propagations(u32);

impl NavObserver<f64, 9> for Propagations {
    fn propagated(
        &mut self,
        _: &StrapdownErrorModel<f64>,
        _: &[f64; 9],
        _: &[f64; 9],
        _: &Arr<f64, 9>,
    ) {
        self.0 += 1;
    }
}

/// 4-Hz fixes off the IMU's grid, on an IMU whose sample intervals jitter (8-11 ms, as the real
/// drive's): the steps keep their 1-s cadence, and each step lands on the sample that passes
/// a fix, so the filter propagates once per fix (the step, and three fixes over the parts of
/// the step elapsed), not once more whenever the jitter puts the step a sample after the fix.
#[test]
fn fixes_at_4_hz_on_a_jittered_imu_propagate_once_each() {
    let nav = navigator(
        Quat::from_euler(0.0, 0.0, 0.0),
        Vector3::zeros(),
        Vector3::zeros(),
    );
    let pos = nav.ins.position();
    let mut nav = nav.with_observer(Propagations(0));
    // Intervals [ms] of the drive's histogram (8: 2 %, 9: 9 %, 10: 74 %, 11: 14 %), cycled.
    let jitter = [10, 10, 11, 10, 9, 10, 10, 11, 10, 8, 10, 10, 9, 10, 11, 10];
    let f = Vector3::new(
        0.0,
        0.0,
        -crate::strapdown::earth::normal_gravity(0.6, 100.0),
    );
    let (mut t, mut k, mut next_fix, mut fixes, mut steps) = (0.0, 0usize, 0.2531, 0u32, 0u32);
    let mut last_step = 0.0;
    while t < 100.0 {
        let dt = f64::from(jitter[k % jitter.len()]) * 1e-3;
        k += 1;
        t += dt;
        let inc = Increment::from_rates(&Vector3::zeros(), &f, dt);
        if nav.imu(t, &inc).unwrap_or_else(|e| panic!("{e:?}")) {
            if steps > 0 {
                // The cadence: one step a second, to within a sample's interval.
                assert!(
                    (t - last_step - 1.0).abs() <= 0.0115,
                    "steps at {last_step}, {t}"
                );
            }
            steps += 1;
            last_step = t;
        }
        while next_fix <= t {
            let fix = GnssFix {
                t: next_fix,
                pos,
                vel: Vector3::zeros(),
                sd_pos: Vector3::repeat(1.0),
                sd_vel: Vector3::repeat(0.1),
            };
            nav.gnss(&fix).unwrap_or_else(|e| panic!("{e:?}"));
            fixes += 1;
            next_fix += 0.25;
        }
    }
    // Before the first fix the steps propagate alone; after it, exactly one per fix.
    assert!((99..=100).contains(&steps), "{steps} steps");
    assert!(
        nav.observer().0 <= fixes + 1,
        "{} propagations for {fixes} fixes and {steps} steps",
        nav.observer().0
    );
}

/// A fix inside the last IMU sample is compared with the solution at its own time: on a
/// vehicle accelerating at 2 m/s^2, a fix 6 ms before the sample's end that carries the
/// mechanised velocity at its time (linear over the sample) has a velocity innovation of
/// rounding only; compared with the velocity at the sample's end, as before, it was 0.012 m/s
/// (2 m/s^2 x 6 ms).
#[test]
fn a_fix_inside_a_sample_is_compared_at_its_own_time() {
    let mut nav = navigator(
        Quat::from_euler(0.0, 0.0, 0.0),
        Vector3::zeros(),
        Vector3::zeros(),
    );
    let g = crate::strapdown::earth::normal_gravity(0.6, 100.0);
    let f = Vector3::new(2.0, 0.0, -g);
    let dt = 0.01;
    let mut t = 0.0;
    let mut v_before = nav.ins.velocity();
    for _ in 0..50 {
        v_before = nav.ins.velocity();
        t += dt;
        let inc = Increment::from_rates(&Vector3::zeros(), &f, dt);
        nav.imu(t, &inc).unwrap_or_else(|e| panic!("{e:?}"));
    }
    let v_after = nav.ins.velocity();
    let lag = 0.006;
    let v_fix = v_after - (v_after - v_before) * (lag / dt);
    assert!((v_after - v_fix).x > 0.011, "{v_after:?} {v_fix:?}");
    let fix = GnssFix {
        t: t - lag,
        pos: nav.ins.position(),
        vel: v_fix,
        sd_pos: Vector3::repeat(1.0),
        sd_vel: Vector3::repeat(0.1),
    };
    let fused = nav.gnss(&fix).unwrap_or_else(|e| panic!("{e:?}"));
    for i in 3..6 {
        assert!(
            fused.innovation[i].abs() < 1e-9,
            "velocity innovations {:?}",
            &fused.innovation[3..]
        );
    }
}
