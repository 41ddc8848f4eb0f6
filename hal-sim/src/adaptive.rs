//! Host driver of the online identification (`imu_ident::adapt`): replays a log through an
//! [`AdaptiveFilter`], collecting estimate rows like [`runner`](crate::runner) and the parameters
//! over time; plus the ACF-loop baselines of the paper (issue 3) for comparison.
//!
//! All numerics are in the no_std core; this module only loops, stores and compares.

use crate::log::LogRow;
use crate::runner::{EstimateRow, RunCounts, MAX_GAP_STEPS};
use anyhow::{anyhow, bail, Result};
use imu_ident::adapt::params::MAXP;
use imu_ident::adapt::{AdaptConfig, AdaptiveFilter, StepStatus};
use imu_ident::autocorr::acf_batch;
use imu_ident::filter::{Estimates, InsFilter};
use imu_ident::ident::{lag1_corrected, paper_eq15, sigma2, SampleAcf};
use imu_ident::model::Quantity;
use imu_ident::model::{Component, InsModel, Sensor};
use imu_ident::Real;
use serde::Serialize;

/// One row of the parameters-over-time log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParamRow {
    /// Time [s].
    pub t: f64,
    /// `accel` or `gyro`.
    pub sensor: &'static str,
    /// Component index within the sensor.
    pub component: usize,
    /// Its kind (model-TOML spelling): with the rows of one time, the selected structure.
    pub kind: &'static str,
    /// Correlation time [s] (NaN when the kind has none).
    pub tau: f64,
    /// Standard deviation (NaN when the kind has none).
    pub sigma: f64,
    /// Oscillation frequency [rad/s] (NaN unless exponential-cosine).
    pub beta: f64,
}

/// Everything one adaptive replay produced.
#[derive(Debug, Clone)]
pub struct AdaptiveRun {
    /// Per-step estimates of the centre filter.
    pub estimates: Vec<EstimateRow>,
    /// What the replay did.
    pub counts: RunCounts,
    /// Parameters after every update (and at the start).
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
}

fn param_rows(t: f64, m: &InsModel<f64>, out: &mut Vec<ParamRow>) {
    for (sensor, comps) in [(Sensor::Accel, &m.accel), (Sensor::Gyro, &m.gyro)] {
        for (i, c) in comps.iter().enumerate() {
            let nan = f64::NAN;
            let (tau, sigma, beta) = match c {
                Component::GaussMarkov(g) => (g.tau, g.sigma, nan),
                Component::ExpCosine(e) => (e.tau, e.sigma, e.beta),
                Component::RandomConstant(r) => (nan, r.sigma, nan),
                Component::RandomWalk(r) => (nan, r.q.sqrt(), nan),
                Component::White(w) => (nan, w.density, nan),
            };
            out.push(ParamRow {
                t,
                sensor: sensor.name(),
                component: i,
                kind: c.kind().name(),
                tau,
                sigma,
                beta,
            });
        }
    }
}

fn row<T: Real>(t: f64, e: &Estimates<T>, nu: T, s: T) -> EstimateRow {
    EstimateRow::new(t, e, nu, s, nu * nu / s)
}

/// Number of steps from `t_prev` to `t` (the runner's rule), or `None` to skip the row.
fn steps_between(t_prev: f64, t: f64, dt: f64) -> Result<Option<u64>> {
    let k = ((t - t_prev) / dt).round();
    if k.is_nan() || k < 1.0 {
        return Ok(None);
    }
    if k > MAX_GAP_STEPS as f64 {
        bail!("time jumps by {} s at t = {t}", t - t_prev);
    }
    Ok(Some(k as u64))
}

