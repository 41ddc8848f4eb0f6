//! The Cramér-Rao intervals of a search's answer: the observed information of the
//! log-likelihood at its maximum, by finite differences on the search's own grid. Shared by
//! the online window search ([`super::adapt`]) and `nav --identify` ([`super::identify`]), as
//! the search itself ([`super::pattern`]).

use anyhow::Result;

/// Step of the curvature's finite differences [decades]: the search's finest step, so that
/// the points the search's last pass tried are reused.
const CURVATURE_STEP: f64 = 0.125;

/// The Cramér-Rao standard deviations of the coordinates at the maximum `x` (value `f0`):
/// the square roots of the diagonal of the inverse observed information, `-H^-1`, with `H`
/// the Hessian of the window log-likelihood by finite differences of step
/// [`CURVATURE_STEP`] (central on the diagonal, forward across; `n (n - 1) / 2` replays
/// beyond the search's own points). `bounds(i)` is coordinate `i`'s interval, `None` for one
/// left out of the search (its sd is NaN). A coordinate whose step would leave its bounds, or
/// whose curvature is not negative, gets an infinite sd; if the information of the others is not
/// positive definite, each gets its own `1 / sqrt(-H_ii)` (conditional on the others, so
/// optimistic).
pub fn cramer_rao_sd(
    x: &[f64],
    f0: f64,
    bounds: &dyn Fn(usize) -> Option<(f64, f64)>,
    eval: &mut dyn FnMut(&[f64]) -> Result<f64>,
) -> Result<Vec<f64>> {
    let n = x.len();
    let h = CURVATURE_STEP;
    let inside =
        |i: usize, v: f64| bounds(i).is_some_and(|(lo, hi)| v >= lo - 1e-12 && v <= hi + 1e-12);
    let at = |moves: &[(usize, f64)]| {
        let mut y = x.to_vec();
        for &(i, d) in moves {
            y[i] += d;
        }
        y
    };
    let ok: Vec<usize> = (0..n)
        .filter(|&i| inside(i, x[i] + h) && inside(i, x[i] - h))
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
    let mut sd: Vec<f64> = (0..n)
        .map(|i| {
            if bounds(i).is_some() {
                f64::INFINITY
            } else {
                f64::NAN
            }
        })
        .collect();
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

#[cfg(test)]
mod tests {
    use super::*;

    /// On a quadratic log-likelihood the finite differences are exact: the sds are the roots
    /// of the diagonal of the covariance whose inverse is the quadratic's matrix. A coordinate
    /// left out gets NaN, one at its bound an infinite sd.
    #[test]
    fn a_quadratic_gives_its_covariance() {
        // Information [[4, 1], [1, 2]]: covariance [[2, -1], [-1, 4]] / 7.
        let m = [0.3, -0.2, 0.0, 1.0];
        let ll = |x: &[f64]| -> Result<f64> {
            let (a, b) = (x[0] - m[0], x[1] - m[1]);
            Ok(-0.5 * (4.0 * a * a + 2.0 * a * b + 2.0 * b * b) - x[2].powi(2) - x[3].powi(2))
        };
        let bounds = |i: usize| match i {
            2 => None,
            3 => Some((-1.0, 1.0)),
            _ => Some((-2.0, 2.0)),
        };
        let f0 = ll(&m).unwrap();
        let sd = cramer_rao_sd(&m, f0, &bounds, &mut |x| ll(x)).unwrap();
        assert!((sd[0] - (2.0f64 / 7.0).sqrt()).abs() < 1e-9, "{sd:?}");
        assert!((sd[1] - (4.0f64 / 7.0).sqrt()).abs() < 1e-9, "{sd:?}");
        assert!(sd[2].is_nan(), "{sd:?}");
        assert!(sd[3].is_infinite(), "{sd:?}");
    }
}
