//! What `hal-sim nav` writes: one record per GNSS epoch (`estimates.csv`), the solution in
//! RTKLIB's format (`solution.pos`) and `summary.json` (README "Strapdown INS/GNSS:
//! `hal-sim nav`"); and the progress bar over the IMU samples.

use super::NavArgs;
use crate::nav_io::{write_solution_pos, GnssFix, OutageSummary, PosEpoch};
use crate::output::{write_csv, write_string};
use anyhow::Result;
use imu_ident::nav::{nav_idx, ImuSensor, Navigator};
use imu_ident::Real;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use std::io::IsTerminal;
use std::path::Path;

/// Navigation error states: attitude `phi` N, E, D [rad], velocity [m/s], position N, E, D [m].
pub const NAV_ERRORS: usize = 9;

/// A progress bar over `n` IMU samples on stderr, hidden when stderr is not a terminal (CI
/// logs, pipes), like `hal-sim series`'s.
pub fn imu_progress(n: usize) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(n as u64);
    let style = ProgressStyle::with_template(
        "nav [{bar:40}] {pos}/{len} IMU samples ({elapsed}, eta {eta})",
    )
    .unwrap_or_else(|_| ProgressStyle::default_bar())
    .progress_chars("=> ");
    bar.set_style(style);
    bar
}

/// The solution and the filter's view at one GNSS epoch.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EpochRecord {
    /// GNSS epoch time [s].
    pub t: f64,
    /// Withheld by the outage schedule.
    pub withheld: bool,
    /// Fused (not withheld, due, heading known).
    pub fused: bool,
    /// Rejected by the vector gate.
    pub gated: bool,
    /// Solution (IMU position moved back to the epoch) [deg, deg, m].
    pub lat_deg: f64,
    /// Longitude [deg].
    pub lon_deg: f64,
    /// Height [m].
    pub h: f64,
    /// NED velocity [m/s].
    pub vel: [f64; 3],
    /// Roll, pitch, yaw [deg].
    pub rpy_deg: [f64; 3],
    /// 1-sigma of the attitude error N, E, D [deg].
    pub sd_att_deg: [f64; 3],
    /// 1-sigma of the velocity error [m/s].
    pub sd_vel: [f64; 3],
    /// 1-sigma of the position error N, E, D [m].
    pub sd_pos: [f64; 3],
    /// Estimated gyro errors [rad/s].
    pub bg: [f64; 3],
    /// Estimated accelerometer errors [m/s^2].
    pub ba: [f64; 3],
    /// Innovations position N, E, D [m], velocity N, E, D [m/s] (NaN: not fused).
    pub innovation: [f64; 6],
    /// Per-axis NIS `nu_i^2 / S_ii`.
    pub nis_axis: [f64; 6],
    /// Per-axis used flag.
    pub used: [bool; 6],
    /// Vector NIS and its degrees of freedom.
    pub nis: f64,
    /// Degrees of freedom of `nis`.
    pub dof: usize,
    /// Log-likelihood of the fused axes (0 when none).
    pub loglik: f64,
    /// The heading was known (from `--yaw` or the GNSS course) when the record was taken.
    pub heading_known: bool,
    /// Time of the solution the record was taken from (the IMU sample at or just after `t`).
    pub t_sol: f64,
    /// Pre-fit innovation standard deviations `sqrt(S_ii)` (NaN: not fused).
    pub inn_sd: [f64; 6],
    /// 1-sigma of the estimated gyro errors [rad/s].
    pub sd_bg: [f64; 3],
    /// 1-sigma of the estimated accelerometer errors [m/s^2].
    pub sd_ba: [f64; 3],
    /// Covariance of the navigation errors (attitude `phi` [rad], velocity [m/s], position
    /// N, E, D [m]; computed minus true), SI.
    pub p_nav: [[f64; NAV_ERRORS]; NAV_ERRORS],
}

impl EpochRecord {
    /// A record with no fusion yet.
    pub fn blank(t: f64, withheld: bool) -> Self {
        let nan = f64::NAN;
        Self {
            t,
            withheld,
            fused: false,
            gated: false,
            lat_deg: nan,
            lon_deg: nan,
            h: nan,
            vel: [nan; 3],
            rpy_deg: [nan; 3],
            sd_att_deg: [nan; 3],
            sd_vel: [nan; 3],
            sd_pos: [nan; 3],
            bg: [nan; 3],
            ba: [nan; 3],
            innovation: [nan; 6],
            nis_axis: [nan; 6],
            used: [false; 6],
            nis: nan,
            dof: 0,
            loglik: 0.0,
            heading_known: false,
            t_sol: nan,
            inn_sd: [nan; 6],
            sd_bg: [nan; 3],
            sd_ba: [nan; 3],
            p_nav: [[nan; NAV_ERRORS]; NAV_ERRORS],
        }
    }

