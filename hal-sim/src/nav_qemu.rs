//! Runs the navigation firmware (`imu-ident-nav-qemu`, `src/bin/nav_qemu.rs`) under QEMU on an
//! IMU + GNSS log and reads back its epochs, instruction counts and stack marks.
//!
//! The log is turned into the core's navigation replay ([`imu_ident::nav::replay`]) with the
//! same start and per-fix decisions as the host run ([`crate::nav::setup`], used by
//! [`crate::nav::run_with`]): the records are the IMU samples after the start, each followed by
//! the fixes it reaches, exactly the order in which `run_with` processes them. The
//! non-holonomic constraint (`--nhc`) travels in the setup (sd, lever arm, whether the heading
//! is given); the firmware's loop applies it after each filter step with the core code the host
//! calls (`imu_ident::nav::Nhc::after_step`). QEMU is run with
//! [`crate::qemu::run_qemu`] and the defmt frames are parsed structurally like the estimator
//! firmware's ([`crate::qemu`]).
//!
//! A live replay ([`encode_live_replay`]) carries the raw stream instead, every sample from the
//! first and every fix undecided, with the live rules in its setup: the firmware's live loop
//! (`imu_ident::nav::live`) starts the run and decides the fixes itself.
//!
//! ```no_run
//! # fn demo(args: &hal_sim::nav::NavArgs) -> anyhow::Result<()> {
//! use hal_sim::nav_io::{read_gnss_csv, read_imu_csv};
//! use hal_sim::nav_qemu::{run_nav_firmware, NAV_ELF_ENV};
//! let (imu, fixes) = (read_imu_csv(&args.imu)?, read_gnss_csv(&args.gnss)?);
//! let elf = std::env::var(NAV_ELF_ENV)?;
//! let run = run_nav_firmware(elf.as_ref(), args, &imu, &fixes, &Default::default())?;
//! assert!(run.success());
//! # Ok(()) }
//! ```

use std::path::Path;
use std::process::ExitStatus;

use anyhow::{anyhow, bail, Context, Result};
use defmt_decoder::{DecodeError, Table};
use imu_ident::nav::live::record_of;
use imu_ident::nav::replay::{encode, ImuRecord, Record};
use imu_ident::nav::NavSetup;
use serde::Serialize;

use crate::nav::setup::{start, FixPlan, FixPlanner};
use crate::nav::{live_fix, NavArgs};
use crate::nav_io::{GnssFix, ImuSample};
use crate::qemu::{field, run_qemu, tagged, Icount, QemuConfig, Stack};
use crate::qemu::{ICOUNT_FIELDS, STACK_FIELDS};

/// The navigation firmware binary.
pub const NAV_BIN: &str = "imu-ident-nav-qemu";
/// How it is built (from the workspace root).
pub const NAV_BUILD_COMMAND: &str = "cargo build --release -p imu-ident --target thumbv7em-none-eabihf --features qemu --bin imu-ident-nav-qemu";
/// The variable naming its ELF (scripts/test.sh sets it).
pub const NAV_ELF_ENV: &str = "IMU_IDENT_NAV_FIRMWARE_ELF";
/// Name of the replay inside QEMU's working directory.
const REPLAY_NAME: &str = "nav.bin";
/// The serial wire's file name in QEMU's working directory.
const WIRE_NAME: &str = "wire.bin";
/// The fields of a firmware `online` frame (one coordinate at one decision of the bank).
const ONLINE_FIELDS: [&str; 5] = ["t", "i", "x", "sd", "ok"];

/// One coordinate at one decision of the firmware's online identification.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OnlineReport {
    /// Time of the decision [s].
    pub t: f64,
    /// Coordinate index.
    pub i: u8,
    /// log10 factor on the starting model after the decision.
    pub x: f64,
    /// Cramér-Rao sd [decades] (infinite: not bounded).
    pub sd: f64,
    /// Identifiable from the data so far (sd at most `IDENTIFIABLE_SD`).
    pub identifiable: bool,
}

/// Fields of the firmware's per-epoch frame.
const NAV_FIELDS: [&str; 11] = [
    "t", "lat", "lon", "h", "vn", "ve", "vd", "sdn", "sde", "sdd", "flags",
];
/// Fields of the firmware's `now` frame (the solution at the newest sample).
const NOW_FIELDS: [&str; 19] = [
    "t", "lat", "lon", "h", "vn", "ve", "vd", "roll", "pitch", "yaw", "san", "sae", "sad", "svn",
    "sve", "svd", "spn", "spe", "spd",
];

