//! Cholesky factorisation of the leading `p x p` block of a symmetric array, the solves built on
//! it, and the positive-definiteness test every filter's health check uses.

// Small fixed-size matrix code reads best with explicit indices (they mirror the equations).
#![allow(clippy::needless_range_loop)]

use crate::linalg::Arr;
use crate::Real;

/// Cholesky factor `L` (lower) of the leading `p x p` block of `a`; `None` if a pivot is not
/// finite and positive.
pub fn cholesky<T: Real, const M: usize>(a: &Arr<T, M>, p: usize) -> Option<Arr<T, M>> {
    let p = p.min(M);
    let mut l = [[T::zero(); M]; M];
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
pub fn chol_solve<T: Real, const M: usize>(l: &Arr<T, M>, b: &[T; M], p: usize) -> [T; M] {
    let p = p.min(M);
    let mut y = [T::zero(); M];
    for i in 0..p {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * y[k];
        }
        y[i] = s / l[i][i];
    }
    let mut x = [T::zero(); M];
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
pub fn inverse_diagonal<T: Real, const M: usize>(l: &Arr<T, M>, p: usize) -> [T; M] {
    let p = p.min(M);
    let mut out = [T::zero(); M];
    for (i, o) in out.iter_mut().enumerate().take(p) {
        let mut e = [T::zero(); M];
        e[i] = T::one();
        *o = chol_solve(l, &e, p)[i];
    }
    out
}

/// Cholesky test of the leading `n x n` block: true when every pivot is finite and positive and
/// every entry of the block is finite.
pub fn is_positive_definite<T: Real, const N: usize>(p: &Arr<T, N>, n: usize) -> bool {
    let n = n.min(N);
    cholesky(p, n).is_some()
        && p.iter()
            .take(n)
            .all(|r| r.iter().take(n).all(|v| v.is_finite()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solve_and_inverse_diagonal() {
        let mut a = [[0.0f64; 4]; 4];
        a[0] = [4.0, 2.0, 0.0, 0.0];
        a[1] = [2.0, 3.0, 0.0, 0.0];
        let l = cholesky(&a, 2).unwrap();
        let x = chol_solve(&l, &[2.0, 1.0, 0.0, 0.0], 2);
        assert!((4.0 * x[0] + 2.0 * x[1] - 2.0).abs() < 1e-12);
        assert!((2.0 * x[0] + 3.0 * x[1] - 1.0).abs() < 1e-12);
        let d = inverse_diagonal(&l, 2);
        assert!((d[0] - 3.0 / 8.0).abs() < 1e-12 && (d[1] - 0.5).abs() < 1e-12);
        assert!(is_positive_definite(&a, 2));
        a[1][1] = -1.0;
        assert!(cholesky(&a, 2).is_none());
        assert!(!is_positive_definite(&a, 2));
        a[1][1] = 3.0;
        a[0][1] = f64::NAN;
        assert!(!is_positive_definite(&a, 2));
    }
}
