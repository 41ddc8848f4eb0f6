//! `hal-sim nav --truth TRUTH.csv` (simulation): the navigation errors at every GNSS epoch
//! against the truth, written to `errors.csv`, and their statistics in `summary.json`
//! (`truth`): RMS and fraction outside 3 sigma per axis, and the NEES of the nine navigation
//! errors with its 99 % chi-square bands.
//!
//! Errors are computed minus true, the filter's convention (`imu_ident::nav::error_model`):
//! position `dp` N, E, D [m] (`dp_D = -(h^ - h)`) at the epoch time `t` (the record's solution
//! is moved back to `t`); velocity [m/s] and attitude at the solution time `t_sol` (the IMU
//! sample at or just after `t`). The truth is interpolated linearly between its rows (yaw
//! across +-180 deg by its shorter way); epochs outside the truth's time span are left out.
//!
//! Attitude: `phi` from `C^ C^T = I + [phi x]` (the skew part of `C^ C^T`), and roll, pitch,
//! yaw differences (yaw wrapped into (-180, 180]) with their sigmas from the covariance of
//! `phi`: `d(roll, pitch, yaw) = M^-1 phi`, `M = [C_z C_y e_x, C_z e_y, e_z]` (the z-y-x
//! sequence), so `cov = M^-1 P_phi M^-T`.
//!
//! NEES: `e^T P^-1 e` of the nine errors `e = (phi, dv, dp)` against the filter's 9x9
//! covariance of them ([`EpochRecord::p_nav`]); chi-square with 9 degrees of freedom per epoch
//! for a consistent filter. Its per-epoch 99 % band is `[chi2_9(0.005), chi2_9(0.995)] = [1.735,
//! 23.59]`; the mean over `n` epochs has the band `[chi2_9n(0.005), chi2_9n(0.995)] / n`, exact
//! for independent epochs only: successive epochs are correlated over the filter's time
//! constants (tens to hundreds of seconds), so that band is far too narrow for a long run. The
//! summary therefore also gives the band for the effective number of independent epochs
//! `n_eff = n / (1 + 2 sum_k rho_k)`, `rho_k` the sample autocorrelation of the NEES series at
//! lag `k` summed up to its first non-positive value (the initial positive sequence), i.e.
//! `chi2_{9 n_eff}(0.005, 0.995) / n_eff`: the approximate band of a consistent filter.
//! Epochs before the heading is known are left out of the statistics (their yaw is not an
//! estimate), not out of `errors.csv`.

use super::records::{EpochRecord, NAV_ERRORS};
use crate::allan::chi2_quantile;
use crate::nav_io::outages::north_east;
use crate::nav_io::TruthRow;
use anyhow::{bail, Result};
use imu_ident::strapdown::Quat;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use serde::Serialize;
use std::path::Path;

/// Degrees of freedom of the per-epoch NEES.
pub const NEES_DOF: usize = NAV_ERRORS;

/// The errors at one GNSS epoch (one row of `errors.csv`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ErrorRow {
    /// Epoch [s].
    pub t: f64,
    /// Withheld by the outage schedule.
    pub withheld: u8,
    /// Fused.
    pub fused: u8,
    /// Heading known (the epoch counts in the statistics).
    pub heading_known: u8,
    /// Position error N, E, D [m].
    pub err_n: f64,
    /// East [m].
    pub err_e: f64,
    /// Down [m].
    pub err_d: f64,
    /// Velocity error N, E, D [m/s].
    pub err_vn: f64,
    /// East [m/s].
    pub err_ve: f64,
    /// Down [m/s].
    pub err_vd: f64,
    /// Roll, pitch, yaw errors [deg] (yaw wrapped).
    pub err_roll: f64,
    /// Pitch [deg].
    pub err_pitch: f64,
    /// Yaw [deg].
    pub err_yaw: f64,
    /// Filter 1-sigma of the position errors [m].
    pub sd_n: f64,
    /// East [m].
    pub sd_e: f64,
    /// Down [m].
    pub sd_d: f64,
    /// Filter 1-sigma of the velocity errors [m/s].
    pub sd_vn: f64,
    /// East [m/s].
    pub sd_ve: f64,
    /// Down [m/s].
    pub sd_vd: f64,
    /// Filter 1-sigma of the roll, pitch, yaw errors [deg].
    pub sd_roll: f64,
    /// Pitch [deg].
    pub sd_pitch: f64,
    /// Yaw [deg].
    pub sd_yaw: f64,
    /// Attitude error `phi` N, E, D [deg].
    pub phi_n: f64,
    /// East [deg].
    pub phi_e: f64,
    /// Down [deg].
    pub phi_d: f64,
    /// NEES of the nine navigation errors (NaN: covariance not positive definite).
    pub nees: f64,
    /// Estimated minus true gyro error, body x, y, z [rad/s] (NaN: no truth biases).
    pub err_bg_x: f64,
    /// y [rad/s].
    pub err_bg_y: f64,
    /// z [rad/s].
    pub err_bg_z: f64,
    /// Estimated minus true accelerometer error, body x, y, z [m/s^2].
    pub err_ba_x: f64,
    /// y [m/s^2].
    pub err_ba_y: f64,
    /// z [m/s^2].
    pub err_ba_z: f64,
}

