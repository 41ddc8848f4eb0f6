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
//! At the answer kept, the Cramér-Rao standard deviation of every coordinate searched comes
//! from the curvature of the log-likelihood ([`super::information::cramer_rao_sd`], the online
//! search's), and a coordinate whose sd exceeds [`IDENTIFIABLE_SD`] decade is flagged "not
//! identifiable from this log" ([`Uncertainty`]): a factor at a bound or on a flat likelihood
//! is where the search stopped, not a measurement. The search's answer lies on its grid
//! (0.125 decade, of the order of the sds or far above them), so it is then moved to the
//! maximum by Newton steps ([`super::information::refine`]): the curvature measured again at
//! steps of one sd where the likelihood is sharper than the grid, each step kept when its run
//! raises the likelihood, the sds those of the point kept. Each coordinate then gets its 95 %
//! likelihood interval, measured by runs along the profile's path under that Hessian
//! ([`super::interval`], about four runs per coordinate where the likelihood is near a
//! quadratic): the Cramér-Rao interval assumes the quadratic, and has nothing to say about a
//! factor at its bound, which the data may still bound on the other side.
//!
//! [`EpochRecord`]: super::EpochRecord

use super::interval::{likelihood_interval, LikelihoodInterval, LEVEL_95};
use super::{run_with, NavArgs};
use crate::nav_io::{GnssFix, ImuSample};
use anyhow::Result;
use imu_ident::model::{Component, ComponentKind};
use imu_ident::nav::ImuErrorModel;
use serde::Serialize;
use statrs::distribution::{ChiSquared, ContinuousCDF};

pub use imu_ident::nav::online::IDENTIFIABLE_SD;

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
pub const SHIFT_PER_DECADE: f64 = 0.1;
/// Largest IMU time shift searched [s].
pub const MAX_SHIFT: f64 = 0.5;

/// Number of IMU factors (gyro white, accelerometer white, gyro bias walk, accelerometer bias
/// walk: the first four of [`FACTORS`]).
const IMU: usize = 4;

