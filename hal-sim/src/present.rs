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
use imu_ident::nav::NAV_N;
use imu_ident::strapdown::{Geodetic, Strapdown};
use nalgebra::Vector3;
use std::collections::HashMap;
use std::path::Path;

/// A simulated drive of `hours` (seed, 100 Hz, 1-Hz GNSS, the MEMS errors) written to `dir`,
/// and the options of its run ([`drive_options`]).
pub fn simulated_drive(dir: &Path, hours: f64, seed: u64, yaw: bool, nhc: bool) -> Result<NavArgs> {
    crate::trajectory::write::simulate_drive_files(hours, 100.0, seed, vec![], dir)?;
    drive_options(dir, yaw, nhc)
}

/// The options of a run on the simulated drive in `dir`: no outage schedule (a live run
/// withholds nothing), a lever arm, the gyro bias seeded from the 50-s window, the MEMS model
/// (the truth's); the heading given when `yaw` (else from the course), the non-holonomic
/// constraint on when `nhc` (0.05 m/s, 0.65 m below the IMU).
pub fn drive_options(dir: &Path, yaw: bool, nhc: bool) -> Result<NavArgs> {
    let truth = crate::nav_io::read_truth_csv(&dir.join("truth.csv"))?;
    let mems = crate::trajectory::errors::ImuErrorModel::mems().to_core()?;
    Ok(NavArgs {
        lever_arm: [0.3, 0.0, -0.8],
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

/// The errors of `ins` against the truth at `t` (none outside the truth's span).
fn error_at(ins: &Strapdown<f32>, truth: &[TruthRow], t: f64) -> Option<SolutionError> {
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
    let dv = [0, 1, 2].map(|k| f64::from(v[k]) - tr.vel_ned[k]);
    let (r, pi, y) = ins.attitude_f64().euler();
    let phi = phi_error([r, pi, y].map(f64::to_degrees), tr.rpy_deg);
    Some(SolutionError {
        horizontal: ne[0].hypot(ne[1]),
        velocity: dv.iter().map(|x| x * x).sum::<f64>().sqrt(),
        attitude: phi.norm().to_degrees(),
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
    }
    out.predicted = nav.predicted_samples();
    out.changes = changes.get();
    Ok(out)
}
