//! `hal-sim import-drive`: the real RTKLIB drive (`../shared/data/real/rtklib-drive-0708`,
//! rtklibexplorer/GNSS_IMU) into the pinned formats: `imu.csv`, `gnss.csv`, `meta.json`.
//!
//! What the source does, and this import does the same way (read from its Python, rewritten):
//! - the IMU CSV has no header, `ax,ay,az` [g], `gx,gy,gz` [deg/s], `tick` [ms since the IMU
//!   powered up]; its first and last lines are skipped;
//! - the `.tag` file (see [`read_tag`]) gives the GPST start of the log and the tick of its last
//!   record; sample `i` is at `start + (tick_i - tick_0) (tick_last_tag / 1000) / (tick_n -
//!   tick_0)`: the tick sum is stretched so the samples span exactly the tag's duration;
//! - a constant offset (`-0.125 s`, "logging delay") is added to every IMU time;
//! - the IMU axes go to the body frame (forward-right-down) through `v_body = C v_imu`, `C =
//!   R1(roll) R2(pitch) R3(yaw)` with `R1, R2, R3` the elementary coordinate-transformation
//!   matrices (Groves' `Euler_to_CTM`, eq. 2.22: the transpose of the body-to-NED direction
//!   cosine matrix of the same angles), and the angles the element-wise SUM of the mounting
//!   `[180, 0, 180]` deg and the misalignment `[0, -6.79, 5.35]` deg (the source adds the two
//!   angle triples, it does not compose two rotations). `[180, 0, 180]` alone is `diag(-1, 1,
//!   -1)`: the IMU's x points backwards and its z up.
//!
//! Not done here: the source's converter also low-pass filters the IMU (zero-phase, 10 Hz, 5 Hz
//! vertical) and its filter scales g by the local gravity; here the samples are raw and 1 g is
//! `--g` (default 9.80665 m/s^2, the standard gravity a MEMS datasheet's "g" means).

use super::gnss_csv::write_gnss_csv;
use super::gpst;
use super::imu_csv::{write_imu_csv, ImuSample};
use super::rtklib_pos::{q, read_pos};
use anyhow::{anyhow, bail, Context, Result};
use nalgebra::{Matrix3, Rotation3, Vector3};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The `.tag` file of an RTKLIB-logged stream.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TagFile {
    /// The 60-byte header text, zeros removed (`TIMETAG RTKLIB demo5`).
    pub header: String,
    /// The `u32` after the header (not used by the source either).
    pub tick_f: u32,
    /// Start time [s since 1980-01-06 GPST].
    pub start: f64,
    /// Number of `(tick, offset)` records.
    pub records: usize,
    /// Tick of the last record [ms since logging started].
    pub last_tick_ms: u32,
    /// Bytes after the last whole record (ignored, as the source does).
    pub trailing_bytes: usize,
}

/// Reads a `.tag` file (little-endian): a 60-byte text header, a `u32` not used, the GPST start
/// as a `u32` of whole seconds since 1970-01-01 (a GPST label read as a Unix time: no leap
/// seconds) plus an `f64` fraction of a second, then 8-byte records `u32 tick [ms since logging
/// started], u32 file offset` to the end.
pub fn read_tag(path: &Path) -> Result<TagFile> {
    let file = path.display().to_string();
    let b = std::fs::read(path).with_context(|| format!("reading time tags {file}"))?;
    const HEAD: usize = 60 + 4 + 4 + 8;
    if b.len() < HEAD + 8 {
        bail!("{file}: {} bytes, too short for a time-tag file (a {HEAD}-byte header and at least one 8-byte record)", b.len());
    }
    let u32_at = |o: usize| u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
    let header: String = b[..60]
        .iter()
        .take_while(|&&c| c != 0)
        .map(|&c| char::from(c))
        .collect();
    if !header.starts_with("TIMETAG") {
        bail!("{file} byte 0: expected a header starting with TIMETAG, found {header:?}");
    }
    let frac = f64::from_le_bytes(b[68..76].try_into()?);
    if !(0.0..1.0).contains(&frac) {
        bail!("{file} byte 68: the fraction of the start second must be in [0, 1), found {frac}");
    }
    let records = (b.len() - HEAD) / 8;
    let last = HEAD + (records - 1) * 8;
    Ok(TagFile {
        header,
        tick_f: u32_at(60),
        start: gpst::from_unix_label(u32_at(64), frac),
        records,
        last_tick_ms: u32_at(last),
        trailing_bytes: (b.len() - HEAD) % 8,
    })
}

