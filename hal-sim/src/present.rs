//! The present solution of a live run with a latency budget (`imu_ident::nav::predictor`),
//! measured: a log streamed through `LiveNav` with its fixes delivered late, and at every
//! sample the solution a consumer reads compared with the truth at that sample's time. The
//! scenario `tests/nav_present.rs` and `examples/present_bench.rs` share.
//!
//! Three solutions at the newest sample's time `t`:
//! - **present**: the output predictor's, at `t`;
//! - **stale**: the run's own, at `t - latency`, read as the present (what a consumer of a
//!   delayed-fusion navigator without a predictor gets);
//! - **run**: the run's own against the truth at its own time (the filter's error, which the
//!   predictor can at best keep).
//!
//! Also checked, per sample: the predicted solution at `t` against the run's when it reaches
//! `t`, bit for bit, wherever no filter step and no fix came between the prediction and `t`.

use crate::nav::setup::{live_config, settings};
use crate::nav::truth::{phi_error, truth_at};
use crate::nav::{live_fix, NavArgs};
use crate::nav_io::outages::north_east;
use crate::nav_io::{GnssFix, ImuSample, TruthRow};
use anyhow::{anyhow, Result};
use imu_ident::nav::live::{LiveConfig, LiveEvent, LiveNav};
use imu_ident::nav::predictor::Present;
use imu_ident::nav::{NavSd, NAV_N};
use imu_ident::strapdown::{Geodetic, Strapdown};
use nalgebra::Vector3;
use std::collections::HashMap;
use std::path::Path;

/// The GNSS antenna of [`simulated_drive`] from the IMU, body forward, right, down [m].
pub const LEVER_ARM: [f64; 3] = [0.3, 0.0, -0.8];

/// A simulated drive of `hours` (seed, 100 Hz, 1-Hz GNSS at the antenna [`LEVER_ARM`], the
/// MEMS errors) written to `dir`, and the options of its run ([`drive_options`]).
pub fn simulated_drive(dir: &Path, hours: f64, seed: u64, yaw: bool, nhc: bool) -> Result<NavArgs> {
    crate::trajectory::write::simulate_drive_files(hours, 100.0, seed, (vec![], LEVER_ARM), dir)?;
    drive_options(dir, yaw, nhc)
}

/// The options of a run on the simulated drive in `dir`: no outage schedule (a live run
/// withholds nothing), the antenna at [`LEVER_ARM`] (as [`simulated_drive`] writes it), the
/// gyro bias seeded from the 50-s window, the MEMS model
/// (the truth's); the heading given when `yaw` (else from the course), the non-holonomic
/// constraint on when `nhc` (0.05 m/s, 0.65 m below the IMU).
pub fn drive_options(dir: &Path, yaw: bool, nhc: bool) -> Result<NavArgs> {
    let truth = crate::nav_io::read_truth_csv(&dir.join("truth.csv"))?;
    let mems = crate::trajectory::errors::ImuErrorModel::mems().to_core()?;
    Ok(NavArgs {
        lever_arm: LEVER_ARM,
        align: 50.0,
        yaw_deg: yaw.then(|| truth[0].rpy_deg[2]),
        nhc: nhc.then_some(0.05),
        nhc_lever: if nhc { [0.0, 0.0, 0.65] } else { [0.0; 3] },
        init: imu_ident::nav::NavInit {
            sd_att: Vector3::repeat(1f64.to_radians()),
            sd_vel: 0.1,
            sd_pos: 1.0,
        },
        single: true,
        ..NavArgs::new(
            dir.join("imu.csv"),
            dir.join("gnss.csv"),
            mems,
            "mems (true)",
        )
    })
}

/// Errors of one solution against the truth at one time.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SolutionError {
    /// Horizontal position [m].
    pub horizontal: f64,
    /// Speed error, the norm of the NED velocity error [m/s].
    pub velocity: f64,
    /// Attitude, the norm of `phi` [deg].
    pub attitude: f64,
}

