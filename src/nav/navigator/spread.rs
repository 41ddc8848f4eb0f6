//! The navigation errors' standard deviations ahead of the filter: the covariance the filter
//! holds at its last propagation, carried to a later time (the newest sample of a live run,
//! whose solution the output predictor gives, [`crate::nav::predictor`]).
//!
//! The filter is propagated at its steps (1 Hz) and at the fixes; between them the solution
//! moves on at the IMU rate and its uncertainty with it. A consumer of the solution at the
//! newest sample needs that uncertainty, not the filter's of up to a step (and the latency
//! budget) ago. A full discretisation per request would cost as much as a filter step (about
//! 0.32M instructions on the M4 at 15 states, BENCHMARKS.md), ten times a second; over at most
//! a step and a budget the transition is its second-order series instead, and only the nine
//! navigation rows are carried:
//!
//! `Phi(s) ~ I + A s + A^2 s^2 / 2`, so row `i` is `m(s) = e_i + a s + b s^2 / 2` with `a` the
//! row `i` of `A` and `b` that of `A^2`, and
//!
//! `var_i(dt) = m(dt)^T P m(dt) + int_0^dt m(s)^T Qc m(s) ds`
//!
//! `= m^T P m + eQe dt + aQe dt^2 + (aQa + bQe) dt^3 / 3 + bQa dt^4 / 4 + bQb dt^5 / 20`
//!
//! (`uQv = u^T Qc v`; the integral is exact for that polynomial `m`). It differs from the
//! exact discretisation (`Phi P Phi^T + int Phi Qc Phi^T`) by the third-order terms of `Phi`,
//! growing as `dt^3`: 5.2e-5 of a standard deviation at 1.25 s on a turning strapdown model
//! (`tests/discretisation.rs`).
//!
//! ```
//! use imu_ident::nav::navigator::spread::carried_variances;
//! // North position error (state 6) driven by the north velocity error (state 3), which a
//! // white acceleration noise of intensity q drives: `dp' = dv`, `dv' = w`.
//! const N: usize = 9;
//! let (q, dt) = (0.01f64, 0.5f64);
//! let mut a = [[0.0f64; N]; N];
//! a[6][3] = 1.0;
//! let mut qc = [[0.0; N]; N];
//! qc[3][3] = q;
//! let mut p = [[0.0; N]; N];
//! p[3][3] = 0.04; // velocity sd 0.2 m/s
//! p[6][6] = 1.0; // position sd 1 m
//! let var = carried_variances(&a, &qc, &p, N, dt);
//! // Exact for this model: P_pp + dt^2 P_vv + q dt^3 / 3, and P_vv + q dt.
//! assert!((var[6] - (1.0 + dt * dt * 0.04 + q * dt * dt * dt / 3.0)).abs() < 1e-15);
//! assert!((var[3] - (0.04 + q * dt)).abs() < 1e-15);
//! ```

use super::{NavError, NavObserver, Navigator};
use crate::linalg::{axpy, dot, Arr};
use crate::nav::error_model::nav_idx;
use crate::Real;

/// Navigation-error states carried: attitude, velocity and position, three each.
const NAV: usize = nav_idx::SENSOR;

/// Standard deviations of the navigation errors, each NED (the filter's states).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NavSd<T> {
    /// Attitude error `phi` [rad].
    pub att: [T; 3],
    /// Velocity error [m/s].
    pub vel: [T; 3],
    /// Position error [m].
    pub pos: [T; 3],
}

/// `v^T M` over the leading `n` states: the rows of `M` weighted by `v` ([`axpy`]), skipping
/// the zero weights (`v` is a sparse row of `A` or of `A^2` here). For a symmetric `M` (`P`,
/// `Qc`) it is `M v`; for `M = A` and `v` a row of `A`, that row of `A^2`.
fn row_times<T: Real, const N: usize>(v: &[T; N], m: &Arr<T, N>, n: usize) -> [T; N] {
    let mut out = [T::zero(); N];
    for (vk, row) in v.iter().zip(m.iter()).take(n) {
        if *vk != T::zero() {
            axpy(&mut out, *vk, row, n);
        }
    }
    out
}