/// The setup and records of a run with `args` on `imu` and `fixes` (module docs).
pub fn replay_records(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
) -> Result<(NavSetup, Vec<Record>)> {
    let shifted = crate::nav::setup::shifted_imu(args, imu);
    let imu = &shifted[..];
    let s = start(args, imu, fixes)?;
    let mut planner = FixPlanner::new(args, &s);
    let mut fix_k = fixes.partition_point(|f| f.t < s.setup.t0);
    let mut out = Vec::with_capacity(imu.len() + fixes.len());
    let f32x3 = |v: [f64; 3]| v.map(|x| x as f32);
    for w in imu[s.k..].windows(2) {
        let b = &w[1];
        let dt = b.t - w[0].t;
        if dt.is_nan() || dt <= 0.0 {
            bail!("IMU time does not increase at t = {}", b.t);
        }
        out.push(Record::Imu(ImuRecord {
            t: b.t,
            gyro: f32x3(b.gyro),
            accel: f32x3(b.accel),
        }));
        while fix_k < fixes.len() && fixes[fix_k].t <= b.t {
            let f = fixes[fix_k];
            fix_k += 1;
            let plan = planner.plan(&f);
            out.push(Record::Gnss(record_of(
                &live_fix(&f),
                &plan,
                args.use_velocity,
            )));
        }
    }
    Ok((s.setup, out))
}

/// The setup and records of a live run with `args` on `imu` and `fixes`: the settings with
/// the live rules ([`NavSetup::live`]), then every sample from the first and every fix, each
/// after the first sample at or past its time, unflagged: the raw stream a navigation
/// computer receives, which the firmware's live loop (`imu_ident::nav::live`) starts and
/// decides by itself. The IMU time shift is applied; the outage schedule is not (a live run
/// withholds nothing).
pub fn live_records(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
) -> Result<(NavSetup, Vec<Record>)> {
    let shifted = crate::nav::setup::shifted_imu(args, imu);
    let setup = NavSetup {
        live: Some(crate::nav::setup::live_config(args)),
        ..crate::nav::setup::settings(args)
    };
    let raw = FixPlan {
        withheld: false,
        heading: None,
        fuse: false,
    };
    let mut out = Vec::with_capacity(shifted.len() + fixes.len());
    let mut fix_k = 0;
    for (i, s) in shifted.iter().enumerate() {
        let increasing = i == 0 || s.t > shifted[i - 1].t;
        if !increasing {
            bail!("IMU time does not increase at t = {}", s.t);
        }
        out.push(Record::Imu(ImuRecord {
            t: s.t,
            gyro: s.gyro.map(|x| x as f32),
            accel: s.accel.map(|x| x as f32),
        }));
        while fix_k < fixes.len() && fixes[fix_k].t <= s.t {
            out.push(Record::Gnss(record_of(
                &live_fix(&fixes[fix_k]),
                &raw,
                false,
            )));
            fix_k += 1;
        }
    }
    Ok((setup, out))
}

/// The live replay file of a run with `args` on `imu` and `fixes` ([`live_records`]).
pub fn encode_live_replay(args: &NavArgs, imu: &[ImuSample], fixes: &[GnssFix]) -> Result<Vec<u8>> {
    let (setup, records) = live_records(args, imu, fixes)?;
    let mut out = Vec::new();
    encode(&setup, &records, |b| out.extend_from_slice(b))
        .map_err(|e| anyhow!("encoding the live navigation replay: {e}"))?;
    Ok(out)
}

/// The replay file of a run with `args` on `imu` and `fixes`.
pub fn encode_replay(args: &NavArgs, imu: &[ImuSample], fixes: &[GnssFix]) -> Result<Vec<u8>> {
    let (setup, records) = replay_records(args, imu, fixes)?;
    let mut out = Vec::new();
    encode(&setup, &records, |b| out.extend_from_slice(b))
        .map_err(|e| anyhow!("encoding the navigation replay: {e}"))?;
    Ok(out)
}

/// The firmware's solution at one GNSS epoch.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NavEpoch {
    /// Epoch time [s].
    pub t: f64,
    /// Latitude [rad].
    pub lat: f64,
    /// Longitude [rad].
    pub lon: f64,
    /// Height [m].
    pub h: f64,
    /// NED velocity [m/s].
    pub vel: [f32; 3],
    /// Position standard deviations N, E, D [m].
    pub sd_pos: [f32; 3],
    /// The record's GNSS flags, plus 0x80 when the fix was gated.
    pub flags: u8,
}

