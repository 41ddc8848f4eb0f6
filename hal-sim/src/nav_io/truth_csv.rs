//! Truth CSV (simulation): `t,lat,lon,h,vn,ve,vd,roll,pitch,yaw` and optionally
//! `bg_x,bg_y,bg_z,ba_x,ba_y,ba_z` (README "Strapdown INS/GNSS formats"): time [s], geodetic
//! latitude and longitude [deg], ellipsoidal height [m], NED velocity [m/s], the body (FRD)
//! attitude relative to NED as roll, pitch, yaw [deg] (z-y-x sequence), the true gyro bias
//! [rad/s] and accelerometer bias [m/s^2] along the body axes. Position and velocity are those
//! of the body origin.

use super::table::{finite, read_file, read_from, split3, triple, Timed};
use anyhow::Result;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One truth row.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct TruthRow {
    /// Time [s].
    pub t: f64,
    /// Geodetic latitude [deg].
    pub lat_deg: f64,
    /// Longitude [deg].
    pub lon_deg: f64,
    /// Ellipsoidal height [m].
    pub h: f64,
    /// Velocity north, east, down [m/s].
    pub vel_ned: [f64; 3],
    /// Roll, pitch, yaw of the body relative to NED [deg].
    pub rpy_deg: [f64; 3],
    /// Gyro bias, body axes [rad/s].
    pub gyro_bias: Option<[f64; 3]>,
    /// Accelerometer bias, body axes [m/s^2].
    pub accel_bias: Option<[f64; 3]>,
}

/// Required columns.
pub const REQUIRED: [&str; 10] = [
    "t", "lat", "lon", "h", "vn", "ve", "vd", "roll", "pitch", "yaw",
];

#[derive(Serialize, Deserialize)]
struct Row {
    t: Option<f64>,
    lat: Option<f64>,
    lon: Option<f64>,
    h: Option<f64>,
    vn: Option<f64>,
    ve: Option<f64>,
    vd: Option<f64>,
    roll: Option<f64>,
    pitch: Option<f64>,
    yaw: Option<f64>,
    #[serde(default)]
    bg_x: Option<f64>,
    #[serde(default)]
    bg_y: Option<f64>,
    #[serde(default)]
    bg_z: Option<f64>,
    #[serde(default)]
    ba_x: Option<f64>,
    #[serde(default)]
    ba_y: Option<f64>,
    #[serde(default)]
    ba_z: Option<f64>,
}

impl Timed for TruthRow {
    fn time(&self) -> f64 {
        self.t
    }
}

fn row(file: &str, line: u64, r: Row) -> Result<TruthRow> {
    let f = |c: &str, v: Option<f64>| finite(file, line, c, v);
    let row = TruthRow {
        t: f("t", r.t)?,
        lat_deg: f("lat", r.lat)?,
        lon_deg: f("lon", r.lon)?,
        h: f("h", r.h)?,
        vel_ned: [f("vn", r.vn)?, f("ve", r.ve)?, f("vd", r.vd)?],
        rpy_deg: [f("roll", r.roll)?, f("pitch", r.pitch)?, f("yaw", r.yaw)?],
        gyro_bias: triple(
            file,
            line,
            ["bg_x", "bg_y", "bg_z"],
            [r.bg_x, r.bg_y, r.bg_z],
        )?,
        accel_bias: triple(
            file,
            line,
            ["ba_x", "ba_y", "ba_z"],
            [r.ba_x, r.ba_y, r.ba_z],
        )?,
    };
    Ok(row)
}

/// Reads a truth CSV; errors name the file, the line and the column.
pub fn read_truth_csv(path: &Path) -> Result<Vec<TruthRow>> {
    read_file(path, "truth CSV", &REQUIRED, row)
}

/// [`read_truth_csv`] from any reader; `file` names it in errors.
pub fn read_truth_csv_from<R: std::io::Read>(reader: R, file: &str) -> Result<Vec<TruthRow>> {
    read_from(reader, file, &REQUIRED, row)
}

/// Writes a truth CSV atomically; the bias columns are empty where a row has none.
pub fn write_truth_csv(path: &Path, rows: &[TruthRow]) -> Result<()> {
    let rows: Vec<Row> = rows
        .iter()
        .map(|r| {
            let [bg_x, bg_y, bg_z] = split3(r.gyro_bias);
            let [ba_x, ba_y, ba_z] = split3(r.accel_bias);
            Row {
                t: Some(r.t),
                lat: Some(r.lat_deg),
                lon: Some(r.lon_deg),
                h: Some(r.h),
                vn: Some(r.vel_ned[0]),
                ve: Some(r.vel_ned[1]),
                vd: Some(r.vel_ned[2]),
                roll: Some(r.rpy_deg[0]),
                pitch: Some(r.rpy_deg[1]),
                yaw: Some(r.rpy_deg[2]),
                bg_x,
                bg_y,
                bg_z,
                ba_x,
                ba_y,
                ba_z,
            }
        })
        .collect();
    crate::output::write_csv(path, &rows)
}
