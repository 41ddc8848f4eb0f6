//! Sample ACF of the series and the exponential-cosine detection on it.
//!
//! The ACF is the core's `acf_batch` (mean removed, 1/N normalisation) of the series averaged
//! in blocks of `decimate` samples (block means, not plain subsampling: they keep the
//! oscillation from aliasing onto a lower frequency). The exponential fit is the core's
//! `ls_slope`; the exponential-cosine fit starts from the core's `exp_cosine` (β from the
//! interpolated first zero crossing, α by least squares before it) and is then refined over
//! all lags `1..=L` by least squares of
//!
//! ```text
//! ρ_j ≈ A e^{−α τ_j} cos β τ_j + B e^{−τ_j / T},
//! ```
//!
//! (Nelder-Mead over `ln α, ln β, ln T`, ordinary least squares for `A, B`). The second term
//! absorbs the positive short-lag correlation of the other components. Lag 0 is left out: it
//! holds the white-noise variance, which would bias `A` and with it α.

use std::f64::consts::PI;

use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::neldermead::NelderMead;
use imu_ident::autocorr::acf_batch;
use imu_ident::ident::{exp_cosine, ls_slope, SampleAcf};

/// A negative lobe counts as an oscillation when the ACF falls below `−max(NEG_LOBE,
/// 4/√N)`: 4/√N is four white-noise standard deviations of ρ_j (Bartlett), and the fixed
/// 0.05 keeps the small negative excursions that slow correlated noise produces on
/// 10⁶-sample records (|ρ| ~ 0.005 on ADIS gyro x) from counting.
pub const NEG_LOBE: f64 = 0.05;

/// The ACF and its fits.
#[derive(Debug, Clone, serde::Serialize)]
pub struct AcfResult {
    /// Decimation factor and the resulting lag step [s].
    pub decimate: usize,
    pub dt: f64,
    /// Samples after decimation.
    pub n: usize,
    /// ρ_0..=ρ_L.
    #[serde(skip)]
    pub rho: Vec<f64>,
    /// Most negative ρ_j and its lag time [s].
    pub min_rho: f64,
    pub min_rho_tau: f64,
    /// Detection threshold on `min_rho`.
    pub threshold: f64,
    /// Core `ls_slope` decay rate [1/s] (exponential fit), if any lag is above its floor.
    pub exp_alpha: Option<f64>,
    /// Core `exp_cosine` estimate `(alpha, beta)`, when the ACF crosses zero.
    pub core_exp_cos: Option<(f64, f64)>,
    /// Refined exponential cosine, when detected.
    pub exp_cos: Option<ExpCosFit>,
}

/// The refined exponential-cosine fit of the ACF.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct ExpCosFit {
    pub alpha: f64,
    pub beta: f64,
    /// 2π/β [s].
    pub period: f64,
    /// Share of the variance in the oscillation (A) and in the exponential term (B).
    pub a: f64,
    pub b: f64,
    /// Exponential term's correlation time [s].
    pub t: f64,
    /// RMS residual of the fit over lags 1..=L.
    pub rms: f64,
}

impl ExpCosFit {
    /// The fitted ACF at lag time `tau`.
    pub fn eval(&self, tau: f64) -> f64 {
        self.a * (-self.alpha * tau).exp() * (self.beta * tau).cos()
            + self.b * (-tau / self.t).exp()
    }
}

/// Block means of `k` samples (a trailing partial block is dropped).
pub fn decimate(y: &[f64], k: usize) -> Vec<f64> {
    if k <= 1 {
        return y.to_vec();
    }
    y.chunks_exact(k)
        .map(|c| c.iter().sum::<f64>() / k as f64)
        .collect()
}