/// Replays `log` through the adaptive filter started from `start` (converted to `T`).
pub fn run<T: Real>(
    start: &InsModel<f64>,
    log: &[LogRow],
    cfg: AdaptConfig<f64>,
) -> Result<AdaptiveRun> {
    let cfg_t = AdaptConfig::<T> {
        block: cfg.block,
        h: T::lit(cfg.h),
        window: T::lit(cfg.window),
        damping: T::lit(cfg.damping),
        hysteresis: T::lit(cfg.hysteresis),
        max_step: T::lit(cfg.max_step),
        tau_max: T::lit(cfg.tau_max),
        spread: T::lit(cfg.spread),
        move_discount: T::lit(cfg.move_discount),
        probe_factor: T::lit(cfg.probe_factor),
        epoch: cfg.epoch,
        warmup: cfg.warmup,
        margin: T::lit(cfg.margin),
        first_margin: T::lit(cfg.first_margin),
        hold_first_epoch: cfg.hold_first_epoch,
        search_until_settled: cfg.search_until_settled,
        adapt: cfg.adapt,
    };
    let mut f = AdaptiveFilter::<T>::new(start.cast(), cfg_t).map_err(|e| anyhow!("{e:?}"))?;
    let dt = start.dt;
    let mut est = Vec::with_capacity(log.len());
    let mut counts = RunCounts::default();
    let mut params = Vec::new();
    param_rows(0.0, start, &mut params);
    let mut t_prev = log.first().map_or(0.0, |r| r.t - dt);
    let trace = std::env::var("ADAPT_TRACE").is_ok();
    for r in log {
        let Some(k) = steps_between(t_prev, r.t, dt)? else {
            counts.skipped_time += 1;
            continue;
        };
        if k > 1 {
            counts.gaps += 1;
        }
        for _ in 1..k {
            f.step(T::lit(f64::NAN));
        }
        t_prev = r.t;
        let rep = f.step(T::lit(r.z));
        match rep.status {
            StepStatus::Updated => counts.updated += 1,
            StepStatus::Missing => counts.missing += 1,
            StepStatus::BadInnovationVariance => counts.repairs += 1,
            StepStatus::Gated => counts.gated += 1,
        }
        counts.steps += 1;
        if trace && r.t % 3600.0 == 0.0 {
            eprintln!(
                "t {} gain {:.2} theta {:?}",
                r.t,
                f.last_gain().as_f64(),
                f.theta()
            );
        }
        if rep.moved {
            let m = f.model().map_err(|e| anyhow!("{e:?}"))?.cast::<f64>();
            param_rows(r.t, &m, &mut params);
        }
        est.push(row(r.t, &f.estimates(), rep.innovation, rep.variance));
    }
    let final_model = f.model().map_err(|e| anyhow!("{e:?}"))?.cast::<f64>();
    let mut theta = [0.0; MAXP];
    for (o, v) in theta.iter_mut().zip(f.theta().iter()) {
        *o = v.as_f64();
    }
    let crb = f
        .crb(f.total_information())
        .map(|c| c.map(|v: T| v.as_f64()));
    Ok(AdaptiveRun {
        estimates: est,
        counts,
        params,
        final_model,
        theta,
        crb,
        updates: f.updates(),
        jumps: f.jumps(),
        total_score: f.total_information().score.map(|v| v.as_f64()),
        total_fisher: f.total_information().fisher.map(|r| r.map(|v| v.as_f64())),
    })
}

/// `(tau, sigma)` of the first Gauss-Markov component of `sensor` in `m`.
pub fn gm_params(m: &InsModel<f64>, sensor: Sensor) -> Option<(f64, f64)> {
    let comps = match sensor {
        Sensor::Accel => &m.accel,
        Sensor::Gyro => &m.gyro,
        Sensor::Observation => return None,
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

/// The paper's loop: every `block` steps, re-identify each sensor's (single Gauss-Markov)
/// `sigma, alpha` from the sample ACF of the filter's own estimates over the last `window`
/// steps, and feed them back (`set_model` keeps `x, P`). Returns the estimates and the final model.
#[allow(clippy::type_complexity)]
pub fn run_acf_loop(
    start: &InsModel<f64>,
    log: &[LogRow],
    variant: AcfVariant,
    block: usize,
    window: usize,
    lags: usize,
) -> Result<(Vec<EstimateRow>, InsModel<f64>)> {
    let mut f = InsFilter::<f64>::new(start.clone()).map_err(|e| anyhow!("{e}"))?;
    let mut hist: [Vec<(f64, f64)>; 2] = [Vec::new(), Vec::new()];
    let mut est = Vec::with_capacity(log.len());
    for (k, r) in log.iter().enumerate() {
        let inn = f.step(r.z);
        let e = f.estimates();
        hist[0].push((e.da, e.sigma_da * e.sigma_da));
        hist[1].push((e.dw, e.sigma_dw * e.sigma_dw));
        est.push(row(r.t, &e, inn.innovation, inn.variance));
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

/// Writes the parameters-over-time log as CSV (`t,sensor,component,kind,tau,sigma,beta`).
pub fn write_params_csv(path: &std::path::Path, rows: &[ParamRow]) -> Result<()> {
    crate::output::write_csv(path, rows)
}

/// The kind of the `i`-th identified parameter, for reports.
pub fn kind_name(k: Quantity) -> &'static str {
    k.name()
}
