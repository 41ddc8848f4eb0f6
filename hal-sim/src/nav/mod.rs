//! `hal-sim nav`: a recorded or simulated IMU + GNSS log through the core's closed-loop
//! strapdown INS/GNSS navigator (`imu_ident::nav::Navigator`), with GNSS outages withheld on a
//! schedule and scored against the GNSS reference.
//!
//! The run ([`run`]):
//! 1. levels from the mean specific force of the first `align` seconds (the vehicle must be at
//!    rest), and estimates the gyro biases from the mean rate over the same window, less the
//!    vertical Earth rate (`--static-gyro-bias`);
//! 2. starts the navigator at the first GNSS position (antenna minus the lever arm) at rest;
//! 3. fuses the GNSS fixes not withheld, each at its own time (every fix by default;
//!    `--fix-interval` thins them);
//!    until the heading is known (from `--yaw`, or the GNSS course once the speed exceeds
//!    `--yaw-speed`), only static fixes are fused;
//! 4. records the solution at every GNSS epoch (withheld ones too), the per-axis NIS and the
//!    estimated sensor errors.

pub mod adapt;
pub mod diagnose;
pub mod drive;
pub mod identify;
pub mod information;
pub mod interval;
pub mod model;
pub mod pattern;
pub mod plot;
pub mod real;
pub mod records;
pub mod report;
pub mod setup;
pub mod shadows;
pub mod track;
pub mod truth;

use crate::nav_io::{self, score_outages, GnssFix, ImuSample, OutageSpec, OutageSummary};
use anyhow::{bail, Result};
use imu_ident::nav::{GnssFix as CoreFix, NavInit};
use imu_ident::strapdown::Geodetic;
use imu_ident::Real;
use nalgebra::Vector3;
use std::path::PathBuf;

pub use records::{EpochRecord, NavSummary};

/// Options of one run.
#[derive(Debug, Clone)]
pub struct NavArgs {
    /// IMU CSV.
    pub imu: PathBuf,
    /// GNSS CSV or RTKLIB `.pos`.
    pub gnss: PathBuf,
    /// Keep `.pos` epochs with `1 <= Q <= max_q`.
    pub max_q: u8,
    /// The noise model.
    pub model: imu_ident::nav::ImuErrorModel<f64>,
    /// Where the model came from (for the summary).
    pub model_name: String,
    /// Outage schedule.
    pub outages: Option<OutageSpec>,
    /// Antenna from the IMU, body FRD [m].
    pub lever_arm: [f64; 3],
    /// Filter step [s].
    pub step: f64,
    /// Shortest interval between fused GNSS fixes [s]; 0 fuses every fix. A fix between
    /// filter steps is fused at its own time, the filter first propagated over the part of
    /// the step elapsed (`Navigator::gnss`).
    pub fix_interval: f64,
    /// A live run's latency budget [s] ([`imu_ident::nav::live::LiveConfig::latency`]; the
    /// batch run has none: it takes every fix in time order).
    pub latency: f64,
    /// Static levelling window at the start [s].
    pub align: f64,
    /// Initial yaw [deg] (else from the GNSS course).
    pub yaw_deg: Option<f64>,
    /// Speed [m/s] above which the GNSS course gives the heading.
    pub yaw_speed: f64,
    /// Initial gyro biases from the static window.
    pub static_gyro_bias: bool,
    /// Initial uncertainty.
    pub init: NavInit<f64>,
    /// Gate multiplier (`None`: no gate).
    pub gate: Option<f64>,
    /// Fuse GNSS velocity too.
    pub use_velocity: bool,
    /// Run the core in `f32`.
    pub single: bool,
    /// Factors on the GNSS position and velocity standard deviations.
    pub gnss_sd_factor: [f64; 2],
    /// Gyro and accelerometer scale-factor errors as random constants with these standard
    /// deviations (dimensionless), or none.
    pub scale_factor_sd: Option<[f64; 2]>,
    /// Added to every IMU time [s] (a residual logging delay; identified by `--identify`).
    pub imu_time_shift: f64,
    /// Non-holonomic constraint: standard deviation [m/s] of the body lateral and vertical
    /// velocity at [`nhc_lever`](Self::nhc_lever), applied every filter step while the heading
    /// is known and the speed is above [`NHC_MIN_SPEED`] (GNSS or not), or none.
    pub nhc: Option<f64>,
    /// The point the constraint holds at, from the IMU, body FRD [m] (the body origin).
    pub nhc_lever: [f64; 3],
    /// Zero-velocity updates after every filter step found at rest
    /// ([`imu_ident::nav::rest`]), or none.
    pub zupt: Option<imu_ident::nav::Zupt<f64>>,
    /// Online identification of the sensor noise ([`adapt`]), or none.
    pub adapt: Option<adapt::AdaptConfig>,
}