/// The per-axis stage of `--identify-axes`: the four IMU factors untied over x, y, z and
/// searched again from the tied answer; kept when the likelihood ratio says so. The test's
/// answers, both on the search's grid: when the per-axis one is kept, [`Identified`] is it
/// after the Newton steps.
#[derive(Debug, Clone, Serialize)]
pub struct AxesFit {
    /// Factors per axis (x, y, z) of the four IMU quantities (the first four of [`FACTORS`];
    /// a quantity the model does not carry stays at its tied factor).
    pub factors: [[f64; 3]; IMU],
    /// The per-axis fit's factors on the GNSS position and velocity standard deviations.
    pub gnss_sd_factors: [f64; 2],
    /// The per-axis fit's IMU time shift, `--imu-time-shift` included [s].
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
    /// kept, the IMU factors are the geometric means of [`Identified::axis_factors`] over the
    /// axes).
    pub factors: [f64; 6],
    /// The identified model's IMU factors per axis (x, y, z) of the first four of [`FACTORS`]:
    /// equal over the axes when tied.
    pub axis_factors: [[f64; 3]; IMU],
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
    /// What the Newton steps off the search's grid gained [nats] (included in `loglik`), or,
    /// when none raised the likelihood, the change at the last tried (negative; the grid
    /// answer is kept); `None` when the curvature gave no step (no concave direction).
    pub newton_nats: Option<f64>,
    /// Runs of the filter made (both stages).
    pub evaluations: usize,
    /// The Cramér-Rao standard deviation of every coordinate searched, at the answer kept (the
    /// per-axis one's coordinates when it was kept); the finite-difference Hessian costs
    /// `n (n + 3) / 2` more runs for `n` coordinates, and the Newton steps about `2 n + 1`
    /// each ([`super::information::refine`]).
    pub uncertainty: Vec<Uncertainty>,
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
        answer_args(
            args,
            self.model.clone(),
            [self.factors[4], self.factors[5]],
            self.imu_time_shift,
            self.nhc_sd_factor,
        )
    }

    /// One line for the terminal: the factors, the shift, the constraint, the likelihoods.
    pub fn summary_line(&self) -> String {
        format!(
            "identified: factors {:?} ({}), IMU time shift {:+.4} s, constraint sd {:?} m/s, loglik {:.1} -> {:.1} (Newton step off the grid {}) in {} runs",
            self.factors,
            FACTORS.join(", "),
            self.imu_time_shift,
            self.nhc_sd,
            self.loglik_start,
            self.loglik,
            self.newton_nats.map_or("none".to_string(), |v| format!(
                "{v:+.2} nats, {}",
                if v > 0.0 { "kept" } else { "not kept" }
            )),
            self.evaluations
        ) + &{
            let flat: Vec<&str> = self
                .uncertainty
                .iter()
                .filter(|u| !u.identifiable)
                .map(|u| u.name.as_str())
                .collect();
            if flat.is_empty() {
                String::new()
            } else {
                format!(
                    "\nnot identifiable from this log (Cramér-Rao sd above {IDENTIFIABLE_SD} decade): {}",
                    flat.join(", ")
                )
            }
        } + &format!(
            "\n95 % likelihood intervals (log10 factors; shift [s]; < and > mark an end at the search's bound): {}",
            self.uncertainty
                .iter()
                .map(|u| u.interval_text())
                .collect::<Vec<_>>()
                .join(", ")
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
        answer_args(
            args,
            scaled_axes(&args.model, &self.factors),
            self.gnss_sd_factors,
            self.imu_time_shift,
            self.nhc_sd_factor,
        )
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

/// How `--identify` treats the three axes of each sensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axes {
    /// One factor per quantity and sensor (the default).
    Tied,
    /// Tied, then untied and tested (`--identify-axes`, [`AxesFit`]).
    Tested,
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

    /// The factors on the GNSS position and velocity standard deviations.
    fn gnss_factors(&self) -> [f64; 2] {
        self.gnss.map(|l| 10f64.powf(l))
    }

    /// The factor on the constraint's standard deviation (with `--nhc`).
    fn nhc_factor(&self, args: &NavArgs) -> Option<f64> {
        args.nhc.map(|_| 10f64.powf(self.nhc))
    }

    /// The IMU time shift, `--imu-time-shift` included [s].
    fn imu_time_shift(&self, args: &NavArgs) -> f64 {
        args.imu_time_shift + self.shift * SHIFT_PER_DECADE
    }

    /// The options of the run at this point (gate off: the search's).
    fn args(&self, args: &NavArgs) -> NavArgs {
        NavArgs {
            gate: None,
            ..answer_args(
                args,
                scaled_axes(&args.model, &self.imu_factors()),
                self.gnss_factors(),
                self.imu_time_shift(args),
                self.nhc_factor(args),
            )
        }
    }
}

/// `args` with an answer's model, factors on the GNSS standard deviations, IMU time shift
/// (`--imu-time-shift` included) and factor on the constraint's sd: the options of its run.
fn answer_args(
    args: &NavArgs,
    model: ImuErrorModel<f64>,
    gnss_factors: [f64; 2],
    imu_time_shift: f64,
    nhc_factor: Option<f64>,
) -> NavArgs {
    NavArgs {
        model,
        gnss_sd_factor: [
            args.gnss_sd_factor[0] * gnss_factors[0],
            args.gnss_sd_factor[1] * gnss_factors[1],
        ],
        imu_time_shift,
        nhc: args.nhc.zip(nhc_factor).map(|(sd, f)| sd * f),
        ..args.clone()
    }
}

/// The search's coordinates: the IMU log-factors (tied: one per quantity; per axis: three,
/// quantity-major), then the two GNSS log-factors, the constraint's and the time shift.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Layout {
    Tied,
    PerAxis,
}

impl Layout {
    /// Number of IMU coordinates.
    fn imu(self) -> usize {
        match self {
            Layout::Tied => IMU,
            Layout::PerAxis => 3 * IMU,
        }
    }

    /// Quantity of IMU coordinate `i` (< [`Self::imu`]).
    fn quantity(self, i: usize) -> usize {
        match self {
            Layout::Tied => i,
            Layout::PerAxis => i / 3,
        }
    }

    /// The point at coordinates `x`.
    fn point(self, x: &[f64]) -> Point {
        let n = self.imu();
        Point {
            imu: std::array::from_fn(|q| match self {
                Layout::Tied => [x[q]; 3],
                Layout::PerAxis => std::array::from_fn(|a| x[3 * q + a]),
            }),
            gnss: [x[n], x[n + 1]],
            nhc: x[n + 2],
            shift: x[n + 3],
        }
    }

