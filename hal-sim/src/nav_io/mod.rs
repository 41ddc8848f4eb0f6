//! Host I/O of the strapdown INS/GNSS work (README "Strapdown INS/GNSS formats"): readers and
//! writers of the pinned IMU, GNSS and truth CSV files, RTKLIB `.pos` solution files (read and
//! written), the import of the real RTKLIB drive (`hal-sim import-drive`), the GNSS outage
//! schedule of `--outages` and the horizontal error at the end of each outage.
//!
//! Time scale everywhere: GPS time in seconds since the GPS epoch, 1980-01-06 00:00:00 GPST
//! ([`gpst`]); no leap seconds, continuous across GPS week roll-overs.

pub mod drive;
pub mod gnss_csv;
pub mod gpst;
pub mod imu_csv;
pub mod outages;
pub mod rtklib_pos;
mod table;
pub mod truth_csv;
pub mod ubx;

pub use gnss_csv::{read_gnss_csv, write_gnss_csv, GnssFix};
pub use imu_csv::{read_imu_csv, write_imu_csv, ImuSample};
pub use outages::{score_outages, OutageScore, OutageSpec, OutageSummary};
pub use rtklib_pos::{read_pos, write_solution_pos, PosEpoch, PosFile};
pub use truth_csv::{read_truth_csv, write_truth_csv, TruthRow};

use anyhow::Result;
use std::path::Path;

/// Reads IMU samples from an IMU CSV, or from a byte stream (`.bin` or `.ubx`: the navigator's
/// serial wire, [`ubx::read_wire_imu`]), by extension.
pub fn read_imu_any(path: &Path) -> Result<Vec<ImuSample>> {
    if is_stream(path) {
        ubx::read_wire_imu(path)
    } else {
        read_imu_csv(path)
    }
}

/// A byte stream by its extension: `.ubx` (a u-blox log) or `.bin` (the navigator's serial
/// wire, which carries the receiver's messages too).
fn is_stream(path: &Path) -> bool {
    let ext = |x: &str| path.extension().is_some_and(|e| e.eq_ignore_ascii_case(x));
    ext("ubx") || ext("bin")
}

/// Reads GNSS fixes from a GNSS CSV, from an RTKLIB `.pos` file (by extension `.pos`),
/// keeping the epochs with quality `1 <= Q <= max_q` (1 fix, 2 float, ... 5 single), or from a
/// u-blox UBX log or a serial wire (`.ubx`, `.bin`: [`ubx::read_ubx`]; what it left out is
/// noted on stderr).
pub fn read_gnss_any(path: &Path, max_q: u8) -> Result<Vec<GnssFix>> {
    let ext = |x: &str| path.extension().is_some_and(|e| e.eq_ignore_ascii_case(x));
    if ext("pos") {
        Ok(read_pos(path)?.fixes(max_q))
    } else if is_stream(path) {
        let (fixes, c) = ubx::read_ubx(path, None)?;
        if c != Default::default() {
            eprintln!(
                "note: {}: {} fixes; left out {} solutions without a 3D fix, {} before the GPS \
                 week, {} messages with a bad checksum or length",
                path.display(),
                fixes.len(),
                c.no_fix,
                c.no_week,
                c.ubx_rejected
            );
        }
        Ok(fixes)
    } else {
        read_gnss_csv(path)
    }
}
