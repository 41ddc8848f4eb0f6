//! Fixed-size Kalman filter for a scalar observation: predict, Joseph-form update, NIS, health.
//!
//! The INS error model is linear, so the "extended" filter's Jacobians are the model matrices
//! themselves; the filter takes `Phi`, `Qd`, `H` and `R` as arguments (adskalman-style: models
//! are small types, the filter composes them).
//!
//! ```
//! use imu_ident::filter::{Ekf, UpdateStatus};
//! use imu_ident::model::{StateMat, StateRow, StateVec};
//! let mut p0 = StateMat::<f64>::zeros();
//! p0[(0, 0)] = 4.0;
//! let mut ekf = Ekf::new(StateVec::zeros(), p0, 1);
//! let mut h = StateRow::zeros();
//! h[0] = 1.0;
//! let out = ekf.update(1.0, &h, 1.0, None);
//! assert_eq!(out.status, UpdateStatus::Updated);
//! assert!((ekf.x[0] - 0.8).abs() < 1e-12); // K = 4 / (4 + 1)
//! assert!((ekf.P[(0, 0)] - 0.8).abs() < 1e-12);
//! // A NaN observation is a missing one: nothing changes.
//! assert_eq!(ekf.update(f64::NAN, &h, 1.0, None).status, UpdateStatus::Missing);
//! ```

use crate::model::{At, StateMat, StateRow, StateVec, NX};
use crate::Real;

/// What happened to one observation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum UpdateStatus {
    /// The observation was used.
    Updated,
    /// The observation was NaN or infinite: treated as missing.
    Missing,
    /// The innovation failed the chi-square gate and was not used.
    Gated,
    /// The innovation variance was not positive and finite: the update was skipped.
    BadInnovationVariance,
}

/// The innovation statistics of one observation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Innovation<T> {
    /// `nu = z - H x` (NaN when the observation is missing).
    pub innovation: T,
    /// `S = H P H^T + R`.
    pub variance: T,
    /// Normalised innovation squared `nu^2 / S` (NaN when missing).
    pub nis: T,
    /// What was done with it.
    pub status: UpdateStatus,
}

/// A Kalman filter over [`NX`] states of which the first `n` are active.
#[allow(non_snake_case)]
#[derive(Debug, Clone, PartialEq)]
pub struct Ekf<T: Real> {
    /// State estimate.
    pub x: StateVec<T>,
    /// Covariance of the estimation error.
    pub P: StateMat<T>,
    n: usize,
}

impl<T: Real> Ekf<T> {
    /// A filter with initial estimate `x0`, covariance `p0` and `n` active states (clamped to
    /// [`NX`]); inactive rows and columns are zeroed.
    pub fn new(x0: StateVec<T>, p0: StateMat<T>, n: usize) -> Self {
        let mut f = Self {
            x: x0,
            P: p0,
            n: n.min(NX),
        };
        f.zero_inactive();
        f
    }

    /// Number of active states.
    pub fn active(&self) -> usize {
        self.n
    }

    fn zero_inactive(&mut self) {
        for i in self.n..NX {
            self.x[i] = T::zero();
            for j in 0..NX {
                self.P[(i, j)] = T::zero();
                self.P[(j, i)] = T::zero();
            }
        }
    }

    /// Time update: `x = Phi x`, `P = Phi P Phi^T + Qd`, symmetric by construction.
    ///
    /// Only the leading `n x n` active block is computed (inactive states are decoupled and
    /// carry zero covariance), so the cost is `n^2 + 1.5 n^3` multiply-adds instead of
    /// `2 NX^3`: 4 active states of 8 cost 112 instead of 1024.
    #[allow(non_snake_case)]
    pub fn predict(&mut self, Phi: &StateMat<T>, Qd: &StateMat<T>) {
        let n = self.n.min(NX);
        let mut x = StateVec::<T>::zeros();
        for i in 0..n {
            let mut s = T::zero();
            for k in 0..n {
                s += Phi.at(i, k) * self.x.el(k);
            }
            x.set_el(i, s);
        }
        self.x = x;
        // M = Phi P (n x n), then P' = M Phi^T + Qd, computing the upper triangle and mirroring.
        let mut m = StateMat::<T>::zeros();
        for i in 0..n {
            for j in 0..n {
                let mut s = T::zero();
                for k in 0..n {
                    s += Phi.at(i, k) * self.P.at(k, j);
                }
                m.set_at(i, j, s);
            }
        }
        for i in 0..n {
            for j in i..n {
                let mut s = Qd.at(i, j);
                for k in 0..n {
                    s += m.at(i, k) * Phi.at(j, k);
                }
                self.P.set_at(i, j, s);
                self.P.set_at(j, i, s);
            }
        }
    }

