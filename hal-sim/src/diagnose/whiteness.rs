//! Innovation whiteness and windowed NIS: model checks that need no truth.
//!
//! For a consistent filter the normalised innovations `e_k = nu_k / sqrt(S_k)` are white with
//! unit variance, so (a) their sample autocorrelation at lag k >= 1 lies within `+-z/sqrt(n)`
//! (Bartlett), (b) the Ljung-Box statistic `Q = n (n+2) sum_k r_k^2 / (n-k)` is chi-square with
//! L degrees of freedom, and (c) the sum of the NIS over a window of W steps is chi2(W).

use crate::records::EstimateRow;
use imu_ident::autocorr::acf_batch;
use serde::Serialize;
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// z of the two-sided 99 % band.
pub const Z99: f64 = 2.5758;

/// Result of the whiteness check.
#[derive(Debug, Clone, Serialize)]
pub struct Whiteness {
    /// Number of innovations used.
    pub n: usize,
    /// Normalised-innovation ACF at lags 0..=L (r_0 = 1).
    pub acf: Vec<f64>,
    /// The 99 % band half-width, `Z99 / sqrt(n)`.
    pub band: f64,
    /// Lags whose |r_k| exceeds the band.
    pub failed_lags: Vec<usize>,
    /// Ljung-Box statistic over lags 1..=L.
    pub ljung_box_q: f64,
    /// Its degrees of freedom, L.
    pub dof: usize,
    /// P-value of Q under chi2(L).
    pub p_value: f64,
}

/// Normalised innovations of the used observations.
pub fn normalised(est: &[EstimateRow]) -> Vec<f64> {
    est.iter()
        .filter(|e| e.innovation.is_finite() && e.innovation_var > 0.0 && e.nis.is_finite())
        .map(|e| e.innovation / e.innovation_var.sqrt())
        .collect()
}

/// Whiteness of the normalised innovations over lags 1..=`max_lag`.
pub fn whiteness(est: &[EstimateRow], max_lag: usize) -> Whiteness {
    let e = normalised(est);
    let n = e.len();
    let lags = max_lag.min(n.saturating_sub(2));
    let mut r = vec![0.0; lags + 1];
    let ok = acf_batch(&e, &mut r).is_ok() && r[0] > 0.0;
    if ok {
        let r0 = r[0];
        r.iter_mut().for_each(|v| *v /= r0);
    }
    let nf = n as f64;
    let band = Z99 / nf.sqrt();
    let failed_lags = (1..=lags).filter(|&k| ok && r[k].abs() > band).collect();
    let q = if ok {
        nf * (nf + 2.0)
            * (1..=lags)
                .map(|k| r[k] * r[k] / (nf - k as f64))
                .sum::<f64>()
    } else {
        f64::NAN
    };
    let p_value = ChiSquared::new(lags.max(1) as f64)
        .map(|c| 1.0 - c.cdf(q))
        .unwrap_or(f64::NAN);
    Whiteness {
        n,
        acf: r,
        band,
        failed_lags,
        ljung_box_q: q,
        dof: lags,
        p_value,
    }
}

/// One window whose NIS sum falls outside its band.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct NisWindow {
    /// Window start and end time [s].
    pub t_start: f64,
    /// End time [s].
    pub t_end: f64,
    /// Mean NIS in the window.
    pub nis_mean: f64,
}

/// Windowed NIS: every window of `w` used observations, its mean, and the 99 % band of the
/// mean (chi2(w)/w quantiles). Returns (all windows, band, failing windows).
pub fn nis_windows(est: &[EstimateRow], w: usize) -> (Vec<NisWindow>, [f64; 2], Vec<NisWindow>) {
    let used: Vec<&EstimateRow> = est.iter().filter(|e| e.nis.is_finite()).collect();
    let band = crate::summary::nis_mean_band(w.max(1), 0.99);
    let all: Vec<NisWindow> = used
        .chunks(w.max(1))
        .filter(|c| c.len() == w.max(1))
        .map(|c| NisWindow {
            t_start: c[0].t,
            t_end: c[c.len() - 1].t,
            nis_mean: c.iter().map(|e| e.nis).sum::<f64>() / c.len() as f64,
        })
        .collect();
    let failed = all
        .iter()
        .copied()
        .filter(|x| x.nis_mean < band[0] || x.nis_mean > band[1])
        .collect();
    (all, band, failed)
}