    /// Fills the solution from the navigator at `t_now`, moved back to the epoch `t`.
    pub fn fill_solution<T: Real, const N: usize, O: imu_ident::nav::NavObserver<T, N>>(
        &mut self,
        nav: &Navigator<T, N, O>,
        t: f64,
        t_now: f64,
    ) {
        let ins = nav.ins();
        // The run's own epoch solution (`imu_ident::nav::run::Run::epoch`): the firmware's.
        let (back, v) = nav.solution_at(t);
        let v = v.map(|x| x.as_f64());
        self.lat_deg = back.lat.to_degrees();
        self.lon_deg = back.lon.to_degrees();
        self.h = back.h;
        self.vel = [v.x, v.y, v.z];
        let (r, p, y) = ins.attitude_f64().euler();
        self.rpy_deg = [r.to_degrees(), p.to_degrees(), y.to_degrees()];
        let sd = nav.sigma_si();
        for i in 0..3 {
            self.sd_att_deg[i] = sd[nav_idx::ATT + i].as_f64().to_degrees();
            self.sd_vel[i] = sd[nav_idx::VEL + i].as_f64();
            self.sd_pos[i] = sd[nav_idx::POS + i].as_f64();
        }
        let (bg, ba) = nav.sensor_errors();
        self.bg = [bg.x.as_f64(), bg.y.as_f64(), bg.z.as_f64()];
        self.ba = [ba.x.as_f64(), ba.y.as_f64(), ba.z.as_f64()];
        self.t_sol = t_now;
        // S_ii = nu_i^2 / NIS_i (the record keeps the NIS; exact unless nu_i = 0).
        for i in 0..6 {
            self.inn_sd[i] = self.innovation[i].abs() / self.nis_axis[i].sqrt();
        }
        // Physical covariance: P is in scaled states, P_si = s_i s_j P_ij with
        // s_i = sigma_si_i / sqrt(P_ii).
        let p = &nav.kalman().P;
        let scale: Vec<f64> = (0..N)
            .map(|i| {
                let pii = p[i][i].as_f64();
                if pii > 0.0 {
                    sd[i].as_f64() / pii.sqrt()
                } else {
                    0.0
                }
            })
            .collect();
        let p_si = |i: usize, j: usize| p[i][j].as_f64() * scale[i] * scale[j];
        for (i, row) in self.p_nav.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = p_si(i, j);
            }
        }
        // Sensor error of an axis: sum_c C_c x_c, variance c^T P c over its states.
        let mut rows: [Vec<(usize, f64)>; 6] = Default::default();
        nav.model().for_each_component(&mut |s, axis, k, c| {
            let blk = c.block();
            let si = if s == ImuSensor::Accel { 3 } else { 0 };
            for j in 0..blk.states {
                rows[si + axis].push((k + j, blk.c[j].as_f64()));
            }
        });
        for (a, r) in rows.iter().enumerate() {
            let var: f64 = r
                .iter()
                .flat_map(|&(i, ci)| r.iter().map(move |&(j, cj)| (i, j, ci * cj)))
                .filter(|&(i, j, _)| i < N && j < N)
                .map(|(i, j, c)| c * p_si(i, j))
                .sum();
            let sd = var.max(0.0).sqrt();
            if a < 3 {
                self.sd_bg[a] = sd;
            } else {
                self.sd_ba[a - 3] = sd;
            }
        }
    }
}

