//! `summary.json`: consistency statistics of a replay.
//!
//! Without truth: the mean NIS with its two-sided 99 % chi-square band (for `n` independent
//! innovations of a consistent filter, `sum NIS ~ chi2(n)`). With truth: the tilt RMS and the
//! fraction of steps where `|true_delta - delta_hat| > 3 sigma_delta`.

use crate::log::LogRow;
use crate::records::{EstimateRow, RunCounts};
use serde::Serialize;

/// The summary written to `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Rows processed.
    pub steps: usize,
    /// Mean normalised innovation squared over the used observations.
    pub nis_mean: f64,
    /// Two-sided 99 % band of the mean NIS for a consistent filter: chi2(n) quantiles / n.
    pub nis_band99: [f64; 2],
    /// Whether `nis_mean` lies inside `nis_band99`.
    pub nis_consistent: bool,
    /// What the replay did with the rows.
    pub counts: RunCounts,
    /// RMS of `true_delta - delta_hat` [rad] (truth only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tilt_rms: Option<f64>,
    /// Fraction of steps with `|true_delta - delta_hat| > 3 sigma_delta` (truth only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tilt_outside_3sigma: Option<f64>,
    /// RMS error of the accelerometer-error estimate [m/s^2] (truth only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub da_rms: Option<f64>,
    /// RMS error of the gyro-drift estimate [rad/s] (truth only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dw_rms: Option<f64>,
}

/// Two-sided `level` band of the mean of `n` chi-square(1) variables: chi2(n) quantiles / n.
/// (`allan::chi2_quantile` is accurate to ~1e-14; statrs's `inverse_cdf` was off by 2.5 % at
/// small n.)
pub fn nis_mean_band(n: usize, level: f64) -> [f64; 2] {
    let nf = n as f64;
    let a = (1.0 - level) / 2.0;
    match (
        crate::allan::chi2_quantile(a, nf),
        crate::allan::chi2_quantile(1.0 - a, nf),
    ) {
        (Some(lo), Some(hi)) => [lo / nf, hi / nf],
        _ => [f64::NAN, f64::NAN],
    }
}

/// Tilt statistics `(rms, fraction outside 3 sigma)` of estimates against truth, matched by
/// time; `None` without truth.
pub fn tilt_stats(log: &[LogRow], est: &[EstimateRow]) -> Option<(f64, f64)> {
    let pairs = truth_pairs(log, est)?;
    let n = pairs.len() as f64;
    let rms = (pairs
        .iter()
        .map(|(t, e)| (t.delta - e.delta_hat).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let out = pairs
        .iter()
        .filter(|(t, e)| (t.delta - e.delta_hat).abs() > 3.0 * e.sigma_delta)
        .count();
    Some((rms, out as f64 / n))
}

fn truth_pairs<'a>(
    log: &'a [LogRow],
    est: &'a [EstimateRow],
) -> Option<Vec<(crate::log::Truth, &'a EstimateRow)>> {
    let mut pairs = Vec::with_capacity(est.len());
    let mut i = 0;
    for e in est {
        while i < log.len() && log[i].t < e.t {
            i += 1;
        }
        let row = log.get(i)?;
        if row.t == e.t {
            pairs.push((row.truth?, e));
        }
    }
    (!pairs.is_empty()).then_some(pairs)
}

/// Builds the summary of one replay.
pub fn summarise(log: &[LogRow], est: &[EstimateRow], counts: RunCounts) -> Summary {
    let nis: Vec<f64> = est
        .iter()
        .map(|e| e.nis)
        .filter(|v| v.is_finite())
        .collect();
    let nis_mean = if nis.is_empty() {
        f64::NAN
    } else {
        nis.iter().sum::<f64>() / nis.len() as f64
    };
    let band = nis_mean_band(nis.len(), 0.99);
    let tilt = tilt_stats(log, est);
    let rms = |f: fn(&crate::log::Truth, &EstimateRow) -> f64| {
        truth_pairs(log, est)
            .map(|p| (p.iter().map(|(t, e)| f(t, e).powi(2)).sum::<f64>() / p.len() as f64).sqrt())
    };
    Summary {
        steps: counts.steps,
        nis_mean,
        nis_band99: band,
        nis_consistent: nis_mean >= band[0] && nis_mean <= band[1],
        counts,
        tilt_rms: tilt.map(|t| t.0),
        tilt_outside_3sigma: tilt.map(|t| t.1),
        da_rms: rms(|t, e| t.da - e.da_hat),
        dw_rms: rms(|t, e| t.dw - e.dw_hat),
    }
}
