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
//! 1. choose `h = dt / 2^s` with `||A h||_1 <= 1/4`;
//! 2. Taylor series at `h`: `Phi_h = sum (A h)^k / k!`, and, because the integrand
//!    `F(s) = e^{As} Qc e^{A^T s}` obeys `F' = A F + F A^T`,
//!    `Q_h = sum_k C_k h^{k+1} / (k+1)!` with `C_0 = Qc`, `C_k = A C_{k-1} + (A C_{k-1})^T`;
//! 3. double `s` times: `Q_{2h} = Phi_h Q_h Phi_h^T + Q_h`, `Phi_{2h} = Phi_h^2`.
//!
//! With `||A h|| <= 1/4` the series terms shrink at least as `(1/2)^k / k!`, so [`taylor_order`]
//! terms put the truncation error below the working precision's epsilon. The result is checked
//! against an independent 2N Van Loan exponential and a 1 ms fine-step reference in the tests.
//!
//! This is the crate's one discretisation: [`discretise_block`] on row-major arrays (the
//! filters' form) and [`discretise`] on nalgebra matrices (all states active) share it.

use crate::linalg::{axpy, from_mat, mul, mul_t_sym, to_mat, transpose, zeros, Arr};
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

/// Largest number of halvings (`2^40` covers `||A dt||` up to 2.7e11).
const MAX_SQUARINGS: u32 = 40;

/// Number of Taylor terms needed at `||A h|| <= 1/4`: (1/2)^k/k! < eps gives 8 for f32 and
/// 14 for f64.
pub fn taylor_order<T: Real>() -> usize {
    if T::EPS > 1e-10 {
        8
    } else {
        14
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
}

impl<T: Real, const N: usize> Expm<T, N> {
    /// Steps 1 and 2 (`Phi_h`) for `A` over `dt`, the leading `n` states.
    #[allow(non_snake_case)]
    pub fn new(A: &Arr<T, N>, dt: T, n: usize) -> Result<Self, ModelError> {
        let n = n.min(N);
        if !(dt.is_finite() && dt > T::zero()) {
            return Err(ModelError::BadDt);
        }
        // Largest absolute column sum (the 1-norm).
        let mut col = [T::zero(); N];
        for ra in A.iter().take(n) {
            for (c, x) in col.iter_mut().zip(ra).take(n) {
                *c += x.abs();
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
        let h = dt / T::lit(libm::exp2(f64::from(s)));
        let order = taylor_order::<T>();
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
        for k in (1..=order).rev() {
            let inv_k = T::one() / T::lit(k as f64);
            let m = mul(&ah, &phi, n);
            for (i, (pr, mr)) in phi.iter_mut().zip(m.iter()).enumerate().take(n) {
                for (j, (p, v)) in pr.iter_mut().zip(mr.iter()).enumerate().take(n) {
                    *p = *v * inv_k + if i == j { T::one() } else { T::zero() };
                }
            }
        }
        Ok(Self {
            phi_h: phi,
            h,
            s,
            n,
        })
    }

    /// `(Phi, Qd)` of `(A, Qc)` over the step, `A` the one given to [`new`](Self::new)
    /// (steps 2's `Q_h` and 3).
    #[allow(non_snake_case)]
    pub fn discretise(
        &self,
        A: &Arr<T, N>,
        Qc: &Arr<T, N>,
    ) -> Result<(Arr<T, N>, Arr<T, N>), ModelError> {
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
        let order = taylor_order::<T>();
        let mut phi = self.phi_h;
        // Q_h = sum_k C_k h^{k+1} / (k+1)!, C_0 = Qc, C_k = A C_{k-1} + (A C_{k-1})^T.
        let mut c = *Qc;
        let mut coef = h;
        let mut q = zeros();
        add_scaled(&mut q, &c, coef, n);
        for k in 1..=order {
            let ac = mul(A, &c, n);
            let act = transpose(&ac);
            for ((cr, ar), tr) in c.iter_mut().zip(ac.iter()).zip(act.iter()).take(n) {
                for ((v, x), y) in cr.iter_mut().zip(ar.iter()).zip(tr.iter()).take(n) {
                    *v = *x + *y;
                }
            }
            coef = coef * h / T::lit((k + 1) as f64);
            add_scaled(&mut q, &c, coef, n);
        }
        for _ in 0..self.s {
            let pq = mul(&phi, &q, n);
            q = mul_t_sym(&pq, &phi, &q, n);
            phi = mul(&phi, &phi, n);
        }
        // Symmetrise (the series is symmetric term by term; this removes rounding asymmetry).
        let qt = transpose(&q);
        for (qr, tr) in q.iter_mut().zip(qt.iter()).take(n) {
            for (v, t) in qr.iter_mut().zip(tr.iter()).take(n) {
                *v = (*v + *t) * T::lit(0.5);
            }
        }
        Ok((phi, q))
    }
}

/// `q += k c` over the leading block.
fn add_scaled<T: Real, const N: usize>(q: &mut Arr<T, N>, c: &Arr<T, N>, k: T, n: usize) {
    for (qr, cr) in q.iter_mut().zip(c.iter()).take(n) {
        axpy(qr, k, cr, n);
    }
}