/// Speed [m/s] of the solution from which the non-holonomic constraint is applied (the core's,
/// shared with the firmware: `imu_ident::nav::run::Nhc::after_step`).
pub use imu_ident::nav::NHC_MIN_SPEED;

impl NavArgs {
    /// The core's online identification (`--adapt --adapt-method bank`): the bank's settings
    /// with the per-axis and correlation-time choices of `--adapt`; the same on the host and
    /// in the firmware's replay.
    pub fn online(&self) -> Option<imu_ident::nav::OnlineConfig> {
        let c = self
            .adapt
            .filter(|c| c.method == adapt::AdaptMethod::Bank)?;
        Some(imu_ident::nav::OnlineConfig {
            // `--adapt-tied-first`: tied first ([`adapt::switch_if_settled`]).
            per_axis: c.per_axis && !c.tied_first,
            taus: c.taus != adapt::TauMode::Held,
            hold_flat_taus: c.taus == adapt::TauMode::Tested,
            gnss_sd: c.gnss_sd,
            ..c.bank
        })
    }

    /// A run of `imu` and `gnss` with `model` and the command's defaults (`hal-sim nav --help`):
    /// 1-s step, every GNSS fix fused, 20-s levelling, heading from the course above 2 m/s,
    /// gyro biases seeded at rest, initial sd 2/2/10 deg, 0.1 m/s, 1 m, gate 1, velocity
    /// fused, f64, no outages, no lever arm, no non-holonomic constraint.
    pub fn new(
        imu: PathBuf,
        gnss: PathBuf,
        model: imu_ident::nav::ImuErrorModel<f64>,
        model_name: &str,
    ) -> Self {
        Self {
            imu,
            gnss,
            max_q: 2,
            model,
            model_name: model_name.into(),
            outages: None,
            lever_arm: [0.0; 3],
            step: 1.0,
            fix_interval: 0.0,
            latency: 0.0,
            align: 20.0,
            yaw_deg: None,
            yaw_speed: 2.0,
            static_gyro_bias: true,
            init: NavInit {
                sd_att: Vector3::new(2f64, 2.0, 10.0).map(f64::to_radians),
                sd_vel: 0.1,
                sd_pos: 1.0,
            },
            gate: Some(1.0),
            use_velocity: true,
            single: false,
            gnss_sd_factor: [1.0, 1.0],
            scale_factor_sd: None,
            imu_time_shift: 0.0,
            nhc: None,
            nhc_lever: [0.0; 3],
            zupt: None,
            adapt: None,
        }
    }

    /// [`new`](Self::new) for a simulated drive whose truth is known: heading given
    /// (`yaw_deg`, the truth's first yaw), 50-s levelling, no gyro-bias seeding at rest (the
    /// simulated biases are part of the model), initial sd 1 deg, 0.1 m/s, 1 m.
    pub fn simulated(
        imu: PathBuf,
        gnss: PathBuf,
        model: imu_ident::nav::ImuErrorModel<f64>,
        model_name: &str,
        yaw_deg: f64,
    ) -> Self {
        Self {
            align: 50.0,
            yaw_deg: Some(yaw_deg),
            static_gyro_bias: false,
            init: NavInit {
                sd_att: Vector3::repeat(1f64.to_radians()),
                sd_vel: 0.1,
                sd_pos: 1.0,
            },
            ..Self::new(imu, gnss, model, model_name)
        }
    }

