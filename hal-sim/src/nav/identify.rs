//! Offline maximum-likelihood identification of the navigator's noise model on one log
//! (`hal-sim nav --identify`): factors on the standard deviation of every white-noise density
//! and random-walk intensity of each sensor type (gyro white, accelerometer white, gyro bias
//! walk, accelerometer bias walk), on the GNSS position and velocity standard deviations and
//! on a residual IMU time shift (a logging delay makes the innovations grow with the
//! acceleration), chosen to maximise the innovation log-likelihood of the run (the sum of [`EpochRecord`]
//! `loglik`, the exact Gaussian likelihood of the fused fixes given the model). With the
//! non-holonomic constraint on (`--nhc SD`), a factor on its standard deviation is one more
//! coordinate: the constraint changes the filter's predictions of the next fixes (attitude,
//! velocity and the sensor errors it helps to estimate), so the GNSS likelihood measures how
//! much it should be trusted; the constraint's own pseudo-innovations are not in the
//! likelihood (they are not measurements, and would favour whatever `SD` makes them look
//! Gaussian). The factor's bounds let the search all but switch the constraint off (x1e3).
//!
//! The run sees the same data as the scored run: fixes withheld by the outage schedule are not
//! used. The search is a pattern search ([`super::pattern`]) on the base-10 logarithms of the
//! six factors (steps of 1, 0.5, 0.25, 0.125 decades, every coordinate tried up and down, a
//! move kept when the likelihood rises), bounded to [1e-2, 1e3].
//!
//! [`EpochRecord`]: super::EpochRecord

use super::{run_with, NavArgs};
use crate::nav_io::{GnssFix, ImuSample};
use anyhow::Result;
use imu_ident::model::Component;
use imu_ident::nav::ImuErrorModel;
use serde::Serialize;

/// Names of the six factors, in search order.
pub const FACTORS: [&str; 6] = [
    "gyro_white",
    "accel_white",
    "gyro_bias_walk",
    "accel_bias_walk",
    "gnss_pos_sd",
    "gnss_vel_sd",
];

/// Step of the IMU time shift per decade of the factors' steps [s]: the shift is searched in
/// steps of 0.1, 0.05, 0.025, 0.0125 s, within [`MAX_SHIFT`].
const SHIFT_PER_DECADE: f64 = 0.1;
/// Largest IMU time shift searched [s].
pub const MAX_SHIFT: f64 = 0.5;

/// The result of an identification.
#[derive(Debug, Clone, Serialize)]
pub struct Identified {
    /// Factors on the standard deviations (file order of [`FACTORS`]).
    pub factors: [f64; 6],
    /// IMU time shift added to `--imu-time-shift` [s] (the last coordinate).
    pub imu_time_shift: f64,
    /// Factor on the non-holonomic constraint's standard deviation (with `--nhc`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nhc_sd_factor: Option<f64>,
    /// The identified standard deviation of the constraint [m/s] (with `--nhc`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nhc_sd: Option<f64>,
    /// Log-likelihood at the start and at the end.
    pub loglik_start: f64,
    /// Log-likelihood of the identified model.
    pub loglik: f64,
    /// Runs of the filter made.
    pub evaluations: usize,
    /// The identified noise model.
    #[serde(skip)]
    pub model: ImuErrorModel<f64>,
}

impl Identified {
    /// One line for the terminal: the factors, the shift, the constraint, the likelihoods.
    pub fn summary_line(&self) -> String {
        format!(
            "identified: factors {:?} ({}), IMU time shift {:+.4} s, constraint sd {:?} m/s, loglik {:.1} -> {:.1} in {} runs",
            self.factors,
            FACTORS.join(", "),
            self.imu_time_shift,
            self.nhc_sd,
            self.loglik_start,
            self.loglik,
            self.evaluations
        )
    }
}

/// `model` with its white densities and random-walk intensities scaled by the factors
/// (standard deviations: `q` scales by the square).
pub fn scaled(model: &ImuErrorModel<f64>, f: &[f64; 6]) -> ImuErrorModel<f64> {
    let mut m = model.clone();
    for (axes, white, walk) in [(&mut m.gyro, f[0], f[2]), (&mut m.accel, f[1], f[3])] {
        for axis in axes.iter_mut() {
            for c in axis.iter_mut() {
                match c {
                    Component::White(w) => w.density *= white,
                    Component::RandomWalk(r) => r.q *= walk * walk,
                    _ => {}
                }
            }
        }
    }
    m
}

/// The likelihood the search maximises: the total innovation log-likelihood of one run of
/// `args` with the gate off (gating would make it discontinuous in the parameters);
/// `-inf` when the run's likelihood is not finite.
pub fn loglik(args: &NavArgs, imu: &[ImuSample], fixes: &[GnssFix]) -> Result<f64> {
    let mut a = args.clone();
    a.gate = None;
    let ll = run_with::<f64>(&a, imu, fixes)?.summary.loglik;
    Ok(if ll.is_finite() {
        ll
    } else {
        f64::NEG_INFINITY
    })
}

/// Runs the search from `args.model` (gate off during the search: gating would make the
/// likelihood discontinuous in the parameters).
pub fn identify(args: &NavArgs, imu: &[ImuSample], fixes: &[GnssFix]) -> Result<Identified> {
    let mut a = args.clone();
    a.gate = None;
    let mut evaluations = 0usize;
    // Coordinates: the six log-factors, the constraint's log-factor (searched with --nhc
    // only), the IMU time shift in units of SHIFT_PER_DECADE.
    const NHC: usize = 6;
    const SHIFT: usize = 7;
    let mut eval = |lg: &[f64; 8]| -> Result<f64> {
        let f: [f64; 6] = std::array::from_fn(|i| 10f64.powf(lg[i]));
        a.imu_time_shift = args.imu_time_shift + lg[SHIFT] * SHIFT_PER_DECADE;
        a.model = scaled(&args.model, &f);
        a.gnss_sd_factor = [args.gnss_sd_factor[0] * f[4], args.gnss_sd_factor[1] * f[5]];
        a.nhc = args.nhc.map(|sd| sd * 10f64.powf(lg[NHC]));
        evaluations += 1;
        loglik(&a, imu, fixes)
    };
    let mut x = [0.0f64; 8];
    let start = eval(&x)?;
    let mut best = start;
    let b = MAX_SHIFT / SHIFT_PER_DECADE;
    let bounds = |i: usize| match i {
        NHC if args.nhc.is_none() => None,
        SHIFT => Some((-b, b)),
        _ => Some((-2.0, 3.0)),
    };
    super::pattern::maximise(
        &mut x,
        &mut best,
        &[1.0, 0.5, 0.25, 0.125],
        6,
        &bounds,
        &mut |y| eval(y.try_into().map_err(|_| anyhow::anyhow!("8 coordinates"))?),
    )?;
    let factors: [f64; 6] = std::array::from_fn(|i| 10f64.powf(x[i]));
    let nhc_sd_factor = args.nhc.map(|_| 10f64.powf(x[NHC]));
    Ok(Identified {
        factors,
        imu_time_shift: args.imu_time_shift + x[SHIFT] * SHIFT_PER_DECADE,
        nhc_sd_factor,
        nhc_sd: args.nhc.zip(nhc_sd_factor).map(|(sd, f)| sd * f),
        loglik_start: start,
        loglik: best,
        evaluations,
        model: scaled(&args.model, &factors),
    })
}
