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
//! move kept when the likelihood rises), bounded to [1e-2, 1e3]. A factor on a quantity the
//! model does not carry (no random walk on the gyros, say) is left out: its likelihood is flat.
//!
//! The factors are tied over the three axes of each sensor. With `--identify-axes`
//! ([`Axes::Tested`]) the tied answer is then searched again with the IMU factors untied (one
//! per axis; the steps 0.5, 0.25, 0.125), and the per-axis answer is kept when it gains more
//! than half the chi-square(`df`) 0.99 quantile over the tied one, `df` two per factor the
//! model carries: the tied model is the per-axis one with equal factors (Wilks), so the test
//! keeps a per-axis answer on at most 1 % of logs whose axes are alike ([`AxesFit`];
//! BENCHMARKS.md "`--identify-axes`").
//!
//! [`EpochRecord`]: super::EpochRecord

use super::{run_with, NavArgs};
use crate::nav_io::{GnssFix, ImuSample};
use anyhow::Result;
use imu_ident::model::{Component, ComponentKind};
use imu_ident::nav::ImuErrorModel;
use serde::Serialize;
use statrs::distribution::{ChiSquared, ContinuousCDF};

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

/// Number of IMU factors (gyro white, accelerometer white, gyro bias walk, accelerometer bias
/// walk: the first four of [`FACTORS`]).
const IMU: usize = 4;

/// The per-axis stage of `--identify-axes`: the four IMU factors untied over x, y, z and
/// searched again from the tied answer; kept when the likelihood ratio says so.
#[derive(Debug, Clone, Serialize)]
pub struct AxesFit {
    /// Factors per axis (x, y, z) of the four IMU quantities (the first four of [`FACTORS`];
    /// a quantity the model does not carry stays at its tied factor).
    pub factors: [[f64; 3]; IMU],
    /// The per-axis fit's factors on the GNSS position and velocity standard deviations.
    pub gnss_sd_factors: [f64; 2],
    /// The per-axis fit's IMU time shift (added to `--imu-time-shift`) [s].
    pub imu_time_shift: f64,
    /// The per-axis fit's factor on the constraint's standard deviation (with `--nhc`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nhc_sd_factor: Option<f64>,
    /// Log-likelihood of the tied fit.
    pub loglik_tied: f64,
    /// Log-likelihood of the per-axis fit.
    pub loglik: f64,
    /// Its gain over the tied fit [nats].
    pub gain_nats: f64,
    /// Degrees of freedom of the test: two per quantity the model carries.
    pub df: usize,
    /// Half the chi-square(`df`) 0.99 quantile [nats]: the tied fit is the per-axis fit with
    /// equal factors, so twice the gain is chi-square(`df`) under the tied model (Wilks).
    pub threshold_nats: f64,
    /// Whether the per-axis fit was kept (`gain_nats > threshold_nats`).
    pub significant: bool,
    /// Runs of the filter made by this stage.
    pub evaluations: usize,
}

/// The result of an identification.
#[derive(Debug, Clone, Serialize)]
pub struct Identified {
    /// Factors on the standard deviations (file order of [`FACTORS`]; with a per-axis answer
    /// kept, the IMU factors are the geometric means of [`AxesFit::factors`] over the axes).
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
    /// Runs of the filter made (both stages).
    pub evaluations: usize,
    /// The per-axis stage (`--identify-axes`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub axes: Option<AxesFit>,
    /// The identified noise model.
    #[serde(skip)]
    pub model: ImuErrorModel<f64>,
}

impl Identified {
    /// The options of the identified run, from the options `args` it was identified with:
    /// the identified model, GNSS factors, IMU time shift and constraint sd.
    pub fn apply(&self, args: &NavArgs) -> NavArgs {
        NavArgs {
            model: self.model.clone(),
            gnss_sd_factor: [
                args.gnss_sd_factor[0] * self.factors[4],
                args.gnss_sd_factor[1] * self.factors[5],
            ],
            imu_time_shift: self.imu_time_shift,
            nhc: self.nhc_sd,
            ..args.clone()
        }
    }

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
        ) + &self.axes.as_ref().map_or(String::new(), |a| {
            format!(
                "\nper axis (x, y, z; {}): {:?}, gain {:.1} nats against {:.1} (chi-square({}) 0.99): {}",
                FACTORS[..IMU].join(", "),
                a.factors,
                a.gain_nats,
                a.threshold_nats,
                a.df,
                if a.significant { "kept" } else { "tied kept" }
            )
        })
    }
}