impl ErrorRow {
    /// Position, velocity and roll/pitch/yaw errors (9, in `errors.csv` order).
    pub fn errors(&self) -> [f64; 9] {
        [
            self.err_n,
            self.err_e,
            self.err_d,
            self.err_vn,
            self.err_ve,
            self.err_vd,
            self.err_roll,
            self.err_pitch,
            self.err_yaw,
        ]
    }

    /// Their 1-sigma (same order).
    pub fn sigmas(&self) -> [f64; 9] {
        [
            self.sd_n,
            self.sd_e,
            self.sd_d,
            self.sd_vn,
            self.sd_ve,
            self.sd_vd,
            self.sd_roll,
            self.sd_pitch,
            self.sd_yaw,
        ]
    }
}

/// `summary.json` `truth`: statistics over the epochs with truth and a known heading.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TruthSummary {
    /// Epochs in the statistics.
    pub epochs: usize,
    /// Epochs outside the truth's time span (not in `errors.csv`).
    pub epochs_without_truth: usize,
    /// Epochs before the heading was known (in `errors.csv`, not in the statistics).
    pub epochs_before_heading: usize,
    /// RMS position error N, E, D [m].
    pub rms_pos_m: [f64; 3],
    /// RMS horizontal position error [m].
    pub rms_horizontal_m: f64,
    /// RMS velocity error N, E, D [m/s].
    pub rms_vel_m_s: [f64; 3],
    /// RMS roll, pitch, yaw error [deg].
    pub rms_att_deg: [f64; 3],
    /// Fraction of epochs with `|error| > 3 sigma`, position N, E, D (0.0027 expected).
    pub outside_3sigma_pos: [f64; 3],
    /// Velocity N, E, D.
    pub outside_3sigma_vel: [f64; 3],
    /// Roll, pitch, yaw.
    pub outside_3sigma_att: [f64; 3],
    /// Degrees of freedom of the per-epoch NEES (9).
    pub nees_dof: usize,
    /// Epochs with a finite NEES.
    pub nees_epochs: usize,
    /// Mean NEES (9 for a consistent filter).
    pub nees_mean: f64,
    /// 99 % band of the mean NEES of independent epochs: `chi2_9n(0.005, 0.995) / n`.
    pub nees_band99_mean: [f64; 2],
    /// Effective number of independent epochs of the NEES series (module docs).
    pub nees_n_effective: f64,
    /// 99 % band of the mean NEES over `nees_n_effective` independent epochs.
    pub nees_band99_effective: [f64; 2],
    /// 99 % band of one epoch's NEES: `chi2_9(0.005, 0.995)`.
    pub nees_band99_epoch: [f64; 2],
    /// Fraction of epochs whose NEES is outside `nees_band99_epoch` (0.01 expected).
    pub nees_outside_epoch_band: f64,
    /// `nees_mean` inside `nees_band99_mean` (independent epochs: rarely true on long runs).
    pub nees_inside_band99_mean: bool,
    /// `nees_mean` inside `nees_band99_effective`: the consistency verdict.
    pub nees_consistent: bool,
}

impl TruthSummary {
    /// The largest 3-sigma fraction of the 9 navigation errors (position, velocity, attitude).
    pub fn worst_outside_3sigma(&self) -> f64 {
        self.outside_3sigma_pos
            .iter()
            .chain(&self.outside_3sigma_vel)
            .chain(&self.outside_3sigma_att)
            .cloned()
            .fold(0.0, f64::max)
    }
}