/// The variances of the first nine states of `x' = A x + w`, `E w w^T = Qc` (white), `dt`
/// after the covariance `P`, over the leading `n` states (module docs: the second-order
/// transition, its noise integrated exactly).
#[allow(non_snake_case)]
pub fn carried_variances<T: Real, const N: usize>(
    A: &Arr<T, N>,
    Qc: &Arr<T, N>,
    P: &Arr<T, N>,
    n: usize,
    dt: T,
) -> [T; NAV] {
    let n = n.min(N);
    let half = T::lit(0.5);
    let (dt2, dt3) = (dt * dt, dt * dt * dt);
    let mut var = [T::zero(); NAV];
    for (i, ((v, a), qc)) in var.iter_mut().zip(A.iter()).zip(Qc.iter()).enumerate() {
        if i >= n {
            break;
        }
        // b = a A: row i of A^2.
        let b = row_times(a, A, n);
        let mut m = [T::zero(); N];
        for ((mk, ak), bk) in m.iter_mut().zip(a.iter()).zip(b.iter()).take(n) {
            *mk = *ak * dt + *bk * dt2 * half;
        }
        if let Some(mi) = m.get_mut(i) {
            *mi += T::one();
        }
        let pm = row_times(&m, P, n);
        let (qa, qb) = (row_times(a, Qc, n), row_times(&b, Qc, n));
        let at = |u: &[T; N]| u.get(i).copied().unwrap_or_else(T::zero);
        let (e_q_e, a_q_e, b_q_e) = (at(qc), at(&qa), at(&qb));
        let (a_q_a, b_q_a, b_q_b) = (dot(a, &qa, n), dot(&b, &qa, n), dot(&b, &qb, n));
        let qd = e_q_e * dt
            + a_q_e * dt2
            + (a_q_a + b_q_e) * dt3 / T::lit(3.0)
            + b_q_a * dt2 * dt2 / T::lit(4.0)
            + b_q_b * dt2 * dt3 / T::lit(20.0);
        *v = dot(&m, &pm, n) + qd;
    }
    var
}

impl<T: Real, const N: usize, O: NavObserver<T, N>> Navigator<T, N, O> {
    /// Standard deviations of the navigation errors at time `t` [s], at or after the
    /// filter's last propagation: its covariance carried by the error model as linearised at
    /// its last step (module docs). At the filter's own time, the square roots of its
    /// diagonal ([`sigma_si`](Self::sigma_si)). [`NavError::BadTime`] for a `t` before the
    /// filter's time or not finite.
    ///
    /// Never inlined: its `A` and `Qc` (two `N x N` arrays, 4.6 KB in `f32` at `N = 24`)
    /// then occupy the stack only during the call; inlined into a firmware's loop, they
    /// stayed in the loop's frame beneath every other call, and the emulated board's deepest
    /// stack grew by 4.9 KB.
    #[allow(non_snake_case)]
    #[inline(never)]
    pub fn sd_at(&self, t: f64) -> Result<NavSd<T>, NavError> {
        let dt = t - self.t_kf;
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(NavError::BadTime);
        }
        let mut A = [[T::zero(); N]; N];
        let mut Qc = [[T::zero(); N]; N];
        let n = self.model.dynamics_into(&self.scale, &mut A, &mut Qc)?;
        let var = carried_variances(&A, &Qc, &self.kf.P, n, T::lit(dt));
        let mut sd = [T::zero(); NAV];
        for ((s, v), k) in sd.iter_mut().zip(var.iter()).zip(self.scale.iter()) {
            *s = v.max(T::zero()).sqrt() * *k;
        }
        let three = |k: usize| [0, 1, 2].map(|j| sd.get(k + j).copied().unwrap_or_else(T::zero));
        Ok(NavSd {
            att: three(nav_idx::ATT),
            vel: three(nav_idx::VEL),
            pos: three(nav_idx::POS),
        })
    }
}