    /// [`simulated`](Self::simulated) for the simulated drive written to `dir` (`imu.csv`,
    /// `gnss.csv`; `fixes` and `truth` as read back), with the simulation benches' GNSS
    /// outages: 60 s every 20 min from 10 min ([`OutageSpec::every_20_min`]).
    pub fn simulated_drive(
        dir: &std::path::Path,
        fixes: &[GnssFix],
        truth: &[crate::nav_io::TruthRow],
        model: imu_ident::nav::ImuErrorModel<f64>,
        model_name: &str,
    ) -> Self {
        Self {
            outages: Some(OutageSpec::every_20_min(
                0.0,
                fixes.first().map_or(0.0, |f| f.t),
            )),
            ..Self::simulated(
                dir.join("imu.csv"),
                dir.join("gnss.csv"),
                model,
                model_name,
                truth.first().map_or(0.0, |r| r.rpy_deg[2]),
            )
        }
    }
}

/// Everything a run produced.
#[derive(Debug, Clone)]
pub struct NavRun {
    /// One record per GNSS epoch after the start.
    pub epochs: Vec<EpochRecord>,
    /// Outage scores (when a schedule was given).
    pub outages: Option<OutageSummary>,
    /// GNSS epochs read.
    pub fixes: Vec<GnssFix>,
    /// Summary.
    pub summary: NavSummary,
    /// The online identification's searches (with `--adapt`).
    pub adapt: Option<adapt::AdaptLog>,
}

/// Reads the inputs and runs (f64 or f32 core).
pub fn run(args: &NavArgs) -> Result<NavRun> {
    let imu = nav_io::read_imu_any(&args.imu)?;
    let fixes = nav_io::read_gnss_any(&args.gnss, args.max_q)?;
    let bar = records::imu_progress(imu.len());
    if args.single {
        run_observed::<f32>(args, &imu, &fixes, &bar)
    } else {
        run_observed::<f64>(args, &imu, &fixes, &bar)
    }
}

/// Identifies the noise model on the log ([`identify::identify`]), then runs with it; writes
/// `identified.json`, `identified-model.toml` and `identified-options.txt` (the `hal-sim nav`
/// options the model file cannot hold: GNSS factors, IMU time shift, constraint sd) into `out`
/// besides the run's files.
pub fn run_identified(
    args: &NavArgs,
    axes: identify::Axes,
    out: &std::path::Path,
) -> Result<(NavRun, identify::Identified)> {
    let imu = nav_io::read_imu_any(&args.imu)?;
    let fixes = nav_io::read_gnss_any(&args.gnss, args.max_q)?;
    let (a, id) = identify_and_write(args, &imu, &fixes, axes, out)?;
    let bar = records::imu_progress(imu.len());
    let run = if a.single {
        run_observed::<f32>(&a, &imu, &fixes, &bar)?
    } else {
        run_observed::<f64>(&a, &imu, &fixes, &bar)?
    };
    Ok((run, id))
}

