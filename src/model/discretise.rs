//! Exact discretisation of `x' = A x + w`, `E[w w^T] = Qc delta(t)`, over one step `dt`:
//!
//! ```text
//! Phi = exp(A dt),     Qd = int_0^dt exp(A s) Qc exp(A^T s) ds      (Van Loan's integral)
//! ```
//!
//! nalgebra's `Matrix::exp` needs `std`, and the firmware re-discretises whenever the
//! identified parameters change, so this is a fixed-size scaling-and-squaring evaluation that
//! needs only `N x N` products (no `2N` Van Loan block matrix), over the leading `n` active
//! states only (`n^3` multiply-adds per product instead of `N^3`; inactive rows and columns of
//! `A` and `Qc` are zero, so the block result is exact):
//!
//! 1. balance: `B = D^-1 A D` with `D = diag(2^e)` small in the 1-norm ([`balance`]); then
//!    choose `h = dt / 2^s` with `x = ||B h||_1 <= 1/4`;
//! 2. Taylor series at `h`: `Phi_h = sum (A h)^k / k!`, and, because the integrand
//!    `F(s) = e^{As} Qc e^{A^T s}` obeys `F' = A F + F A^T`,
//!    `Q_h = sum_k C_k h^{k+1} / (k+1)!` with `C_0 = Qc`, `C_k = A C_{k-1} + (A C_{k-1})^T`;
//! 3. double `s` times: `Q_{2h} = Phi_h Q_h Phi_h^T + Q_h`, `Phi_{2h} = Phi_h^2`.
//!
//! Why balance: an error-state `A` mixes units and rates. In the strapdown model the
//! specific force couples attitude into velocity (9.8 m/s^2 per rad) and `1/R` couples back
//! (1.6e-7 per s), so even in the filter's scaled units `||A dt||_1` is about 0.7 at 1 s: two
//! squarings and 14 dense terms. Balanced, the pair meets near the Schuler frequency and
//! `||B dt||` is set by the fastest noise state: the moving 18-state model of the tests needs
//! no squaring, 10 terms for `Phi` and 15 for `Q`, each a sparse product ([`mul`] skips `A`'s
//! zeros). Because `D` holds powers of two, the series on `A h` is the series on `B h` scaled
//! back, bit for bit; `D` only enters the bound on the remainder. That bound is taken in `B`'s
//! coordinates and carried back with the spread `max d / min d` of `D` (its square for `Q`),
//! and [`series_order`] picks the smallest number of terms that puts it below the working
//! precision's epsilon. The result is checked against an independent 2N Van Loan exponential
//! and a 1 ms fine-step reference in the tests (`tests/discretisation.rs`, on the one-channel
//! model and on a moving strapdown model with every component kind).
//!
//! This is the crate's one discretisation: [`discretise_block`] on row-major arrays (the
//! filters' form) and [`discretise`] on nalgebra matrices (all states active) share it.

use crate::linalg::{
    axpy, from_mat, head, mul, mul_pattern_into, mul_t_sym, row_pattern, to_mat, transpose_into,
    zeros, Arr,
};
use crate::model::ModelError;
use crate::Real;
use nalgebra::SMatrix;

/// A discrete-time transition and its process-noise covariance.
#[allow(non_snake_case)]
#[derive(Debug, Clone, PartialEq)]
pub struct Discrete<T: Real, const N: usize> {
    /// Transition matrix `Phi = exp(A dt)`.
    pub Phi: SMatrix<T, N, N>,
    /// Process-noise covariance `Qd`.
    pub Qd: SMatrix<T, N, N>,
}

/// Largest number of halvings (`2^40` covers `||B dt||` up to 2.7e11).
const MAX_SQUARINGS: u32 = 40;

/// The balancing exponents stay within `[-BAL_E, BAL_E]`, so the spread `kappa` of `D` is at
/// most `2^(2 BAL_E)`; a source or a sink state (no off-diagonal row or column) goes to a bound.
const BAL_E: i32 = 16;

