//! Replays a log through the core's [`InsFilter`] and collects the estimates and a summary.
//!
//! Time comes from the log: before each row the filter predicts `k = round((t - t_prev) / dt)`
//! steps (the first row is one step after the start). A gap (`k > 1`) is predicted through and
//! counted; a row whose time does not advance (`k < 1`) is skipped and counted, never silently
//! misread.

use crate::log::LogRow;
use anyhow::{anyhow, bail, Result};
use imu_ident::filter::{Estimates, Innovation, InsFilter, UpdateStatus};
use imu_ident::model::InsModel;
use imu_ident::Real;
use serde::Serialize;

/// Longest gap predicted through, in steps (10 days at 1 Hz).
pub const MAX_GAP_STEPS: u64 = 864_000;

/// One output row of `estimates.csv`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EstimateRow {
    pub t: f64,
    pub dv_hat: f64,
    pub delta_hat: f64,
    pub da_hat: f64,
    pub dw_hat: f64,
    pub sigma_dv: f64,
    pub sigma_delta: f64,
    pub sigma_da: f64,
    pub sigma_dw: f64,
    pub innovation: f64,
    pub innovation_var: f64,
    pub nis: f64,
}

impl EstimateRow {
    /// A row from SI estimates and the innovation `nu`, its variance `s` and NIS.
    pub fn new<T: Real>(t: f64, e: &Estimates<T>, nu: T, s: T, nis: T) -> Self {
        EstimateRow {
            t,
            dv_hat: e.dv.as_f64(),
            delta_hat: e.delta.as_f64(),
            da_hat: e.da.as_f64(),
            dw_hat: e.dw.as_f64(),
            sigma_dv: e.sigma_dv.as_f64(),
            sigma_delta: e.sigma_delta.as_f64(),
            sigma_da: e.sigma_da.as_f64(),
            sigma_dw: e.sigma_dw.as_f64(),
            innovation: nu.as_f64(),
            innovation_var: s.as_f64(),
            nis: nis.as_f64(),
        }
    }
}

impl EstimateRow {
    /// A row from a telemetry record of the firmware's step (host or QEMU).
    pub fn from_record(r: &imu_ident::telemetry::Record) -> Self {
        let f = f64::from;
        EstimateRow {
            t: r.t,
            dv_hat: f(r.dv),
            delta_hat: f(r.delta),
            da_hat: f(r.da),
            dw_hat: f(r.dw),
            sigma_dv: f(r.sigma_dv),
            sigma_delta: f(r.sigma_delta),
            sigma_da: f(r.sigma_da),
            sigma_dw: f(r.sigma_dw),
            innovation: f(r.innovation),
            innovation_var: f(r.variance),
            nis: f(r.nis),
        }
    }
}

/// Counts of what the replay did with the rows.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct RunCounts {
    /// Rows processed.
    pub steps: usize,
    /// Observations used.
    pub updated: usize,
    /// Missing (NaN) observations.
    pub missing: usize,
    /// Observations rejected by the outlier gate.
    pub gated: usize,
    /// Rows after a gap in time (predicted through).
    pub gaps: usize,
    /// Rows skipped because time did not advance.
    pub skipped_time: usize,
    /// Covariance repairs.
    pub repairs: usize,
}

/// Replays `log` through a filter built from `model` (in precision `T`), calling `visit` after
/// each processed row with the row, the filter and the innovation. Gaps are predicted through;
/// rows whose time does not advance are skipped. Returns the counts.
pub fn replay<T: Real>(
    model: &InsModel<f64>,
    log: &[LogRow],
    mut visit: impl FnMut(&LogRow, &InsFilter<T>, &Innovation<T>),
) -> Result<RunCounts> {
    let mut filter = InsFilter::<T>::new(model.cast()).map_err(|e| anyhow!("model: {e}"))?;
    let dt = model.dt;
    let mut counts = RunCounts::default();
    let Some(first) = log.first() else {
        return Ok(counts);
    };
    let mut t_prev = first.t - dt;
    for row in log {
        let k = ((row.t - t_prev) / dt).round();
        // NaN (from a non-finite t) and non-advancing times are both skipped.
        let advances = k >= 1.0;
        if !advances {
            counts.skipped_time += 1;
            continue;
        }
        if k > MAX_GAP_STEPS as f64 {
            bail!(
                "time jumps by {} s at t = {} (more than {MAX_GAP_STEPS} steps)",
                row.t - t_prev,
                row.t
            );
        }
        if k > 1.0 {
            counts.gaps += 1;
        }
        for _ in 0..(k as u64) {
            filter.predict();
        }
        t_prev = row.t;
        let inn = filter.update(T::lit(row.z));
        match inn.status {
            UpdateStatus::Updated => counts.updated += 1,
            UpdateStatus::Missing => counts.missing += 1,
            UpdateStatus::Gated => counts.gated += 1,
            UpdateStatus::BadInnovationVariance => {}
        }
        if filter.repair() {
            counts.repairs += 1;
        }
        counts.steps += 1;
        visit(row, &filter, &inn);
    }
    Ok(counts)
}

/// Runs `model` (converted to precision `T`) over `log`, collecting every estimate.
pub fn run<T: Real>(
    model: &InsModel<f64>,
    log: &[LogRow],
) -> Result<(Vec<EstimateRow>, RunCounts)> {
    let mut out = Vec::with_capacity(log.len());
    let counts = replay::<T>(model, log, |row, filter, inn| {
        out.push(EstimateRow::new(
            row.t,
            &filter.estimates(),
            inn.innovation,
            inn.variance,
            inn.nis,
        ));
    })?;
    Ok((out, counts))
}

/// Gaussian log-likelihood of the innovations, `-0.5 sum (ln(2 pi S) + nu^2 / S)` over the
/// used observations, with the number of terms.
pub fn log_likelihood(model: &InsModel<f64>, log: &[LogRow]) -> Result<(f64, usize)> {
    let mut ll = 0.0;
    let mut n = 0;
    replay::<f64>(model, log, |_, _, inn| {
        if inn.status == UpdateStatus::Updated {
            ll -= 0.5 * ((2.0 * std::f64::consts::PI * inn.variance).ln() + inn.nis);
            n += 1;
        }
    })?;
    Ok((ll, n))
}