/// Identifies the noise model on the log and writes the identification's three files into
/// `out` ([`run_identified`]); returns the options of the identified run.
pub fn identify_and_write(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    axes: identify::Axes,
    out: &std::path::Path,
) -> Result<(NavArgs, identify::Identified)> {
    let id = identify::identify_axes(args, imu, fixes, axes)?;
    let mut a = id.apply(args);
    a.model_name = format!(
        "{} identified on this log (factors {:?}{})",
        args.model_name,
        id.factors,
        if id.axes.as_ref().is_some_and(|x| x.significant) {
            ", per axis"
        } else {
            ""
        }
    );
    std::fs::create_dir_all(out)?;
    crate::output::write_string(
        &out.join("identified.json"),
        &serde_json::to_string_pretty(&id)?,
    )?;
    let toml = model::to_toml(&id.model)?;
    crate::output::write_string(
        &out.join("identified-model.toml"),
        &toml.to_text(&format!(
            "# Identified by hal-sim nav --identify from {} on {}\n# factors on the standard deviations ({}): {:?}\n{}",
            args.model_name,
            args.imu.display(),
            identify::FACTORS.join(", "),
            id.factors,
            match &id.axes {
                Some(x) if x.significant => format!(
                    "# per axis (x, y, z) the first four: {:?} (--identify-axes: {:.1} nats over the tied fit, threshold {:.1}; the four above are their geometric means)\n",
                    id.axis_factors, x.gain_nats, x.threshold_nats
                ),
                _ => String::new(),
            }
        ))?,
    )?;
    // What the model file cannot hold (GNSS factors, the IMU time shift, the constraint's sd):
    // the options that rerun the identified filter with `--model identified-model.toml`.
    let mut opts = format!(
        "--imu-time-shift {} --gnss-sd-factor {},{}",
        a.imu_time_shift, a.gnss_sd_factor[0], a.gnss_sd_factor[1]
    );
    if let Some(sd) = a.nhc {
        opts += &format!(" --nhc {sd}");
    }
    if let Some(z) = a.zupt {
        opts += &format!(
            " --zupt {} --zupt-detector {},{},{}",
            z.sd, z.gyro_max, z.accel_max, z.speed_max
        );
    }
    crate::output::write_string(&out.join("identified-options.txt"), &(opts + "\n"))?;
    Ok((a, id))
}

/// The run on samples and fixes already read.
pub fn run_with<T: Real>(args: &NavArgs, imu: &[ImuSample], fixes: &[GnssFix]) -> Result<NavRun> {
    run_observed::<T>(args, imu, fixes, &indicatif::ProgressBar::hidden())
}

/// IMU samples per advance of the progress bar.
const PROGRESS_BATCH: u64 = 100;

/// [`run_with`] advancing `bar` by the IMU samples mechanised, `PROGRESS_BATCH` at a time
/// ([`records::imu_progress`]).
pub fn run_observed<T: Real>(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    bar: &indicatif::ProgressBar,
) -> Result<NavRun> {
    let started = std::time::Instant::now();
    let shifted = setup::shifted_imu(args, imu);
    let imu = &shifted[..];
    // 1-2. The start (levelling, static gyro bias, first position) and the navigator: shared
    // with the firmware replay (`setup`, `hal_sim::nav_qemu`). 3. The loop (`drive`).
    let (mut lp, outages) = drive::NavLoop::<T>::start(args, imu, fixes)?;
    let mut epochs = Vec::with_capacity(fixes.len());
    bar.set_length((imu.len() - lp.i).saturating_sub(1) as u64);
    bar.reset();
    let name = args.imu.display().to_string();
    let t_start = lp.time(imu);
    // `--adapt-tied-first`: the per-axis bank that takes over once the tied one settles.
    let per_axis_next = args
        .online()
        .filter(|_| args.adapt.is_some_and(|c| c.per_axis && c.tied_first))
        .map(|o| imu_ident::nav::OnlineConfig {
            per_axis: true,
            ..o
        });
    if let Some(online) = args.online() {
        adapt::start_bank(online, per_axis_next, lp.nav_mut(), t_start)?;
    }
    let mut adapter = args
        .adapt
        .filter(|c| c.method == adapt::AdaptMethod::Replay)
        .map(|c| adapt::Adapter::new(args, c, &lp, t_start));
    // Samples mechanised and not yet added to the bar: `inc` reads the clock, and once per
    // sample that was 2 % of a diagnosis run (perf, BENCHMARKS.md "CI time: bit-exact kernels").
    let unshown = std::cell::Cell::new(0u64);
    loop {
        let t_end = adapter.as_ref().map_or(f64::INFINITY, |a| a.next_time());
        // With the switch pending, advances of a minute, the switch between them.
        let pending = lp.nav().observer().per_axis_next.is_some();
        let t_end = if pending {
            t_end.min(lp.time(imu) + 60.0)
        } else {
            t_end
        };
        lp.advance(imu, fixes, t_end, &mut epochs, &name, &|| {
            let k = unshown.get() + 1;
            if k >= PROGRESS_BATCH {
                bar.inc(k);
                unshown.set(0);
            } else {
                unshown.set(k);
            }
        })?;
        if pending {
            let t = lp.time(imu);
            adapt::switch_if_settled(lp.nav_mut(), t)?;
            if adapter.is_none() && lp.i + 1 < imu.len() {
                continue;
            }
        }
        match adapter.as_mut() {
            Some(a) if lp.i + 1 < imu.len() => a.search(&mut lp, imu, fixes, &name)?,
            _ => break,
        }
    }
    bar.inc(unshown.get());
    bar.finish_and_clear();
    let heading_known = lp.planner.heading_known();
    let scores = args.outages.map(|_| {
        let track: Vec<(f64, f64, f64)> =
            epochs.iter().map(|e| (e.t, e.lat_deg, e.lon_deg)).collect();
        let reference: Vec<GnssFix> = fixes.to_vec();
        score_outages(&track, &reference, &outages)
    });
    let mut summary = NavSummary::new(
        args,
        &epochs,
        scores.as_ref(),
        lp.nav().gaps(),
        started.elapsed().as_secs_f64(),
        heading_known,
    );
    summary.nhc = lp.nhc.map(records::NhcSummary::finish);
    summary.zupt = lp.zupt.map(records::ZuptSummary::finish);
    Ok(NavRun {
        epochs,
        outages: scores,
        fixes: fixes.to_vec(),
        summary,
        adapt: adapter
            .map(adapt::Adapter::finish)
            .or_else(|| adapt::bank_log(lp.nav().observer(), args.gnss_sd_factor)),
    })
}