/// The firmware's solution at the newest IMU sample (a live run's `now` frame, every tenth
/// sample: the output predictor's, `imu_ident::nav::predictor`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NavPresent {
    /// Time of the newest sample [s].
    pub t: f64,
    /// Latitude [rad].
    pub lat: f64,
    /// Longitude [rad].
    pub lon: f64,
    /// Height [m].
    pub h: f64,
    /// NED velocity [m/s].
    pub vel: [f32; 3],
    /// Roll, pitch, yaw [rad].
    pub euler: [f32; 3],
    /// Standard deviations of the attitude error N, E, D [rad] (`LiveNav::present_sd`; NaN
    /// when there are none).
    pub sd_att: [f32; 3],
    /// Standard deviations of the velocity error N, E, D [m/s].
    pub sd_vel: [f32; 3],
    /// Standard deviations of the position error N, E, D [m].
    pub sd_pos: [f32; 3],
}

/// What one navigation firmware run produced.
#[derive(Debug, Clone)]
pub struct NavFirmwareRun {
    /// One per GNSS epoch after the start.
    pub epochs: Vec<NavEpoch>,
    /// A live run's solution at the newest sample, every tenth sample once the run started.
    pub present: Vec<NavPresent>,
    /// Instruction counts: `imu` (mechanisation only), `step` (IMU sample + 1 Hz filter
    /// propagation), `nhc` (the same plus the non-holonomic constraint; none without it),
    /// `gnss` (fusion of one fix).
    pub icount: Vec<Icount>,
    /// Stack high-water marks: `init` (building the navigator) and `run`.
    pub stack: Vec<Stack>,
    /// The online identification's decisions (with `--adapt-method bank`), per coordinate.
    pub online: Vec<OnlineReport>,
    /// Every other frame, formatted (`LEVEL message`).
    pub messages: Vec<String>,
    /// QEMU's exit status: the firmware's.
    pub status: ExitStatus,
    /// QEMU's diagnostics.
    pub stderr: String,
}

impl NavFirmwareRun {
    /// The firmware exited with success (complete, valid replay).
    pub fn success(&self) -> bool {
        self.status.success()
    }
}

/// Runs the navigation firmware `elf` with `args` on `imu` and `fixes`.
pub fn run_nav_firmware(
    elf: &Path,
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    cfg: &QemuConfig,
) -> Result<NavFirmwareRun> {
    run_nav_firmware_bytes(elf, &encode_replay(args, imu, fixes)?, cfg)
}

/// Like [`run_nav_firmware`] with the replay given as bytes (to test corrupt files).
pub fn run_nav_firmware_bytes(
    elf: &Path,
    replay: &[u8],
    cfg: &QemuConfig,
) -> Result<NavFirmwareRun> {
    run_nav_files(elf, &[(REPLAY_NAME, replay)], cfg)
}

/// The serial wire of a run with `args` on `imu` and `fixes` (the IMU shifted as the run
/// shifts it; [`crate::nav_io::ubx::serial_stream`], each fix on the wire `delay` s after its
/// time).
pub fn wire_of(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    delay: f64,
) -> Result<Vec<u8>> {
    crate::nav_io::ubx::serial_stream(&crate::nav::setup::shifted_imu(args, imu), fixes, delay)
}

/// [`wire_of`] from a hub that stamps its samples with `osc`'s timer instead of GPS time
/// ([`crate::clock::counted_stream`]).
pub fn counted_wire_of(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    delay: f64,
    osc: &mut crate::trajectory::oscillator::Oscillator,
) -> Result<Vec<u8>> {
    crate::clock::counted_stream(
        &crate::nav::setup::shifted_imu(args, imu),
        fixes,
        delay,
        osc,
    )
}

/// Runs the firmware on a serial wire (`wire`, as [`wire_of`] writes it) with the live setup
/// of `args`: a live replay with no records, then the wire's bytes through the core's
/// decoders.
pub fn run_nav_firmware_wire(
    elf: &Path,
    args: &NavArgs,
    wire: &[u8],
    cfg: &QemuConfig,
) -> Result<NavFirmwareRun> {
    let (setup, _) = live_records(args, &[], &[])?;
    let mut replay = Vec::new();
    encode(&setup, &[], |b| replay.extend_from_slice(b))
        .map_err(|e| anyhow!("encoding the live setup: {e}"))?;
    run_nav_files(elf, &[(REPLAY_NAME, &replay), (WIRE_NAME, wire)], cfg)
}