/// `errors.csv` rows and their statistics.
#[derive(Debug, Clone)]
pub struct TruthComparison {
    /// One row per epoch inside the truth's span.
    pub rows: Vec<ErrorRow>,
    /// Statistics.
    pub summary: TruthSummary,
}

/// `a` wrapped into (-180, 180] [deg].
pub fn wrap_deg(a: f64) -> f64 {
    let w = a.rem_euclid(360.0);
    if w > 180.0 {
        w - 360.0
    } else {
        w
    }
}

/// The truth at `t`, interpolated linearly (yaw by the shorter way); `None` outside its span.
pub fn truth_at(truth: &[TruthRow], t: f64) -> Option<TruthRow> {
    let k = truth.partition_point(|r| r.t < t);
    let b = *truth.get(k)?;
    if b.t == t {
        return Some(b);
    }
    let a = *truth.get(k.checked_sub(1)?)?;
    let u = (t - a.t) / (b.t - a.t);
    let lerp = |x: f64, y: f64| x + u * (y - x);
    let lerp3 = |x: [f64; 3], y: [f64; 3]| [lerp(x[0], y[0]), lerp(x[1], y[1]), lerp(x[2], y[2])];
    let opt3 = |x: Option<[f64; 3]>, y: Option<[f64; 3]>| x.zip(y).map(|(x, y)| lerp3(x, y));
    let mut rpy = lerp3(a.rpy_deg, b.rpy_deg);
    rpy[2] = wrap_deg(a.rpy_deg[2] + u * wrap_deg(b.rpy_deg[2] - a.rpy_deg[2]));
    Some(TruthRow {
        t,
        lat_deg: lerp(a.lat_deg, b.lat_deg),
        lon_deg: lerp(a.lon_deg, b.lon_deg),
        h: lerp(a.h, b.h),
        vel_ned: lerp3(a.vel_ned, b.vel_ned),
        rpy_deg: rpy,
        gyro_bias: opt3(a.gyro_bias, b.gyro_bias),
        accel_bias: opt3(a.accel_bias, b.accel_bias),
    })
}

fn dcm(rpy_deg: [f64; 3]) -> Matrix3<f64> {
    let [r, p, y] = rpy_deg.map(f64::to_radians);
    Quat::from_euler(r, p, y).dcm()
}

/// `phi` [rad] with `C(est) = (I + [phi x]) C(true)` (the skew part of `C(est) C(true)^T`).
pub fn phi_error(est_rpy_deg: [f64; 3], true_rpy_deg: [f64; 3]) -> Vector3<f64> {
    let e = dcm(est_rpy_deg) * dcm(true_rpy_deg).transpose();
    0.5 * Vector3::new(e.m32 - e.m23, e.m13 - e.m31, e.m21 - e.m12)
}

/// `M` with `phi = M d(roll, pitch, yaw)` at the angles `rpy_deg` (z-y-x sequence).
fn euler_to_phi(rpy_deg: [f64; 3]) -> Matrix3<f64> {
    let [_, p, y] = rpy_deg.map(f64::to_radians);
    let (sp, cp, sy, cy) = (p.sin(), p.cos(), y.sin(), y.cos());
    Matrix3::new(cy * cp, -sy, 0.0, sy * cp, cy, 0.0, -sp, 0.0, 1.0)
}

/// The 99 % two-sided chi-square band of the mean of `n` independent chi-square(`dof`) values.
pub fn mean_band99(dof: usize, n: usize) -> [f64; 2] {
    mean_band99_real(dof, n as f64)
}

/// [`mean_band99`] for a real (effective) `n > 0`.
pub fn mean_band99_real(dof: usize, n: f64) -> [f64; 2] {
    let n = n.max(1e-9);
    let nu = dof as f64 * n;
    let q = |p: f64| chi2_quantile(p, nu).unwrap_or(f64::NAN) / n;
    [q(0.005), q(0.995)]
}