impl AxesFit {
    /// The options of the per-axis fit's run, from the options `args` it was identified with
    /// (kept or not).
    pub fn apply(&self, args: &NavArgs) -> NavArgs {
        NavArgs {
            model: scaled_axes(&args.model, &self.factors),
            gnss_sd_factor: [
                args.gnss_sd_factor[0] * self.gnss_sd_factors[0],
                args.gnss_sd_factor[1] * self.gnss_sd_factors[1],
            ],
            imu_time_shift: self.imu_time_shift,
            nhc: args.nhc.zip(self.nhc_sd_factor).map(|(sd, f)| sd * f),
            ..args.clone()
        }
    }
}

/// `model` with its white densities and random-walk intensities scaled by the factors
/// (standard deviations: `q` scales by the square).
pub fn scaled(model: &ImuErrorModel<f64>, f: &[f64; 6]) -> ImuErrorModel<f64> {
    scaled_axes(model, &std::array::from_fn(|q| [f[q]; 3]))
}

/// `model` with each axis's white densities and random-walk intensities scaled by that axis's
/// factor of `f` (rows in the order of [`FACTORS`]'s first four, columns x, y, z).
pub fn scaled_axes(model: &ImuErrorModel<f64>, f: &[[f64; 3]; IMU]) -> ImuErrorModel<f64> {
    let mut m = model.clone();
    for (axes, white, walk) in [(&mut m.gyro, f[0], f[2]), (&mut m.accel, f[1], f[3])] {
        for ((axis, white), walk) in axes.iter_mut().zip(white).zip(walk) {
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

/// Whether `model` carries the quantity IMU factor `q` scales (0 gyro white, 1 accelerometer
/// white, 2 gyro walk, 3 accelerometer walk) on some axis: a factor on nothing is not searched
/// (its likelihood is flat) and not counted in the per-axis test's degrees of freedom.
fn carries(model: &ImuErrorModel<f64>, q: usize) -> bool {
    let (axes, kind) = match q {
        0 => (&model.gyro, ComponentKind::White),
        1 => (&model.accel, ComponentKind::White),
        2 => (&model.gyro, ComponentKind::RandomWalk),
        _ => (&model.accel, ComponentKind::RandomWalk),
    };
    axes.iter().flatten().any(|c| c.kind() == kind)
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

/// A point of the search: base-10 logarithms of the IMU factors per axis, of the two GNSS
/// factors and of the constraint's factor, and the IMU time shift in units of
/// [`SHIFT_PER_DECADE`].
#[derive(Debug, Clone, Copy, Default)]
struct Point {
    imu: [[f64; 3]; IMU],
    gnss: [f64; 2],
    nhc: f64,
    shift: f64,
}

impl Point {
    /// The IMU factors per axis.
    fn imu_factors(&self) -> [[f64; 3]; IMU] {
        self.imu.map(|q| q.map(|l| 10f64.powf(l)))
    }

    /// The options of the run at this point.
    fn args(&self, args: &NavArgs) -> NavArgs {
        let mut a = args.clone();
        a.gate = None;
        a.imu_time_shift = args.imu_time_shift + self.shift * SHIFT_PER_DECADE;
        a.model = scaled_axes(&args.model, &self.imu_factors());
        a.gnss_sd_factor = [
            args.gnss_sd_factor[0] * 10f64.powf(self.gnss[0]),
            args.gnss_sd_factor[1] * 10f64.powf(self.gnss[1]),
        ];
        a.nhc = args.nhc.map(|sd| sd * 10f64.powf(self.nhc));
        a
    }
}

/// How `--identify` treats the three axes of each sensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axes {
    /// One factor per quantity and sensor (the default).
    Tied,
    /// Tied, then untied and tested (`--identify-axes`, [`AxesFit`]).
    Tested,
}

/// Runs the search from `args.model` with the three axes of each sensor tied (gate off during
/// the search: gating would make the likelihood discontinuous in the parameters).
pub fn identify(args: &NavArgs, imu: &[ImuSample], fixes: &[GnssFix]) -> Result<Identified> {
    identify_axes(args, imu, fixes, Axes::Tied)
}

/// [`identify`]; with [`Axes::Tested`] (`--identify-axes`) the tied answer is then searched again
/// with the four IMU factors untied over x, y, z (the GNSS, constraint and time-shift
/// coordinates free too), and the per-axis answer is kept when it gains more than half the
/// chi-square(`df`) 0.99 quantile over the tied one ([`AxesFit`]).
pub fn identify_axes(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    axes: Axes,
) -> Result<Identified> {
    let evaluations = std::cell::Cell::new(0usize);
    let eval = |p: &Point| -> Result<f64> {
        evaluations.set(evaluations.get() + 1);
        loglik(&p.args(args), imu, fixes)
    };
    let carried: [bool; IMU] = std::array::from_fn(|q| carries(&args.model, q));
    let shift_bound = MAX_SHIFT / SHIFT_PER_DECADE;
    // Stage 1, tied. Coordinates: the four IMU log-factors, the two GNSS ones, the
    // constraint's (searched with --nhc only), the IMU time shift.
    const NHC: usize = 6;
    const SHIFT: usize = 7;
    let tied_point = |x: &[f64]| Point {
        imu: std::array::from_fn(|q| [x[q]; 3]),
        gnss: [x[4], x[5]],
        nhc: x[NHC],
        shift: x[SHIFT],
    };
    let mut x = [0.0f64; 8];
    let start = eval(&tied_point(&x))?;
    let mut best = start;
    let bounds = |i: usize| match i {
        NHC if args.nhc.is_none() => None,
        SHIFT => Some((-shift_bound, shift_bound)),
        q if q < IMU && !carried[q] => None,
        _ => Some((-2.0, 3.0)),
    };
    super::pattern::maximise(
        &mut x,
        &mut best,
        &[1.0, 0.5, 0.25, 0.125],
        6,
        &bounds,
        &mut |y| eval(&tied_point(y)),
    )?;
    let mut point = tied_point(&x);
    let mut loglik = best;
    let axes = if axes == Axes::Tested {
        // Stage 2, per axis: 12 IMU log-factors (quantity-major: 3 q + axis), then the GNSS,
        // constraint and shift coordinates, from the tied answer, at the finer steps.
        const N: usize = 3 * IMU;
        let axes_point = |y: &[f64]| Point {
            imu: std::array::from_fn(|q| std::array::from_fn(|a| y[3 * q + a])),
            gnss: [y[N], y[N + 1]],
            nhc: y[N + 2],
            shift: y[N + 3],
        };
        let mut y: Vec<f64> = point.imu.iter().flatten().copied().collect();
        y.extend([point.gnss[0], point.gnss[1], point.nhc, point.shift]);
        let before = evaluations.get();
        let mut best_axes = best;
        let bounds = |i: usize| match i {
            _ if i < N && !carried[i / 3] => None,
            _ if i == N + 2 && args.nhc.is_none() => None,
            _ if i == N + 3 => Some((-shift_bound, shift_bound)),
            _ => Some((-2.0, 3.0)),
        };
        super::pattern::maximise(
            &mut y,
            &mut best_axes,
            &[0.5, 0.25, 0.125],
            6,
            &bounds,
            &mut |z| eval(&axes_point(z)),
        )?;
        let df = 2 * carried.iter().filter(|&&c| c).count();
        let threshold_nats = if df == 0 {
            f64::INFINITY
        } else {
            0.5 * ChiSquared::new(df as f64)?.inverse_cdf(0.99)
        };
        let gain_nats = best_axes - best;
        let significant = gain_nats > threshold_nats;
        let fit = axes_point(&y);
        if significant {
            point = fit;
            loglik = best_axes;
        }
        Some(AxesFit {
            factors: fit.imu_factors(),
            gnss_sd_factors: fit.gnss.map(|l| 10f64.powf(l)),
            imu_time_shift: args.imu_time_shift + fit.shift * SHIFT_PER_DECADE,
            nhc_sd_factor: args.nhc.map(|_| 10f64.powf(fit.nhc)),
            loglik_tied: best,
            loglik: best_axes,
            gain_nats,
            df,
            threshold_nats,
            significant,
            evaluations: evaluations.get() - before,
        })
    } else {
        None
    };
    // The factors: a per-axis answer's IMU factors as their geometric means over the axes.
    let f = point.imu_factors();
    let mean = |q: usize| 10f64.powf(point.imu[q].iter().sum::<f64>() / 3.0);
    let factors: [f64; 6] = std::array::from_fn(|i| match i {
        q if q < IMU => mean(q),
        g => 10f64.powf(point.gnss[g - IMU]),
    });
    let nhc_sd_factor = args.nhc.map(|_| 10f64.powf(point.nhc));
    Ok(Identified {
        factors,
        imu_time_shift: args.imu_time_shift + point.shift * SHIFT_PER_DECADE,
        nhc_sd_factor,
        nhc_sd: args.nhc.zip(nhc_sd_factor).map(|(sd, f)| sd * f),
        loglik_start: start,
        loglik,
        evaluations: evaluations.get(),
        axes,
        model: scaled_axes(&args.model, &f),
    })
}
