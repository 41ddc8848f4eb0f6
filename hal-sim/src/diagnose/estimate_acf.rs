//! The ACF of each estimated sensor error against what the model predicts for it.
//!
//! The filter's estimates are not the sensor errors: they are smoothed by the filter (their
//! variance is about `K(0) - P`) and the sample ACF of a finite window is biased and noisy. So
//! the model's prediction for the estimates' ACF, and its band, come from Monte Carlo: the
//! model itself is simulated `MC_RUNS` times over the same duration, the same filter runs on
//! each, and the band is the pointwise mean ± 2.58 standard deviations (99 %) of the normalised
//! ACFs of its estimates. That band contains both the filter's P and the finite window.

use crate::records::EstimateRow;
use crate::replay;
use crate::sim;
use anyhow::{anyhow, Result};
use imu_ident::autocorr::acf_batch;
use imu_ident::model::{ErrorSource, InsModel};
use serde::Serialize;

/// Monte Carlo runs behind the band.
pub const MC_RUNS: usize = 10;
/// Lag step [samples] and number of lags reported.
pub const LAG_STEP: usize = 20;
/// Largest lag [samples].
pub const MAX_LAG: usize = 3000;

/// One sensor's comparison.
#[derive(Debug, Clone, Serialize)]
pub struct EstimateAcf {
    /// `accel` or `gyro`.
    pub sensor: &'static str,
    /// Lags [s].
    pub lags: Vec<f64>,
    /// Normalised ACF of the estimates on the data.
    pub data: Vec<f64>,
    /// Model prediction (Monte Carlo mean) and its 99 % band.
    pub model: Vec<f64>,
    /// Lower band.
    pub lo: Vec<f64>,
    /// Upper band.
    pub hi: Vec<f64>,
    /// Lags [s] where the data leave the band.
    pub outside: Vec<f64>,
}

fn normalised_acf(x: &[f64], max_lag: usize) -> Result<Vec<f64>> {
    let mut r = vec![0.0; max_lag + 1];
    acf_batch(x, &mut r).map_err(|e| anyhow!("ACF: {e:?}"))?;
    // NaN and non-positive variances are both refused.
    let positive = r[0] > 0.0;
    if !positive {
        return Err(anyhow!("ACF: constant estimates"));
    }
    Ok(r.iter().step_by(LAG_STEP).map(|v| v / r[0]).collect())
}

fn pick(sensor: ErrorSource, e: &EstimateRow) -> f64 {
    if sensor == ErrorSource::Accel {
        e.da_hat
    } else {
        e.dw_hat
    }
}

/// Compares the estimates `est` of `model` on the data with the model's Monte Carlo band, for
/// each sensor that has components. `seed` fixes the Monte Carlo.
pub fn compare(model: &InsModel<f64>, est: &[EstimateRow], seed: u64) -> Result<Vec<EstimateAcf>> {
    let n = est.len();
    let max_lag = MAX_LAG.min(n / 4);
    if max_lag < LAG_STEP {
        return Ok(Vec::new());
    }
    let sensors: Vec<ErrorSource> = [ErrorSource::Accel, ErrorSource::Gyro]
        .into_iter()
        .filter(|s| {
            if *s == ErrorSource::Accel {
                !model.accel.is_empty()
            } else {
                !model.gyro.is_empty()
            }
        })
        .collect();
    let mut mc: Vec<Vec<Vec<f64>>> = vec![Vec::new(); sensors.len()];
    for k in 0..MC_RUNS {
        let log = sim::simulate(model, n, seed.wrapping_add(k as u64))?;
        let (e, _) = replay::estimates::<f64>(model, &log)?;
        for (i, s) in sensors.iter().enumerate() {
            let x: Vec<f64> = e.iter().map(|r| pick(*s, r)).collect();
            mc[i].push(normalised_acf(&x, max_lag)?);
        }
    }
    let mut out = Vec::new();
    for (i, s) in sensors.iter().enumerate() {
        let x: Vec<f64> = est.iter().map(|r| pick(*s, r)).collect();
        let data = normalised_acf(&x, max_lag)?;
        let m = data.len();
        let mean: Vec<f64> = (0..m)
            .map(|j| mc[i].iter().map(|v| v[j]).sum::<f64>() / MC_RUNS as f64)
            .collect();
        // The sample sd over the runs, inflated by sqrt(1 + 1/M) for predicting a new run.
        let sd: Vec<f64> = (0..m)
            .map(|j| {
                let v = mc[i].iter().map(|r| (r[j] - mean[j]).powi(2)).sum::<f64>()
                    / (MC_RUNS - 1) as f64;
                (v * (1.0 + 1.0 / MC_RUNS as f64)).sqrt()
            })
            .collect();
        let lo: Vec<f64> = (0..m).map(|j| mean[j] - 2.5758 * sd[j]).collect();
        let hi: Vec<f64> = (0..m).map(|j| mean[j] + 2.5758 * sd[j]).collect();
        let lags: Vec<f64> = (0..m).map(|j| (j * LAG_STEP) as f64 * model.dt).collect();
        let outside = (1..m)
            .filter(|&j| data[j] < lo[j] || data[j] > hi[j])
            .map(|j| lags[j])
            .collect();
        out.push(EstimateAcf {
            sensor: s.name(),
            lags,
            data,
            model: mean,
            lo,
            hi,
            outside,
        });
    }
    Ok(out)
}