    /// The coordinates of `p` (tied: a tied point's, each quantity's x-axis value).
    fn coordinates(self, p: &Point) -> Vec<f64> {
        let mut x: Vec<f64> = match self {
            Layout::Tied => p.imu.iter().map(|q| q[0]).collect(),
            Layout::PerAxis => p.imu.iter().flatten().copied().collect(),
        };
        x.extend([p.gnss[0], p.gnss[1], p.nhc, p.shift]);
        x
    }

    /// Coordinate `i`'s name (`gyro_white`, `gyro_white_x`, `gnss_pos_sd`, `constraint_sd`,
    /// `imu_time_shift`).
    fn name(self, i: usize) -> String {
        let n = self.imu();
        match i {
            _ if i < n => match self {
                Layout::Tied => FACTORS[i].to_string(),
                Layout::PerAxis => format!("{}_{}", FACTORS[i / 3], ["x", "y", "z"][i % 3]),
            },
            _ if i < n + 2 => FACTORS[IMU + i - n].to_string(),
            _ if i == n + 2 => "constraint_sd".to_string(),
            _ => "imu_time_shift".to_string(),
        }
    }

    /// Coordinate `i`'s interval under `args` (`None`: not searched): a factor on a quantity
    /// the model does not carry, or on the constraint without `--nhc`, is left out.
    fn bounds(self, i: usize, args: &NavArgs, carried: &[bool; IMU]) -> Option<(f64, f64)> {
        let n = self.imu();
        let shift = MAX_SHIFT / SHIFT_PER_DECADE;
        match i {
            _ if i < n && !carried[self.quantity(i)] => None,
            _ if i == n + 2 && args.nhc.is_none() => None,
            _ if i == n + 3 => Some((-shift, shift)),
            _ => Some((-2.0, 3.0)),
        }
    }
}

/// The Cramér-Rao standard deviation of one identified coordinate.
#[derive(Debug, Clone, Serialize)]
pub struct Uncertainty {
    /// The coordinate: a factor of [`FACTORS`] (per axis with `_x`, `_y`, `_z`),
    /// `constraint_sd` or `imu_time_shift`.
    pub name: String,
    /// Its identified value: the base-10 logarithm of the factor, or the shift [s].
    pub value: f64,
    /// Its Cramér-Rao standard deviation, in the same unit (decades, or s); `null` where the
    /// likelihood does not bound it (flat, or the maximum at a bound).
    pub cr_sd: Option<f64>,
    /// The sd is at most [`IDENTIFIABLE_SD`] decades (for the shift, that many times
    /// [`SHIFT_PER_DECADE`] s): the data determine it. `false` is the flag "not identifiable
    /// from this log".
    pub identifiable: bool,
    /// The 95 % likelihood interval, in the same unit ([`super::interval`]): where the
    /// log-likelihood has fallen by [`LEVEL_95`] nats, measured by runs; open on a side the
    /// data do not bound within the search's bounds. It is skewed where the likelihood is not
    /// quadratic, and it exists where the Cramér-Rao sd does not (a factor at a bound).
    pub interval_95: LikelihoodInterval,
}

/// A rise above the answer along an interval's path worth a word [nats]: the chi-square(1)
/// 0.5 quantile over two, below which the answer is as good as the point found.
pub const ABOVE_NOTED: f64 = 0.227;

