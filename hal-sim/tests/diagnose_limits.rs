//! The levelling limit, checked: an accelerometer random constant enters the innovations as one
//! Gaussian number, so the largest likelihood gain any fitted random constant can achieve is
//! the closed form `(y - 1 - ln y)/2`, `y = xi^2 J` (`diagnose::limits`). If the fit ever
//! gained more, the data would hold more on the bias than the limit says, and the threshold the
//! diagnosis reports would be wrong.
//!
//! Bound: the identity is exact for a linear-Gaussian model (rank-one change of the innovation
//! covariance); the tolerance, 0.02 nat + 0.2 %, covers only the fit's optimiser stopping short
//! of the maximum (the refined fit is a golden-section search in ln sigma) and never lets it
//! exceed the closed form by more than rounding. Seeds fixed; the bias is drawn with
//! sigma 5e-3 m/s^2 so that both sides of the threshold occur.

use hal_sim::diagnose::{fit, limits};
use hal_sim::log::LogRow;
use hal_sim::replay::log_likelihood;
use hal_sim::{hidden, scenario, sim};

#[test]
fn a_fitted_accelerometer_constant_gains_exactly_what_one_gaussian_sample_allows() {
    let base = scenario::load("paper").unwrap().to_core().unwrap();
    let candidate = hidden::by_label("accel/random-constant").unwrap();
    let (mut below, mut above) = (0, 0);
    for seed in 10..22u64 {
        let truth = candidate.add_to(&base, &[5e-3_f64.ln()]).unwrap();
        let log: Vec<LogRow> = sim::simulate(&truth, 43_200, seed)
            .unwrap()
            .into_iter()
            .map(|r| LogRow { truth: None, ..r })
            .collect();
        let (ll0, n) = log_likelihood(&base, &log).unwrap();
        let coarse = fit::fit(&base, candidate, &log).unwrap();
        let gain = fit::refine(&base, &coarse, &log).log_likelihood - ll0;
        let bias = limits::accel_bias_observability(&base, &log).unwrap();
        let theory = bias.max_gain();
        assert!(
            gain <= theory + 1e-6 && gain >= theory - 0.02 - 2e-3 * theory,
            "seed {seed}: fitted gain {gain:.4} vs one-sample bound {theory:.4}"
        );
        // Named by BIC exactly when |xi| clears the reported threshold.
        let threshold = limits::one_sample_threshold((n as f64).ln()).sqrt() * bias.sd;
        let named = gain > 0.5 * (n as f64).ln();
        assert_eq!(named, bias.estimate.abs() > threshold, "seed {seed}");
        if named {
            above += 1;
        } else {
            below += 1;
        }
    }
    assert!(
        below > 0 && above > 0,
        "both sides of the threshold: {below} below, {above} above"
    );
}
