//! Exact discretisation restricted to the `n` active states.
//!
//! The same algorithm as [`crate::model::discretise`] (scaling and squaring of the Taylor series
//! of `exp(A h)`, and of the Van Loan integral through `C_k = A C_{k-1} + (A C_{k-1})^T`), but
//! every product runs over the leading `n x n` block: `n^3` multiply-adds instead of `NX^3`
//! (64 instead of 512 for the paper model). The bank re-discretises `2p + 1` filters at every
//! parameter move, so this bounds the worst-case step time. Inactive rows and columns of `A`
//! and `Qc` are zero (see [`InsModel`](crate::model::InsModel)), so the block result is exact and
//! the tests check it against the full-size routine.

// Small fixed-size matrix code reads best with explicit indices (they mirror the equations).
#![allow(clippy::needless_range_loop)]

use crate::adapt::mat::{self, Arr};
use crate::model::{InsModel, ModelError, Scaling, StateMat, NX};
use crate::Real;

/// Largest number of halvings (as in the full-size routine).
const MAX_SQUARINGS: u32 = 40;

/// `Phi = exp(A dt)` and `Qd = int_0^dt exp(A s) Qc exp(A^T s) ds` over the leading `n` states,
/// as row-major arrays `(Phi, Qd)` (zero outside the block).
#[allow(non_snake_case)]
pub fn discretise_active<T: Real>(
    A: &StateMat<T>,
    Qc: &StateMat<T>,
    dt: T,
    n: usize,
) -> Result<(Arr<T>, Arr<T>), ModelError> {
    let n = n.min(NX);
    if !(dt.is_finite() && dt > T::zero()) {
        return Err(ModelError::BadDt);
    }
    let a = mat::from_mat(A);
    let qc = mat::from_mat(Qc);
    // Largest absolute column sum of each block (the 1-norm used by the full routine).
    let mut col = [T::zero(); NX];
    let mut qcol = [T::zero(); NX];
    for (ra, rq) in a.iter().zip(qc.iter()).take(n) {
        for (((c, q), x), y) in col.iter_mut().zip(qcol.iter_mut()).zip(ra).zip(rq).take(n) {
            *c += x.abs();
            *q += y.abs();
        }
    }
    let norm = col.iter().fold(T::zero(), |m, v| m.max(*v));
    let qnorm = qcol.iter().fold(T::zero(), |m, v| m.max(*v));
    let mut scaled = norm * dt;
    if !(scaled.is_finite() && qnorm.is_finite()) {
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
    let order = crate::model::discretise::taylor_order::<T>();
    let mut ah = a;
    for row in ah.iter_mut().take(n) {
        for v in row.iter_mut().take(n) {
            *v *= h;
        }
    }
    // Phi_h = I + Ah (I + Ah/2 (I + Ah/3 (...))) (Horner).
    let mut phi = mat::zeros();
    for (i, row) in phi.iter_mut().enumerate().take(n) {
        row[i] = T::one();
    }
    for k in (1..=order).rev() {
        let inv_k = T::one() / T::lit(k as f64);
        let m = mat::mul(&ah, &phi, n);
        for (i, (pr, mr)) in phi.iter_mut().zip(m.iter()).enumerate().take(n) {
            for (j, (p, v)) in pr.iter_mut().zip(mr.iter()).enumerate().take(n) {
                *p = *v * inv_k + if i == j { T::one() } else { T::zero() };
            }
        }
    }
    // Q_h = sum_k C_k h^{k+1} / (k+1)!, C_0 = Qc, C_k = A C_{k-1} + (A C_{k-1})^T.
    let mut c = qc;
    let mut coef = h;
    let mut q = mat::zeros();
    add_scaled(&mut q, &c, coef, n);
    for k in 1..=order {
        let ac = mat::mul(&a, &c, n);
        let act = mat::transpose(&ac);
        for ((cr, ar), tr) in c.iter_mut().zip(ac.iter()).zip(act.iter()).take(n) {
            for ((v, x), y) in cr.iter_mut().zip(ar.iter()).zip(tr.iter()).take(n) {
                *v = *x + *y;
            }
        }
        coef = coef * h / T::lit((k + 1) as f64);
        add_scaled(&mut q, &c, coef, n);
    }
    for _ in 0..s {
        let pq = mat::mul(&phi, &q, n);
        q = mat::mul_t_sym(&pq, &phi, &q, n);
        phi = mat::mul(&phi, &phi, n);
    }
    // Symmetrise (the series is symmetric term by term; this removes rounding asymmetry).
    let qt = mat::transpose(&q);
    for (qr, tr) in q.iter_mut().zip(qt.iter()).take(n) {
        for (v, t) in qr.iter_mut().zip(tr.iter()).take(n) {
            *v = (*v + *t) * T::lit(0.5);
        }
    }
    Ok((phi, q))
}

/// `q += k c` over the leading block.
fn add_scaled<T: Real>(q: &mut Arr<T>, c: &Arr<T>, k: T, n: usize) {
    for (qr, cr) in q.iter_mut().zip(c.iter()).take(n) {
        mat::axpy(qr, k, cr, n);
    }
}

/// `(Phi, Qd)` of `model` in the states scaled by `scale`, over its active states.
pub fn discretise_model<T: Real>(
    model: &InsModel<T>,
    scale: &Scaling<T>,
) -> Result<(Arr<T>, Arr<T>), ModelError> {
    let c = model.continuous(scale)?;
    discretise_active(&c.A, &c.Qc, model.dt, c.n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::InsModel;

    #[test]
    fn matches_the_full_size_routine() {
        let mut m = InsModel::<f64>::paper();
        for tau in [1.0, 100.0, 1e5] {
            if let Some(crate::model::Component::GaussMarkov(g)) = m.accel.get_mut(0) {
                g.tau = tau;
            }
            let s = m.scaling().unwrap();
            let (c, full) = m.discretise(&s).unwrap();
            let (phi, qd) = discretise_active(&c.A, &c.Qc, m.dt, c.n).unwrap();
            for i in 0..c.n {
                for j in 0..c.n {
                    let e = (phi[i][j] - full.Phi[(i, j)]).abs();
                    assert!(e < 1e-12, "Phi {i} {j}: {e}");
                    let e = (qd[i][j] - full.Qd[(i, j)]).abs();
                    assert!(e < 1e-12 * (1.0 + full.Qd[(i, i)].abs()), "Qd {i} {j}: {e}");
                }
            }
        }
    }
}
