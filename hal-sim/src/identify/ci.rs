//! Parameter intervals of a fitted composite (Gauss-Newton covariance, delta method).

use std::f64::consts::PI;

use nalgebra::DMatrix;

use super::fit::{Kind, Problem, Term, Z95};

/// Approximate 95 % intervals of every term's parameters, `(var_lo, var_hi, tc_lo, tc_hi)`,
/// from the Gauss-Newton covariance `s² (JᵀJ)⁻¹` of the weighted log-ADEV residuals in the
/// log-parameters, with `s² = max(1, χ²/(n − p))` so that a misfit widens the intervals.
/// Correlation between the overlapping ADEV points is ignored, so they are optimistic.
/// `None` when JᵀJ is singular (a term the data do not constrain).
pub fn intervals(prob: &Problem, terms: &[Term]) -> Option<Vec<[f64; 4]>> {
    let (cov, shaped) = gn_cov(prob, terms)?;
    let sd = |i: usize| {
        let v = cov[(i, i)];
        (v.is_finite() && v >= 0.0).then(|| v.sqrt())
    };
    let mut out = Vec::with_capacity(terms.len());
    for (j, t) in terms.iter().enumerate() {
        let sv = sd(j)?;
        let (tlo, thi) = match shaped.iter().position(|&s| s == j) {
            Some(i) => {
                let st = sd(terms.len() + i)?;
                (t.tc * (-Z95 * st).exp(), t.tc * (Z95 * st).exp())
            }
            None => (f64::NAN, f64::NAN),
        };
        out.push([
            t.var * (-Z95 * sv).exp(),
            t.var * (Z95 * sv).exp(),
            tlo,
            thi,
        ]);
    }
    Some(out)
}

/// Correlation times up to this count as "white" in [`white_density`]: a tenth of the
/// τ = 1 s at which IEEE Std 952 reads the angle random walk off the −½ slope.
pub const ARW_TC_MAX: f64 = 0.1;

/// Long-τ white level N² a term contributes to the angle / velocity random walk: white and
/// filtered white their N², a Gauss-Markov with T_c ≤ [`ARW_TC_MAX`] its 2σ²T_c, an exp-cosine
/// with 1/α ≤ [`ARW_TC_MAX`] its 2σ²α/(α² + β²) (zero-frequency PSD, theory module docs).
fn white_level(t: &Term) -> f64 {
    match t.kind {
        Kind::White | Kind::FilteredWhite => t.var,
        Kind::GaussMarkov if t.tc <= ARW_TC_MAX => 2.0 * t.var * t.tc,
        Kind::ExpCosine if t.tc <= ARW_TC_MAX => {
            let (a, b) = (1.0 / t.tc, 2.0 * PI / t.period);
            2.0 * t.var * a / (a * a + b * b)
        }
        _ => 0.0,
    }
}

/// The angle / velocity random walk of the model, `N = sqrt(Σ white_level)`: what every
/// short-correlated term adds up to at τ ≫ 0.1 s. The terms trade off against each other
/// (white against filtered white or a one-sample Gauss-Markov), so this sum is far better
/// determined by the data than any one of them, and is what replicates should share.
/// 95 % interval by the delta method on the covariance of [`intervals`] (numerical gradient
/// of `ln Σ` in the same log-parameters). Returns `(N, lo, hi)`.
pub fn white_density(prob: &Problem, terms: &[Term]) -> Option<[f64; 3]> {
    let total: f64 = terms.iter().map(white_level).sum();
    if total.is_nan() || total <= 0.0 {
        return None;
    }
    let n = total.sqrt();
    let Some((cov, shaped)) = gn_cov(prob, terms) else {
        return Some([n, f64::NAN, f64::NAN]);
    };
    let x = log_params(terms, &shaped);
    let g0 = total.ln();
    let h = 1e-6;
    let grad: Vec<f64> = (0..x.len())
        .map(|i| {
            let mut xp = x.clone();
            xp[i] += h;
            let t = from_log_params(terms, &shaped, &xp);
            (t.iter().map(white_level).sum::<f64>().ln() - g0) / h
        })
        .collect();
    let mut var = 0.0;
    for i in 0..x.len() {
        for j in 0..x.len() {
            var += grad[i] * grad[j] * cov[(i, j)];
        }
    }
    // sd of ln N is half that of ln Σ.
    let sd = 0.5 * var.max(0.0).sqrt();
    Some([n, n * (-Z95 * sd).exp(), n * (Z95 * sd).exp()])
}

/// `[ln v_j…, ln tc of the shaped terms…]`.
fn log_params(terms: &[Term], shaped: &[usize]) -> Vec<f64> {
    let mut x: Vec<f64> = terms.iter().map(|t| t.var.max(1e-300).ln()).collect();
    x.extend(shaped.iter().map(|&j| terms[j].tc.ln()));
    x
}

fn from_log_params(terms: &[Term], shaped: &[usize], x: &[f64]) -> Vec<Term> {
    let mut t = terms.to_vec();
    for (j, term) in t.iter_mut().enumerate() {
        term.var = x[j].exp();
    }
    for (i, &j) in shaped.iter().enumerate() {
        t[j].tc = x[terms.len() + i].exp();
    }
    t
}

/// Gauss-Newton covariance of `[ln v_j…, ln tc of shaped terms…]` and the shaped indices.
fn gn_cov(prob: &Problem, terms: &[Term]) -> Option<(DMatrix<f64>, Vec<usize>)> {
    let shaped: Vec<usize> = (0..terms.len()).filter(|&j| terms[j].has_shape()).collect();
    let x = log_params(terms, &shaped);
    let build = |x: &[f64]| from_log_params(terms, &shaped, x);
    let resid = |t: &[Term]| -> Vec<f64> {
        prob.pts
            .iter()
            .map(|p| {
                let a: f64 = t.iter().map(|c| c.avar(p.m, prob.dt)).sum();
                (0.5 * a.ln() - p.ln_adev) / p.s
            })
            .collect()
    };
    let r0 = resid(&build(&x));
    let (n, p) = (r0.len(), x.len());
    if n <= p {
        return None;
    }
    let h = 1e-5;
    let mut jac = DMatrix::zeros(n, p);
    for i in 0..p {
        let mut xp = x.clone();
        xp[i] += h;
        let rp = resid(&build(&xp));
        for k in 0..n {
            jac[(k, i)] = (rp[k] - r0[k]) / h;
        }
    }
    let chi2: f64 = r0.iter().map(|r| r * r).sum();
    let scale = (chi2 / (n - p) as f64).max(1.0);
    let cov = (jac.transpose() * &jac).try_inverse()? * scale;
    Some((cov, shaped))
}
