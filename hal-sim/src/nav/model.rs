//! The noise model of `hal-sim nav`: an IMU model TOML (README "IMU model TOML", per-axis
//! `[[gyro.x]]` sections or the `[[gyro.all]]` shorthand), or a built-in:
//! - `drive-datasheet`: the real drive's datasheet-style values (its README): white noise on
//!   every axis, a bias random walk, initial bias uncertainty 0.1 deg/s and 0.1 m/s^2 (the
//!   source's `init.bias_*_unc`);
//! - `drive-inflated`: the same with the source's hand-chosen factors on the noise standard
//!   deviations: velocity (accelerometer white) 2, accelerometer bias 4, gyro bias 2.

use crate::nav_io::drive::noise_facts;
use anyhow::{anyhow, Result};
use imu_ident::model::{Component, RandomWalk, WhiteNoise};
use imu_ident::nav::ImuErrorModel;
use std::path::Path;

/// Built-in model names.
pub const BUILT_IN: [&str; 2] = ["drive-datasheet", "drive-inflated"];

/// The drive's datasheet model with factors on the standard deviations of
/// `[attitude (gyro white), velocity (accel white), accel bias, gyro bias]`.
pub fn drive_model(factors: [f64; 4]) -> ImuErrorModel<f64> {
    let n = noise_facts();
    let mut m = ImuErrorModel::default();
    let gyro = [
        Component::White(WhiteNoise {
            density: n.gyro_white_rad_s_sqrt_hz * factors[0],
        }),
        Component::RandomWalk(RandomWalk {
            q: (n.gyro_bias_rw_rad_s2_sqrt_hz * factors[3]).powi(2),
            sigma0: 0.1f64.to_radians(),
        }),
    ];
    let accel = [
        Component::White(WhiteNoise {
            density: n.accel_white_m_s2_sqrt_hz * factors[1],
        }),
        Component::RandomWalk(RandomWalk {
            q: (n.accel_bias_rw_m_s3_sqrt_hz * factors[2]).powi(2),
            sigma0: 0.1,
        }),
    ];
    // Four components fit MAX_AXIS_COMPONENTS: cannot fail.
    let _ = m.set_all_gyro(&gyro);
    let _ = m.set_all_accel(&accel);
    m
}

/// The model named `spec`: a built-in name or an IMU model TOML file.
pub fn load(spec: &str) -> Result<ImuErrorModel<f64>> {
    match spec {
        "drive-datasheet" => Ok(drive_model([1.0; 4])),
        "drive-inflated" => Ok(drive_model([1.0, 2.0, 4.0, 2.0])),
        path => {
            let p = Path::new(path);
            if !p.exists() {
                return Err(anyhow!(
                    "--model {path}: no such file, and not a built-in ({})",
                    BUILT_IN.join(", ")
                ));
            }
            crate::imu_model::load(p)?.to_nav(path)
        }
    }
}

/// The IMU model TOML of a navigator model (per-axis sections).
pub fn to_toml(m: &ImuErrorModel<f64>) -> Result<crate::imu_model::ImuModelToml> {
    use crate::imu_model::{AxesToml, ImuModelToml};
    use crate::model_toml::ComponentToml;
    let axes = |a: &[imu_ident::nav::AxisModel<f64>; 3]| {
        let conv =
            |v: &imu_ident::nav::AxisModel<f64>| v.iter().map(ComponentToml::from_core).collect();
        AxesToml {
            all: vec![],
            x: conv(&a[0]),
            y: conv(&a[1]),
            z: conv(&a[2]),
        }
    };
    Ok(ImuModelToml {
        dt: 1.0,
        gyro: axes(&m.gyro),
        accel: axes(&m.accel),
    })
}

/// `m` with every standard deviation scaled by `k` (white density, Gauss-Markov, exp-cosine
/// and random-constant sigma; a random walk's `q` by `k^2`): the paper's "noise 10x too
/// small / too large" starts of the issue-16 benches.
pub fn scaled_sd(m: &ImuErrorModel<f64>, k: f64) -> ImuErrorModel<f64> {
    let mut out = m.clone();
    for axis in out.gyro.iter_mut().chain(out.accel.iter_mut()) {
        for c in axis.iter_mut() {
            scale_sd(c, k);
        }
    }
    out
}

/// One component of [`scaled_sd`]: its standard deviation times `k` (a random walk's `q` by
/// `k^2`).
pub fn scale_sd(c: &mut Component<f64>, k: f64) {
    match c {
        Component::White(w) => w.density *= k,
        Component::GaussMarkov(g) => g.sigma *= k,
        Component::RandomWalk(r) => r.q *= k * k,
        Component::RandomConstant(r) => r.sigma *= k,
        Component::ExpCosine(e) => e.sigma *= k,
    }
}
