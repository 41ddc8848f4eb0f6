//! Small dense kernels over the leading `n x n` block of row-major `[[T; N]; N]` arrays.
//!
//! Why not nalgebra's indexing: on the identification bank's hot path every element access
//! `m[(i, j)]` is a bounds-checked column-major address computation; measured with callgrind,
//! the first version of the member predict cost ~17 instructions per multiply-add. These kernels
//! walk rows with slice iterators (`zip`, `take(n)`), which need no bounds checks and no index
//! arithmetic, so a multiply-add is a load, a fused multiply-add and the loop step.

use crate::Real;
use nalgebra::{SMatrix, SVector};

/// A row-major `N x N` array.
pub type Arr<T, const N: usize> = [[T; N]; N];

/// Zero array.
pub fn zeros<T: Real, const N: usize>() -> Arr<T, N> {
    [[T::zero(); N]; N]
}

/// From an nalgebra matrix.
pub fn from_mat<T: Real, const N: usize>(m: &SMatrix<T, N, N>) -> Arr<T, N> {
    let mut a = zeros();
    for (i, row) in a.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = m.get((i, j)).copied().unwrap_or_else(T::zero);
        }
    }
    a
}

/// To an nalgebra matrix.
pub fn to_mat<T: Real, const N: usize>(a: &Arr<T, N>) -> SMatrix<T, N, N> {
    SMatrix::from_fn(|i, j| {
        a.get(i)
            .and_then(|r| r.get(j))
            .copied()
            .unwrap_or_else(T::zero)
    })
}

/// To an nalgebra vector.
pub fn to_vec<T: Real, const N: usize>(x: &[T; N]) -> SVector<T, N> {
    SVector::from_fn(|i, _| x.get(i).copied().unwrap_or_else(T::zero))
}

