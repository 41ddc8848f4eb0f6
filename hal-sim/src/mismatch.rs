//! Mismatched models for the paper's experiment (METHOD.md §5, Fig. 4): the drift coefficient
//! `alpha = 1/tau` and the diffusion coefficient `sigma sqrt(2/tau)` of every Gauss-Markov and
//! exponential-cosine component multiplied by a factor.

use imu_ident::model::{Component, InsModel};

/// Scales drift and diffusion of `c` by `k`: `tau' = tau / k`, `sigma' = k sigma sqrt(tau'/tau)`
/// (so that `sigma' sqrt(2/tau') = k sigma sqrt(2/tau)`).
pub fn scale_component(c: &Component<f64>, k: f64) -> Component<f64> {
    let scale = |sigma: f64, tau: f64| {
        let tau2 = tau / k;
        (k * sigma * (tau2 / tau).sqrt(), tau2)
    };
    match *c {
        Component::GaussMarkov(mut g) => {
            (g.sigma, g.tau) = scale(g.sigma, g.tau);
            Component::GaussMarkov(g)
        }
        Component::ExpCosine(mut e) => {
            (e.sigma, e.tau) = scale(e.sigma, e.tau);
            Component::ExpCosine(e)
        }
        other => other,
    }
}

/// The model with accelerometer components scaled by `ka` and gyro components by `kg`.
pub fn scaled(model: &InsModel<f64>, ka: f64, kg: f64) -> InsModel<f64> {
    let mut m = model.clone();
    for c in m.accel.iter_mut() {
        *c = scale_component(c, ka);
    }
    for c in m.gyro.iter_mut() {
        *c = scale_component(c, kg);
    }
    m
}

/// The model with each identified quantity (`imu_ident::adapt::params` order: accelerometer
/// first, then gyro; `sigma, tau` for a Gauss-Markov component) multiplied by the matching
/// factor (missing factors 1): the starts of the identification benches (issue 13). `None` if
/// the result is not a valid model.
pub fn factored(model: &InsModel<f64>, factors: &[f64]) -> Option<InsModel<f64>> {
    use imu_ident::adapt::params::{apply, specs, theta_of};
    let sp = specs(model);
    let mut theta = theta_of(model, &sp);
    for (t, f) in theta.iter_mut().zip(factors) {
        *t += f.ln();
    }
    apply(model, &sp, &theta)
}