/// Runs the firmware with `files` as its arguments.
fn run_nav_files(elf: &Path, files: &[(&str, &[u8])], cfg: &QemuConfig) -> Result<NavFirmwareRun> {
    let out = run_qemu(elf, NAV_BIN, files, cfg)?;
    let mut run = decode_nav(&out.elf_bytes, &out.stdout)
        .with_context(|| format!("decoding the output of {}", elf.display()))?;
    run.status = out.status;
    run.stderr = out.stderr;
    Ok(run)
}

/// Decodes the navigation firmware's defmt stream.
fn decode_nav(elf_bytes: &[u8], stream: &[u8]) -> Result<NavFirmwareRun> {
    let table = Table::parse(elf_bytes)
        .context("reading the defmt table")?
        .ok_or_else(|| anyhow!("the ELF has no defmt table (not built with defmt?)"))?;
    let mut decoder = table.new_stream_decoder();
    decoder.received(stream);
    let mut run = NavFirmwareRun {
        epochs: vec![],
        present: vec![],
        icount: vec![],
        stack: vec![],
        online: vec![],
        messages: vec![],
        status: std::process::ExitStatus::default(),
        stderr: String::new(),
    };
    loop {
        let frame = match decoder.decode() {
            Ok(frame) => frame,
            Err(DecodeError::UnexpectedEof) => break,
            Err(DecodeError::Malformed) if table.encoding().can_recover() => {
                run.messages.push("<malformed defmt frame skipped>".into());
                continue;
            }
            Err(DecodeError::Malformed) => bail!("malformed defmt frame in a raw-encoded stream"),
        };
        if let Some(v) = tagged(&frame, "nav", &NAV_FIELDS)? {
            let [t, lat, lon, h, vn, ve, vd, sn, se, sd, flags] = v;
            run.epochs.push(NavEpoch {
                t: field("t", &t)?,
                lat: field("lat", &lat)?,
                lon: field("lon", &lon)?,
                h: field("h", &h)?,
                vel: [field("vn", &vn)?, field("ve", &ve)?, field("vd", &vd)?],
                sd_pos: [field("sdn", &sn)?, field("sde", &se)?, field("sdd", &sd)?],
                flags: field("flags", &flags)?,
            });
        } else if let Some(v) = tagged(&frame, "now", &NOW_FIELDS)? {
            let [t, lat, lon, h, vn, ve, vd, roll, pitch, yaw, sd @ ..] = v;
            let mut sds = [0.0f32; 9];
            for ((s, text), name) in sds.iter_mut().zip(&sd).zip(&NOW_FIELDS[10..]) {
                *s = field(name, text)?;
            }
            run.present.push(NavPresent {
                t: field("t", &t)?,
                lat: field("lat", &lat)?,
                lon: field("lon", &lon)?,
                h: field("h", &h)?,
                vel: [field("vn", &vn)?, field("ve", &ve)?, field("vd", &vd)?],
                euler: [
                    field("roll", &roll)?,
                    field("pitch", &pitch)?,
                    field("yaw", &yaw)?,
                ],
                sd_att: [sds[0], sds[1], sds[2]],
                sd_vel: [sds[3], sds[4], sds[5]],
                sd_pos: [sds[6], sds[7], sds[8]],
            });
        } else if let Some(v) = tagged(&frame, "icount", &ICOUNT_FIELDS)? {
            let [class, n, mean, worst, worst_k] = v;
            run.icount.push(Icount {
                class,
                n: field("n", &n)?,
                mean: field("mean", &mean)?,
                worst: field("worst", &worst)?,
                worst_k: field("worst_k", &worst_k)?,
            });
        } else if let Some(v) = tagged(&frame, "online", &ONLINE_FIELDS)? {
            let [t, i, x, sd, ok] = v;
            run.online.push(OnlineReport {
                t: field("t", &t)?,
                i: field("i", &i)?,
                x: field("x", &x)?,
                sd: field("sd", &sd)?,
                identifiable: field("ok", &ok)?,
            });
        } else if let Some(v) = tagged(&frame, "stack", &STACK_FIELDS)? {
            let [phase, h, e, top] = v;
            run.stack.push(Stack {
                phase,
                high_water: field("high_water", &h)?,
                statics_end: field("statics_end", &e)?,
                ram_top: field("ram_top", &top)?,
            });
        } else {
            run.messages.push(frame.display(false).to_string());
        }
    }
    Ok(run)
}

