//! Writers of the strapdown CSV formats (README, "Strapdown formats"). The readers live in
//! `hal_sim::nav_io`; the column names here are the contract.

use super::errors::{ImuErrorModel, ImuErrors};
use super::gnss::{GnssConfig, GnssFix, GnssSim};
use super::profile::Profile;
use super::truth::{TruthGen, TruthSample};
use crate::output::write_csv;
use anyhow::Result;
use imu_ident::strapdown::Geodetic;
use serde::Serialize;
use std::path::Path;

/// IMU CSV row: mean body (FRD) rates [rad/s] and specific force [m/s^2] over `(t - dt, t]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ImuRow {
    pub t: f64,
    pub gx: f64,
    pub gy: f64,
    pub gz: f64,
    pub ax: f64,
    pub ay: f64,
    pub az: f64,
}

/// Truth CSV row: angles in degrees, heights in metres, velocities NED in m/s, and the true
/// sensor biases (every non-white error component) [rad/s, m/s^2].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TruthRow {
    pub t: f64,
    pub lat: f64,
    pub lon: f64,
    pub h: f64,
    pub vn: f64,
    pub ve: f64,
    pub vd: f64,
    pub roll: f64,
    pub pitch: f64,
    pub yaw: f64,
    pub bg_x: f64,
    pub bg_y: f64,
    pub bg_z: f64,
    pub ba_x: f64,
    pub ba_y: f64,
    pub ba_z: f64,
}

/// GNSS CSV row: position (deg, deg, m), NED velocity (m/s) and their stated standard
/// deviations (m, m/s).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GnssRow {
    pub t: f64,
    pub lat: f64,
    pub lon: f64,
    pub h: f64,
    pub vn: f64,
    pub ve: f64,
    pub vd: f64,
    pub sd_n: f64,
    pub sd_e: f64,
    pub sd_d: f64,
    pub sd_vn: f64,
    pub sd_ve: f64,
    pub sd_vd: f64,
}

impl From<&GnssFix> for GnssRow {
    fn from(f: &GnssFix) -> Self {
        Self {
            t: f.t,
            lat: f.pos.lat.to_degrees(),
            lon: f.pos.lon.to_degrees(),
            h: f.pos.h,
            vn: f.vel.x,
            ve: f.vel.y,
            vd: f.vel.z,
            sd_n: f.sd_pos[0],
            sd_e: f.sd_pos[1],
            sd_d: f.sd_pos[2],
            sd_vn: f.sd_vel[0],
            sd_ve: f.sd_vel[1],
            sd_vd: f.sd_vel[2],
        }
    }
}

/// A simulated drive: the three files' rows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Drive {
    /// IMU rows (from `t = dt`).
    pub imu: Vec<ImuRow>,
    /// Truth rows (from `t = 0`; the biases of row `k` are those of IMU interval `k`).
    pub truth: Vec<TruthRow>,
    /// GNSS rows.
    pub gnss: Vec<GnssRow>,
}

fn truth_row(s: &TruthSample, bg: [f64; 3], ba: [f64; 3]) -> TruthRow {
    TruthRow {
        t: s.t,
        lat: s.pos.lat.to_degrees(),
        lon: s.pos.lon.to_degrees(),
        h: s.pos.h,
        vn: s.vel.x,
        ve: s.vel.y,
        vd: s.vel.z,
        roll: s.euler[0].to_degrees(),
        pitch: s.euler[1].to_degrees(),
        yaw: s.euler[2].to_degrees(),
        bg_x: bg[0],
        bg_y: bg[1],
        bg_z: bg[2],
        ba_x: ba[0],
        ba_y: ba[1],
        ba_z: ba[2],
    }
}

