//! Per-axis sensor errors of a strapdown IMU: for each of the three gyros and three
//! accelerometers, a sum of the core's noise components (white, Gauss-Markov, exp-cosine,
//! random walk, random constant), propagated with the core's exact discretisations
//! (`imu_ident::model::*::discretise`, `ExpCosine::phi`/`qd`, `WhiteNoise::sampled_sigma`) and
//! a seeded ChaCha generator.
//!
//! Each IMU interval `(t - dt, t]` gets one value per component: the stateful ones are
//! advanced by one exact step (`x_k = Phi x_{k-1} + w_k`, `w_k ~ N(0, Qd)`), starting from their
//! initial covariance (the stationary one for stationary kinds), and held over the interval;
//! white noise adds `N(0, (N / sqrt(dt))^2)` to the mean rate. The measured increment is the
//! exact one plus `dt` times the total error.

use anyhow::{bail, Result};
use imu_ident::model::{Component, GaussMarkov, Realisation, WhiteNoise};
use imu_ident::strapdown::Increment;
use nalgebra::{Matrix2, SymmetricEigen, Vector2, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// The components of the six sensor axes, in sensor units (rad/s for gyros, m/s^2 for
/// accelerometers); `[x, y, z]` of the body FRD frame.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ImuErrorModel {
    /// Gyro components per axis.
    pub gyro: [Vec<Component<f64>>; 3],
    /// Accelerometer components per axis.
    pub accel: [Vec<Component<f64>>; 3],
}

impl ImuErrorModel {
    /// A MEMS-grade preset on every axis (the `simulate-drive` default): gyro white
    /// 0.15 deg/sqrt(h) plus Gauss-Markov 10 deg/h over 300 s; accelerometer white
    /// 0.1 m/s/sqrt(h) plus Gauss-Markov 0.5 mg over 300 s.
    pub fn mems() -> Self {
        let deg = std::f64::consts::PI / 180.0;
        let gyro = [
            Component::White(WhiteNoise {
                density: 0.15 * deg / 60.0,
            }),
            Component::GaussMarkov(GaussMarkov {
                sigma: 10.0 * deg / 3600.0,
                tau: 300.0,
            }),
        ];
        let accel = [
            Component::White(WhiteNoise {
                density: 0.1 / 60.0,
            }),
            Component::GaussMarkov(GaussMarkov {
                sigma: 0.5e-3 * imu_ident::model::ins::G0,
                tau: 300.0,
            }),
        ];
        Self::same_on_all_axes(&gyro, &accel)
    }

    /// A tactical-grade preset on every axis (the issue-16 simulation benches): gyro white
    /// 0.005 deg/sqrt(h) plus Gauss-Markov 0.5 deg/h over 1 h; accelerometer white
    /// 0.02 m/s/sqrt(h) plus Gauss-Markov 50 ug over 1 h.
    pub fn tactical() -> Self {
        let deg = std::f64::consts::PI / 180.0;
        Self::same_on_all_axes(
            &[
                Component::White(WhiteNoise {
                    density: 0.005 * deg / 60.0,
                }),
                Component::GaussMarkov(GaussMarkov {
                    sigma: 0.5 * deg / 3600.0,
                    tau: 3600.0,
                }),
            ],
            &[
                Component::White(WhiteNoise {
                    density: 0.02 / 60.0,
                }),
                Component::GaussMarkov(GaussMarkov {
                    sigma: 50e-6 * 9.80665,
                    tau: 3600.0,
                }),
            ],
        )
    }

    /// The core navigator's model of the same components (at most
    /// [`imu_ident::nav::MAX_AXIS_COMPONENTS`] per axis).
    pub fn to_core(&self) -> Result<imu_ident::nav::ImuErrorModel<f64>> {
        let mut out = imu_ident::nav::ImuErrorModel::default();
        for (src, dst) in [(&self.gyro, &mut out.gyro), (&self.accel, &mut out.accel)] {
            for (s, d) in src.iter().zip(dst.iter_mut()) {
                for c in s {
                    d.push(*c).map_err(|_| {
                        anyhow::anyhow!(
                            "more than {} components on one axis",
                            imu_ident::nav::MAX_AXIS_COMPONENTS
                        )
                    })?;
                }
            }
        }
        Ok(out)
    }

