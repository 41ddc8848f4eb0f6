//! What a one-channel velocity observation cannot show, stated with the verdict.
//!
//! A verdict of "adequate", or a named effect, is only as good as what the innovations can
//! reveal. Two limits follow from the error model itself (METHOD.md §5), whatever the test:
//!
//! - **An accelerometer random constant is seen once.** The velocity sees
//!   `u = -g delta + b`, and `u' = -g dV/R - g eps` holds no constant `b`: `b` enters the
//!   innovations only through the apparent initial tilt (the levelling limit), which the
//!   model's initial tilt and accelerometer uncertainty already explain. All the data hold on
//!   `b` is one Gaussian number, its least-squares estimate `xi ~ N(b, s0^2)` with
//!   `s0 = 1/sqrt(J)` ([`accel_bias_observability`] computes both by running the model with
//!   `b` added). Fitting a random constant of any `sigma_b` gains at most `(y - 1 - ln y)/2`
//!   nats for `y = xi^2/s0^2 > 1` ([`BiasObservability::max_gain`]); BIC accepts it when that
//!   exceeds `(1/2) ln n`, so a bias is named only if `|xi|` is above `sqrt(y*) s0`,
//!   `y* - 1 - ln y* = ln n` (3.8 s0 over 12 h at 1 Hz; `s0` = 1.1e-3 m/s^2 for `paper`, about
//!   `g sigma_delta0` = 9.8e-4 plus a share of the accelerometer's own 1e-3). Below that, the
//!   bias is absorbed into the tilt estimate and no innovation test can see it.
//! - **Gyro white noise and an accelerometer random walk are the same to the velocity.** Both
//!   drive `u' = -g dV/R - g eps - g w + n` through `-g w + n`: a gyro white noise of density
//!   `N` and an accelerometer random walk of intensity `q = g^2 N^2` give every innovation
//!   sequence the same likelihood. The diagnosis names the one with the least expected tilt
//!   regret ([`super::tie`]: the gyro). That choice keeps the tilt RMS near the oracle's under
//!   either truth, but not the filter's honesty: when the accelerometer is the cause, the
//!   gyro-white model's tilt sigma is far too small (`diagnose_bench`, accel/random-walk: 50 to
//!   96 % of ticks outside 3 sigma). Telling them apart needs another observation or a prior on
//!   sensor grade.

use crate::candidates::LIBRARY;
use crate::log::LogRow;
use imu_ident::filter::InsFilter;
use imu_ident::model::ins::G0;
use imu_ident::model::{ComponentKind, ErrorSource, InsModel};
use serde::Serialize;

/// One limit of what the data can show.
#[derive(Debug, Clone, Serialize)]
pub struct Limit {
    /// The candidates concerned (`sensor/kind`).
    pub candidates: Vec<String>,
    /// The smallest magnitude the diagnosis can name, when there is one, in `unit`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub threshold: Option<f64>,
    /// The data's own estimate of that magnitude (same unit), when there is one: the effect
    /// can be named only if it exceeds `threshold` in absolute value.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub estimate: Option<f64>,
    /// Unit of `threshold`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unit: Option<&'static str>,
    /// Why, in one line.
    pub why: String,
}

/// The root `y* > 1` of `y - 1 - ln y = c` (`c > 0`): the smallest squared ratio `x^2/s0^2`
/// of one Gaussian sample at which fitting its variance gains `c/2` nats. `y - 1 - ln y` is
/// increasing for `y > 1`, so bisection on `[1, c + 2 + ln(c + 2)]` (where it exceeds `c`)
/// converges; 200 halvings reach machine precision.
pub fn one_sample_threshold(c: f64) -> f64 {
    let f = |y: f64| y - 1.0 - y.ln() - c;
    let (mut lo, mut hi) = (1.0_f64, c + 2.0 + (c + 2.0).ln());
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f(mid) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    0.5 * (lo + hi)
}

/// What the log says about a constant accelerometer bias under `model`: the generalised
/// least-squares estimate `xi` of a constant `b` added to the model, and its standard deviation
/// `1/sqrt(J)`, `J = h^T C^-1 h` the Fisher information (`C` the innovations' covariance under
/// `model`, `h` the velocity's response to a unit `b`).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct BiasObservability {
    /// `xi` [m/s^2].
    pub estimate: f64,
    /// `1/sqrt(J)` [m/s^2]: `xi`'s standard deviation when there is no bias.
    pub sd: f64,
}