/// ACF up to `max_lag` lags of `y` averaged over `k` samples at `rate` Hz, with its fits.
pub fn analyse(y: &[f64], rate: f64, k: usize, max_lag: usize) -> anyhow::Result<AcfResult> {
    let x = decimate(y, k.max(1));
    let n = x.len();
    let lags = max_lag.min(n / 4);
    anyhow::ensure!(
        lags >= 2 && n >= SampleAcf::<f64>::MIN_WINDOW as usize,
        "ACF: {n} samples after decimation by {k} are too few"
    );
    let mut r = vec![0.0; lags + 1];
    acf_batch(&x, &mut r).map_err(|e| anyhow::anyhow!("ACF: {e:?}"))?;
    let dt = k.max(1) as f64 / rate;
    anyhow::ensure!(r[0] > 0.0, "ACF: the series is constant");
    let rho: Vec<f64> = r.iter().map(|v| v / r[0]).collect();
    let window = u32::try_from(n).unwrap_or(u32::MAX);
    let acf = SampleAcf::new(&r, dt, window).map_err(|e| anyhow::anyhow!("ACF: {e:?}"))?;
    let exp_alpha = ls_slope(&acf).ok().map(|e| e.alpha);
    let core = exp_cosine(&acf).ok();
    let (jmin, min_rho) =
        rho.iter().enumerate().skip(1).fold(
            (0, f64::INFINITY),
            |a, (j, &v)| if v < a.1 { (j, v) } else { a },
        );
    let threshold = -(NEG_LOBE.max(4.0 / (n as f64).sqrt()));
    let exp_cos = match core {
        Some(c) if min_rho < threshold => refine(&rho, dt, c.alpha, c.beta, exp_alpha),
        _ => None,
    };
    Ok(AcfResult {
        decimate: k.max(1),
        dt,
        n,
        rho,
        min_rho,
        min_rho_tau: jmin as f64 * dt,
        threshold,
        exp_alpha,
        core_exp_cos: core.map(|c| (c.alpha, c.beta)),
        exp_cos,
    })
}

struct AcfCost<'a> {
    rho: &'a [f64],
    dt: f64,
}

impl AcfCost<'_> {
    /// Least-squares `(A, B)` and the residual sum of squares for `x = [ln α, ln β, ln T]`.
    fn solve(&self, x: &[f64]) -> Option<(f64, f64, f64)> {
        let (alpha, beta, t) = (x[0].exp(), x[1].exp(), x[2].exp());
        let (mut s11, mut s12, mut s22, mut s1y, mut s2y) = (0.0, 0.0, 0.0, 0.0, 0.0);
        let basis = |j: usize| {
            let tau = j as f64 * self.dt;
            ((-alpha * tau).exp() * (beta * tau).cos(), (-tau / t).exp())
        };
        for (j, &y) in self.rho.iter().enumerate().skip(1) {
            let (u, v) = basis(j);
            (s11, s12, s22, s1y, s2y) = (
                s11 + u * u,
                s12 + u * v,
                s22 + v * v,
                s1y + u * y,
                s2y + v * y,
            );
        }
        let det = s11 * s22 - s12 * s12;
        if det.is_nan() || det.abs() <= 1e-12 * s11 * s22 {
            return None;
        }
        let a = (s1y * s22 - s2y * s12) / det;
        let b = (s2y * s11 - s1y * s12) / det;
        let rss: f64 = self
            .rho
            .iter()
            .enumerate()
            .skip(1)
            .map(|(j, &y)| {
                let (u, v) = basis(j);
                (y - a * u - b * v).powi(2)
            })
            .sum();
        rss.is_finite().then_some((a, b, rss))
    }
}

impl CostFunction for AcfCost<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Vec<f64>) -> Result<f64, Error> {
        // β must stay below Nyquist (π/dt); α, T within (0.1 dt, 10⁶ dt).
        let (lo, hi) = ((0.1 * self.dt).ln(), (1e6 * self.dt).ln());
        let ln_t_ok = |v: f64| v >= lo && v <= hi;
        if !(ln_t_ok(-x[0]) && ln_t_ok(x[2]) && x[1] < (PI / self.dt).ln() && x[1] > -30.0) {
            return Ok(f64::INFINITY);
        }
        Ok(self.solve(x).map_or(f64::INFINITY, |(a, _, rss)| {
            // A negative A would be a cosine shifted by half a period: not this model.
            if a > 0.0 {
                rss
            } else {
                f64::INFINITY
            }
        }))
    }
}

