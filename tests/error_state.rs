//! The generic error-state filter: the one-channel model through it equals the dedicated
//! `InsFilter` exactly (same kernel, same discretisation), sequential scalar fusion equals the
//! vector Kalman update, and the vector gate's NIS is chi-square under the model.

use imu_ident::filter::{AxisStatus, ErrorStateFilter, InsFilter};
use imu_ident::model::{ContinuousSystem, ErrorModel, InsModel, ModelError, StateBlock, NX};
use nalgebra::{Matrix2, Vector2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

#[test]
fn one_channel_model_through_the_generic_filter_equals_ins_filter() {
    let m = InsModel::<f64>::paper();
    let mut a = InsFilter::new(m.clone()).unwrap();
    let mut b = ErrorStateFilter::<f64, InsModel<f64>, NX, 1>::new(m).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for k in 0..3000 {
        let z: f64 = if k % 97 == 0 {
            f64::NAN
        } else {
            0.03 * Distribution::<f64>::sample(&StandardNormal, &mut rng)
        };
        let ia = a.step(z);
        let fb = b.step(&[z], None);
        assert_eq!(
            ia.innovation.to_bits(),
            fb.innovation[0].to_bits(),
            "step {k}"
        );
        assert_eq!(a.kalman().P, b.kalman().P, "step {k}");
        assert_eq!(a.kalman().x, b.kalman().x, "step {k}");
    }
    let mut names = Vec::new();
    ErrorModel::<f64, NX, 1>::blocks(b.model(), &mut |s: StateBlock| names.push(s.name));
    assert_eq!(names, ["vel", "tilt", "accel", "gyro"]);
}

/// Two random-walk states, each observed directly by one axis: the smallest model with a
/// vector observation.
#[derive(Clone)]
struct TwoAxes {
    q: f64,
    r: f64,
}

impl ErrorModel<f64, 2, 2> for TwoAxes {
    fn dt(&self) -> f64 {
        1.0
    }
    fn scaling(&self) -> Result<[f64; 2], ModelError> {
        Ok([1.0, 1.0])
    }
    #[allow(non_snake_case)]
    fn system(&self, _: &[f64; 2]) -> Result<ContinuousSystem<f64, 2, 2>, ModelError> {
        Ok(ContinuousSystem {
            A: [[0.0; 2]; 2],
            Qc: [[self.q, 0.0], [0.0, self.q]],
            P0: [[1.0, 0.2], [0.2, 1.0]],
            H: [[1.0, 0.0], [0.5, 1.0]],
            R: [self.r, 2.0 * self.r],
            n: 2,
        })
    }
    fn blocks(&self, f: &mut dyn FnMut(StateBlock)) {
        f(StateBlock {
            name: "pos",
            start: 0,
            width: 2,
            component: None,
        });
    }
    fn same_layout(&self, _: &Self) -> bool {
        true
    }
}

#[test]
#[allow(non_snake_case)]
fn sequential_scalar_fusion_equals_the_vector_update() {
    let model = TwoAxes { q: 0.01, r: 0.04 };
    let mut f = ErrorStateFilter::<f64, TwoAxes, 2, 2>::new(model).unwrap();
    f.predict();
    let P = Matrix2::new(1.01, 0.2, 0.2, 1.01);
    let H = Matrix2::new(1.0, 0.0, 0.5, 1.0);
    let R = Matrix2::new(0.04, 0.0, 0.0, 0.08);
    let z = Vector2::new(0.3, -0.2);
    // The textbook vector update.
    let S = H * P * H.transpose() + R;
    let K = P * H.transpose() * S.try_inverse().unwrap();
    let x = K * z;
    let P1 = (Matrix2::identity() - K * H) * P;
    let out = f.update(&[0.3, -0.2], None);
    assert_eq!(out.axes, [AxisStatus::Used; 2]);
    let nis = z.transpose() * S.try_inverse().unwrap() * z;
    assert!((out.nis - nis[0]).abs() < 1e-12);
    for i in 0..2 {
        assert!((f.kalman().x[i] - x[i]).abs() < 1e-12);
        for j in 0..2 {
            assert!((f.kalman().P[i][j] - P1[(i, j)]).abs() < 1e-12);
        }
    }
}

#[test]
fn vector_gate_withholds_the_whole_observation_and_its_nis_is_chi_square() {
    let model = TwoAxes { q: 0.01, r: 0.04 };
    let mut f = ErrorStateFilter::<f64, TwoAxes, 2, 2>::new(model).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut truth = [0.0f64; 2];
    let n = |rng: &mut ChaCha8Rng| -> f64 { StandardNormal.sample(rng) };
    let (mut sum, mut count) = (0.0, 0usize);
    let steps = 4000;
    for k in 0..steps {
        for t in truth.iter_mut() {
            *t += 0.1 * n(&mut rng);
        }
        let mut z = [
            truth[0] + 0.2 * n(&mut rng),
            0.5 * truth[0] + truth[1] + 0.08f64.sqrt() * n(&mut rng),
        ];
        // A 100-sigma fault on the first axis every 500 steps.
        let fault = k % 500 == 250;
        if fault {
            z[0] += 20.0;
        }
        let out = f.step(&z, Some(13.8)); // chi-square(2) quantile at 1 - 1e-3
        if fault {
            assert!(out.gated, "step {k}");
            assert_eq!(out.axes, [AxisStatus::Gated; 2]);
        } else if k >= 100 {
            sum += out.nis;
            count += 1;
        }
    }
    // Under the model, the NIS values of a steady filter are independent chi-square(2): mean 2,
    // variance 4. The mean of `count` (~3890) of them has sd 2/sqrt(count) = 0.032; the bound is
    // 5 sd (the 1e-3 gate truncates the tail, lowering the mean by < 0.02).
    let mean = sum / count as f64;
    let sd = 2.0 / (count as f64).sqrt();
    assert!((mean - 2.0).abs() < 5.0 * sd + 0.02, "mean NIS {mean}");
    // A missing axis leaves one degree of freedom.
    let out = f.step(&[f64::NAN, 0.0], Some(13.8));
    assert_eq!(out.dof, 1);
    assert_eq!(out.axes[0], AxisStatus::Missing);
}