/// One line of the logger's IMU CSV, in its units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawImu {
    /// Specific force, IMU axes [g].
    pub accel_g: [f64; 3],
    /// Angular rate, IMU axes [deg/s].
    pub gyro_dps: [f64; 3],
    /// Milliseconds since power-up.
    pub tick_ms: u64,
}

/// Reads the logger's header-less IMU CSV (`ax,ay,az,gx,gy,gz,tick`), skipping the first and
/// the last line as the source does. Ticks must increase.
pub fn read_raw_imu(path: &Path) -> Result<Vec<RawImu>> {
    let file = path.display().to_string();
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .trim(csv::Trim::All)
        .from_path(path)
        .with_context(|| format!("opening IMU log {file}"))?;
    const NAMES: [&str; 7] = ["ax", "ay", "az", "gx", "gy", "gz", "tick"];
    let mut out: Vec<RawImu> = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            anyhow!("{file} line {line}: malformed CSV record: {e}")
        })?;
        let line = rec.position().map_or(0, |p| p.line());
        if rec.len() < 7 {
            bail!(
                "{file} line {line}: expected 7 fields ax,ay,az,gx,gy,gz,tick, found {}",
                rec.len()
            );
        }
        let mut v = [0.0; 6];
        for k in 0..6 {
            v[k] = rec[k]
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    anyhow!(
                        "{file} line {line}, field {}: expected a finite number, found {:?}",
                        NAMES[k],
                        &rec[k]
                    )
                })?;
        }
        let tick: u64 = rec[6].parse().map_err(|_| {
            anyhow!(
                "{file} line {line}, field tick: expected an integer number of ms, found {:?}",
                &rec[6]
            )
        })?;
        out.push(RawImu {
            accel_g: [v[0], v[1], v[2]],
            gyro_dps: [v[3], v[4], v[5]],
            tick_ms: tick,
        });
        if let [.., p, c] = &out[..] {
            if c.tick_ms <= p.tick_ms {
                bail!(
                    "{file} line {line}, field tick: {} does not increase (previous {})",
                    c.tick_ms,
                    p.tick_ms
                );
            }
        }
    }
    if out.len() < 4 {
        bail!(
            "{file}: {} lines; need at least 4 (the first and last are skipped)",
            out.len()
        );
    }
    out.pop();
    out.remove(0);
    Ok(out)
}

/// The IMU-to-body matrix `C = R1(roll) R2(pitch) R3(yaw)` [rad] (module documentation): the
/// transpose of nalgebra's `from_euler_angles`, which is `Rz(yaw) Ry(pitch) Rx(roll)`.
pub fn imu_to_body(rpy: [f64; 3]) -> Matrix3<f64> {
    Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2])
        .matrix()
        .transpose()
}

/// Options of the import (defaults: the `drive_0708` configuration of the source).
#[derive(Debug, Clone, Serialize)]
pub struct DriveImport {
    /// Logger IMU CSV.
    pub imu: PathBuf,
    /// Its `.tag` file.
    pub tag: PathBuf,
    /// RTKLIB `.pos` solution.
    pub pos: PathBuf,
    /// Output folder.
    pub out: PathBuf,
    /// Mounting roll, pitch, yaw [deg].
    pub mount_deg: [f64; 3],
    /// Misalignment roll, pitch, yaw [deg], added to the mounting angles.
    pub misalign_deg: [f64; 3],
    /// Added to every IMU time [s].
    pub imu_time_offset: f64,
    /// 1 g [m/s^2].
    pub g: f64,
    /// Keep `.pos` epochs with `1 <= Q <= max_q` in `gnss.csv`.
    pub max_q: u8,
    /// IMU position from the body origin, forward-right-down [m].
    pub imu_lever: [f64; 3],
    /// Antenna position from the body origin, forward-right-down [m].
    pub antenna_lever: [f64; 3],
}

