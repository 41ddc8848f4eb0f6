//! Small dense kernels over the leading `n x n` block of row-major `[[T; NX]; NX]` arrays.
//!
//! Why not nalgebra's indexing: on the bank's hot path every element access `m[(i, j)]` is a
//! bounds-checked column-major address computation; measured with callgrind, the first version of
//! the member predict cost ~17 instructions per multiply-add. These kernels walk rows with slice
//! iterators (`zip`, `take(n)`), which need no bounds checks and no index arithmetic, so a
//! multiply-add is a load, a fused multiply-add and the loop step.

use crate::filter::is_positive_definite;
use crate::model::{StateMat, StateVec, NX};
use crate::Real;

/// A row-major `NX x NX` array.
pub type Arr<T> = [[T; NX]; NX];
/// An `NX` vector.
pub type Vec8<T> = [T; NX];

/// Zero array.
pub fn zeros<T: Real>() -> Arr<T> {
    [[T::zero(); NX]; NX]
}

/// From an nalgebra matrix.
pub fn from_mat<T: Real>(m: &StateMat<T>) -> Arr<T> {
    let mut a = zeros();
    for (i, row) in a.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = m.get((i, j)).copied().unwrap_or_else(T::zero);
        }
    }
    a
}

/// To an nalgebra matrix.
pub fn to_mat<T: Real>(a: &Arr<T>) -> StateMat<T> {
    StateMat::from_fn(|i, j| {
        a.get(i)
            .and_then(|r| r.get(j))
            .copied()
            .unwrap_or_else(T::zero)
    })
}

/// To an nalgebra vector.
pub fn to_vec<T: Real>(x: &Vec8<T>) -> StateVec<T> {
    StateVec::from_fn(|i, _| x.get(i).copied().unwrap_or_else(T::zero))
}

/// The first `n` entries (all of them if `n` is larger): one bounds check, after which `zip`
/// over two such slices compiles to a plain counted loop.
#[inline(always)]
pub fn head<T>(s: &[T], n: usize) -> &[T] {
    s.get(..n).unwrap_or(s)
}

/// Mutable [`head`].
#[inline(always)]
pub fn head_mut<T>(s: &mut [T], n: usize) -> &mut [T] {
    let len = s.len();
    &mut s[..n.min(len)]
}

/// Dot product of the first `n` entries.
#[inline]
pub fn dot<T: Real>(a: &[T], b: &[T], n: usize) -> T {
    let mut s = T::zero();
    for (x, y) in head(a, n).iter().zip(head(b, n)) {
        s += *x * *y;
    }
    s
}

/// `y += k x` over the first `n` entries.
#[inline]
pub fn axpy<T: Real>(y: &mut [T], k: T, x: &[T], n: usize) {
    for (v, w) in head_mut(y, n).iter_mut().zip(head(x, n)) {
        *v += k * *w;
    }
}

/// `a b` over the leading `n x n` block (the rest zero): rows of `c` accumulate rows of `b`.
pub fn mul<T: Real>(a: &Arr<T>, b: &Arr<T>, n: usize) -> Arr<T> {
    let mut c = zeros();
    for (ci, ai) in head_mut(&mut c, n).iter_mut().zip(head(a, n)) {
        for (aik, bk) in head(ai, n).iter().zip(head(b, n)) {
            axpy(ci, *aik, bk, n);
        }
    }
    c
}

/// `out = a b^T + d` over the leading block, upper half computed and mirrored (the result is
/// symmetric when `a b^T` is, as in `(Phi P) Phi^T`). Entries outside the block are untouched.
pub fn mul_t_sym_into<T: Real>(out: &mut Arr<T>, a: &Arr<T>, b: &Arr<T>, d: &Arr<T>, n: usize) {
    let n = n.min(NX);
    for i in 0..n {
        for j in i..n {
            let v = dot(&a[i], &b[j], n) + d[i][j];
            out[i][j] = v;
            out[j][i] = v;
        }
    }
}

/// `a b^T + d` over the leading block (see [`mul_t_sym_into`]), zero elsewhere.
pub fn mul_t_sym<T: Real>(a: &Arr<T>, b: &Arr<T>, d: &Arr<T>, n: usize) -> Arr<T> {
    let mut c = zeros();
    mul_t_sym_into(&mut c, a, b, d, n);
    c
}