/// Balancing sweeps (each `O(n^2)`); they stop early once no exponent changes. On the moving
/// strapdown model of the tests the third settles the exponents; more terms cover a partial
/// balance, since the remainder bound uses whatever `D` is reached.
const BAL_SWEEPS: usize = 4;

/// Largest Taylor order: [`series_order`] needs at most 26 at `x = 1/4` with the largest
/// spread in f64.
const MAX_ORDER: usize = 40;

/// Smallest order `K` whose remainder is below `eps` after the spread: with `x <= 1/2` the
/// tail `sum_{k > K} x^k / c_k` (`c_k = k!` for `Phi`, `(k + 1)!` for `Q`) is below twice its
/// first term, and an error `r` of the balanced series is at most `spread r` in the original
/// coordinates (entry `(i, j)` scales by `d_i / d_j` for `Phi`, by `d_i d_j / min d^2` for `Q`).
fn series_order<T: Real>(x: T, spread: T, q_series: bool) -> usize {
    let eps = T::lit(T::EPS);
    let mut term = T::one();
    // The divisor k (Phi) or k + 1 (Q), counted in T: an integer-to-float conversion through
    // `f64` is software on the MCU. Small integers are exact, so the bits are those of
    // `T::lit(k as f64)`.
    let mut div = if q_series { T::one() } else { T::zero() };
    for k in 1..=MAX_ORDER {
        div += T::one();
        // The first omitted term after order k - 1 is x^k / k! (Phi) or x^k / (k + 1)! (Q).
        term *= x / div;
        if T::lit(2.0) * spread * term <= eps {
            return k - 1;
        }
    }
    MAX_ORDER
}

/// The power-of-two diagonal `D` of [`balance`]: `d = 2^e`, its inverse, and its spread
/// `max d / min d`.
struct Balanced<T: Real, const N: usize> {
    d: [T; N],
    inv: [T; N],
    spread: T,
}