impl DriveImport {
    /// The drive's configuration with these files.
    pub fn drive_0708(imu: PathBuf, tag: PathBuf, pos: PathBuf, out: PathBuf) -> Self {
        Self {
            imu,
            tag,
            pos,
            out,
            mount_deg: [180.0, 0.0, 180.0],
            misalign_deg: [0.0, -6.79, 5.35],
            imu_time_offset: -0.125,
            g: 9.806_65,
            max_q: q::FLOAT,
            imu_lever: [0.0, 0.0, -0.65],
            antenna_lever: [0.0, -0.05, -0.65],
        }
    }
}

/// Datasheet-style noise of the drive's IMU (TDK ICM-45686), from the source's configuration.
#[derive(Debug, Clone, Serialize)]
pub struct NoiseFacts {
    /// Gyro angle random walk [rad/s/sqrt(Hz)] (0.0038 deg/s/sqrt(Hz)).
    pub gyro_white_rad_s_sqrt_hz: f64,
    /// Accelerometer velocity random walk [m/s^2/sqrt(Hz)] (70 ug/sqrt(Hz)).
    pub accel_white_m_s2_sqrt_hz: f64,
    /// Accelerometer bias random walk [m/s^3/sqrt(Hz)] (7 ug/s/sqrt(Hz)).
    pub accel_bias_rw_m_s3_sqrt_hz: f64,
    /// Gyro bias random walk [rad/s^2/sqrt(Hz)] (3.8e-5 deg/s^2/sqrt(Hz)).
    pub gyro_bias_rw_rad_s2_sqrt_hz: f64,
    /// Where the numbers come from.
    pub source: &'static str,
}

/// `meta.json`.
#[derive(Debug, Clone, Serialize)]
pub struct DriveMeta {
    /// The time scale of `t` in `imu.csv` and `gnss.csv`.
    pub time_scale: &'static str,
    /// The options used.
    pub import: DriveImport,
    /// The sum of mounting and misalignment angles [deg] that built the matrix.
    pub imu_to_body_rpy_deg: [f64; 3],
    /// `C` (rows), `v_body = C v_imu`.
    pub imu_to_body_matrix: [[f64; 3]; 3],
    /// Antenna minus IMU, body forward-right-down [m].
    pub antenna_from_imu: [f64; 3],
    /// The time-tag file.
    pub tag: TagFile,
    /// IMU start before the offset, as a GPST date.
    pub imu_start_gpst: String,
    /// IMU samples written.
    pub imu_samples: usize,
    /// First and last IMU time written [s].
    pub imu_t: [f64; 2],
    /// Span of the IMU times [s].
    pub imu_span: f64,
    /// Mean sample interval [s].
    pub imu_dt_mean: f64,
    /// Stretch of the tick clock onto GPST (tag span over tick span).
    pub tick_scale: f64,
    /// Epochs in the `.pos` file, and how many of them are fixed (Q=1) and float (Q=2).
    pub pos_epochs: usize,
    /// Fixed epochs.
    pub pos_fixed: usize,
    /// Float epochs.
    pub pos_float: usize,
    /// Epochs written to `gnss.csv`.
    pub gnss_epochs: usize,
    /// First and last `.pos` epoch [s], and as GPST dates.
    pub gnss_t: [f64; 2],
    /// First `.pos` epoch as a GPST date.
    pub gnss_start_gpst: String,
    /// IMU start (before the offset) minus the first GNSS epoch [s].
    pub imu_start_after_gnss: f64,
    /// The datasheet noise.
    pub noise: NoiseFacts,
}

/// The drive's noise facts (README of the data: values and conversions).
pub fn noise_facts() -> NoiseFacts {
    const G0: f64 = 9.806_65;
    NoiseFacts {
        gyro_white_rad_s_sqrt_hz: 0.0038_f64.to_radians(),
        accel_white_m_s2_sqrt_hz: 70e-6 * G0,
        accel_bias_rw_m_s3_sqrt_hz: 7e-6 * G0,
        gyro_bias_rw_rad_s2_sqrt_hz: 3.8e-5_f64.to_radians(),
        source: "rtklibexplorer/GNSS_IMU src/drive_config.py (datasheet-style values, before its hand-chosen factors)",
    }
}