impl Uncertainty {
    /// `name [lo, hi]`, an end at the search's bound written `<lo` or `>hi`.
    pub fn interval_text(&self) -> String {
        let v = &self.interval_95;
        format!(
            "{} [{}{:+.4}, {}{:+.4}]{}",
            self.name,
            if v.lo_open { "<" } else { "" },
            v.lo,
            if v.hi_open { ">" } else { "" },
            v.hi,
            if v.above_nats > ABOVE_NOTED {
                format!(" (a run {:.1} nats above the answer)", v.above_nats)
            } else {
                String::new()
            }
        )
    }
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
    // Stage 1, tied, from the model as given.
    let tied = Layout::Tied;
    let mut x = tied.coordinates(&Point::default());
    let start = eval(&tied.point(&x))?;
    let mut best = start;
    super::pattern::maximise(
        &mut x,
        &mut best,
        &[1.0, 0.5, 0.25, 0.125],
        6,
        &|i| tied.bounds(i, args, &carried),
        &[],
        &mut |y| eval(&tied.point(y)),
    )?;
    let mut layout = tied;
    let mut point = tied.point(&x);
    let mut loglik = best;
    let axes = if axes == Axes::Tested {
        // Stage 2, per axis, from the tied answer, at the finer steps.
        let per_axis = Layout::PerAxis;
        let mut y = per_axis.coordinates(&point);
        let before = evaluations.get();
        let mut best_axes = best;
        super::pattern::maximise(
            &mut y,
            &mut best_axes,
            &[0.5, 0.25, 0.125],
            6,
            &|i| per_axis.bounds(i, args, &carried),
            &[],
            &mut |z| eval(&per_axis.point(z)),
        )?;
        let df = 2 * carried.iter().filter(|&&c| c).count();
        let threshold_nats = if df == 0 {
            f64::INFINITY
        } else {
            0.5 * ChiSquared::new(df as f64)?.inverse_cdf(0.99)
        };
        let gain_nats = best_axes - best;
        let significant = gain_nats > threshold_nats;
        let fit = per_axis.point(&y);
        if significant {
            layout = per_axis;
            point = fit;
            loglik = best_axes;
        }
        Some(AxesFit {
            factors: fit.imu_factors(),
            gnss_sd_factors: fit.gnss_factors(),
            imu_time_shift: fit.imu_time_shift(args),
            nhc_sd_factor: fit.nhc_factor(args),
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
    // The answer kept, moved off the search's grid to the maximum by Newton steps, with its
    // Cramér-Rao sds, in its own coordinates.
    let mut x = layout.coordinates(&point);
    let bounds = |i: usize| layout.bounds(i, args, &carried);
    let refined = super::information::refine(&x, loglik, &bounds, &mut |y| eval(&layout.point(y)))?;
    let sd = &refined.sd;
    let newton_nats = refined.newton_nats;
    if refined.f > loglik {
        loglik = refined.f;
        point = layout.point(&refined.x);
        x = refined.x.clone();
    }
    let uncertainty = (0..x.len())
        .filter(|&i| bounds(i).is_some())
        .map(|i| {
            let interval = likelihood_interval(
                &x,
                loglik,
                i,
                refined.covariance.as_ref(),
                sd[i].is_finite().then_some(sd[i]),
                LEVEL_95,
                &bounds,
                &mut |y| eval(&layout.point(y)),
            )?;
            let shift = i + 1 == x.len();
            let unit = if shift { SHIFT_PER_DECADE } else { 1.0 };
            let offset = if shift { args.imu_time_shift } else { 0.0 };
            let cr_sd = sd[i].is_finite().then_some(sd[i] * unit);
            Ok(Uncertainty {
                name: layout.name(i),
                value: x[i] * unit + offset,
                cr_sd,
                identifiable: cr_sd.is_some_and(|v| v <= IDENTIFIABLE_SD * unit),
                interval_95: LikelihoodInterval {
                    lo: interval.lo * unit + offset,
                    hi: interval.hi * unit + offset,
                    ..interval
                },
            })
        })
        .collect::<Result<_>>()?;
    // The factors: a per-axis answer's IMU factors as their geometric means over the axes.
    let mean = |q: usize| 10f64.powf(point.imu[q].iter().sum::<f64>() / 3.0);
    let factors: [f64; 6] = std::array::from_fn(|i| match i {
        q if q < IMU => mean(q),
        g => point.gnss_factors()[g - IMU],
    });
    let nhc_sd_factor = point.nhc_factor(args);
    Ok(Identified {
        factors,
        axis_factors: point.imu_factors(),
        imu_time_shift: point.imu_time_shift(args),
        nhc_sd_factor,
        nhc_sd: args.nhc.zip(nhc_sd_factor).map(|(sd, f)| sd * f),
        loglik_start: start,
        loglik,
        newton_nats,
        evaluations: evaluations.get(),
        axes,
        uncertainty,
        model: scaled_axes(&args.model, &point.imu_factors()),
    })
}