    /// The same components on all three axes of each sensor.
    pub fn same_on_all_axes(gyro: &[Component<f64>], accel: &[Component<f64>]) -> Self {
        Self {
            gyro: [gyro.to_vec(), gyro.to_vec(), gyro.to_vec()],
            accel: [accel.to_vec(), accel.to_vec(), accel.to_vec()],
        }
    }

    /// This model with each axis's standard deviations times its own factor, `factor()` called
    /// once per axis (gyro x, y, z, then accelerometer x, y, z;
    /// [`scale_sd`](crate::nav::model::scale_sd) on each component).
    pub fn scaled_axes(&self, mut factor: impl FnMut() -> f64) -> Self {
        let mut out = self.clone();
        for axis in out.gyro.iter_mut().chain(out.accel.iter_mut()) {
            let f = factor();
            for c in axis.iter_mut() {
                crate::nav::model::scale_sd(c, f);
            }
        }
        out
    }
}

/// Symmetric square root of a 2x2 covariance (negative rounding eigenvalues clamped to 0).
fn sqrt_psd2(m: &Matrix2<f64>) -> Matrix2<f64> {
    let e = SymmetricEigen::new(*m);
    let d = Matrix2::from_diagonal(&e.eigenvalues.map(|x| x.max(0.0).sqrt()));
    e.eigenvectors * d * e.eigenvectors.transpose()
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// One component's state and exact step.
#[derive(Debug, Clone)]
enum State {
    /// One state: `x <- phi x + sd w`.
    Scalar { phi: f64, sd: f64, x: f64 },
    /// Exp-cosine: two states, output the second.
    Pair {
        phi: Matrix2<f64>,
        sq: Matrix2<f64>,
        x: Vector2<f64>,
    },
    /// White: a fresh draw of standard deviation `sd` each interval.
    White { sd: f64 },
}

impl State {
    fn new(c: &Component<f64>, dt: f64, rng: &mut ChaCha8Rng) -> Result<Self> {
        if let Err(e) = c.validate() {
            bail!("invalid {} component: {e}", c.kind().name());
        }
        // The paper's realisation, whose `phi` and `qd` step the exp-cosine below: its
        // stationary covariance, not the filter's damped rotation's (`sigma^2 I`). Drawn from
        // the rotation's, the exp-cosine's first state (a rate, stationary sd about
        // `sigma b`, `b^2 = alpha^2 + beta^2`) started about `1 / b` times too large, and the
        // output began with an oscillation of about `sigma / beta` (95 sigma at a 600-s
        // period) that decayed over `tau`.
        let p0 = c.block_in(Realisation::Paper).p0;
        let mut scalar = |(phi, qd): (f64, f64)| Self::Scalar {
            phi,
            sd: qd.sqrt(),
            x: p0[(0, 0)].sqrt() * normal(rng),
        };
        Ok(match c {
            Component::GaussMarkov(g) => scalar(g.discretise(dt)),
            Component::RandomWalk(r) => scalar(r.discretise(dt)),
            Component::RandomConstant(r) => scalar(r.discretise(dt)),
            Component::ExpCosine(e) => {
                let x0 = Vector2::new(normal(rng), normal(rng));
                Self::Pair {
                    phi: e.phi(dt),
                    sq: sqrt_psd2(&e.qd(dt)),
                    x: sqrt_psd2(&p0) * x0,
                }
            }
            Component::White(w) => Self::White {
                sd: w.sampled_sigma(dt),
            },
        })
    }

    /// Advances one interval; returns `(coloured part, white part)` of this interval's value.
    fn step(&mut self, rng: &mut ChaCha8Rng) -> (f64, f64) {
        match self {
            Self::Scalar { phi, sd, x } => {
                *x = *phi * *x + *sd * normal(rng);
                (*x, 0.0)
            }
            Self::Pair { phi, sq, x } => {
                let w = Vector2::new(normal(rng), normal(rng));
                *x = *phi * *x + *sq * w;
                (x[1], 0.0)
            }
            Self::White { sd } => (0.0, *sd * normal(rng)),
        }
    }
}

/// The six axes' error generators.
#[derive(Debug, Clone)]
pub struct ImuErrors {
    gyro: [Vec<State>; 3],
    accel: [Vec<State>; 3],
    rng: ChaCha8Rng,
}

/// One interval's sensor errors (mean over the interval), body FRD.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorErrors {
    /// Total gyro error [rad/s] (every component, white included).
    pub gyro: Vector3<f64>,
    /// Total accelerometer error [m/s^2].
    pub accel: Vector3<f64>,
    /// The gyro error without its white part (the bias a filter can estimate) [rad/s].
    pub gyro_bias: Vector3<f64>,
    /// The accelerometer error without its white part [m/s^2].
    pub accel_bias: Vector3<f64>,
}

