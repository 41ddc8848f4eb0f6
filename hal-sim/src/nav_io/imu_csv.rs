//! IMU CSV: `t,gx,gy,gz,ax,ay,az` (README "Strapdown INS/GNSS formats"). `t` in seconds of GPS
//! time since 1980-01-06 ([`super::gpst`]) for real data (any consistent scale for simulated
//! data), angular rate in rad/s and specific force in m/s^2, both in the body frame
//! forward-right-down. Columns are found by name in any order; others are ignored.

use super::table::{finite, read_file, read_from, Timed};
use anyhow::Result;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One IMU sample.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ImuSample {
    /// Time [s].
    pub t: f64,
    /// Angular rate, body FRD [rad/s].
    pub gyro: [f64; 3],
    /// Specific force, body FRD [m/s^2] (at rest about (0, 0, -9.8): it points up).
    pub accel: [f64; 3],
}

/// Column names, in the order the writer puts them.
pub const COLUMNS: [&str; 7] = ["t", "gx", "gy", "gz", "ax", "ay", "az"];

#[derive(Serialize, Deserialize)]
struct Row {
    t: Option<f64>,
    gx: Option<f64>,
    gy: Option<f64>,
    gz: Option<f64>,
    ax: Option<f64>,
    ay: Option<f64>,
    az: Option<f64>,
}

impl Timed for ImuSample {
    fn time(&self) -> f64 {
        self.t
    }
}

fn row(file: &str, line: u64, r: Row) -> Result<ImuSample> {
    let f = |c: &str, v: Option<f64>| finite(file, line, c, v);
    let s = ImuSample {
        t: f("t", r.t)?,
        gyro: [f("gx", r.gx)?, f("gy", r.gy)?, f("gz", r.gz)?],
        accel: [f("ax", r.ax)?, f("ay", r.ay)?, f("az", r.az)?],
    };
    Ok(s)
}

/// Reads an IMU CSV. Every cell must be a finite number and `t` must increase; errors name the
/// file, the line and the column.
pub fn read_imu_csv(path: &Path) -> Result<Vec<ImuSample>> {
    read_file(path, "IMU CSV", &COLUMNS, row)
}

/// [`read_imu_csv`] from any reader; `file` names it in errors.
pub fn read_imu_csv_from<R: std::io::Read>(reader: R, file: &str) -> Result<Vec<ImuSample>> {
    read_from(reader, file, &COLUMNS, row)
}

/// Writes an IMU CSV atomically (shortest round-trip decimal form of every value).
pub fn write_imu_csv(path: &Path, samples: &[ImuSample]) -> Result<()> {
    let rows: Vec<Row> = samples
        .iter()
        .map(|s| Row {
            t: Some(s.t),
            gx: Some(s.gyro[0]),
            gy: Some(s.gyro[1]),
            gz: Some(s.gyro[2]),
            ax: Some(s.accel[0]),
            ay: Some(s.accel[1]),
            az: Some(s.accel[2]),
        })
        .collect();
    crate::output::write_csv(path, &rows)
}
