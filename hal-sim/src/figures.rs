//! The paper's figures, reproduced on the `paper` scenario (`hal-sim figures --out DIR`):
//!
//! - Fig. 3: normalised ACF of the gyro drift — the prior (true) model `r_m`, the experimental
//!   ACF `r_e` of the oracle filter's drift estimates, the exponential fit `r_a1` (bias-corrected
//!   lag-1) and the exponential-cosine fit `r_a2` (core estimators);
//! - Fig. 4: the filter with drift and diffusion 0.1x: tilt error against its ±3 sigma;
//! - Fig. 5: the adaptive filter started from the same wrong model, on the same axes.

use crate::log::LogRow;
use crate::output::write_string;
use crate::records::EstimateRow;
use crate::report::line_chart;
use crate::{adaptive, mismatch, replay, scenario, sim};
use anyhow::{anyhow, Context, Result};
use imu_ident::adapt::AdaptConfig;
use imu_ident::autocorr::acf_batch;
use imu_ident::ident::{exp_cosine, lag1_corrected, SampleAcf};
use imu_ident::model::Component;
use std::path::Path;

/// Lags shown in Fig. 3 [s].
const LAGS: usize = 4000;

fn tilt_series(log: &[LogRow], est: &[EstimateRow]) -> Vec<(String, Vec<(f64, f64)>)> {
    let mut e = vec![];
    let (mut hi, mut lo) = (vec![], vec![]);
    for (row, x) in log.iter().zip(est).step_by(30) {
        let Some(tr) = row.truth else { continue };
        let h = x.t / 3600.0;
        e.push((h, (tr.delta - x.delta_hat) * 1e6));
        hi.push((h, 3.0 * x.sigma_delta * 1e6));
        lo.push((h, -3.0 * x.sigma_delta * 1e6));
    }
    vec![
        ("delta - delta_hat".into(), e),
        ("+3 sigma".into(), hi),
        ("-3 sigma".into(), lo),
    ]
}

/// Writes `fig3_acf.svg`, `fig4_mismatched.svg`, `fig5_adaptive.svg` into `out`.
pub fn write(out: &Path, seed: u64) -> Result<()> {
    let truth = scenario::load("paper")?.to_core()?;
    let log = sim::simulate(&truth, 43_200, seed)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;

    // Fig. 3 on the oracle filter's gyro-drift estimates.
    let (est, _) = replay::estimates::<f64>(&truth, &log)?;
    let dw: Vec<f64> = est.iter().map(|e| e.dw_hat).collect();
    let mut r = vec![0.0; LAGS + 1];
    acf_batch(&dw, &mut r).map_err(|e| anyhow!("ACF: {e:?}"))?;
    let acf = SampleAcf::new(&r, 1.0, dw.len() as u32).map_err(|e| anyhow!("ACF: {e:?}"))?;
    let a1 = lag1_corrected(&acf)
        .map_err(|e| anyhow!("lag-1 fit: {e:?}"))?
        .alpha;
    let a2 = exp_cosine(&acf).ok();
    let prior = match truth.gyro.first() {
        Some(Component::GaussMarkov(g)) => 1.0 / g.tau,
        _ => return Err(anyhow!("paper gyro model is not Gauss-Markov")),
    };
    let lag = |f: &dyn Fn(f64) -> f64| {
        (0..=LAGS)
            .step_by(20)
            .map(|k| (k as f64, f(k as f64)))
            .collect::<Vec<_>>()
    };
    let mut series = vec![
        ("r_m: prior model".to_string(), lag(&|t| (-prior * t).exp())),
        (
            "r_e: experimental".to_string(),
            lag(&|t| r[t as usize] / r[0]),
        ),
        (
            format!("r_a1: exponential, tau {:.0} s", 1.0 / a1),
            lag(&|t| (-a1 * t).exp()),
        ),
    ];
    if let Some(e) = a2 {
        let label = format!(
            "r_a2: exp-cosine, tau {:.0} s, period {:.0} s",
            1.0 / e.alpha,
            2.0 * std::f64::consts::PI / e.beta
        );
        series.push((label, lag(&|t| (-e.alpha * t).exp() * (e.beta * t).cos())));
    }
    let title = if a2.is_some() {
        "Fig. 3: normalised ACF of the gyro drift estimate".to_string()
    } else {
        "Fig. 3: normalised ACF of the gyro drift estimate (no zero crossing: no exp-cosine fit)"
            .to_string()
    };
    let svg = line_chart(&title, "lag [s]", "r", &series, &[0.0])?;
    write_string(&out.join("fig3_acf.svg"), &svg)?;

    // Fig. 4 and 5: the 0.1x model, fixed and adaptive.
    let wrong = mismatch::scaled(&truth, 0.1, 0.1);
    let (est4, _) = replay::estimates::<f64>(&wrong, &log)?;
    let svg = line_chart(
        "Fig. 4: EKF with drift and diffusion 0.1x",
        "t [h]",
        "tilt error [µrad]",
        &tilt_series(&log, &est4),
        &[],
    )?;
    write_string(&out.join("fig4_mismatched.svg"), &svg)?;
    let run5 = adaptive::run::<f64>(&wrong, &log, AdaptConfig::default())?;
    let svg = line_chart(
        "Fig. 5: adaptive filter from the same 0.1x start",
        "t [h]",
        "tilt error [µrad]",
        &tilt_series(&log, &run5.estimates),
        &[],
    )?;
    write_string(&out.join("fig5_adaptive.svg"), &svg)?;
    Ok(())
}