/// `summary.json`.
#[derive(Debug, Clone, Serialize)]
pub struct NavSummary {
    /// The noise model's name.
    pub model: String,
    /// Inputs.
    pub imu: String,
    /// GNSS input.
    pub gnss: String,
    /// Core precision.
    pub precision: &'static str,
    /// GNSS epochs after the start.
    pub epochs: usize,
    /// Fused epochs.
    pub fused: usize,
    /// Gated epochs.
    pub gated: usize,
    /// Withheld epochs.
    pub withheld: usize,
    /// Mean per-axis NIS over the fused epochs (pos N, E, D, vel N, E, D); 1 for a
    /// consistent filter.
    pub mean_nis_axis: [f64; 6],
    /// Innovation log-likelihood summed over the fused epochs (without `ln 2 pi`).
    pub loglik: f64,
    /// Heading was aligned.
    pub heading_known: bool,
    /// IMU gaps longer than 0.1 s.
    pub imu_gaps: u32,
    /// Host run time [s] (reading excluded).
    pub run_seconds: f64,
    /// Horizontal error at the end of each outage, RMS / median / max [m].
    pub outage_rms_m: Option<f64>,
    /// Median [m].
    pub outage_median_m: Option<f64>,
    /// Max [m].
    pub outage_max_m: Option<f64>,
    /// Scored outages.
    pub outages_scored: Option<usize>,
    /// Errors against the truth (`--truth`; README "errors.csv").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truth: Option<super::truth::TruthSummary>,
    /// The non-holonomic constraint's updates (`--nhc`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nhc: Option<NhcSummary>,
    /// The zero-velocity updates (`--zupt`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub zupt: Option<ZuptSummary>,
}

/// What the non-holonomic constraint did over a run (`--nhc`; not part of `loglik`, which is
/// the GNSS innovations' only: the constraint is a model of the vehicle, not a measurement).
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct NhcSummary {
    /// Standard deviation of the body lateral and vertical velocity [m/s].
    pub sd: f64,
    /// The constrained point from the IMU, body FRD [m].
    pub lever: [f64; 3],
    /// Updates made (filter steps with the heading known and the speed above the threshold).
    pub updates: usize,
    /// Of which rejected by the gate.
    pub gated: usize,
    /// Updates made while GNSS was withheld.
    pub in_outages: usize,
    /// Mean per-axis NIS of the accepted updates (body y, z): 1 when `sd` plus the filter's
    /// own velocity and attitude uncertainty match the spread of the constraint's violation.
    pub mean_nis_axis: [f64; 2],
    /// RMS of the pre-fit innovation (the predicted body y, z velocity) [m/s].
    pub rms_innovation: [f64; 2],
}

impl NhcSummary {
    /// Adds one update's pre-fit innovation `nu`, variance `s`, and gate result.
    pub fn add(&mut self, nu: [f64; 2], s: [f64; 2], gated: bool, withheld: bool) {
        self.updates += 1;
        self.in_outages += usize::from(withheld);
        if gated {
            self.gated += 1;
            return;
        }
        for i in 0..2 {
            self.mean_nis_axis[i] += nu[i] * nu[i] / s[i];
            self.rms_innovation[i] += nu[i] * nu[i];
        }
    }

    /// Turns the sums of [`add`](Self::add) into means.
    pub fn finish(mut self) -> Self {
        let n = (self.updates - self.gated).max(1) as f64;
        for i in 0..2 {
            self.mean_nis_axis[i] /= n;
            self.rms_innovation[i] = (self.rms_innovation[i] / n).sqrt();
        }
        self
    }
}

/// What the zero-velocity updates did over a run (`--zupt`; like the constraint, not part of
/// `loglik`).
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct ZuptSummary {
    /// Standard deviation of each velocity axis at rest [m/s].
    pub sd: f64,
    /// The rest detector's bounds: rate [rad/s], specific force from gravity [m/s^2], speed
    /// [m/s] (`imu_ident::nav::rest`).
    pub detector: [f64; 3],
    /// Updates made (filter steps found at rest).
    pub updates: usize,
    /// Of which rejected by the gate.
    pub gated: usize,
    /// Updates made while GNSS was withheld.
    pub in_outages: usize,
    /// Mean NIS per axis of the accepted updates (1 when the velocity sd is honest at rest).
    pub mean_nis_axis: f64,
}

impl ZuptSummary {
    /// No update yet, with the run's settings.
    pub fn new(z: imu_ident::nav::Zupt<f64>) -> Self {
        Self {
            sd: z.sd,
            detector: [z.gyro_max, z.accel_max, z.speed_max],
            ..Self::default()
        }
    }

    /// Adds one update: its NIS summed over the three axes, and the gate's result.
    pub fn add(&mut self, nis: f64, gated: bool, withheld: bool) {
        self.updates += 1;
        self.in_outages += usize::from(withheld);
        if gated {
            self.gated += 1;
        } else {
            self.mean_nis_axis += nis / 3.0;
        }
    }

