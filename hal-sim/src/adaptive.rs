//! The online identification (`imu_ident::adapt`) on the host: a replay through the step
//! identifying online ([`crate::replay`]), collecting estimate rows and the parameters over
//! time; plus the ACF-loop baselines of the paper (issue 3) for comparison.
//!
//! All numerics are in the no_std core; this module only loops, stores and compares.

use crate::log::LogRow;
use crate::records::{EstimateRow, ParamRow, RunCounts};
use crate::replay;
use anyhow::{anyhow, Result};
use imu_ident::adapt::params::MAXP;
use imu_ident::adapt::AdaptConfig;
use imu_ident::autocorr::acf_batch;
use imu_ident::filter::InsFilter;
use imu_ident::ident::{lag1_corrected, paper_eq15, sigma2, SampleAcf};
use imu_ident::model::Quantity;
use imu_ident::model::{Component, ErrorSource, InsModel};
use imu_ident::Real;

/// Everything one adaptive replay produced.
#[derive(Debug, Clone)]
pub struct AdaptiveRun {
    /// Per-tick estimates of the centre filter (bridged ticks included).
    pub estimates: Vec<EstimateRow>,
    /// What the replay did.
    pub counts: RunCounts,
    /// Parameters at the first tick and after every update.
    pub params: Vec<ParamRow>,
    /// The identified model at the end.
    pub final_model: InsModel<f64>,
    /// `ln` parameters at the end.
    pub theta: [f64; MAXP],
    /// `sqrt(diag(I_total^-1))` at the end (relative std of each parameter), if defined.
    pub crb: Option<[f64; MAXP]>,
    /// Parameter updates applied.
    pub updates: u32,
    /// Jumps to a probe.
    pub jumps: u32,
    /// Score summed over the whole run (no forgetting), `ln` parameters.
    pub total_score: [f64; MAXP],
    /// Fisher information summed over the whole run (no forgetting).
    pub total_fisher: [[f64; MAXP]; MAXP],
    /// Where the global stage dated the last change in service it found [s from the first
    /// tick] (`None`: none found).
    pub last_change: Option<f64>,
}

impl AdaptiveRun {
    /// Times [h] of the ticks whose telemetry flags carry any bit of `flag` (for example
    /// `imu_ident::telemetry::SENSOR_CHANGE`).
    pub fn flagged_hours(&self, flag: u16) -> Vec<f64> {
        self.estimates
            .iter()
            .filter(|e| e.flags & flag != 0)
            .map(|e| e.t / 3600.0)
            .collect()
    }
}

/// Replays `log` through the step identifying online ([`replay::run`] with `cfg`), started
/// from `start`, in precision `T`.
pub fn run<T: Real>(
    start: &InsModel<f64>,
    log: &[LogRow],
    cfg: AdaptConfig<f64>,
) -> Result<AdaptiveRun> {
    let r = replay::run::<T>(start, Some(&cfg), log)?;
    let f = r
        .estimator
        .adaptive()
        .ok_or_else(|| anyhow!("the step is not adapting"))?;
    let mut theta = [0.0; MAXP];
    for (o, v) in theta.iter_mut().zip(f.theta().iter()) {
        *o = v.as_f64();
    }
    let crb = f
        .crb(f.total_information())
        .map(|c| c.map(|v: T| v.as_f64()));
    Ok(AdaptiveRun {
        estimates: r.telemetry.estimate_rows(),
        counts: r.telemetry.counts(),
        params: r.telemetry.param_rows(),
        final_model: r.end_model()?,
        theta,
        crb,
        updates: f.updates(),
        jumps: f.jumps(),
        total_score: f.total_information().score.map(|v| v.as_f64()),
        total_fisher: f.total_information().fisher.map(|r| r.map(|v| v.as_f64())),
        last_change: (f.global().changes() > 0)
            .then(|| f64::from(f.global().floor()) * f64::from(cfg.global.block) * start.dt),
    })
}

/// `(tau, sigma)` of the first Gauss-Markov component of `sensor` in `m`.
pub fn gm_params(m: &InsModel<f64>, sensor: ErrorSource) -> Option<(f64, f64)> {
    let comps = match sensor {
        ErrorSource::Accel => &m.accel,
        ErrorSource::Gyro => &m.gyro,
        ErrorSource::Observation => return None,
    };
    comps.iter().find_map(|c| match c {
        Component::GaussMarkov(g) => Some((g.tau, g.sigma)),
        _ => None,
    })
}