/// What a live run with its fixes late gave (module docs).
#[derive(Debug, Clone, Default)]
pub struct PresentRun {
    /// Samples given to the run.
    pub samples: usize,
    /// Per sample from `settle` on, with a truth: present, stale, run.
    pub errors: Vec<[SolutionError; 3]>,
    /// Per sample from `settle` on, with a truth: the present's errors of attitude, velocity
    /// and position (N, E, D each) over their standard deviations, as [`LiveNav::present_sd`]
    /// gives them (`[0]`) and as the filter's own at its last propagation, not carried
    /// (`[1]`).
    pub normalised: Vec<[[f64; 9]; 3]>,
    /// Per sample from `settle` on, without a truth: the horizontal distance [m] of the
    /// present and of the stale solution read at a sample's time from the run's solution when
    /// the run reaches that time (the later, better-informed answer about the same instant).
    pub to_run: Vec<[f64; 2]>,
    /// Predictions compared bit for bit with the run at their time (no step or fix between).
    pub compared: usize,
    /// Of them, the ones that differ in a bit of position, velocity or attitude.
    pub differ: usize,
    /// Samples the predictor mechanised (`LiveNav::predicted_samples`).
    pub predicted: u64,
    /// Changes of the run's solution other than by a sample: filter steps, fixes, the start.
    pub changes: u64,
    /// The present solution after every sample once running (the truth CSV's columns).
    pub rows: Vec<TruthRow>,
    /// Its standard deviations at the same samples (`present_sd.csv`; a row for each of
    /// `rows` that has them).
    pub sd_rows: Vec<PresentSdRow>,
}

/// A row of `present_sd.csv`: the standard deviations of the present solution's errors at its
/// time ([`LiveNav::present_sd`]), attitude `phi` [deg], velocity [m/s] and position [m],
/// N, E, D each.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PresentSdRow {
    /// Time of the present [s] (`present.csv`'s `t`).
    pub t: f64,
    pub sd_phi_n: f64,
    pub sd_phi_e: f64,
    pub sd_phi_d: f64,
    pub sd_vn: f64,
    pub sd_ve: f64,
    pub sd_vd: f64,
    pub sd_n: f64,
    pub sd_e: f64,
    pub sd_d: f64,
}

impl PresentSdRow {
    fn new(t: f64, sd: &NavSd<f32>) -> Self {
        let (a, v, p) = (
            sd.att.map(|x| f64::from(x).to_degrees()),
            sd.vel.map(f64::from),
            sd.pos.map(f64::from),
        );
        Self {
            t,
            sd_phi_n: a[0],
            sd_phi_e: a[1],
            sd_phi_d: a[2],
            sd_vn: v[0],
            sd_ve: v[1],
            sd_vd: v[2],
            sd_n: p[0],
            sd_e: p[1],
            sd_d: p[2],
        }
    }
}

/// The present solution as a row of the truth CSV's columns (no sensor errors).
fn row_of(now: &Present<'_, f32>) -> TruthRow {
    let ins = now.ins();
    let (p, v) = (ins.position(), ins.velocity());
    let (r, pi, y) = ins.attitude_f64().euler();
    TruthRow {
        t: now.time(),
        lat_deg: p.lat.to_degrees(),
        lon_deg: p.lon.to_degrees(),
        h: p.h,
        vel_ned: [v.x, v.y, v.z].map(f64::from),
        rpy_deg: [r, pi, y].map(f64::to_degrees),
        gyro_bias: None,
        accel_bias: None,
    }
}

/// The bits of a solution: latitude, longitude, height, velocity and attitude.
fn bits(ins: &Strapdown<f32>) -> [u64; 10] {
    let p = ins.position();
    let v = ins.velocity();
    let q = ins.attitude_f64();
    [
        p.lat.to_bits(),
        p.lon.to_bits(),
        p.h.to_bits(),
        u64::from(v.x.to_bits()),
        u64::from(v.y.to_bits()),
        u64::from(v.z.to_bits()),
        q.w.to_bits(),
        q.x.to_bits(),
        q.y.to_bits(),
        q.z.to_bits(),
    ]
}

