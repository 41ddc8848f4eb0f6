//! Before/after comparison of models on one log: the checks that need no truth (likelihood,
//! innovation whiteness, windowed NIS) and, with truth, the tilt error against its 3 sigma.

use crate::diagnose::estimate_acf::{self, EstimateAcf};
use crate::diagnose::whiteness::{nis_windows, whiteness, NisWindow, Whiteness};
use crate::diagnose::{NIS_WINDOW, WHITENESS_LAGS};
use crate::log::LogRow;
use crate::records::EstimateRow;
use crate::replay;
use crate::summary::{summarise, Summary};
use anyhow::Result;
use imu_ident::model::InsModel;
use serde::Serialize;

/// One model's results on the log.
#[derive(Debug, Clone, Serialize)]
pub struct ModelRun {
    /// Label (file name or role).
    pub name: String,
    /// Innovation log-likelihood.
    pub log_likelihood: f64,
    /// The run summary (NIS mean, tilt with truth).
    pub summary: Summary,
    /// Whiteness of the normalised innovations.
    pub whiteness: Whiteness,
    /// Windowed NIS and its band.
    pub nis_windows: Vec<NisWindow>,
    /// 99 % band of a window's mean NIS.
    pub nis_band: [f64; 2],
    /// Windows outside the band.
    pub nis_failed: usize,
    /// ACF of each estimated sensor error against the model's Monte Carlo band.
    pub estimate_acf: Vec<EstimateAcf>,
    /// The estimates (for plots; not serialised).
    #[serde(skip)]
    pub estimates: Vec<EstimateRow>,
}

/// Runs `model` on `log` and collects every comparison metric.
pub fn evaluate(name: &str, model: &InsModel<f64>, log: &[LogRow]) -> Result<ModelRun> {
    let tel = replay::run::<f64>(model, None, log)?.telemetry;
    let (est, counts) = (tel.estimate_rows(), tel.counts());
    let (ll, _) = tel.log_likelihood();
    let (windows, band, failed) = nis_windows(&est, NIS_WINDOW);
    Ok(ModelRun {
        name: name.to_string(),
        log_likelihood: ll,
        summary: summarise(log, &est, counts),
        whiteness: whiteness(&est, WHITENESS_LAGS),
        nis_windows: windows,
        nis_band: band,
        nis_failed: failed.len(),
        estimate_acf: estimate_acf::compare(model, &est, 0xACF)?,
        estimates: est,
    })
}

/// A plain-text before/after table.
pub fn table(runs: &[ModelRun]) -> String {
    let mut s = format!(
        "{:<28} {:>14} {:>10} {:>12} {:>9} {:>12} {:>14} {:>12}\n",
        "model",
        "log-lik",
        "LB p",
        "lags out",
        "NIS",
        "windows out",
        "tilt RMS[urad]",
        "out 3sigma"
    );
    for r in runs {
        let tilt = r
            .summary
            .tilt_rms
            .map_or("-".into(), |v| format!("{:.2}", v * 1e6));
        let out = r
            .summary
            .tilt_outside_3sigma
            .map_or("-".into(), |v| format!("{:.2} %", v * 100.0));
        s += &format!(
            "{:<28} {:>14.1} {:>10.3} {:>12} {:>9.3} {:>12} {:>14} {:>12}\n",
            r.name,
            r.log_likelihood,
            r.whiteness.p_value,
            format!("{}/{}", r.whiteness.failed_lags.len(), r.whiteness.dof),
            r.summary.nis_mean,
            format!("{}/{}", r.nis_failed, r.nis_windows.len()),
            tilt,
            out
        );
    }
    s
}