/// The body origin from the IMU (`-import.imu_lever`, body FRD [m]) from the `meta.json` that
/// `hal-sim import-drive` writes beside `imu.csv`, if there is one (the default of
/// `--nhc-lever`: a car's body origin, not its roof, is what does not slide sideways).
pub fn nhc_lever_from_meta(imu: &std::path::Path) -> Result<Option<[f64; 3]>> {
    let meta = imu.with_file_name("meta.json");
    if !meta.is_file() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&meta)?;
    let json: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", meta.display()))?;
    let Some(lever) = json.pointer("/import/imu_lever").and_then(|v| v.as_array()) else {
        return Ok(None);
    };
    let v: Vec<f64> = lever.iter().filter_map(|x| x.as_f64()).collect();
    match <[f64; 3]>::try_from(v) {
        // `0.0 - x`, not `-x`: no negative zeros in the summary.
        Ok(l) => Ok(Some(l.map(|x| 0.0 - x))),
        Err(_) => bail!("{}: import.imu_lever is not three numbers", meta.display()),
    }
}

/// The core's fix from a host fix (velocity optional).
pub(crate) fn to_core_fix<T: Real>(f: &GnssFix, use_velocity: bool) -> CoreFix<T> {
    let nan3 = Vector3::repeat(T::lit(f64::NAN));
    let v3 = |a: Option<[f64; 3]>| a.map(|a| Vector3::from(a).map(T::lit)).unwrap_or(nan3);
    CoreFix {
        t: f.t,
        pos: Geodetic {
            lat: f.lat_deg.to_radians(),
            lon: f.lon_deg.to_radians(),
            h: f.h,
        },
        vel: if use_velocity { v3(f.vel_ned) } else { nan3 },
        sd_pos: v3(f.sd_pos_ned),
        sd_vel: v3(f.sd_vel_ned),
    }
}

/// The fix `f` as the core's live loop takes it (angles in radians).
pub fn live_fix(f: &GnssFix) -> imu_ident::nav::live::LiveFix {
    imu_ident::nav::live::LiveFix {
        t: f.t,
        pos: Geodetic {
            lat: f.lat_deg.to_radians(),
            lon: f.lon_deg.to_radians(),
            h: f.h,
        },
        vel: f.vel_ned,
        sd_pos: f.sd_pos_ned,
        sd_vel: f.sd_vel_ned,
    }
}

/// `p` moved by the NED offset `d` [m]: the core's, which the firmware uses too.
pub use imu_ident::nav::run::move_by;
