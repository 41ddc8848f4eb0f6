//! The truth simulator: draws a sample path of the INS error model in double precision with a
//! seeded RNG, using the core's exact discretisation (no Euler steps).
//!
//! `x_0 ~ N(0, P0)`, `x_k = Phi x_{k-1} + w_k`, `w_k ~ N(0, Qd)`, `z_k = H x_k + v_k` at
//! `t_k = k dt`, `k = 1..=steps`. Noise is shaped by the symmetric square root of `Qd` (from its
//! eigen-decomposition), which also handles the singular `Qd` of random constants.

use crate::log::{LogRow, Truth};
use anyhow::{anyhow, Result};
use imu_ident::model::{idx, ErrorSource, InsModel, Realisation, StateMat, StateVec, NX};
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

/// Simulates `steps` observations of `model` with `seed`.
pub fn simulate(model: &InsModel<f64>, steps: usize, seed: u64) -> Result<Vec<LogRow>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut rows = Vec::with_capacity(steps);
    continue_path(model, None, steps, &mut rng, &mut rows)?;
    Ok(rows)
}

/// What the states do at a simulated change in service.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Seam {
    /// Every state restarts from a fresh stationary draw of the new model (BENCHMARKS.md §6):
    /// `z` jumps at the change. Seeds `2000 + seed` before, `3000 + seed` after.
    Fresh,
    /// Every state continues through the change; only the noise driving it changes, as when a
    /// sensor's noise changes in service (its Gauss-Markov states then relax to the new
    /// variance within their correlation times). One stream, seed `4000 + seed`.
    Continuous,
}

/// A change in service: `before` steps of `a`, then `after` steps of `b` (the same structure),
/// its times continuing the first part's, the states at the change as `seam` says.
pub fn simulate_change(
    a: &InsModel<f64>,
    b: &InsModel<f64>,
    (before, after): (usize, usize),
    seed: u64,
    seam: Seam,
) -> Result<Vec<LogRow>> {
    let mut rows = Vec::with_capacity(before + after);
    match seam {
        Seam::Fresh => {
            let mut rng = ChaCha8Rng::seed_from_u64(2000 + seed);
            continue_path(a, None, before, &mut rng, &mut rows)?;
            let mut rng = ChaCha8Rng::seed_from_u64(3000 + seed);
            continue_path(b, None, after, &mut rng, &mut rows)?;
        }
        Seam::Continuous => {
            // The states carry over one for one: the two models must lay them out alike.
            let layout = |m: &InsModel<f64>| m.layout().map_err(|e| anyhow!("truth model: {e}"));
            if layout(a)? != layout(b)? {
                return Err(anyhow!(
                    "a continuous change needs models of the same structure (their states differ)"
                ));
            }
            let mut rng = ChaCha8Rng::seed_from_u64(4000 + seed);
            let x = continue_path(a, None, before, &mut rng, &mut rows)?;
            continue_path(b, Some(x), after, &mut rng, &mut rows)?;
        }
    }
    Ok(rows)
}

/// Appends `steps` observations of `model` to `rows` (times continuing theirs), from the
/// physical state `x0` or, when `None`, from a stationary draw; returns the last physical state.
fn continue_path(
    model: &InsModel<f64>,
    x0: Option<StateVec<f64>>,
    steps: usize,
    rng: &mut ChaCha8Rng,
    rows: &mut Vec<LogRow>,
) -> Result<StateVec<f64>> {
    // The paper's realisation of every component: a seed draws the same path as before the
    // filters took the damped-rotation form of the exponential-cosine (`Realisation`). The
    // physical state `x0` of a continued path is in this realisation too.
    let r = Realisation::Paper;
    let scale = model
        .scaling_in(r)
        .map_err(|e| anyhow!("truth model: {e}"))?;
    let (sys, disc) = model
        .discretise_in(&scale, r)
        .map_err(|e| anyhow!("truth model: {e}"))?;
    let accel = model
        .output_row_in(ErrorSource::Accel, &scale, r)
        .map_err(|e| anyhow!("{e}"))?;
    let gyro = model
        .output_row_in(ErrorSource::Gyro, &scale, r)
        .map_err(|e| anyhow!("{e}"))?;
    let lq = sqrt_psd(&disc.Qd);
    // Scaled states: `x_scaled = x_physical / scale` entry by entry.
    let mut x = match x0 {
        Some(p) => p.component_div(&scale),
        None => sqrt_psd(&sys.P0) * normal_vec(rng),
    };
    let t0 = rows.last().map_or(0.0, |r| r.t);
    for k in 1..=steps {
        x = disc.Phi * x + lq * normal_vec(rng);
        let v: f64 = StandardNormal.sample(rng);
        let z = (sys.H * x)[0] + model.sigma_v * v;
        let truth = Truth {
            dv: x[idx::DV] * scale[idx::DV],
            delta: x[idx::DELTA] * scale[idx::DELTA],
            da: (accel * x)[0],
            dw: (gyro * x)[0],
        };
        rows.push(LogRow {
            t: t0 + k as f64 * model.dt,
            z,
            truth: Some(truth),
        });
    }
    debug_assert!(x.len() == NX);
    Ok(x.component_mul(&scale))
}
