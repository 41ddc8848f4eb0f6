//! Exact discretisation of `x' = A x + w`, `E[w w^T] = Qc delta(t)`, over one step `dt`:
//!
//! ```text
//! Phi = exp(A dt),     Qd = int_0^dt exp(A s) Qc exp(A^T s) ds      (Van Loan's integral)
//! ```
//!
//! nalgebra's `Matrix::exp` needs `std`, and the firmware re-discretises whenever the
//! identified parameters change, so this is a fixed-size scaling-and-squaring evaluation that
//! needs only `NX x NX` products (no `2NX` Van Loan block matrix):
//!
//! 1. choose `h = dt / 2^s` with `||A h||_1 <= 1/4`;
//! 2. Taylor series at `h`: `Phi_h = sum (A h)^k / k!`, and, because the integrand
//!    `F(s) = e^{As} Qc e^{A^T s}` obeys `F' = A F + F A^T`,
//!    `Q_h = sum_k C_k h^{k+1} / (k+1)!` with `C_0 = Qc`, `C_k = A C_{k-1} + (A C_{k-1})^T`;
//! 3. double `s` times: `Q_{2h} = Phi_h Q_h Phi_h^T + Q_h`, `Phi_{2h} = Phi_h^2`.
//!
//! With `||A h|| <= 1/4` the series terms shrink at least as `(1/2)^k / k!`, so [`taylor_order`]
//! terms put the truncation error below the working precision's epsilon. The result is checked
//! against an independent 2NX Van Loan exponential and a 1 ms fine-step reference in the tests.

use crate::model::ins::{StateMat, NX};
use crate::model::ModelError;
use crate::Real;

/// A discrete-time transition and its process-noise covariance.
#[allow(non_snake_case)]
#[derive(Debug, Clone, PartialEq)]
pub struct Discrete<T: Real> {
    /// Transition matrix `Phi = exp(A dt)`.
    pub Phi: StateMat<T>,
    /// Process-noise covariance `Qd`.
    pub Qd: StateMat<T>,
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

/// Maximum absolute column sum.
fn norm1<T: Real>(m: &StateMat<T>) -> T {
    let mut best = T::zero();
    for j in 0..NX {
        let mut s = T::zero();
        for i in 0..NX {
            s += m[(i, j)].abs();
        }
        best = best.max(s);
    }
    best
}

/// Exact `(Phi, Qd)` of the continuous system `(A, Qc)` over `dt`.
#[allow(non_snake_case)]
pub fn discretise<T: Real>(
    A: &StateMat<T>,
    Qc: &StateMat<T>,
    dt: T,
) -> Result<Discrete<T>, ModelError> {
    if !(dt.is_finite() && dt > T::zero()) {
        return Err(ModelError::BadDt);
    }
    let norm = norm1(A) * dt;
    if !(norm.is_finite() && norm1(Qc).is_finite()) {
        return Err(ModelError::NonFinite);
    }
    let mut s = 0u32;
    let mut scaled = norm;
    while scaled > T::lit(0.25) {
        if s >= MAX_SQUARINGS {
            return Err(ModelError::NonFinite);
        }
        scaled *= T::lit(0.5);
        s += 1;
    }
    let h = dt / T::lit(libm::exp2(s as f64));
    let Ah = A * h;
    let order = taylor_order::<T>();

    // Phi_h by Horner: I + Ah (I + Ah/2 (I + Ah/3 (...))).
    let eye = StateMat::<T>::identity();
    let mut phi = eye;
    for k in (1..=order).rev() {
        phi = eye + (Ah * phi) / T::lit(k as f64);
    }

    // Q_h = sum_k C_k h^{k+1}/(k+1)!, accumulated with coefficient c = h^{k+1}/(k+1)!.
    let mut c_k = *Qc;
    let mut coef = h;
    let mut q = c_k * coef;
    for k in 1..=order {
        let ac = A * c_k;
        c_k = ac + ac.transpose();
        coef = coef * h / T::lit((k + 1) as f64);
        q += c_k * coef;
    }

    for _ in 0..s {
        q = phi * q * phi.transpose() + q;
        phi = phi * phi;
    }
    let q = (q + q.transpose()) * T::lit(0.5);
    Ok(Discrete { Phi: phi, Qd: q })
}