impl ImuErrors {
    /// Generators for `model` at the IMU interval `dt`, seeded.
    pub fn new(model: &ImuErrorModel, dt: f64, seed: u64) -> Result<Self> {
        if !(dt.is_finite() && dt > 0.0) {
            bail!("dt must be positive");
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut build = |comps: &[Component<f64>]| -> Result<Vec<State>> {
            comps.iter().map(|c| State::new(c, dt, &mut rng)).collect()
        };
        let gyro = [
            build(&model.gyro[0])?,
            build(&model.gyro[1])?,
            build(&model.gyro[2])?,
        ];
        let accel = [
            build(&model.accel[0])?,
            build(&model.accel[1])?,
            build(&model.accel[2])?,
        ];
        Ok(Self { gyro, accel, rng })
    }

    /// The errors of the next interval.
    pub fn next_errors(&mut self) -> SensorErrors {
        let mut e = SensorErrors {
            gyro: Vector3::zeros(),
            accel: Vector3::zeros(),
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
        };
        for axis in 0..3 {
            for s in &mut self.gyro[axis] {
                let (c, w) = s.step(&mut self.rng);
                e.gyro_bias[axis] += c;
                e.gyro[axis] += c + w;
            }
            for s in &mut self.accel[axis] {
                let (c, w) = s.step(&mut self.rng);
                e.accel_bias[axis] += c;
                e.accel[axis] += c + w;
            }
        }
        e
    }

    /// The measured increment over `dt`: exact increment plus `dt` times the errors.
    pub fn corrupt(&mut self, exact: &Increment<f64>, dt: f64) -> (Increment<f64>, SensorErrors) {
        let e = self.next_errors();
        (
            Increment {
                dtheta: exact.dtheta + e.gyro * dt,
                dv: exact.dv + e.accel * dt,
            },
            e,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use imu_ident::model::ExpCosine;

    /// Every component starts stationary: over `K` seeds, the mean square of the output over
    /// the first `T` s is its variance `sigma^2`. The estimator's relative sd is below
    /// `sqrt(2 / K)` = 5 % for `K` = 800 independent seeds (fewer effective samples than
    /// steps: the mean over a correlated window has at most the variance of one sample), so
    /// the 20 % bound is four of them. Drawn from the wrong covariance, an exp-cosine of
    /// 600-s period started at about 95 sigma.
    #[test]
    fn every_component_starts_stationary() {
        let (k, t, dt) = (800u64, 300usize, 1.0);
        let ec = Component::ExpCosine(ExpCosine {
            sigma: 1e-3,
            tau: 1200.0,
            beta: 2.0 * std::f64::consts::PI / 600.0,
        });
        let gm = Component::GaussMarkov(GaussMarkov {
            sigma: 2e-3,
            tau: 300.0,
        });
        let model = ImuErrorModel::same_on_all_axes(&[gm], &[ec]);
        let (mut ms_g, mut ms_a) = (0.0, 0.0);
        for seed in 0..k {
            let mut e = ImuErrors::new(&model, dt, seed).unwrap_or_else(|e| panic!("{e:#}"));
            for _ in 0..t {
                let s = e.next_errors();
                ms_g += s.gyro_bias.x * s.gyro_bias.x;
                ms_a += s.accel_bias.x * s.accel_bias.x;
            }
        }
        let n = (k as usize * t) as f64;
        let (rg, ra) = (ms_g / n / 4e-6, ms_a / n / 1e-6);
        assert!(
            (rg - 1.0).abs() < 0.2,
            "Gauss-Markov: mean square / sigma^2 = {rg}"
        );
        assert!(
            (ra - 1.0).abs() < 0.2,
            "exp-cosine: mean square / sigma^2 = {ra}"
        );
    }
}