fn refine(
    rho: &[f64],
    dt: f64,
    alpha: f64,
    beta: f64,
    exp_alpha: Option<f64>,
) -> Option<ExpCosFit> {
    let cost = AcfCost { rho, dt };
    let t0 = exp_alpha.map_or(10.0 * dt, |a| 1.0 / a);
    // The residual is very multimodal in β over many periods, and the core β (first zero
    // crossing) is biased by the other components at short lags: scan β over a factor 4
    // around it (log grid, 0.25 % steps, below Nyquist) and α over two decades, then start
    // Nelder-Mead from the best grid points.
    let nyq = (PI / dt).ln();
    let mut grid: Vec<(f64, Vec<f64>)> = Vec::new();
    for i in 0..=560 {
        let lb = beta.ln() + (i as f64 / 560.0 - 0.5) * 4.0_f64.ln();
        if lb >= nyq {
            continue;
        }
        for la in [alpha.ln(), (0.1 * alpha).ln(), (0.01 * alpha).ln()] {
            let x = vec![la, lb, t0.ln()];
            if let Ok(c) = cost.cost(&x) {
                if c.is_finite() {
                    grid.push((c, x));
                }
            }
        }
    }
    grid.sort_by(|a, b| a.0.total_cmp(&b.0));
    let starts: Vec<Vec<f64>> = grid.into_iter().take(3).map(|g| g.1).collect();
    let mut best: Option<(Vec<f64>, f64)> = None;
    for x0 in starts {
        let mut simplex = vec![x0.clone()];
        for i in 0..3 {
            let mut v = x0.clone();
            v[i] += if i == 1 { 0.005 } else { 0.5 };
            simplex.push(v);
        }
        let Some(res) = NelderMead::new(simplex)
            .with_sd_tolerance(1e-10)
            .ok()
            .and_then(|s| {
                Executor::new(AcfCost { rho, dt }, s)
                    .configure(|st| st.max_iters(400))
                    .run()
                    .ok()
            })
        else {
            continue;
        };
        let c = res.state.get_best_cost();
        if let Some(p) = res.state.get_best_param().cloned() {
            if c.is_finite() && best.as_ref().is_none_or(|b| c < b.1) {
                best = Some((p, c));
            }
        }
    }
    let (x, rss) = best?;
    let (a, b, _) = cost.solve(&x)?;
    let beta = x[1].exp();
    Some(ExpCosFit {
        alpha: x[0].exp(),
        beta,
        period: 2.0 * PI / beta,
        a,
        b,
        t: x[2].exp(),
        rms: (rss / (rho.len() - 1) as f64).sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_is_block_means() {
        assert_eq!(decimate(&[1.0, 3.0, 5.0, 7.0, 9.0], 2), vec![2.0, 6.0]);
    }

    #[test]
    fn finds_a_sampled_oscillation() {
        // A deterministic damped-cosine ACF: the refined fit must return its period.
        let dt = 0.01;
        let rho: Vec<f64> = (0..300)
            .map(|j| {
                let t = j as f64 * dt;
                if j == 0 {
                    1.0
                } else {
                    0.4 * (-0.5 * t).exp() * (2.0 * PI / 0.05 * t).cos() + 0.2 * (-t / 0.02).exp()
                }
            })
            .collect();
        let f = refine(&rho, dt, 50.0, 110.0, Some(60.0)).expect("fit");
        assert!((f.period / 0.05 - 1.0).abs() < 1e-3, "{f:?}");
        assert!((f.alpha / 0.5 - 1.0).abs() < 0.05, "{f:?}");
    }
}
