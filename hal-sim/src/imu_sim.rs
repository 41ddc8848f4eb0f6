//! A static six-axis IMU recording drawn from an IMU model TOML: each axis is the sum of its
//! components (white, Gauss-Markov, exponential cosine, random walk, random constant), each
//! propagated with the core's exact discretisation (`discretise`, `phi`/`qd`,
//! `sampled_sigma`: no Euler steps), seeded ChaCha8 with one stream per axis. The output is
//! what `hal-sim identify --imu` reads (`gyro_x_rads, ..., accel_z_mps2`), so that a model can
//! be taken round the loop datasheet → model → recording → identification.

use std::path::Path;

use anyhow::{anyhow, Result};
use imu_ident::model::Component;
use nalgebra::{Matrix2, Vector2};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::imu_model::{ImuModelToml, AXES};
use crate::output::write_atomic;

/// Symmetric square root of a 2x2 covariance (rounding negatives clipped).
fn sqrt2(m: Matrix2<f64>) -> Matrix2<f64> {
    let e = m.symmetric_eigen();
    let d = e.eigenvalues.map(|l| l.max(0.0).sqrt());
    e.eigenvectors * Matrix2::from_diagonal(&d) * e.eigenvectors.transpose()
}

/// One component's sample path generator.
enum State {
    White(f64),
    Scalar {
        x: f64,
        phi: f64,
        sd: f64,
    },
    Pair {
        x: Vector2<f64>,
        phi: Matrix2<f64>,
        l: Matrix2<f64>,
    },
}

impl State {
    fn new(c: &Component<f64>, dt: f64, rng: &mut ChaCha8Rng) -> Self {
        let mut n = || rng.sample::<f64, _>(StandardNormal);
        match c {
            Component::White(w) => State::White(w.sampled_sigma(dt)),
            Component::GaussMarkov(g) => {
                let (phi, qd) = g.discretise(dt);
                State::Scalar {
                    x: g.sigma * n(),
                    phi,
                    sd: qd.max(0.0).sqrt(),
                }
            }
            Component::RandomWalk(r) => {
                let (phi, qd) = r.discretise(dt);
                State::Scalar {
                    x: r.sigma0 * n(),
                    phi,
                    sd: qd.max(0.0).sqrt(),
                }
            }
            Component::RandomConstant(r) => State::Scalar {
                x: r.sigma * n(),
                phi: 1.0,
                sd: 0.0,
            },
            Component::ExpCosine(e) => {
                let x = sqrt2(e.p_inf()) * Vector2::new(n(), n());
                State::Pair {
                    x,
                    phi: e.phi(dt),
                    l: sqrt2(e.qd(dt)),
                }
            }
        }
    }

    /// Advances one step and returns the component's output.
    fn step(&mut self, rng: &mut ChaCha8Rng) -> f64 {
        let mut n = || rng.sample::<f64, _>(StandardNormal);
        match self {
            State::White(sd) => *sd * n(),
            State::Scalar { x, phi, sd } => {
                *x = *phi * *x + *sd * n();
                *x
            }
            State::Pair { x, phi, l } => {
                *x = *phi * *x + *l * Vector2::new(n(), n());
                // The exp-cosine's error is its second state (README "Model TOML").
                x[1]
            }
        }
    }
}

/// `n` samples at `dt` of one axis made of `comps`.
pub fn simulate_axis(
    comps: &[Component<f64>],
    dt: f64,
    n: usize,
    seed: u64,
    stream: u64,
) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    let mut states: Vec<State> = comps.iter().map(|c| State::new(c, dt, &mut rng)).collect();
    (0..n)
        .map(|_| states.iter_mut().map(|s| s.step(&mut rng)).sum())
        .collect()
}

/// Column names of [`simulate`], in the order gx, gy, gz, ax, ay, az.
pub const COLUMNS: [&str; 6] = [
    "gyro_x_rads",
    "gyro_y_rads",
    "gyro_z_rads",
    "accel_x_mps2",
    "accel_y_mps2",
    "accel_z_mps2",
];

/// `n` samples of the six axes of `model` (SI), axis `i` on ChaCha stream `i`.
pub fn simulate(model: &ImuModelToml, n: usize, seed: u64) -> Result<Vec<Vec<f64>>> {
    let mut out = Vec::with_capacity(6);
    for sensor in ["gyro", "accel"] {
        for a in AXES {
            let core = model
                .channel(sensor, a)?
                .to_core()
                .map_err(|e| anyhow!("{sensor}.{a}: {e:#}"))?;
            let comps = if sensor == "gyro" {
                core.gyro
            } else {
                core.accel
            };
            out.push(simulate_axis(&comps, model.dt, n, seed, out.len() as u64));
        }
    }
    Ok(out)
}

/// Writes the six columns as a CSV with the [`COLUMNS`] header (atomically).
pub fn write_csv(path: &Path, cols: &[Vec<f64>]) -> Result<()> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(COLUMNS)?;
    let n = cols.first().map_or(0, Vec::len);
    for i in 0..n {
        w.write_record(cols.iter().map(|c| format!("{:e}", c[i])))?;
    }
    let bytes = w.into_inner().map_err(|e| anyhow!("csv: {e}"))?;
    write_atomic(path, |f| Ok(f.write_all(&bytes)?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use imu_ident::model::{GaussMarkov, WhiteNoise};

    /// Sample variance of white + GM equals N²/dt + σ² within 4 standard errors
    /// (n = 2e5 samples, but the GM part is correlated over T_c/dt = 100 samples, so its
    /// variance estimate has ~n/(2·100) effective samples: s.e. ≈ σ² sqrt(2·100/n) ≈ 3 %).
    #[test]
    fn variance_matches_the_model() {
        let dt = 0.01;
        let w = WhiteNoise::new(0.01).expect("white");
        let g = GaussMarkov::new(0.5, 1.0).expect("gm");
        let comps = [Component::White(w), Component::GaussMarkov(g)];
        let y = simulate_axis(&comps, dt, 200_000, 7, 0);
        let mean = y.iter().sum::<f64>() / y.len() as f64;
        let var = y.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / y.len() as f64;
        let want = 0.01f64.powi(2) / dt + 0.25;
        let se = 0.25 * (2.0 * 100.0 / 200_000.0f64).sqrt() + 0.01 * 0.01 / dt * 0.01;
        assert!((var - want).abs() < 4.0 * se, "{var} vs {want} (se {se})");
        // Same seed and stream, same path; another stream, another path.
        assert_eq!(y[..10], simulate_axis(&comps, dt, 10, 7, 0)[..]);
        assert_ne!(y[..10], simulate_axis(&comps, dt, 10, 7, 1)[..]);
    }
}