/// Tilt RMS and fraction outside 3 sigma over rows with `t0 <= t < t1` (truth required).
pub fn tilt_window(log: &[LogRow], est: &[EstimateRow], t0: f64, t1: f64) -> Option<(f64, f64)> {
    let mut n = 0usize;
    let (mut ss, mut out) = (0.0, 0usize);
    let mut i = 0;
    for e in est.iter().filter(|e| e.t >= t0 && e.t < t1) {
        while i < log.len() && log[i].t < e.t {
            i += 1;
        }
        let tr = log.get(i)?.truth?;
        let d = tr.delta - e.delta_hat;
        ss += d * d;
        out += usize::from(d.abs() > 3.0 * e.sigma_delta);
        n += 1;
    }
    (n > 0).then(|| ((ss / n as f64).sqrt(), out as f64 / n as f64))
}

/// Which ACF estimator the baseline loop uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AcfVariant {
    /// The paper as printed (sign fixed): eq. 15 slope, `sigma^2 = R_0`.
    Paper,
    /// Bias-corrected lag 1, `sigma^2 = R_0 + mean(P)`.
    Corrected,
}

/// The paper's loop: every `block` ticks, re-identify each sensor's (single Gauss-Markov)
/// `sigma, alpha` from the sample ACF of the filter's own estimates over the last `window`
/// ticks, and feed them back (`set_model` keeps `x, P`). Returns the estimates and the final
/// model.
///
/// The step has no external model feedback, so this baseline runs its own filter, but on the
/// ticks the step decides: it [`follow`](replay::follow)s a driven run of `start` (bridged
/// ticks predict only, skipped rows are skipped). The paper's loop has no outlier gate, so
/// every row's observation is used.
#[allow(clippy::type_complexity)]
pub fn run_acf_loop(
    start: &InsModel<f64>,
    log: &[LogRow],
    variant: AcfVariant,
    block: usize,
    window: usize,
    lags: usize,
) -> Result<(Vec<EstimateRow>, InsModel<f64>)> {
    let plan = replay::run::<f64>(start, None, log)?.telemetry.records;
    let mut f = InsFilter::<f64>::new(start.clone()).map_err(|e| anyhow!("{e}"))?;
    let mut hist: [Vec<(f64, f64)>; 2] = [Vec::new(), Vec::new()];
    let mut est = Vec::with_capacity(plan.len());
    for (k, tick) in replay::follow(log, &plan).enumerate() {
        let inn = f.step(tick.row.map_or(f64::NAN, |r| r.z));
        let e = f.estimates();
        hist[0].push((e.da, e.sigma_da * e.sigma_da));
        hist[1].push((e.dw, e.sigma_dw * e.sigma_dw));
        est.push(EstimateRow {
            t: tick.record.t,
            dv_hat: e.dv,
            delta_hat: e.delta,
            da_hat: e.da,
            dw_hat: e.dw,
            sigma_dv: e.sigma_dv,
            sigma_delta: e.sigma_delta,
            sigma_da: e.sigma_da,
            sigma_dw: e.sigma_dw,
            innovation: inn.innovation,
            innovation_var: inn.variance,
            nis: inn.nis,
            flags: tick.record.flags & imu_ident::telemetry::BRIDGED,
        });
        if (k + 1) % block != 0 || k + 1 < window {
            continue;
        }
        let mut m = f.model().clone();
        for (s, h) in hist.iter().enumerate() {
            let w = &h[h.len() - window..];
            let x: Vec<f64> = w.iter().map(|v| v.0).collect();
            let mut acf = vec![0.0; lags + 1];
            if acf_batch(&x, &mut acf).is_err() {
                continue;
            }
            let Ok(sa) = SampleAcf::new(&acf, start.dt, window as u32) else {
                continue;
            };
            let pm = w.iter().map(|v| v.1).sum::<f64>() / window as f64;
            let (alpha, var) = match variant {
                AcfVariant::Paper => (paper_eq15(&sa).map(|a| a.alpha), Ok(acf[0])),
                AcfVariant::Corrected => (
                    lag1_corrected(&sa).map(|a| a.alpha),
                    sigma2(acf[0], pm).map(|v| v.corrected),
                ),
            };
            let (Ok(alpha), Ok(var)) = (alpha, var) else {
                continue;
            };
            let comps = if s == 0 { &mut m.accel } else { &mut m.gyro };
            if let Some(Component::GaussMarkov(g)) = comps.first_mut() {
                g.tau = 1.0 / alpha;
                g.sigma = var.max(1e-30).sqrt();
            }
        }
        // A rejected model keeps the old one (the loop goes on).
        let _ = f.set_model(m);
    }
    Ok((est, f.model().clone()))
}

/// The kind of the `i`-th identified parameter, for reports.
pub fn kind_name(k: Quantity) -> &'static str {
    k.name()
}
