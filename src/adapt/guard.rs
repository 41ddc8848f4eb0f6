//! Safeguards of the Gauss-Newton update: the damped solve, the hysteresis (ignore steps smaller
//! than their standard error), the rate limit, and the physical bounds.

// Small fixed-size matrix code reads best with explicit indices (they mirror the equations).
#![allow(clippy::needless_range_loop)]

use crate::adapt::params::{ParamKind, Specs, MAXP};
use crate::Real;

/// A `MAXP x MAXP` matrix (only the leading `p x p` block is used).
pub type Mat<T> = [[T; MAXP]; MAXP];

/// Cholesky factor `L` (lower) of the leading `p x p` block of `a`; `None` if a pivot is not
/// finite and positive.
pub fn cholesky<T: Real>(a: &Mat<T>, p: usize) -> Option<Mat<T>> {
    let p = p.min(MAXP);
    let mut l = [[T::zero(); MAXP]; MAXP];
    for j in 0..p {
        let mut d = a[j][j];
        for k in 0..j {
            d -= l[j][k] * l[j][k];
        }
        if !(d.is_finite() && d > T::zero()) {
            return None;
        }
        let djj = d.sqrt();
        l[j][j] = djj;
        for i in (j + 1)..p {
            let mut s = a[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            l[i][j] = s / djj;
        }
    }
    Some(l)
}

/// Solves `L L^T x = b` over the leading `p` entries.
pub fn chol_solve<T: Real>(l: &Mat<T>, b: &[T; MAXP], p: usize) -> [T; MAXP] {
    let p = p.min(MAXP);
    let mut y = [T::zero(); MAXP];
    for i in 0..p {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * y[k];
        }
        y[i] = s / l[i][i];
    }
    let mut x = [T::zero(); MAXP];
    for i in (0..p).rev() {
        let mut s = y[i];
        for k in (i + 1)..p {
            s -= l[k][i] * x[k];
        }
        x[i] = s / l[i][i];
    }
    x
}

/// Diagonal of `A^-1` from its Cholesky factor (the variances of the estimates when `A` is a
/// Fisher information): column by column, `e_i^T A^-1 e_i`.
pub fn inverse_diagonal<T: Real>(l: &Mat<T>, p: usize) -> [T; MAXP] {
    let p = p.min(MAXP);
    let mut out = [T::zero(); MAXP];
    for (i, o) in out.iter_mut().enumerate().take(p) {
        let mut e = [T::zero(); MAXP];
        e[i] = T::one();
        *o = chol_solve(l, &e, p)[i];
    }
    out
}

/// Lower and upper bounds of each `theta_i` (natural logarithms).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Bounds<T> {
    /// Lower bounds.
    pub lo: [T; MAXP],
    /// Upper bounds.
    pub hi: [T; MAXP],
}

impl<T: Real> Bounds<T> {
    /// All zeros (a compile-time placeholder).
    pub const BLANK: Self = Self {
        lo: [T::ZERO; MAXP],
        hi: [T::ZERO; MAXP],
    };

    /// Physical bounds around the starting `theta0`: `tau` within `[dt, tau_max]`, every scale
    /// (sigma, q, density) within `spread` decades of its starting value either way. The finite
    /// difference step `h` is kept inside too, so that no bank member leaves the bounds.
    pub fn new(specs: &Specs, theta0: &[T; MAXP], dt: T, tau_max: T, spread: T, h: T) -> Self {
        let mut lo = [T::zero(); MAXP];
        let mut hi = [T::zero(); MAXP];
        let dec = spread * T::ln_10();
        for (i, s) in specs.iter().enumerate().take(MAXP) {
            let (l, u) = match s.kind {
                ParamKind::Tau => (dt.ln(), tau_max.ln()),
                _ => (theta0[i] - dec, theta0[i] + dec),
            };
            lo[i] = l + h;
            hi[i] = (u - h).max(l + h);
        }
        Self { lo, hi }
    }

    /// `theta` clamped into the bounds.
    pub fn clamp(&self, theta: &[T; MAXP], p: usize) -> [T; MAXP] {
        let mut out = *theta;
        for i in 0..p.min(MAXP) {
            out[i] = out[i].max(self.lo[i]).min(self.hi[i]);
        }
        out
    }
}

/// Limits a step: components smaller than `threshold` standard errors are dropped (hysteresis),
/// and the rest is scaled down as a whole (keeping its direction, which matters when parameters
/// are strongly correlated, like `sigma` and `tau` of a slow Gauss-Markov process) so that no
/// component exceeds `max_step`.
pub fn limit_step<T: Real>(
    delta: &[T; MAXP],
    std_err: &[T; MAXP],
    threshold: T,
    max_step: T,
    p: usize,
) -> [T; MAXP] {
    let p = p.min(MAXP);
    let mut d = *delta;
    let mut biggest = T::zero();
    for i in 0..p {
        if !(d[i].is_finite()) || d[i].abs() < threshold * std_err[i] {
            d[i] = T::zero();
        }
        biggest = biggest.max(d[i].abs());
    }
    if biggest > max_step {
        let k = max_step / biggest;
        for v in d.iter_mut().take(p) {
            *v *= k;
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solve_and_inverse_diagonal() {
        let mut a = [[0.0f64; MAXP]; MAXP];
        a[0] = [4.0, 2.0, 0.0, 0.0];
        a[1] = [2.0, 3.0, 0.0, 0.0];
        let l = cholesky(&a, 2).unwrap();
        let x = chol_solve(&l, &[2.0, 1.0, 0.0, 0.0], 2);
        assert!((4.0 * x[0] + 2.0 * x[1] - 2.0).abs() < 1e-12);
        assert!((2.0 * x[0] + 3.0 * x[1] - 1.0).abs() < 1e-12);
        let d = inverse_diagonal(&l, 2);
        assert!((d[0] - 3.0 / 8.0).abs() < 1e-12 && (d[1] - 0.5).abs() < 1e-12);
        a[1][1] = -1.0;
        assert!(cholesky(&a, 2).is_none());
    }

    #[test]
    fn step_limits() {
        let d = limit_step(
            &[2.0f64, -0.1, 0.5, 0.0],
            &[0.1, 0.2, 0.1, 0.1],
            1.0,
            1.0,
            4,
        );
        assert_eq!(d[1], 0.0);
        assert!((d[0] - 1.0).abs() < 1e-12 && (d[2] - 0.25).abs() < 1e-12);
    }
}
