//! GNSS CSV: `t,lat,lon,h,vn,ve,vd,sd_n,sd_e,sd_d,sd_vn,sd_ve,sd_vd` (README "Strapdown INS/GNSS
//! formats"): time [s, GPS time since 1980-01-06 for real data], geodetic WGS84 latitude and
//! longitude [deg], ellipsoidal height [m], NED velocity [m/s], and the standard deviations of
//! the position [m] and velocity [m/s] along north, east, down. The velocity and the two sd
//! groups are optional, each as a group of three (all three cells filled, or all three empty or
//! `NaN`); the columns may be absent altogether. Positions are those of the antenna.

use super::table::{finite, read_file, read_from, split3, triple, Timed};
use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One GNSS fix.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct GnssFix {
    /// Time [s].
    pub t: f64,
    /// Geodetic latitude, WGS84 [deg].
    pub lat_deg: f64,
    /// Longitude [deg].
    pub lon_deg: f64,
    /// Ellipsoidal height [m].
    pub h: f64,
    /// Velocity north, east, down [m/s].
    pub vel_ned: Option<[f64; 3]>,
    /// Position standard deviation north, east, down [m].
    pub sd_pos_ned: Option<[f64; 3]>,
    /// Velocity standard deviation north, east, down [m/s].
    pub sd_vel_ned: Option<[f64; 3]>,
}

/// Required columns.
pub const REQUIRED: [&str; 4] = ["t", "lat", "lon", "h"];

#[derive(Serialize, Deserialize)]
struct Row {
    t: Option<f64>,
    lat: Option<f64>,
    lon: Option<f64>,
    h: Option<f64>,
    #[serde(default)]
    vn: Option<f64>,
    #[serde(default)]
    ve: Option<f64>,
    #[serde(default)]
    vd: Option<f64>,
    #[serde(default)]
    sd_n: Option<f64>,
    #[serde(default)]
    sd_e: Option<f64>,
    #[serde(default)]
    sd_d: Option<f64>,
    #[serde(default)]
    sd_vn: Option<f64>,
    #[serde(default)]
    sd_ve: Option<f64>,
    #[serde(default)]
    sd_vd: Option<f64>,
}

impl Timed for GnssFix {
    fn time(&self) -> f64 {
        self.t
    }
}

fn row(file: &str, line: u64, r: Row) -> Result<GnssFix> {
    let lat = finite(file, line, "lat", r.lat)?;
    if lat.abs() > 90.0 {
        bail!("{file} line {line}, column lat: {lat} is not a latitude in degrees");
    }
    let sd = |cols: [&str; 3], v: [Option<f64>; 3]| -> Result<Option<[f64; 3]>> {
        let s = triple(file, line, cols, v)?;
        if let Some(s) = s {
            if let Some(k) = (0..3).find(|&k| s[k] < 0.0) {
                bail!(
                    "{file} line {line}, column {}: a standard deviation cannot be negative ({})",
                    cols[k],
                    s[k]
                );
            }
        }
        Ok(s)
    };
    let fix = GnssFix {
        t: finite(file, line, "t", r.t)?,
        lat_deg: lat,
        lon_deg: finite(file, line, "lon", r.lon)?,
        h: finite(file, line, "h", r.h)?,
        vel_ned: triple(file, line, ["vn", "ve", "vd"], [r.vn, r.ve, r.vd])?,
        sd_pos_ned: sd(["sd_n", "sd_e", "sd_d"], [r.sd_n, r.sd_e, r.sd_d])?,
        sd_vel_ned: sd(["sd_vn", "sd_ve", "sd_vd"], [r.sd_vn, r.sd_ve, r.sd_vd])?,
    };
    Ok(fix)
}

/// Reads a GNSS CSV; errors name the file, the line and the column.
pub fn read_gnss_csv(path: &Path) -> Result<Vec<GnssFix>> {
    read_file(path, "GNSS CSV", &REQUIRED, row)
}

/// [`read_gnss_csv`] from any reader; `file` names it in errors.
pub fn read_gnss_csv_from<R: std::io::Read>(reader: R, file: &str) -> Result<Vec<GnssFix>> {
    read_from(reader, file, &REQUIRED, row)
}

/// Writes a GNSS CSV atomically, all thirteen columns; a missing group is left empty.
pub fn write_gnss_csv(path: &Path, fixes: &[GnssFix]) -> Result<()> {
    let rows: Vec<Row> = fixes
        .iter()
        .map(|f| {
            let [vn, ve, vd] = split3(f.vel_ned);
            let [sd_n, sd_e, sd_d] = split3(f.sd_pos_ned);
            let [sd_vn, sd_ve, sd_vd] = split3(f.sd_vel_ned);
            Row {
                t: Some(f.t),
                lat: Some(f.lat_deg),
                lon: Some(f.lon_deg),
                h: Some(f.h),
                vn,
                ve,
                vd,
                sd_n,
                sd_e,
                sd_d,
                sd_vn,
                sd_ve,
                sd_vd,
            }
        })
        .collect();
    crate::output::write_csv(path, &rows)
}