/// Dot product of the first `N` entries, `N` a compile-time constant (`N <= NX`). Unrolled by
/// hand in blocks of four: the release profile optimises for size (`opt-level = "s"`), which
/// does not unroll, and a rolled loop costs ~6 instructions per multiply-add against ~2.5 here
/// (callgrind). With `N = 4` the block loop runs once and disappears.
#[inline(always)]
fn dot_c<T: Real, const N: usize, const A: usize, const B: usize>(a: &[T; A], b: &[T; B]) -> T {
    let n = N.min(A).min(B);
    let mut s = T::zero();
    let mut k = 0;
    while k + 4 <= n {
        // `k + 3 < n <= min(A, B)`: in bounds, known at compile time.
        s += a[k] * b[k] + a[k + 1] * b[k + 1] + a[k + 2] * b[k + 2] + a[k + 3] * b[k + 3];
        k += 4;
    }
    while k < n {
        s += a[k] * b[k];
        k += 1;
    }
    s
}

/// Kalman predict over the leading `N` states: `x = Phi x`, `P = (Phi P) Phi^T + Qd` with `P`
/// symmetric, so that `(Phi P)_ij = Phi_i . P_j` and every product is a row-by-row dot product.
/// `N^2 + N^3 + N^2 (N+1)/2` multiply-adds.
pub fn predict_c<T: Real, const N: usize>(
    x: &mut Vec8<T>,
    p: &mut Arr<T>,
    phi: &Arr<T>,
    qd: &Arr<T>,
) {
    // Temporaries of the active size only (no 8x8 zero fill).
    let n = N.min(NX);
    let mut xn = [T::zero(); N];
    let mut t = [[T::zero(); N]; N];
    for i in 0..n {
        xn[i] = dot_c::<T, N, NX, NX>(&phi[i], x);
        for j in 0..n {
            t[i][j] = dot_c::<T, N, NX, NX>(&phi[i], &p[j]);
        }
    }
    for i in 0..n {
        for j in i..n {
            let v = dot_c::<T, N, N, NX>(&t[i], &phi[j]) + qd[i][j];
            p[i][j] = v;
            p[j][i] = v;
        }
    }
    x[..n].copy_from_slice(&xn[..n]);
}

/// Scalar Kalman update over the leading `N` states: `a = P h`, `S = h a + r`,
/// `x += a nu / S`, `P -= a a^T / S` (upper half, mirrored). Returns `(nu, S)`, or `None` with
/// nothing changed when `S` is not finite and positive.
pub fn update_c<T: Real, const N: usize>(
    x: &mut Vec8<T>,
    p: &mut Arr<T>,
    h: &Vec8<T>,
    z: T,
    r: T,
) -> Option<(T, T)> {
    let n = N.min(NX);
    let mut a = [T::zero(); NX];
    for i in 0..n {
        a[i] = dot_c::<T, N, NX, NX>(&p[i], h);
    }
    let s = r + dot_c::<T, N, NX, NX>(h, &a);
    if !(s.is_finite() && s > T::zero()) {
        return None;
    }
    let nu = z - dot_c::<T, N, NX, NX>(h, x);
    let inv = T::one() / s;
    for i in 0..n {
        let ki = a[i] * inv;
        x[i] += ki * nu;
        for j in i..n {
            let v = p[i][j] - ki * a[j];
            p[i][j] = v;
            p[j][i] = v;
        }
    }
    Some((nu, s))
}

/// Cholesky test of the leading `n x n` block of a symmetric `p`: true when every pivot is
/// finite and positive. The fixed filter's [`is_positive_definite`] on a copy (its accesses are
/// checked, so no panic path; one call per step costs ~64 copies and `n^3 / 6` multiply-adds).
pub fn positive_definite<T: Real>(p: &Arr<T>, n: usize) -> bool {
    is_positive_definite(&to_mat(p), n)
}

/// `A^T`.
pub fn transpose<T: Real>(a: &Arr<T>) -> Arr<T> {
    let mut t = zeros();
    for (i, row) in a.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            t[j][i] = *v;
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernels_match_nalgebra() {
        let a = StateMat::<f64>::from_fn(|i, j| ((i * 3 + j * 7) % 5) as f64 - 2.0);
        let b = StateMat::<f64>::from_fn(|i, j| ((i * 5 + j) % 7) as f64 * 0.5);
        let n = 5;
        let c = mul(&from_mat(&a), &from_mat(&b), n);
        let p = a.fixed_view::<5, 5>(0, 0) * b.fixed_view::<5, 5>(0, 0);
        for i in 0..n {
            for j in 0..n {
                assert!((c[i][j] - p[(i, j)]).abs() < 1e-12);
            }
        }
        let s = from_mat(&(a * a.transpose()));
        let q = mul_t_sym(&from_mat(&a), &from_mat(&a), &zeros(), NX);
        assert_eq!(to_mat(&q), to_mat(&s));
    }
}