impl BiasObservability {
    /// The largest log-likelihood gain of adding a random constant of any `sigma` to `model`:
    /// the data are Gaussian with covariance `C + sigma^2 h h^T` (rank one), which gives
    /// `(y - 1 - ln y)/2` for `y = xi^2 J > 1`, else 0, exactly.
    pub fn max_gain(&self) -> f64 {
        let y = (self.estimate / self.sd).powi(2);
        if y > 1.0 {
            0.5 * (y - 1.0 - y.ln())
        } else {
            0.0
        }
    }
}

/// Runs `model` plus an accelerometer random constant of a prior `sigma0` far above what the
/// data can resolve; the final posterior is `N(xi, 1/(J + 1/sigma0^2))`, corrected here for
/// `sigma0` exactly. `None` when the model cannot take one more component or the run fails.
pub fn accel_bias_observability(
    model: &InsModel<f64>,
    log: &[LogRow],
) -> Option<BiasObservability> {
    let candidate = LIBRARY
        .iter()
        .copied()
        .find(|c| c.sensor == ErrorSource::Accel && c.kind == ComponentKind::RandomConstant)?;
    // A prior 1e3 times the model's own initial tilt in specific force (at least 1e-6):
    // large against 1/sqrt(J), small enough to keep the scaled covariance well conditioned.
    let sigma0 = (1e3 * G0 * model.sigma_delta0).max(1e-6);
    let augmented = candidate.add_to(model, &[sigma0.ln()])?;
    let slot = augmented
        .layout()
        .ok()?
        .iter()
        .rfind(|s| s.sensor == ErrorSource::Accel)
        .copied()?;
    // The step does not expose one state's posterior: a bare filter of the same model follows
    // the ticks the step decided (same observations, same gate decisions, same repairs), so
    // it holds the step's state bitwise.
    let plan = crate::replay::run::<f64>(&augmented, None, log)
        .ok()?
        .telemetry
        .records;
    let mut filter = InsFilter::<f64>::new(augmented).ok()?;
    for tick in crate::replay::follow(log, &plan) {
        filter.step(tick.used_z());
        filter.repair();
    }
    let (x, p) = (filter.state_si(), filter.covariance_si());
    let (estimate, var) = (x[slot.start], p[(slot.start, slot.start)]);
    let info = 1.0 / var - 1.0 / (sigma0 * sigma0);
    (estimate.is_finite() && info.is_finite() && info > 0.0).then(|| BiasObservability {
        estimate,
        sd: info.sqrt().recip(),
    })
}

/// The limits for `model` on `log` (`n` innovations).
pub fn limits(model: &InsModel<f64>, log: &[LogRow], n: usize) -> Vec<Limit> {
    let z = one_sample_threshold((n.max(2) as f64).ln()).sqrt();
    let bias = accel_bias_observability(model, log);
    let sd = bias.map_or(f64::NAN, |b| b.sd);
    let estimate = bias.map_or(f64::NAN, |b| b.estimate);
    vec![
        Limit {
            candidates: vec!["accel/random-constant".into()],
            threshold: Some(z * sd).filter(|t| t.is_finite()),
            estimate: Some(estimate).filter(|e| e.is_finite()),
            unit: Some("m/s^2"),
            why: format!(
                "a constant accelerometer bias enters the velocity only through the apparent initial tilt (levelling limit): these data estimate it as {estimate:.2e} +- {sd:.2e} m/s^2, so a bias below about {z:.1} x {sd:.2e} is absorbed into the tilt and cannot be named"
            ),
        },
        Limit {
            candidates: vec!["gyro/white".into(), "accel/random-walk".into()],
            threshold: None,
            estimate: None,
            unit: None,
            why: "gyro white noise N and an accelerometer random walk q = g^2 N^2 drive the velocity identically (-g w + n): the innovations cannot tell them apart. The one with the least expected tilt-RMS regret is named (the gyro, when they tie); if the accelerometer is the cause, the tilt RMS stays near the best achievable but the filter's tilt sigma is overconfident (measured: 50-96 % of ticks outside 3 sigma), so do not trust the tilt sigma without another observation".into(),
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The root solves its equation, and at 12 h of 1 Hz data it is the 3.8 s0 quoted above.
    #[test]
    fn one_sample_threshold_solves_its_equation() {
        for c in [0.1, 1.0, 10.67, 100.0] {
            let y = one_sample_threshold(c);
            assert!(
                y > 1.0 && (y - 1.0 - y.ln() - c).abs() < 1e-9,
                "c {c}: y {y}"
            );
        }
        let z = one_sample_threshold(43_200f64.ln()).sqrt();
        assert!((3.7..3.9).contains(&z), "{z}");
    }
}
