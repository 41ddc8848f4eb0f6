//! The real RTKLIB drive (`../shared/data/real/rtklib-drive-0708`) ready for a run: imported
//! into a folder (`import-drive`) and the run's options as `scripts/real-drive.sh` sets them.
//! The tests of the host and of the firmware read it through this one function.

use super::NavArgs;
use crate::nav_io::drive::{import, DriveImport};
use crate::nav_io::{read_gnss_csv, read_imu_csv, GnssFix, ImuSample, OutageSpec};
use crate::shared_data::{present, real_dir};
use anyhow::Result;
use std::path::Path;

/// A drive ready for a run: the run's options, the IMU samples, the fixes.
pub type Drive = (NavArgs, Vec<ImuSample>, Vec<GnssFix>);

/// The drive imported into `dir` and read: the run's options (the datasheet model, the data's
/// outage test `40,15,45,30`, the antenna's lever arm, the constraint's point at the body
/// origin), the IMU samples and the fixes. `None` (printed) when the data are missing, except
/// under `CI=true`, where that panics ([`present`]).
pub fn drive_0708(dir: &Path) -> Result<Option<Drive>> {
    let d = real_dir().join("rtklib-drive-0708");
    let (imu, tag, pos) = (
        d.join("imu_1934.csv"),
        d.join("imu_1934.csv.tag"),
        d.join("gnss_1934_sf.pos"),
    );
    if !present(&[&imu, &tag, &pos]) {
        return Ok(None);
    }
    let meta = import(&DriveImport::drive_0708(imu, tag, pos, dir.to_path_buf()))?;
    let samples = read_imu_csv(&dir.join("imu.csv"))?;
    let fixes = read_gnss_csv(&dir.join("gnss.csv"))?;
    let args = NavArgs {
        outages: Some("40,15,45,30".parse::<OutageSpec>()?),
        lever_arm: meta.antenna_from_imu,
        // The body origin from the IMU (the IMU is 0.65 m above it).
        nhc_lever: meta.import.imu_lever.map(|x| 0.0 - x),
        ..NavArgs::new(
            dir.join("imu.csv"),
            dir.join("gnss.csv"),
            super::model::load("drive-datasheet")?,
            "drive-datasheet",
        )
    };
    Ok(Some((args, samples, fixes)))
}