    /// Measurement update for `z = H x + v`, `v ~ N(0, R)`.
    ///
    /// A non-finite `z` is a missing observation. With `gate = Some(g)`, an innovation whose
    /// NIS exceeds `g` is rejected (chi-square test with one degree of freedom).
    ///
    /// The covariance update is Joseph's form `P = (I - K H) P (I - K H)^T + K R K^T`, expanded
    /// for a scalar observation as `P - K a^T - a K^T + S K K^T` with `a = P H^T`: O(NX^2)
    /// instead of O(NX^3), and still symmetric and positive semi-definite for any gain `K`.
    #[allow(non_snake_case)]
    pub fn update(&mut self, z: T, H: &StateRow<T>, R: T, gate: Option<T>) -> Innovation<T> {
        let n = self.n.min(NX);
        let mut a = StateVec::<T>::zeros();
        for i in 0..n {
            let mut s = T::zero();
            for k in 0..n {
                s += self.P.at(i, k) * H.el(k);
            }
            a.set_el(i, s);
        }
        let mut hx = T::zero();
        let mut hph = T::zero();
        for k in 0..n {
            hx += H.el(k) * self.x.el(k);
            hph += H.el(k) * a.el(k);
        }
        let S = hph + R;
        let nan = T::lit(f64::NAN);
        if !z.is_finite() {
            return Innovation {
                innovation: nan,
                variance: S,
                nis: nan,
                status: UpdateStatus::Missing,
            };
        }
        let nu = z - hx;
        if !(S.is_finite() && S > T::zero()) {
            let status = UpdateStatus::BadInnovationVariance;
            return Innovation {
                innovation: nu,
                variance: S,
                nis: nan,
                status,
            };
        }
        let nis = nu * nu / S;
        if let Some(g) = gate {
            // A NaN NIS or gate fails the test too: only a NIS within the gate passes.
            let within = nis <= g;
            if !within {
                return Innovation {
                    innovation: nu,
                    variance: S,
                    nis,
                    status: UpdateStatus::Gated,
                };
            }
        }
        let K = a / S;
        for i in 0..n {
            self.x.set_el(i, self.x.el(i) + K.el(i) * nu);
            for j in i..n {
                // Joseph, expanded: P - K a^T - a K^T + S K K^T (symmetric by construction).
                let p =
                    self.P.at(i, j) - K.el(i) * a.el(j) - a.el(i) * K.el(j) + S * K.el(i) * K.el(j);
                self.P.set_at(i, j, p);
                self.P.set_at(j, i, p);
            }
        }
        Innovation {
            innovation: nu,
            variance: S,
            nis,
            status: UpdateStatus::Updated,
        }
    }

    /// True when `x` and `P` are finite and the active block of `P` is positive definite
    /// (checked by an in-place Cholesky factorisation of a copy).
    pub fn is_healthy(&self) -> bool {
        self.x.iter().all(|v| v.is_finite()) && is_positive_definite(&self.P, self.n)
    }

    /// Restores a usable covariance after numerical trouble: the estimate is kept if finite
    /// (else zeroed) and `P` is replaced by `fallback`. Returns true if a repair was needed.
    pub fn repair(&mut self, fallback: &StateMat<T>) -> bool {
        if self.is_healthy() {
            return false;
        }
        if !self.x.iter().all(|v| v.is_finite()) {
            self.x = StateVec::zeros();
        }
        self.P = *fallback;
        self.zero_inactive();
        true
    }
}

/// Cholesky test of the leading `n x n` block: true when every pivot is finite and positive.
pub fn is_positive_definite<T: Real>(p: &StateMat<T>, n: usize) -> bool {
    let n = n.min(NX);
    let mut l = StateMat::<T>::zeros();
    for j in 0..n {
        let mut d = p.at(j, j);
        for k in 0..j {
            d -= l.at(j, k) * l.at(j, k);
        }
        if !(d.is_finite() && d > T::zero()) {
            return false;
        }
        let djj = d.sqrt();
        l.set_at(j, j, djj);
        for i in (j + 1)..n {
            let mut s = p.at(i, j);
            for k in 0..j {
                s -= l.at(i, k) * l.at(j, k);
            }
            l.set_at(i, j, s / djj);
        }
    }
    (0..n).all(|i| (0..n).all(|j| p.at(i, j).is_finite()))
}