/// The imported IMU samples (SI, body FRD, GPST seconds with the offset) and what was measured.
pub fn convert_imu(
    raw: &[RawImu],
    tag: &TagFile,
    c: &Matrix3<f64>,
    offset: f64,
    g: f64,
) -> Result<(Vec<ImuSample>, f64)> {
    let (Some(first), Some(last)) = (raw.first(), raw.last()) else {
        bail!("no IMU samples");
    };
    let span_ticks = (last.tick_ms - first.tick_ms) as f64 / 1000.0;
    if span_ticks <= 0.0 || tag.last_tick_ms == 0 {
        bail!("IMU ticks or time tags span no time");
    }
    let scale = f64::from(tag.last_tick_ms) / 1000.0 / span_ticks;
    let samples = raw
        .iter()
        .map(|r| {
            let rel = (r.tick_ms - first.tick_ms) as f64 / 1000.0;
            let f = c * Vector3::from(r.accel_g) * g;
            let w = c * Vector3::from(r.gyro_dps.map(f64::to_radians));
            ImuSample {
                t: tag.start + rel * scale + offset,
                gyro: [w.x, w.y, w.z],
                accel: [f.x, f.y, f.z],
            }
        })
        .collect();
    Ok((samples, scale))
}

/// Runs the import: writes `imu.csv`, `gnss.csv` and `meta.json` into `opt.out`.
pub fn import(opt: &DriveImport) -> Result<DriveMeta> {
    if !(opt.g.is_finite() && opt.g > 0.0 && opt.imu_time_offset.is_finite()) {
        bail!("--g must be positive and --imu-time-offset finite");
    }
    let tag = read_tag(&opt.tag)?;
    let raw = read_raw_imu(&opt.imu)?;
    let pos = read_pos(&opt.pos)?;
    let rpy_deg: [f64; 3] = std::array::from_fn(|k| opt.mount_deg[k] + opt.misalign_deg[k]);
    let c = imu_to_body(rpy_deg.map(f64::to_radians));
    let (imu, tick_scale) = convert_imu(&raw, &tag, &c, opt.imu_time_offset, opt.g)
        .with_context(|| format!("{} with {}", opt.imu.display(), opt.tag.display()))?;
    let gnss = pos.fixes(opt.max_q);
    let (Some(p0), Some(p1)) = (pos.epochs.first(), pos.epochs.last()) else {
        bail!("{}: no solution epochs", opt.pos.display());
    };
    std::fs::create_dir_all(&opt.out).with_context(|| format!("creating {}", opt.out.display()))?;
    write_imu_csv(&opt.out.join("imu.csv"), &imu)?;
    write_gnss_csv(&opt.out.join("gnss.csv"), &gnss)?;
    let (i0, i1) = (imu[0].t, imu[imu.len() - 1].t);
    let meta = DriveMeta {
        time_scale: "GPS time, seconds since 1980-01-06 00:00:00 GPST (no leap seconds)",
        import: opt.clone(),
        imu_to_body_rpy_deg: rpy_deg,
        imu_to_body_matrix: std::array::from_fn(|i| std::array::from_fn(|j| c[(i, j)])),
        antenna_from_imu: std::array::from_fn(|k| opt.antenna_lever[k] - opt.imu_lever[k]),
        imu_start_gpst: gpst::to_calendar(tag.start).unwrap_or_default(),
        imu_samples: imu.len(),
        imu_t: [i0, i1],
        imu_span: i1 - i0,
        imu_dt_mean: (i1 - i0) / (imu.len() - 1).max(1) as f64,
        tick_scale,
        pos_epochs: pos.epochs.len(),
        pos_fixed: pos.count_q(q::FIX),
        pos_float: pos.count_q(q::FLOAT),
        gnss_epochs: gnss.len(),
        gnss_t: [p0.fix.t, p1.fix.t],
        gnss_start_gpst: gpst::to_calendar(p0.fix.t).unwrap_or_default(),
        imu_start_after_gnss: tag.start - p0.fix.t,
        noise: noise_facts(),
        tag,
    };
    crate::output::write_string(
        &opt.out.join("meta.json"),
        &serde_json::to_string_pretty(&meta)?,
    )?;
    Ok(meta)
}
