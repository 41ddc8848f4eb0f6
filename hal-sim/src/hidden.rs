//! Hidden effects for test data: a candidate of the library added to the `paper` truth at a
//! realistic magnitude, i.e. one where a filter that ignores it loses at least 1.2x tilt RMS.
//!
//! Magnitudes were calibrated once by scanning multipliers of a first guess over 3 seeds
//! (`hal-sim/examples/hidden_scan.rs`); each effect's range starts where ignoring it cost about
//! 1.3x and spans a factor of about 3. Correlation times and periods are drawn log-uniformly
//! over a factor of 4, so benchmarks never run on the exact values seen during development.

use crate::candidates::{Candidate, LIBRARY};
use imu_ident::model::{ComponentKind as K, ErrorSource as S, InsModel};
use rand::Rng;

/// Log-uniform draw in `[lo, hi]`.
fn log_uniform<R: Rng>(rng: &mut R, lo: f64, hi: f64) -> f64 {
    (lo.ln() + rng.gen::<f64>() * (hi.ln() - lo.ln())).exp()
}

/// Log-parameters of a hidden `candidate` (as [`Candidate::component`] takes them).
pub fn draw<R: Rng>(candidate: Candidate, rng: &mut R) -> Vec<f64> {
    let mut lu = |lo: f64, hi: f64| log_uniform(rng, lo, hi).ln();
    match (candidate.sensor, candidate.kind) {
        (S::Accel, K::White) => vec![lu(0.03, 0.09)],
        (S::Gyro, K::White) => vec![lu(3e-5, 9e-5)],
        (S::Accel, K::GaussMarkov) => vec![lu(1.2e-2, 3e-2), lu(600.0, 2400.0)],
        (S::Gyro, K::GaussMarkov) => vec![lu(2e-6, 6e-6), lu(60.0, 240.0)],
        (S::Accel, K::ExpCosine) => vec![lu(3e-3, 9e-3), lu(600.0, 2400.0), lu(200.0, 800.0)],
        (S::Gyro, K::ExpCosine) => vec![lu(1.5e-6, 4.5e-6), lu(1800.0, 7200.0), lu(300.0, 1200.0)],
        (S::Accel, K::RandomWalk) => vec![lu(2e-9, 6e-9)],
        (S::Gyro, K::RandomWalk) => vec![lu(6e-16, 2e-15)],
        (S::Accel, K::RandomConstant) => vec![lu(1e-3, 3e-3)],
        (S::Gyro, K::RandomConstant) => vec![lu(1.5e-6, 4.5e-6)],
        (S::Observation, _) => vec![lu(0.1, 0.3), lu(30.0, 120.0)],
    }
}

/// Finds a library candidate by its label (`gyro/exp-cosine`) or by `sensor-kind`.
pub fn by_label(label: &str) -> Option<Candidate> {
    let norm = label.replace('-', "/");
    LIBRARY
        .iter()
        .copied()
        .find(|c| c.label() == label || c.label().replace('-', "/") == norm)
}

/// The truth model: `base` plus the drawn effect.
pub fn truth<R: Rng>(
    base: &InsModel<f64>,
    candidate: Candidate,
    rng: &mut R,
) -> Option<InsModel<f64>> {
    candidate.add_to(base, &draw(candidate, rng))
}