/// Simulates a drive along `profile` from `start` at IMU interval `dt`: sensor errors seeded
/// with `seed`, GNSS noise with `seed + 1`.
pub fn simulate_drive(
    profile: &Profile,
    start: Geodetic,
    dt: f64,
    errors: &ImuErrorModel,
    gnss: GnssConfig,
    seed: u64,
) -> Result<Drive> {
    let mut sensor = ImuErrors::new(errors, dt, seed)?;
    let mut fixes = GnssSim::new(gnss, seed.wrapping_add(1))?;
    let mut drive = Drive::default();
    for s in TruthGen::new(profile, start, dt)? {
        let (bg, ba) = if s.t > 0.0 {
            let (m, e) = sensor.corrupt(&s.inc, dt);
            drive.imu.push(ImuRow {
                t: s.t,
                gx: m.dtheta.x / dt,
                gy: m.dtheta.y / dt,
                gz: m.dtheta.z / dt,
                ax: m.dv.x / dt,
                ay: m.dv.y / dt,
                az: m.dv.z / dt,
            });
            (e.gyro_bias.into(), e.accel_bias.into())
        } else {
            ([0.0; 3], [0.0; 3])
        };
        drive.truth.push(truth_row(&s, bg, ba));
        if let Some(f) = fixes.offer(&s) {
            drive.gnss.push(GnssRow::from(&f));
        }
    }
    Ok(drive)
}

/// Writes `imu.csv`, `truth.csv` and `gnss.csv` in `dir`.
pub fn write_drive(dir: &Path, drive: &Drive) -> Result<()> {
    write_csv(&dir.join("imu.csv"), &drive.imu)?;
    write_csv(&dir.join("truth.csv"), &drive.truth)?;
    write_csv(&dir.join("gnss.csv"), &drive.gnss)
}

/// The logs of a drive as `hal-sim nav` reads them: the simulation written into `dir`
/// ([`write_drive`]) and read back through `nav_io` (IMU samples, GNSS fixes, truth rows), so
/// that a bench runs on exactly what the command would see.
pub type DriveLogs = (
    Vec<crate::nav_io::ImuSample>,
    Vec<crate::nav_io::GnssFix>,
    Vec<crate::nav_io::TruthRow>,
);

/// Writes `drive` into `dir` and reads it back ([`DriveLogs`]).
pub fn write_and_read_drive(dir: &Path, drive: &Drive) -> Result<DriveLogs> {
    write_drive(dir, drive)?;
    Ok((
        crate::nav_io::read_imu_csv(&dir.join("imu.csv"))?,
        crate::nav_io::read_gnss_csv(&dir.join("gnss.csv"))?,
        crate::nav_io::read_truth_csv(&dir.join("truth.csv"))?,
    ))
}

/// Where the simulated drives start (`simulate-drive`, the navigation tests and benches):
/// 45 deg N, 7 deg E, 300 m.
pub fn course_start() -> Geodetic {
    Geodetic {
        lat: 45f64.to_radians(),
        lon: 7f64.to_radians(),
        h: 300.0,
    }
}

/// `simulate-drive`: the figure-eight course of [`Profile::figure_eight_course`] (aircraft
/// banking) for `hours` from 45 N 7 E, 300 m, at `rate_hz`, with the [`ImuErrorModel::mems`]
/// errors and default 1-Hz GNSS with the given outage windows, its antenna at `lever_arm` from
/// the IMU (body forward, right, down [m]); writes the three files in `out`. Returns the
/// numbers of IMU and GNSS rows.
pub fn simulate_drive_files(
    hours: f64,
    rate_hz: f64,
    seed: u64,
    (outages, lever_arm): (Vec<(f64, f64)>, [f64; 3]),
    out: &Path,
) -> Result<(usize, usize)> {
    if !(hours.is_finite() && hours > 0.0 && rate_hz.is_finite() && rate_hz > 0.0) {
        anyhow::bail!("--hours and --rate must be positive");
    }
    let profile = Profile::figure_eight_course(hours, 1.0)?;
    let start = course_start();
    let gnss = GnssConfig {
        outages,
        lever_arm,
        ..GnssConfig::default()
    };
    let drive = simulate_drive(
        &profile,
        start,
        1.0 / rate_hz,
        &ImuErrorModel::mems(),
        gnss,
        seed,
    )?;
    write_drive(out, &drive)?;
    Ok((drive.imu.len(), drive.gnss.len()))
}

/// Parses an outage window `START:END` [s].
pub fn parse_outage(s: &str) -> Result<(f64, f64)> {
    let (a, b) = s
        .split_once(':')
        .ok_or_else(|| anyhow::anyhow!("outage `{s}`: expected START:END in seconds"))?;
    let (a, b): (f64, f64) = (a.trim().parse()?, b.trim().parse()?);
    if !(a.is_finite() && b.is_finite() && b > a) {
        anyhow::bail!("outage `{s}`: END must exceed START");
    }
    Ok((a, b))
}
