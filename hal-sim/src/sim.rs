//! The truth simulator: draws a sample path of the INS error model in double precision with a
//! seeded RNG, using the core's exact discretisation (no Euler steps).
//!
//! `x_0 ~ N(0, P0)`, `x_k = Phi x_{k-1} + w_k`, `w_k ~ N(0, Qd)`, `z_k = H x_k + v_k` at
//! `t_k = k dt`, `k = 1..=steps`. Noise is shaped by the symmetric square root of `Qd` (from its
//! eigen-decomposition), which also handles the singular `Qd` of random constants.

use crate::log::{LogRow, Truth};
use anyhow::{anyhow, Result};
use imu_ident::model::{idx, ErrorSource, InsModel, StateMat, StateVec, NX};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Symmetric square root of a covariance (negative eigenvalues from rounding are clipped).
pub fn sqrt_psd(m: &StateMat<f64>) -> StateMat<f64> {
    let eig = m.symmetric_eigen();
    let d = eig.eigenvalues.map(|l| l.max(0.0).sqrt());
    eig.eigenvectors * StateMat::from_diagonal(&d) * eig.eigenvectors.transpose()
}

fn normal_vec(rng: &mut ChaCha8Rng) -> StateVec<f64> {
    StateVec::from_fn(|_, _| StandardNormal.sample(rng))
}

/// A change in service (BENCHMARKS.md §6): `before` steps of `a` (seed `2000 + seed`), then
/// `after` steps of `b` (seed `3000 + seed`) from a fresh stationary state, its times continuing
/// the first part's.
pub fn simulate_change(
    a: &InsModel<f64>,
    b: &InsModel<f64>,
    before: usize,
    after: usize,
    seed: u64,
) -> Result<Vec<LogRow>> {
    let mut log = simulate(a, before, 2000 + seed)?;
    let mut second = simulate(b, after, 3000 + seed)?;
    let shift = before as f64 * a.dt;
    for r in second.iter_mut() {
        r.t += shift;
    }
    log.extend(second);
    Ok(log)
}

/// Simulates `steps` observations of `model` with `seed`.
pub fn simulate(model: &InsModel<f64>, steps: usize, seed: u64) -> Result<Vec<LogRow>> {
    let scale = model.scaling().map_err(|e| anyhow!("truth model: {e}"))?;
    let (sys, disc) = model
        .discretise(&scale)
        .map_err(|e| anyhow!("truth model: {e}"))?;
    let accel = model
        .output_row(ErrorSource::Accel, &scale)
        .map_err(|e| anyhow!("{e}"))?;
    let gyro = model
        .output_row(ErrorSource::Gyro, &scale)
        .map_err(|e| anyhow!("{e}"))?;
    let lq = sqrt_psd(&disc.Qd);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut x = sqrt_psd(&sys.P0) * normal_vec(&mut rng);
    let mut rows = Vec::with_capacity(steps);
    for k in 1..=steps {
        x = disc.Phi * x + lq * normal_vec(&mut rng);
        let v: f64 = StandardNormal.sample(&mut rng);
        let z = (sys.H * x)[0] + model.sigma_v * v;
        let truth = Truth {
            dv: x[idx::DV] * scale[idx::DV],
            delta: x[idx::DELTA] * scale[idx::DELTA],
            da: (accel * x)[0],
            dw: (gyro * x)[0],
        };
        rows.push(LogRow {
            t: k as f64 * model.dt,
            z,
            truth: Some(truth),
        });
    }
    debug_assert!(x.len() == NX);
    Ok(rows)
}