/// The errors of `ins` against the truth at `t`, the filter's states: attitude `phi` [rad],
/// velocity [m/s] and position [m], N, E, D each (none outside the truth's span).
fn axis_errors(ins: &Strapdown<f32>, truth: &[TruthRow], t: f64) -> Option<[f64; 9]> {
    let tr = truth_at(truth, t)?;
    let p: Geodetic = ins.position();
    let ne = north_east(
        tr.lat_deg,
        tr.lon_deg,
        tr.h,
        p.lat.to_degrees(),
        p.lon.to_degrees(),
    );
    let v = ins.velocity();
    let (r, pi, y) = ins.attitude_f64().euler();
    let phi = phi_error([r, pi, y].map(f64::to_degrees), tr.rpy_deg);
    let dv = |k: usize| f64::from(v[k]) - tr.vel_ned[k];
    Some([
        phi.x,
        phi.y,
        phi.z,
        dv(0),
        dv(1),
        dv(2),
        ne[0],
        ne[1],
        tr.h - p.h,
    ])
}

/// The errors of `ins` against the truth at `t` (none outside the truth's span): the norms of
/// [`axis_errors`]' horizontal position, velocity and attitude.
fn error_at(ins: &Strapdown<f32>, truth: &[TruthRow], t: f64) -> Option<SolutionError> {
    let e = axis_errors(ins, truth, t)?;
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    Some(SolutionError {
        horizontal: e[6].hypot(e[7]),
        velocity: norm(&e[3..6]),
        attitude: norm(&e[0..3]).to_degrees(),
    })
}

