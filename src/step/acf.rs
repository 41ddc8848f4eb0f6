//! The paper's identification of one sensor from the autocorrelation of its estimates
//! (METHOD.md §3), kept as telemetry beside the online identification.

use super::EstimateAcf;
use crate::ident::{lag1_corrected, sigma2, SampleAcf};
use crate::model::ErrorSource;
use crate::telemetry::AcfRecord;
use crate::Real;

/// The identification of one sensor from its estimate autocorrelator and mean variance.
pub(super) fn acf_record<T: Real>(
    acf: &EstimateAcf<T>,
    p_mean: T,
    dt: T,
    sensor: ErrorSource,
    k: u32,
    t: f64,
) -> AcfRecord {
    let mut r = [T::zero(); 2];
    let mut out = AcfRecord {
        k,
        t,
        sensor,
        tau: f32::NAN,
        sigma: f32::NAN,
    };
    // Only a full window: a partial one after start-up would report the transient.
    if !acf.is_full() || acf.acf(&mut r).is_err() {
        return out;
    }
    let n = acf.len() as u32;
    if let Ok(a) = SampleAcf::new(&r, dt, n).and_then(|s| lag1_corrected(&s)) {
        out.tau = (T::one() / a.alpha).as_f64() as f32;
    }
    if let Ok(v) = sigma2(r[0], p_mean) {
        out.sigma = v.corrected.max(T::zero()).sqrt().as_f64() as f32;
    }
    out
}