    /// Turns the sum of [`add`](Self::add) into a mean.
    pub fn finish(mut self) -> Self {
        self.mean_nis_axis /= (self.updates - self.gated).max(1) as f64;
        self
    }
}

impl NavSummary {
    /// From the records.
    pub fn new(
        args: &NavArgs,
        epochs: &[EpochRecord],
        scores: Option<&OutageSummary>,
        imu_gaps: u32,
        run_seconds: f64,
        heading_known: bool,
    ) -> Self {
        let fused: Vec<&EpochRecord> = epochs.iter().filter(|e| e.fused && !e.gated).collect();
        let mut mean = [0.0; 6];
        for (i, m) in mean.iter_mut().enumerate() {
            let v: Vec<f64> = fused
                .iter()
                .map(|e| e.nis_axis[i])
                .filter(|x| x.is_finite())
                .collect();
            *m = v.iter().sum::<f64>() / v.len().max(1) as f64;
        }
        Self {
            model: args.model_name.clone(),
            imu: args.imu.display().to_string(),
            gnss: args.gnss.display().to_string(),
            precision: if args.single { "f32" } else { "f64" },
            epochs: epochs.len(),
            fused: epochs.iter().filter(|e| e.fused).count(),
            gated: epochs.iter().filter(|e| e.gated).count(),
            withheld: epochs.iter().filter(|e| e.withheld).count(),
            mean_nis_axis: mean,
            loglik: epochs.iter().map(|e| e.loglik).sum(),
            heading_known,
            imu_gaps,
            run_seconds,
            outage_rms_m: scores.map(|s| s.rms),
            outage_median_m: scores.map(|s| s.median),
            outage_max_m: scores.map(|s| s.max),
            outages_scored: scores.map(|s| s.outages.len()),
            truth: None,
            nhc: None,
            zupt: None,
        }
    }
}

#[derive(Serialize)]
struct Row {
    t: f64,
    withheld: u8,
    fused: u8,
    gated: u8,
    lat: f64,
    lon: f64,
    h: f64,
    vn: f64,
    ve: f64,
    vd: f64,
    roll: f64,
    pitch: f64,
    yaw: f64,
    sd_att_n: f64,
    sd_att_e: f64,
    sd_att_d: f64,
    sd_vn: f64,
    sd_ve: f64,
    sd_vd: f64,
    sd_n: f64,
    sd_e: f64,
    sd_d: f64,
    bg_x: f64,
    bg_y: f64,
    bg_z: f64,
    ba_x: f64,
    ba_y: f64,
    ba_z: f64,
    inn_n: f64,
    inn_e: f64,
    inn_d: f64,
    inn_vn: f64,
    inn_ve: f64,
    inn_vd: f64,
    nis_n: f64,
    nis_e: f64,
    nis_d: f64,
    nis_vn: f64,
    nis_ve: f64,
    nis_vd: f64,
    nis: f64,
    dof: usize,
    heading_known: u8,
    sd_bg_x: f64,
    sd_bg_y: f64,
    sd_bg_z: f64,
    sd_ba_x: f64,
    sd_ba_y: f64,
    sd_ba_z: f64,
    sd_inn_n: f64,
    sd_inn_e: f64,
    sd_inn_d: f64,
    sd_inn_vn: f64,
    sd_inn_ve: f64,
    sd_inn_vd: f64,
}

/// Everything `hal-sim nav` writes: [`write_all`], `errors.csv` (with a truth comparison) and
/// `report.html` (with the further `(title, HTML)` `sections`, [`super::report::html`]).
pub fn write_outputs(
    out: &Path,
    run: &super::NavRun,
    cmp: Option<&super::truth::TruthComparison>,
    id: Option<&super::identify::Identified>,
    sections: &[(String, String)],
) -> Result<()> {
    write_all(out, run)?;
    if let Some(c) = cmp {
        super::truth::write_errors_csv(&out.join("errors.csv"), &c.rows)?;
    }
    super::report::write(out, run, cmp, id, sections)
}