/// Streams `imu` and `fixes` through a live `f32` run of `args` with the latency budget
/// `latency` [s], each fix delivered once the samples reach its time plus `delay` [s]; the
/// errors are kept from `settle` [s] after the first sample on.
pub fn present_run(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    truth: Option<&[TruthRow]>,
    (delay, latency, settle): (f64, f64, f64),
) -> Result<PresentRun> {
    let cfg = LiveConfig {
        latency,
        ..live_config(args)
    };
    let mut nav =
        LiveNav::<f32, NAV_N>::new(settings(args), cfg, LiveNav::<f32, NAV_N>::no_observer);
    let mut out = PresentRun::default();
    // Filter steps and fixes of the run so far: a prediction made at count `c` is the run's
    // solution at its time when the run reaches that time with the count still `c`.
    let changes = std::cell::Cell::new(0u64);
    let mut count = |e: LiveEvent<'_, f32>| match e {
        LiveEvent::Imu(_, step) if step.stepped => changes.set(changes.get() + 1),
        LiveEvent::Fix { .. } | LiveEvent::Started(_) => changes.set(changes.get() + 1),
        _ => {}
    };
    // Per sample time: the change count, the prediction's bits, the prediction's and the
    // stale solution's latitude and longitude [rad].
    let mut predictions: HashMap<u64, (u64, [u64; 10], [f64; 4])> = HashMap::new();
    let t_first = imu.first().map_or(0.0, |s| s.t);
    let mut k = 0;
    for s in imu {
        while k < fixes.len() && fixes[k].t + delay < s.t {
            let f = &fixes[k];
            nav.gnss(&live_fix(f), &mut count)
                .map_err(|e| anyhow!("fix at {} s: {e:?}", f.t))?;
            k += 1;
        }
        nav.imu(s.t, s.gyro, s.accel, &mut count)
            .map_err(|e| anyhow!("sample at {} s: {e:?}", s.t))?;
        out.samples += 1;
        let (Some(run), Some(now)) = (nav.run(), nav.present()) else {
            continue;
        };
        out.rows.push(row_of(&now));
        let now_sd = nav.present_sd();
        if let Some(sd) = &now_sd {
            out.sd_rows.push(PresentSdRow::new(now.time(), sd));
        }
        let c = changes.get();
        let ins = run.navigator().ins();
        let (p, q) = (now.ins().position(), ins.position());
        let at = [p.lat, p.lon, q.lat, q.lon];
        predictions.insert(now.time().to_bits(), (c, bits(now.ins()), at));
        let settled = s.t - t_first >= settle;
        if let Some((made, b, at)) = predictions.remove(&run.time().to_bits()) {
            if made == c {
                out.compared += 1;
                out.differ += usize::from(b != bits(ins));
            }
            let (lat, lon, h) = (q.lat.to_degrees(), q.lon.to_degrees(), q.h);
            let d = |la: f64, lo: f64| {
                let ne = north_east(lat, lon, h, la.to_degrees(), lo.to_degrees());
                ne[0].hypot(ne[1])
            };
            if settled {
                out.to_run.push([d(at[0], at[1]), d(at[2], at[3])]);
            }
        }
        predictions.retain(|t, _| f64::from_bits(*t) > run.time());
        let Some(truth) = truth.filter(|_| settled) else {
            continue;
        };
        let errs = (
            error_at(now.ins(), truth, now.time()),
            error_at(ins, truth, now.time()),
            error_at(ins, truth, run.time()),
        );
        if let (Some(a), Some(b), Some(c)) = errs {
            out.errors.push([a, b, c]);
        }
        let carried = now_sd.map(|sd| {
            let mut all = [0.0; 9];
            for (k, v) in sd.att.iter().chain(&sd.vel).chain(&sd.pos).enumerate() {
                all[k] = f64::from(*v);
            }
            all
        });
        let own = run.navigator().sigma_si();
        let at_run = run.navigator().sd_at(run.time()).ok();
        let both = (
            axis_errors(now.ins(), truth, now.time()),
            axis_errors(ins, truth, run.time()),
        );
        if let ((Some(e), Some(er)), Some(sd), Some(sr)) = (both, carried, at_run) {
            let z = |k: usize, s: f64| e[k] / s;
            let sr: Vec<f64> = sr
                .att
                .iter()
                .chain(&sr.vel)
                .chain(&sr.pos)
                .map(|v| f64::from(*v))
                .collect();
            out.normalised.push([
                core::array::from_fn(|k| z(k, sd[k])),
                core::array::from_fn(|k| z(k, f64::from(own[k]))),
                core::array::from_fn(|k| er[k] / sr[k]),
            ]);
        }
    }
    out.predicted = nav.predicted_samples();
    out.changes = changes.get();
    Ok(out)
}