/// `firmware.json` of `hal-sim nav --qemu-elf`: the firmware's run of the same log, set
/// against the host's.
#[derive(Debug, Clone, Serialize)]
pub struct FirmwareComparison {
    /// The ELF run.
    pub elf: String,
    /// The firmware exited with success.
    pub exit_success: bool,
    /// Epochs reported by the firmware and by the host.
    pub epochs: [usize; 2],
    /// Worst position difference firmware minus host over the common epochs, N/E/D, in units
    /// of the host's position standard deviation.
    pub worst_position_diff_sigma: f64,
    /// Instruction counts (`imu`, `step`, `nhc`, `gnss`).
    pub icount: Vec<Icount>,
    /// Stack high-water marks.
    pub stack: Vec<Stack>,
    /// With the online identification (`--adapt --adapt-method bank`): the firmware's
    /// decisions (its `online` telemetry) against the host's.
    pub online: Option<OnlineComparison>,
}

/// The firmware's online decisions against the host's (same times, same coordinates).
#[derive(Debug, Clone, Serialize)]
pub struct OnlineComparison {
    /// Decisions reported by the firmware and by the host.
    pub decisions: [usize; 2],
    /// Worst difference of a coordinate's log10 factor [decades] over the decisions both
    /// reported.
    pub worst_factor_diff_decades: f64,
    /// Coordinates of those decisions whose "identifiable" flags differ.
    pub flags_differ: usize,
}

/// The firmware's decision telemetry `fw` (one report per coordinate per decision) set
/// against the host's decision log.
pub fn compare_online(fw: &[OnlineReport], host: &crate::nav::adapt::AdaptLog) -> OnlineComparison {
    let p = host.coordinates.len().max(1);
    let mut worst = 0.0f64;
    let mut flags_differ = 0;
    for s in &host.searches {
        for r in fw.iter().filter(|r| r.t == s.t) {
            let i = usize::from(r.i);
            if let Some(x) = s.log10_factors.get(i) {
                worst = worst.max((r.x - x).abs());
            }
            if s.identifiable
                .get(i)
                .is_some_and(|ok| *ok != r.identifiable)
            {
                flags_differ += 1;
            }
        }
    }
    OnlineComparison {
        decisions: [fw.len() / p, host.searches.len()],
        worst_factor_diff_decades: worst,
        flags_differ,
    }
}

/// Runs `elf` on the log of `host` (same `args`, same samples and fixes) and compares.
pub fn compare_with_host(
    elf: &Path,
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    host: &crate::nav::NavRun,
) -> Result<FirmwareComparison> {
    let fw = run_nav_firmware(elf, args, imu, fixes, &QemuConfig::default())?;
    Ok(compare_firmware(elf, args, &fw, host))
}

/// The firmware's run `fw` of `elf` set against the host's run `host` of the same inputs:
/// the worst position difference at the epochs both have, in the host's sigmas, and the
/// bank's decisions.
pub fn compare_firmware(
    elf: &Path,
    args: &NavArgs,
    fw: &NavFirmwareRun,
    host: &crate::nav::NavRun,
) -> FirmwareComparison {
    let mut worst = 0.0f64;
    for e in &fw.epochs {
        let k = host.epochs.partition_point(|h| h.t < e.t - 1e-9);
        let Some(h) = host.epochs.get(k).filter(|h| (h.t - e.t).abs() < 1e-9) else {
            continue;
        };
        let ne = crate::nav_io::outages::north_east(
            h.lat_deg,
            h.lon_deg,
            h.h,
            e.lat.to_degrees(),
            e.lon.to_degrees(),
        );
        let d = [ne[0], ne[1], h.h - e.h];
        for (x, s) in d.iter().zip(h.sd_pos.iter()) {
            worst = worst.max(x.abs() / s);
        }
    }
    FirmwareComparison {
        elf: elf.display().to_string(),
        exit_success: fw.success(),
        epochs: [fw.epochs.len(), host.epochs.len()],
        worst_position_diff_sigma: worst,
        online: host
            .adapt
            .as_ref()
            .filter(|_| args.online().is_some())
            .map(|log| compare_online(&fw.online, log)),
        icount: fw.icount.clone(),
        stack: fw.stack.clone(),
    }
}
