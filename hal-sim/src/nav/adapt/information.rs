//! The Cramér-Rao intervals of a search's answer: the observed information of the window
//! log-likelihood at its maximum, by finite differences on the search's own grid.

use super::MAX_DECADES;
use anyhow::Result;

/// Step of the curvature's finite differences [decades]: the search's finest step, so that
/// the points the search's last pass tried are reused.
const CURVATURE_STEP: f64 = 0.125;

/// The Cramér-Rao standard deviations of the log10 factors at the maximum `x` (value `f0`):
/// the square roots of the diagonal of the inverse observed information, `-H^-1`, with `H`
/// the Hessian of the window log-likelihood by finite differences of step
/// [`CURVATURE_STEP`] (central on the diagonal, forward across; `n (n - 1) / 2` replays
/// beyond the search's own points). A coordinate whose step would leave the bounds, or whose
/// curvature is not negative, gets an infinite sd; if the information of the others is not
/// positive definite, each gets its own `1 / sqrt(-H_ii)` (conditional on the others, so
/// optimistic).
pub fn cramer_rao_sd(
    x: &[f64],
    f0: f64,
    eval: &mut dyn FnMut(&[f64]) -> Result<f64>,
) -> Result<Vec<f64>> {
    let n = x.len();
    let h = CURVATURE_STEP;
    let inside = |v: f64| v.abs() <= MAX_DECADES + 1e-12;
    let at = |moves: &[(usize, f64)]| {
        let mut y = x.to_vec();
        for &(i, d) in moves {
            y[i] += d;
        }
        y
    };
    let ok: Vec<usize> = (0..n)
        .filter(|&i| inside(x[i] + h) && inside(x[i] - h))
        .collect();
    let mut up = vec![f64::NAN; n];
    let mut hess = nalgebra::DMatrix::<f64>::zeros(ok.len(), ok.len());
    for (a, &i) in ok.iter().enumerate() {
        up[i] = eval(&at(&[(i, h)]))?;
        let down = eval(&at(&[(i, -h)]))?;
        hess[(a, a)] = (up[i] - 2.0 * f0 + down) / (h * h);
    }
    for (a, &i) in ok.iter().enumerate() {
        for (b, &j) in ok.iter().enumerate().skip(a + 1) {
            let both = eval(&at(&[(i, h), (j, h)]))?;
            let v = (both - up[i] - up[j] + f0) / (h * h);
            hess[(a, b)] = v;
            hess[(b, a)] = v;
        }
    }
    let mut sd = vec![f64::INFINITY; n];
    let finite = hess.iter().all(|v| v.is_finite());
    match (-hess.clone()).cholesky().filter(|_| finite) {
        Some(c) => {
            let cov = c.inverse();
            for (a, &i) in ok.iter().enumerate() {
                sd[i] = cov[(a, a)].sqrt();
            }
        }
        None => {
            for (a, &i) in ok.iter().enumerate() {
                if hess[(a, a)] < 0.0 {
                    sd[i] = (-1.0 / hess[(a, a)]).sqrt();
                }
            }
        }
    }
    Ok(sd)
}