/// Median, 95th percentile, worst and RMS of `v`.
fn stats(v: &[f64]) -> serde_json::Value {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let at = |q: f64| {
        s.get(((s.len().max(1) - 1) as f64 * q).round() as usize)
            .copied()
    };
    let rms = (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
    serde_json::json!({ "median": at(0.5), "p95": at(0.95), "worst": at(1.0), "rms": rms })
}

/// Per state (attitude, velocity, position; N, E, D) the RMS of the present's normalised
/// errors and their fraction outside 3 sd, with its standard deviations carried to its time
/// (`carried`) and as the filter had them (`not_carried`); null without a truth.
fn sd_consistency(r: &PresentRun) -> serde_json::Value {
    if r.normalised.is_empty() {
        return serde_json::Value::Null;
    }
    let names = [
        "phi_n", "phi_e", "phi_d", "v_n", "v_e", "v_d", "p_n", "p_e", "p_d",
    ];
    let n = r.normalised.len() as f64;
    let mut out = serde_json::Map::new();
    for (w, label) in ["carried", "not_carried"].iter().enumerate() {
        let mut axes = serde_json::Map::new();
        for (k, name) in names.iter().enumerate() {
            let z = r.normalised.iter().map(|z| z[w][k]);
            let rms = (z.clone().map(|v| v * v).sum::<f64>() / n).sqrt();
            let outside = z.filter(|v| v.abs() > 3.0).count() as f64 / n;
            axes.insert(
                (*name).into(),
                serde_json::json!({ "rms_z": rms, "outside_3sd": outside }),
            );
        }
        out.insert((*label).into(), axes.into());
    }
    out.into()
}

/// `hal-sim nav --present DELAY,LATENCY`: the log of `args` streamed live (module docs), every
/// fix `delay` [s] late within the budget `latency` [s]; writes `present.csv` (the present
/// solution after every sample, the truth CSV's columns), `present_sd.csv` (its standard
/// deviations, [`PresentSdRow`]) and `present.json` (with a truth, the three solutions'
/// errors from the first sample on and the present's against its deviations; without, the
/// distances from the run's own later solution) into `out`. Returns a one-line summary.
pub fn write_present(
    args: &NavArgs,
    truth: Option<&[TruthRow]>,
    (delay, latency): (f64, f64),
    out: &Path,
) -> Result<String> {
    if !(delay.is_finite() && latency.is_finite() && latency >= 0.0) {
        anyhow::bail!(
            "--present: DELAY and LATENCY must be finite, LATENCY >= 0 (got {delay}, {latency})"
        );
    }
    let imu = crate::nav_io::read_imu_any(&args.imu)?;
    let fixes = crate::nav_io::read_gnss_any(&args.gnss, args.max_q)?;
    let imu = crate::nav::setup::shifted_imu(args, &imu);
    let r = present_run(args, &imu, &fixes, truth, (delay, latency, 0.0))?;
    crate::nav_io::write_truth_csv(&out.join("present.csv"), &r.rows)?;
    crate::output::write_csv(&out.join("present_sd.csv"), &r.sd_rows)?;
    let names = ["present", "stale", "run"];
    let mut errors = serde_json::Map::new();
    for (k, name) in names.iter().enumerate() {
        let pick =
            |f: fn(&SolutionError) -> f64| r.errors.iter().map(|e| f(&e[k])).collect::<Vec<_>>();
        errors.insert(
            (*name).into(),
            serde_json::json!({
                "horizontal_m": stats(&pick(|e| e.horizontal)),
                "velocity_m_s": stats(&pick(|e| e.velocity)),
                "attitude_deg": stats(&pick(|e| e.attitude)),
            }),
        );
    }
    let json = serde_json::json!({
        "delay_s": delay,
        "latency_s": latency,
        "samples": r.samples,
        "rows": r.rows.len(),
        "mechanised_per_sample": r.predicted as f64 / r.samples.max(1) as f64,
        "compared_bit_for_bit": r.compared,
        "differ": r.differ,
        "errors_against_truth": if r.errors.is_empty() { serde_json::Value::Null } else { errors.into() },
        "sd_against_truth": sd_consistency(&r),
        "distance_from_the_run_m": {
            "present": stats(&r.to_run.iter().map(|d| d[0]).collect::<Vec<_>>()),
            "stale": stats(&r.to_run.iter().map(|d| d[1]).collect::<Vec<_>>()),
        },
    });
    crate::output::write_string(
        &out.join("present.json"),
        &serde_json::to_string_pretty(&json)?,
    )?;
    let rms = |k: &str| {
        json["distance_from_the_run_m"][k]["rms"]
            .as_f64()
            .unwrap_or(f64::NAN)
    };
    Ok(format!(
        "present: {} rows in present.csv (fixes {delay} s late, a {latency}-s budget); RMS distance \
         from the run's later solution {:.3} m (stale {:.3} m); {} predictions compared bit for \
         bit, {} differ; present.json",
        r.rows.len(),
        rms("present"),
        rms("stale"),
        r.compared,
        r.differ
    ))
}