/// From an nalgebra vector (or row: any `1 x N` / `N x 1` storage read linearly).
pub fn from_vec<T: Real, const R: usize, const C: usize>(v: &SMatrix<T, R, C>) -> [T; C] {
    let mut out = [T::zero(); C];
    for (k, o) in out.iter_mut().enumerate() {
        *o = v.get(k).copied().unwrap_or_else(T::zero);
    }
    out
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
///
/// A zero `a[i][k]` is skipped: the error-state models' `A` is sparse (the noise states' rows
/// hold their own dynamics only, the navigation rows a few couplings), and so are the noise
/// states' rows of `Phi`, so the discretisation's Taylor and `Q` series (`A` on the left) cost
/// `nnz(A) n` instead of `n^3` (BENCHMARKS.md "Sparse products in the discretisation"). For
/// finite `b` the result is the same, bit for bit (`+ 0 b` adds nothing); an infinite or NaN
/// `b[k]` no longer spreads through a zero `a[i][k]` (the discretisation checks its inputs are
/// finite).
pub fn mul<T: Real, const N: usize>(a: &Arr<T, N>, b: &Arr<T, N>, n: usize) -> Arr<T, N> {
    let mut c = zeros();
    mul_into(&mut c, a, b, n);
    c
}

/// [`mul`] into `c`: its leading `n x n` block is overwritten with `a b` (the same bits), the
/// rest untouched. A series that multiplies every term reuses one `c` instead of zeroing and
/// moving a fresh `N x N` array per product (BENCHMARKS.md "The discretisation's series
/// without temporaries").
pub fn mul_into<T: Real, const N: usize>(
    c: &mut Arr<T, N>,
    a: &Arr<T, N>,
    b: &Arr<T, N>,
    n: usize,
) {
    for (ci, ai) in head_mut(c, n).iter_mut().zip(head(a, n)) {
        for v in head_mut(ci, n).iter_mut() {
            *v = T::zero();
        }
        for (aik, bk) in head(ai, n).iter().zip(head(b, n)) {
            if *aik != T::zero() {
                axpy(ci, *aik, bk, n);
            }
        }
    }
}

/// Up to this many active states [`row_pattern`] gives `None`: on the one-channel model (4-8
/// states) the pattern's walk cost the Cortex-M4 more than the zero tests it saves (its worst
/// re-identification tick 387 920 instructions without the pattern, 391 920 with it; QEMU
/// icount).
pub const PATTERN_MIN: usize = 8;

/// The non-zero pattern of `a`'s leading `n x n` block, a bit mask per row (bit `k` of row `i`
/// set when `a[i][k] != 0`, NaN included), for [`mul_pattern_into`]; `None` when `N > 64`,
/// and for blocks of at most [`PATTERN_MIN`] states, where the plain product is cheaper.
/// Built once for a factor that multiplies many times (the discretisation's series: 10-15
/// products by the same sparse `A`), it replaces a test per entry per product, a branch on an
/// irregular pattern that was the series' largest cost (perf; BENCHMARKS.md "CI time: bit-exact
/// kernels"). Building it inside every product was measured no faster (session 62).
pub fn row_pattern<T: Real, const N: usize>(a: &Arr<T, N>, n: usize) -> Option<[u64; N]> {
    if N > 64 || n <= PATTERN_MIN {
        return None;
    }
    let mut rows = [0u64; N];
    for (mask, ai) in rows.iter_mut().zip(head(a, n)) {
        for (k, v) in head(ai, n).iter().enumerate() {
            *mask |= u64::from(*v != T::zero()).wrapping_shl(k as u32);
        }
    }
    Some(rows)
}

/// [`mul_into`] with `a`'s non-zero pattern given ([`row_pattern`] of the same `a` and `n`):
/// the same products in the same order, so the same bits; without a pattern, [`mul_into`].
pub fn mul_pattern_into<T: Real, const N: usize>(
    c: &mut Arr<T, N>,
    a: &Arr<T, N>,
    pattern: Option<&[u64; N]>,
    b: &Arr<T, N>,
    n: usize,
) {
    let Some(rows) = pattern else {
        mul_into(c, a, b, n);
        return;
    };
    let b = head(b, n);
    for ((ci, ai), mask) in head_mut(c, n).iter_mut().zip(head(a, n)).zip(rows) {
        for v in head_mut(ci, n).iter_mut() {
            *v = T::zero();
        }
        let mut mask = *mask;
        while mask != 0 {
            let k = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            if let (Some(aik), Some(bk)) = (ai.get(k), b.get(k)) {
                axpy(ci, *aik, bk, n);
            }
        }
    }
}

/// `out = a b^T + d` over the leading block, upper half computed and mirrored (the result is
/// symmetric when `a b^T` is, as in `(Phi P) Phi^T`). Entries outside the block are untouched.
pub fn mul_t_sym_into<T: Real, const N: usize>(
    out: &mut Arr<T, N>,
    a: &Arr<T, N>,
    b: &Arr<T, N>,
    d: &Arr<T, N>,
    n: usize,
) {
    let n = n.min(N);
    for i in 0..n {
        for j in i..n {
            let v = dot(&a[i], &b[j], n) + d[i][j];
            out[i][j] = v;
            out[j][i] = v;
        }
    }
}

/// `a b^T + d` over the leading block (see [`mul_t_sym_into`]), zero elsewhere.
pub fn mul_t_sym<T: Real, const N: usize>(
    a: &Arr<T, N>,
    b: &Arr<T, N>,
    d: &Arr<T, N>,
    n: usize,
) -> Arr<T, N> {
    let mut c = zeros();
    mul_t_sym_into(&mut c, a, b, d, n);
    c
}

/// Dot product of the first `K` entries, `K` a compile-time constant. Unrolled by hand in
/// blocks of four: the release profile optimises for size (`opt-level = "s"`), which does not
/// unroll, and a rolled loop costs ~6 instructions per multiply-add against ~2.5 here
/// (callgrind). With `K = 4` the block loop runs once and disappears.
#[inline(always)]
pub(crate) fn dot_c<T: Real, const K: usize, const A: usize, const B: usize>(
    a: &[T; A],
    b: &[T; B],
) -> T {
    let n = K.min(A).min(B);
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

/// The leading `n x n` block of `a` transposed into `t` (the rest of `t` untouched).
pub fn transpose_into<T: Real, const N: usize>(t: &mut Arr<T, N>, a: &Arr<T, N>, n: usize) {
    for (i, row) in head(a, n).iter().enumerate() {
        for (j, v) in head(row, n).iter().enumerate() {
            if let Some(x) = t.get_mut(j).and_then(|r| r.get_mut(i)) {
                *x = *v;
            }
        }
    }
}

/// `A^T`.
pub fn transpose<T: Real, const N: usize>(a: &Arr<T, N>) -> Arr<T, N> {
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
    use nalgebra::SMatrix;

    #[test]
    fn kernels_match_nalgebra() {
        let a = SMatrix::<f64, 8, 8>::from_fn(|i, j| ((i * 3 + j * 7) % 5) as f64 - 2.0);
        let b = SMatrix::<f64, 8, 8>::from_fn(|i, j| ((i * 5 + j) % 7) as f64 * 0.5);
        let n = 5;
        let c = mul(&from_mat(&a), &from_mat(&b), n);
        let p = a.fixed_view::<5, 5>(0, 0) * b.fixed_view::<5, 5>(0, 0);
        for i in 0..n {
            for j in 0..n {
                assert!((c[i][j] - p[(i, j)]).abs() < 1e-12);
            }
        }
        let s = from_mat(&(a * a.transpose()));
        let q = mul_t_sym(&from_mat(&a), &from_mat(&a), &zeros(), 8);
        assert_eq!(to_mat(&q), to_mat(&s));
        assert_eq!(transpose(&from_mat(&a)), from_mat(&a.transpose()));
    }

    /// The product through the row pattern is the zero-testing product, bit for bit, at every
    /// active size, on sparse factors with entries of both signs, NaN and infinities included.
    #[test]
    fn the_pattern_product_is_the_plain_product() {
        use rand::{Rng, SeedableRng};
        const N: usize = 24;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(66_002);
        let entry = |rng: &mut rand_chacha::ChaCha8Rng, zeros: f64| -> f64 {
            match rng.gen_range(0.0..1.0) {
                u if u < zeros => 0.0,
                u if u < zeros + 0.01 => f64::NAN,
                u if u < zeros + 0.02 => f64::NEG_INFINITY,
                _ => rng.gen_range(-1e3..1e3),
            }
        };
        for n in 0..=N {
            let mut a = zeros::<f64, N>();
            let mut b = zeros::<f64, N>();
            for i in 0..n {
                for j in 0..n {
                    a[i][j] = entry(&mut rng, 0.8);
                    b[i][j] = entry(&mut rng, 0.1);
                }
            }
            let pattern = row_pattern(&a, n);
            assert_eq!(pattern.is_some(), n > PATTERN_MIN);
            let (mut want, mut got) = ([[7.0; N]; N], [[7.0; N]; N]);
            mul_into(&mut want, &a, &b, n);
            mul_pattern_into(&mut got, &a, pattern.as_ref(), &b, n);
            for (w, g) in want.iter().zip(got.iter()) {
                let bits = |r: &[f64; N]| r.map(f64::to_bits);
                assert_eq!(bits(w), bits(g), "n = {n}");
            }
        }
    }
}