/// Writes `estimates.csv`, `solution.pos` and `summary.json` (and `outages.json`) into `out`.
pub fn write_all(out: &Path, run: &super::NavRun) -> Result<()> {
    std::fs::create_dir_all(out)?;
    let rows: Vec<Row> = run
        .epochs
        .iter()
        .map(|e| Row {
            t: e.t,
            withheld: e.withheld.into(),
            fused: e.fused.into(),
            gated: e.gated.into(),
            lat: e.lat_deg,
            lon: e.lon_deg,
            h: e.h,
            vn: e.vel[0],
            ve: e.vel[1],
            vd: e.vel[2],
            roll: e.rpy_deg[0],
            pitch: e.rpy_deg[1],
            yaw: e.rpy_deg[2],
            sd_att_n: e.sd_att_deg[0],
            sd_att_e: e.sd_att_deg[1],
            sd_att_d: e.sd_att_deg[2],
            sd_vn: e.sd_vel[0],
            sd_ve: e.sd_vel[1],
            sd_vd: e.sd_vel[2],
            sd_n: e.sd_pos[0],
            sd_e: e.sd_pos[1],
            sd_d: e.sd_pos[2],
            bg_x: e.bg[0],
            bg_y: e.bg[1],
            bg_z: e.bg[2],
            ba_x: e.ba[0],
            ba_y: e.ba[1],
            ba_z: e.ba[2],
            inn_n: e.innovation[0],
            inn_e: e.innovation[1],
            inn_d: e.innovation[2],
            inn_vn: e.innovation[3],
            inn_ve: e.innovation[4],
            inn_vd: e.innovation[5],
            nis_n: e.nis_axis[0],
            nis_e: e.nis_axis[1],
            nis_d: e.nis_axis[2],
            nis_vn: e.nis_axis[3],
            nis_ve: e.nis_axis[4],
            nis_vd: e.nis_axis[5],
            nis: e.nis,
            dof: e.dof,
            heading_known: e.heading_known.into(),
            sd_bg_x: e.sd_bg[0],
            sd_bg_y: e.sd_bg[1],
            sd_bg_z: e.sd_bg[2],
            sd_ba_x: e.sd_ba[0],
            sd_ba_y: e.sd_ba[1],
            sd_ba_z: e.sd_ba[2],
            sd_inn_n: e.inn_sd[0],
            sd_inn_e: e.inn_sd[1],
            sd_inn_d: e.inn_sd[2],
            sd_inn_vn: e.inn_sd[3],
            sd_inn_ve: e.inn_sd[4],
            sd_inn_vd: e.inn_sd[5],
        })
        .collect();
    write_csv(&out.join("estimates.csv"), &rows)?;
    let pos: Vec<PosEpoch> = run
        .epochs
        .iter()
        .map(|e| PosEpoch {
            fix: GnssFix {
                t: e.t,
                lat_deg: e.lat_deg,
                lon_deg: e.lon_deg,
                h: e.h,
                vel_ned: Some(e.vel),
                sd_pos_ned: Some(e.sd_pos),
                sd_vel_ned: Some(e.sd_vel),
            },
            // RTKLIB has no "INS" quality; 5 (single) marks every epoch as not RTK.
            q: 5,
            ns: 0,
            sd_cross: [0.0; 3],
            age: 0.0,
            ratio: 0.0,
            sd_vel_cross: [0.0; 3],
        })
        .collect();
    write_solution_pos(
        &out.join("solution.pos"),
        &pos,
        "hal-sim nav (imu-ident strapdown INS/GNSS)",
    )?;
    write_string(
        &out.join("summary.json"),
        &serde_json::to_string_pretty(&run.summary)?,
    )?;
    if let Some(o) = &run.outages {
        write_string(&out.join("outages.json"), &serde_json::to_string_pretty(o)?)?;
    }
    if let Some(a) = &run.adapt {
        write_string(&out.join("adapt.json"), &serde_json::to_string_pretty(a)?)?;
        a.write_csv(&out.join("adapt.csv"))?;
        let toml = super::model::to_toml(&a.model)?;
        let mut head = String::from("# The model in use at the end of hal-sim nav --adapt\n");
        if a.coordinates.iter().any(|c| c.gnss_sd().is_some()) {
            // What the model file cannot hold: the GNSS factors the run ended with.
            let [p, v] = a.gnss_sd_factor_end();
            head += &format!("# with the GNSS standard deviations: --gnss-sd-factor {p},{v}\n");
        }
        write_string(&out.join("adapt-model.toml"), &toml.to_text(&head)?)?;
    }
    Ok(())
}