/// Effective number of independent values of a correlated series: `n / (1 + 2 sum rho_k)`,
/// summed over the initial positive sequence of the sample autocorrelation (at most `n / 2`
/// lags); between 1 and `n`.
pub fn n_effective(x: &[f64]) -> f64 {
    let n = x.len();
    if n < 3 {
        return n as f64;
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let d: Vec<f64> = x.iter().map(|v| v - mean).collect();
    let c0 = d.iter().map(|v| v * v).sum::<f64>();
    if c0 <= 0.0 {
        return n as f64;
    }
    let mut sum = 0.0;
    for k in 1..n / 2 {
        let rho = d[..n - k]
            .iter()
            .zip(&d[k..])
            .map(|(a, b)| a * b)
            .sum::<f64>()
            / c0;
        if rho <= 0.0 {
            break;
        }
        sum += rho;
    }
    (n as f64 / (1.0 + 2.0 * sum)).clamp(1.0, n as f64)
}

/// The errors of one epoch against the truth (`None` outside the truth's span).
fn epoch_errors(e: &EpochRecord, truth: &[TruthRow]) -> Option<ErrorRow> {
    let tp = truth_at(truth, e.t)?;
    let t_sol = if e.t_sol.is_finite() { e.t_sol } else { e.t };
    let tv = truth_at(truth, t_sol)?;
    let ne = north_east(tp.lat_deg, tp.lon_deg, tp.h, e.lat_deg, e.lon_deg);
    let dp = Vector3::new(ne[0], ne[1], -(e.h - tp.h));
    let dv = Vector3::from(e.vel) - Vector3::from(tv.vel_ned);
    let phi = phi_error(e.rpy_deg, tv.rpy_deg);
    let x = SVector::<f64, 9>::from_iterator(phi.iter().chain(dv.iter()).chain(dp.iter()).copied());
    let p = SMatrix::<f64, 9, 9>::from_fn(|i, j| e.p_nav[i][j]);
    let nees = p.cholesky().map_or(f64::NAN, |c| x.dot(&c.solve(&x)));
    let m_inv = euler_to_phi(tv.rpy_deg).try_inverse();
    let p_phi = p.fixed_view::<3, 3>(0, 0).into_owned();
    let sd_euler = m_inv.map_or([f64::NAN; 3], |mi| {
        let c = mi * p_phi * mi.transpose();
        [0, 1, 2].map(|i| c[(i, i)].max(0.0).sqrt().to_degrees())
    });
    let d_euler = [0, 1, 2].map(|i| wrap_deg(e.rpy_deg[i] - tv.rpy_deg[i]));
    let bias = |est: [f64; 3], tru: Option<[f64; 3]>| {
        tru.map_or([f64::NAN; 3], |b| [0, 1, 2].map(|i| est[i] - b[i]))
    };
    let ebg = bias(e.bg, tv.gyro_bias);
    let eba = bias(e.ba, tv.accel_bias);
    Some(ErrorRow {
        t: e.t,
        withheld: e.withheld.into(),
        fused: e.fused.into(),
        heading_known: e.heading_known.into(),
        err_n: dp.x,
        err_e: dp.y,
        err_d: dp.z,
        err_vn: dv.x,
        err_ve: dv.y,
        err_vd: dv.z,
        err_roll: d_euler[0],
        err_pitch: d_euler[1],
        err_yaw: d_euler[2],
        sd_n: e.sd_pos[0],
        sd_e: e.sd_pos[1],
        sd_d: e.sd_pos[2],
        sd_vn: e.sd_vel[0],
        sd_ve: e.sd_vel[1],
        sd_vd: e.sd_vel[2],
        sd_roll: sd_euler[0],
        sd_pitch: sd_euler[1],
        sd_yaw: sd_euler[2],
        phi_n: phi.x.to_degrees(),
        phi_e: phi.y.to_degrees(),
        phi_d: phi.z.to_degrees(),
        nees,
        err_bg_x: ebg[0],
        err_bg_y: ebg[1],
        err_bg_z: ebg[2],
        err_ba_x: eba[0],
        err_ba_y: eba[1],
        err_ba_z: eba[2],
    })
}

/// Compares every epoch with the truth; an error when no epoch falls in the truth's span.
pub fn compare(epochs: &[EpochRecord], truth: &[TruthRow], file: &str) -> Result<TruthComparison> {
    let rows: Vec<ErrorRow> = epochs
        .iter()
        .filter_map(|e| epoch_errors(e, truth))
        .collect();
    let stats: Vec<&ErrorRow> = rows.iter().filter(|r| r.heading_known == 1).collect();
    if stats.is_empty() {
        let span = truth.first().zip(truth.last()).map(|(a, b)| (a.t, b.t));
        bail!(
            "--truth {file}: no GNSS epoch with a known heading inside the truth's time span {span:?} ({} of {} epochs inside)",
            rows.len(),
            epochs.len()
        );
    }
    let n = stats.len() as f64;
    let mut rms = [0.0; 9];
    let mut out = [0.0; 9];
    for r in &stats {
        for (i, (x, s)) in r.errors().iter().zip(r.sigmas()).enumerate() {
            rms[i] += x * x / n;
            if x.abs() > 3.0 * s {
                out[i] += 1.0 / n;
            }
        }
    }
    let rms = rms.map(f64::sqrt);
    let nees: Vec<f64> = stats
        .iter()
        .map(|r| r.nees)
        .filter(|x| x.is_finite())
        .collect();
    let m = nees.len();
    let band_epoch = mean_band99(NEES_DOF, 1);
    let nees_mean = nees.iter().sum::<f64>() / m.max(1) as f64;
    let band_mean = mean_band99(NEES_DOF, m);
    let n_eff = n_effective(&nees);
    let band_eff = mean_band99_real(NEES_DOF, n_eff);
    let inside = |b: [f64; 2]| m > 0 && nees_mean >= b[0] && nees_mean <= b[1];
    let pick = |v: &[f64; 9], k: usize| [v[k], v[k + 1], v[k + 2]];
    let summary = TruthSummary {
        epochs: stats.len(),
        epochs_without_truth: epochs.len() - rows.len(),
        epochs_before_heading: rows.len() - stats.len(),
        rms_pos_m: pick(&rms, 0),
        rms_horizontal_m: rms[0].hypot(rms[1]),
        rms_vel_m_s: pick(&rms, 3),
        rms_att_deg: pick(&rms, 6),
        outside_3sigma_pos: pick(&out, 0),
        outside_3sigma_vel: pick(&out, 3),
        outside_3sigma_att: pick(&out, 6),
        nees_dof: NEES_DOF,
        nees_epochs: m,
        nees_mean,
        nees_band99_mean: band_mean,
        nees_n_effective: n_eff,
        nees_band99_effective: band_eff,
        nees_band99_epoch: band_epoch,
        nees_outside_epoch_band: nees
            .iter()
            .filter(|x| **x < band_epoch[0] || **x > band_epoch[1])
            .count() as f64
            / m.max(1) as f64,
        nees_inside_band99_mean: inside(band_mean),
        nees_consistent: inside(band_eff),
    };
    Ok(TruthComparison { rows, summary })
}

/// Compares `run` with the truth read from `path` and puts the statistics into its summary.
pub fn attach(run: &mut super::NavRun, truth: &[TruthRow], path: &Path) -> Result<TruthComparison> {
    let c = compare(&run.epochs, truth, &path.display().to_string())?;
    run.summary.truth = Some(c.summary.clone());
    Ok(c)
}

/// Writes `errors.csv`.
pub fn write_errors_csv(path: &Path, rows: &[ErrorRow]) -> Result<()> {
    crate::output::write_csv(path, rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phi_matches_the_euler_differences_through_m() {
        let t = [3.0, -4.0, 170.0];
        let d = [0.01, -0.02, 0.03];
        let est = [t[0] + d[0], t[1] + d[1], t[2] + d[2]];
        let phi = phi_error(est, t);
        let lin = euler_to_phi(t) * Vector3::from(d.map(f64::to_radians));
        assert!((phi - lin).norm() < 1e-3 * lin.norm(), "{phi} vs {lin}");
    }

    #[test]
    fn nees_bands_are_the_chi_square_quantiles() {
        let b = mean_band99(9, 1);
        assert!(
            (b[0] - 1.735).abs() < 1e-3 && (b[1] - 23.589).abs() < 1e-3,
            "{b:?}"
        );
        let b = mean_band99(9, 1000);
        assert!(b[0] > 8.6 && b[1] < 9.4, "{b:?}");
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(16);
        let white: Vec<f64> = (0..1000).map(|_| rng.gen::<f64>()).collect();
        assert!(n_effective(&white) > 500.0);
        let slow: Vec<f64> = (0..1000).map(|k| (k as f64 / 100.0).sin()).collect();
        assert!(n_effective(&slow) < 50.0);
        assert_eq!(wrap_deg(190.0), -170.0);
        assert_eq!(wrap_deg(-180.0), 180.0);
    }
}