/// Power-of-two scales `D = diag(2^e)` that make `B = D^-1 A D` small in the 1-norm: the
/// Parlett-Reinsch iteration (LAPACK's `gebal`) on the off-diagonal row and column sums of the
/// leading `n` states, each step taken only if it lowers the pair's sum by
/// 5 %. Powers of two make `B` exact, so the series on `A h` is, bit for bit, the series on
/// `B h` scaled back: only the bound on the remainder uses `D`.
#[allow(non_snake_case)]
fn balance<T: Real, const N: usize>(A: &Arr<T, N>, n: usize) -> Balanced<T, N> {
    let n = n.min(N);
    let mut e = [0i32; N];
    // d = 2^e and its inverse, in the working precision: on the MCU's single-precision FPU
    // `f64` arithmetic is software. The exponents come from `Real::binary_exponent` and
    // `Real::pow2` (`frexpf`/`ldexpf` in f32: bit operations), not from `log2` and `exp2`.
    let mut d = [T::one(); N];
    let mut inv = [T::one(); N];
    for _ in 0..BAL_SWEEPS {
        let mut changed = false;
        for (i, ra) in A.iter().enumerate().take(n) {
            let di = d.get(i).copied().unwrap_or_else(T::one);
            let ii = inv.get(i).copied().unwrap_or_else(T::one);
            // Row: B_ij = A_ij d_j / d_i; column: B_ji = A_ji d_i / d_j (j != i). Each sum
            // in the order j = 0, 1, ..., n - 1, over j < i and then j > i: no branch on
            // `j == i` in the loop (BENCHMARKS.md "CI time: bit-exact kernels").
            let mut r = T::zero();
            let mut c = T::zero();
            let row = head(ra, n);
            let (rows, ds, invs) = (head(A, n), head(&d, n), head(&inv, n));
            for (aij, dj) in row.iter().zip(ds).take(i) {
                r += aij.abs() * *dj;
            }
            for (aij, dj) in row.iter().zip(ds).skip(i + 1) {
                r += aij.abs() * *dj;
            }
            for (rj, ij) in rows.iter().zip(invs).take(i) {
                c += rj.get(i).map_or(T::zero(), |v| v.abs()) * *ij;
            }
            for (rj, ij) in rows.iter().zip(invs).skip(i + 1) {
                c += rj.get(i).map_or(T::zero(), |v| v.abs()) * *ij;
            }
            let (r, c) = (r * ii, c * di);
            let ei = e.get(i).copied().unwrap_or(0);
            let k = if c == T::zero() && r == T::zero() {
                0
            } else if c == T::zero() {
                BAL_E - ei
            } else if r == T::zero() {
                -BAL_E - ei
            } else {
                // d_i 2^k scales c by 2^k and r by 2^-k: balanced when 4^k = r / c, that is
                // k = log2(r / c) / 2, here within one binade (r / c = m 2^x, m in [1/2, 1)).
                let x = (r / c).binary_exponent();
                let k = ei.saturating_add(x.div_euclid(2)).clamp(-BAL_E, BAL_E) - ei;
                let f = T::pow2(k);
                if c * f + r / f < T::lit(0.95) * (c + r) {
                    k
                } else {
                    0
                }
            };
            if k != 0 {
                changed = true;
                if let (Some(ei), Some(di), Some(ii)) = (e.get_mut(i), d.get_mut(i), inv.get_mut(i))
                {
                    *ei += k;
                    *di = T::pow2(*ei);
                    *ii = T::pow2(-*ei);
                }
            }
        }
        if !changed {
            break;
        }
    }
    let (lo, hi) = e
        .iter()
        .take(n)
        .fold((0i32, 0i32), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    Balanced {
        d,
        inv,
        spread: T::pow2(hi - lo),
    }
}

/// Exact `(Phi, Qd)` of the continuous system `(A, Qc)` over `dt`, all `N` states active.
#[allow(non_snake_case)]
pub fn discretise<T: Real, const N: usize>(
    A: &SMatrix<T, N, N>,
    Qc: &SMatrix<T, N, N>,
    dt: T,
) -> Result<Discrete<T, N>, ModelError> {
    let (phi, qd) = discretise_block(&from_mat(A), &from_mat(Qc), dt, N)?;
    Ok(Discrete {
        Phi: to_mat(&phi),
        Qd: to_mat(&qd),
    })
}

/// `Phi = exp(A dt)` and `Qd = int_0^dt exp(A s) Qc exp(A^T s) ds` over the leading `n` states,
/// as row-major arrays `(Phi, Qd)` (zero outside the block).
#[allow(non_snake_case)]
pub fn discretise_block<T: Real, const N: usize>(
    A: &Arr<T, N>,
    Qc: &Arr<T, N>,
    dt: T,
    n: usize,
) -> Result<(Arr<T, N>, Arr<T, N>), ModelError> {
    let e = Expm::new(A, dt, n)?;
    e.discretise(A, Qc)
}

/// [`discretise_block`] into the caller's `phi` and `q` ([`Expm::discretise_into`]).
#[allow(non_snake_case)]
pub fn discretise_block_into<T: Real, const N: usize>(
    A: &Arr<T, N>,
    Qc: &Arr<T, N>,
    dt: T,
    n: usize,
    phi: &mut Arr<T, N>,
    q: &mut Arr<T, N>,
) -> Result<(), ModelError> {
    Expm::new(A, dt, n)?.discretise_into(A, Qc, phi, q)
}

/// The part of the discretisation that depends on `A` and `dt` only (steps 1 and 2's
/// `Phi_h`): several noise intensities `Qc` over one `A` share it
/// ([`discretise`](Self::discretise) for each), and `Qd` is linear in `Qc`, so the
/// identification's shadow filters that differ only in an intensity share their `Phi` and
/// add a multiple of one `Qd` (`nav::online`).
#[derive(Debug, Clone)]
pub struct Expm<T: Real, const N: usize> {
    /// `Phi_h = exp(A h)` by the Taylor series.
    phi_h: Arr<T, N>,
    /// `h = dt / 2^s`.
    h: T,
    s: u32,
    n: usize,
    /// Terms of the `Phi_h` and `Q_h` series.
    order: usize,
    q_order: usize,
}

impl<T: Real, const N: usize> Expm<T, N> {
    /// Steps 1 and 2 (`Phi_h`) for `A` over `dt`, the leading `n` states.
    #[allow(non_snake_case)]
    pub fn new(A: &Arr<T, N>, dt: T, n: usize) -> Result<Self, ModelError> {
        let n = n.min(N);
        if !(dt.is_finite() && dt > T::zero()) {
            return Err(ModelError::BadDt);
        }
        if !A.iter().take(n).flatten().all(|v| v.is_finite()) {
            return Err(ModelError::NonFinite);
        }
        let Balanced { d, inv, spread } = balance(A, n);
        // Largest absolute column sum (the 1-norm) of the balanced B = D^-1 A D.
        let mut col = [T::zero(); N];
        for (ra, ii) in A.iter().zip(inv.iter()).take(n) {
            for ((c, x), dj) in col.iter_mut().zip(ra).zip(d.iter()).take(n) {
                *c += x.abs() * *dj * *ii;
            }
        }
        let norm = col.iter().fold(T::zero(), |m, v| m.max(*v));
        let mut scaled = norm * dt;
        if !scaled.is_finite() {
            return Err(ModelError::NonFinite);
        }
        let mut s = 0u32;
        while scaled > T::lit(0.25) {
            if s >= MAX_SQUARINGS {
                return Err(ModelError::NonFinite);
            }
            scaled *= T::lit(0.5);
            s += 1;
        }
        let h = dt / T::pow2(s as i32);
        let order = series_order(scaled, spread, false);
        // ||C_k|| <= (2 ||B h||)^k ||Qc|| / h^k, and Qd's entries scale by d_i d_j: the spread
        // of D^2.
        let q_order = series_order(T::lit(2.0) * scaled, spread * spread, true);
        let mut ah = *A;
        for row in ah.iter_mut().take(n) {
            for v in row.iter_mut().take(n) {
                *v *= h;
            }
        }
        // Phi_h = I + Ah (I + Ah/2 (I + Ah/3 (...))) (Horner).
        let mut phi = zeros();
        for (i, row) in phi.iter_mut().enumerate().take(n) {
            row[i] = T::one();
        }
        // k counted down in T (see `series_order`).
        let mut kk = T::lit(order as f64);
        // One product buffer for the whole series (`mul_into`), and `A h`'s non-zero pattern
        // found once for all its products.
        let mut m = zeros();
        let pattern = row_pattern(&ah, n);
        for _ in 0..order {
            let inv_k = T::one() / kk;
            kk -= T::one();
            mul_pattern_into(&mut m, &ah, pattern.as_ref(), &phi, n);
            // Scale, then add the identity: a branch on `i == j` inside the row loop kept it
            // from vectorising (a third of this function's time, perf).
            for (i, (pr, mr)) in phi.iter_mut().zip(m.iter()).enumerate().take(n) {
                for (p, v) in pr.iter_mut().zip(mr.iter()).take(n) {
                    *p = *v * inv_k;
                }
                if let Some(p) = pr.get_mut(i) {
                    *p += T::one();
                }
            }
        }
        Ok(Self {
            phi_h: phi,
            h,
            s,
            n,
            order,
            q_order,
        })
    }

    /// Number of squarings `s` (`h = dt / 2^s`; at most 40).
    pub fn squarings(&self) -> u32 {
        self.s
    }

    /// Orders of the `Phi_h` and `Q_h` Taylor series.
    pub fn orders(&self) -> (usize, usize) {
        (self.order, self.q_order)
    }

    /// `(Phi, Qd)` of `(A, Qc)` over the step, `A` the one given to [`new`](Self::new)
    /// (steps 2's `Q_h` and 3).
    #[allow(non_snake_case)]
    pub fn discretise(
        &self,
        A: &Arr<T, N>,
        Qc: &Arr<T, N>,
    ) -> Result<(Arr<T, N>, Arr<T, N>), ModelError> {
        let (mut phi, mut q) = (zeros(), zeros());
        self.discretise_into(A, Qc, &mut phi, &mut q)?;
        Ok((phi, q))
    }

    /// [`discretise`](Self::discretise) into the caller's `phi` and `q` (every entry written;
    /// untouched on error): the firmware's filter step keeps its `N x N` arrays in place
    /// instead of moving them through return values (BENCHMARKS.md "The filter step in
    /// place").
    #[allow(non_snake_case)]
    pub fn discretise_into(
        &self,
        A: &Arr<T, N>,
        Qc: &Arr<T, N>,
        phi: &mut Arr<T, N>,
        q: &mut Arr<T, N>,
    ) -> Result<(), ModelError> {
        let (n, h) = (self.n, self.h);
        let mut qcol = [T::zero(); N];
        for rq in Qc.iter().take(n) {
            for (q, y) in qcol.iter_mut().zip(rq).take(n) {
                *q += y.abs();
            }
        }
        if !qcol.iter().fold(T::zero(), |m, v| m.max(*v)).is_finite() {
            return Err(ModelError::NonFinite);
        }
        let order = self.q_order;
        *phi = self.phi_h;
        // Q_h = sum_k C_k h^{k+1} / (k+1)!, C_0 = Qc, C_k = A C_{k-1} + (A C_{k-1})^T.
        let mut c = *Qc;
        let mut coef = h;
        for row in q.iter_mut() {
            row.fill(T::zero());
        }
        for (qr, cr) in q.iter_mut().zip(c.iter()).take(n) {
            axpy(qr, coef, cr, n);
        }
        // k + 1 counted in T (see `series_order`).
        let mut k1 = T::one();
        // `A C_{k-1}` and its transpose, one buffer each for the whole series (`mul_into`).
        let (mut ac, mut act) = (zeros(), zeros());
        let pattern = row_pattern(A, n);
        for _ in 1..=order {
            mul_pattern_into(&mut ac, A, pattern.as_ref(), &c, n);
            transpose_into(&mut act, &ac, n);
            k1 += T::one();
            coef = coef * h / k1;
            // C_k = A C + (A C)^T, and Q_h += coef C_k, in one pass over the rows.
            for ((cr, qr), (ar, tr)) in c
                .iter_mut()
                .zip(q.iter_mut())
                .zip(ac.iter().zip(act.iter()))
                .take(n)
            {
                for ((v, qv), (x, y)) in cr
                    .iter_mut()
                    .zip(qr.iter_mut())
                    .zip(ar.iter().zip(tr.iter()))
                    .take(n)
                {
                    *v = *x + *y;
                    *qv += coef * *v;
                }
            }
        }
        for _ in 0..self.s {
            let pq = mul(phi, q, n);
            *q = mul_t_sym(&pq, phi, q, n);
            *phi = mul(phi, phi, n);
        }
        // Symmetrise (the series is symmetric term by term; this removes rounding asymmetry),
        // the transpose in the series' buffer.
        transpose_into(&mut act, q, n);
        for (qr, tr) in q.iter_mut().zip(act.iter()).take(n) {
            for (v, t) in qr.iter_mut().zip(tr.iter()).take(n) {
                *v = (*v + *t) * T::lit(0.5);
            }
        }
        Ok(())
    }
}
