//! The one Kalman kernel of the crate: predict, Joseph-form scalar update, chi-square gate,
//! health test and repair, over the leading `n` active states of a fixed capacity `N`.
//!
//! Every filter in the crate runs on it: the fixed-model filter ([`ErrorStateFilter`], and
//! [`InsFilter`] on it), the strapdown navigator's, each member of
//! the identification bank and each probe ([`crate::adapt`]). Error models are linear, so the
//! "extended" filter's Jacobians are the model matrices themselves; the kernel takes `Phi`,
//! `Qd`, `h` and `r` as arguments (adskalman-style: models are small types, the filter composes
//! them). Vector observations are fused as sequential scalar updates.
//!
//! ```
//! use imu_ident::filter::{Kalman, UpdateStatus};
//! let mut p0 = [[0.0f64; 4]; 4];
//! p0[0][0] = 4.0;
//! let mut kf = Kalman::<f64, 4>::new(&p0, 1);
//! let h = [1.0, 0.0, 0.0, 0.0];
//! let out = kf.update(1.0, &h, 1.0, None);
//! assert_eq!(out.status, UpdateStatus::Updated);
//! assert!((kf.x[0] - 0.8).abs() < 1e-12); // K = 4 / (4 + 1)
//! assert!((kf.P[0][0] - 0.8).abs() < 1e-12);
//! // A NaN observation is a missing one: nothing changes.
//! assert_eq!(kf.update(f64::NAN, &h, 1.0, None).status, UpdateStatus::Missing);
//! ```
//!
//! [`InsFilter`]: crate::filter::InsFilter
//! [`ErrorStateFilter`]: crate::filter::ErrorStateFilter

// Small fixed-size matrix code reads best with explicit indices (they mirror the equations).
#![allow(clippy::needless_range_loop)]

use crate::linalg::dense::dot_c;
use crate::linalg::{is_positive_definite, to_mat, to_vec, Arr};
use crate::Real;
use nalgebra::{SMatrix, SVector};

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

impl<T: Real> Innovation<T> {
    /// Log-likelihood of the innovation, `-1/2 (ln S + nu^2 / S)` (without `ln 2 pi`).
    pub fn loglik(&self) -> T {
        -T::lit(0.5) * (self.variance.ln() + self.nis)
    }
}

/// A Kalman filter over `N` states of which the first `n` are active. Inactive states are
/// decoupled (zero rows and columns) and carry zero covariance.
#[allow(non_snake_case)]
#[derive(Debug, Clone, PartialEq)]
pub struct Kalman<T: Real, const N: usize> {
    /// State estimate.
    pub x: [T; N],
    /// Covariance of the estimation error (row-major, symmetric).
    pub P: Arr<T, N>,
    n: usize,
}

impl<T: Real, const N: usize> Kalman<T, N> {
    /// All zeros, no active state (a compile-time value for filters built in place).
    pub const BLANK: Self = Self {
        x: [T::ZERO; N],
        P: [[T::ZERO; N]; N],
        n: 0,
    };

    /// A zero estimate with covariance `p0` over `n` active states (clamped to `N`); inactive
    /// rows and columns are zeroed.
    pub fn new(p0: &Arr<T, N>, n: usize) -> Self {
        let mut f = Self::BLANK;
        f.reset(p0, n);
        f
    }

    /// [`new`](Self::new) in place.
    pub fn reset(&mut self, p0: &Arr<T, N>, n: usize) {
        self.n = n.min(N);
        self.x = [T::zero(); N];
        self.P = *p0;
        self.zero_inactive();
    }

    /// Number of active states.
    pub fn active(&self) -> usize {
        self.n
    }

    fn zero_inactive(&mut self) {
        let n = self.n.min(N);
        for (i, row) in self.P.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                if i >= n || j >= n {
                    *v = T::zero();
                }
            }
        }
        for v in self.x.iter_mut().skip(n) {
            *v = T::zero();
        }
    }

    /// The state as an nalgebra vector.
    pub fn state(&self) -> SVector<T, N> {
        to_vec(&self.x)
    }

    /// The covariance as an nalgebra matrix.
    pub fn covariance(&self) -> SMatrix<T, N, N> {
        to_mat(&self.P)
    }

    /// Time update `x = Phi x`, `P = (Phi P) Phi^T + Qd` over the active block.
    ///
    /// Dispatched to a kernel with the active size as a compile-time constant up to 8, so that
    /// the dot products are unrolled (callgrind: ~3x fewer instructions than a run-time loop).
    /// Above 8, to the active size rounded up to a multiple of 4 (12, 16, 20; else `N`): the
    /// same blocks of four in `dot_c` as the `N`-state kernel over `Phi` and `Qd` zero
    /// outside the active block (as the discretisation leaves them), whose further blocks only
    /// add `+-0` to a sum that starts at `+0` and so is never `-0`: the same bits, at
    /// `(20/24)^3` of the work for up to 20 states (BENCHMARKS.md "CI time: bit-exact kernels").
    /// The inactive part of `x` and `P` past that size is left as it is (zero).
    #[allow(non_snake_case)]
    pub fn predict(&mut self, Phi: &Arr<T, N>, Qd: &Arr<T, N>) {
        let (x, p) = (&mut self.x, &mut self.P);
        match self.n {
            0 => {}
            1 => predict_c::<T, 1, N>(x, p, Phi, Qd),
            2 => predict_c::<T, 2, N>(x, p, Phi, Qd),
            3 => predict_c::<T, 3, N>(x, p, Phi, Qd),
            4 => predict_c::<T, 4, N>(x, p, Phi, Qd),
            5 => predict_c::<T, 5, N>(x, p, Phi, Qd),
            6 => predict_c::<T, 6, N>(x, p, Phi, Qd),
            7 => predict_c::<T, 7, N>(x, p, Phi, Qd),
            8 => predict_c::<T, 8, N>(x, p, Phi, Qd),
            9..=12 if 12 < N => predict_c::<T, 12, N>(x, p, Phi, Qd),
            13..=16 if 16 < N => predict_c::<T, 16, N>(x, p, Phi, Qd),
            17..=20 if 20 < N => predict_c::<T, 20, N>(x, p, Phi, Qd),
            _ => predict_c::<T, N, N>(x, p, Phi, Qd),
        }
    }

    /// `(nu, S)` of observation `z = h x + v`, `v ~ N(0, r)`, without updating (for a gate
    /// that must decide before any filter of a bank uses `z`).
    pub fn innovation(&self, z: T, h: &[T; N], r: T) -> (T, T) {
        let n = self.n.min(N);
        let (mut hx, mut s) = (T::zero(), r);
        for i in 0..n {
            hx += h[i] * self.x[i];
            let mut a = T::zero();
            for j in 0..n {
                a += self.P[i][j] * h[j];
            }
            s += h[i] * a;
        }
        (z - hx, s)
    }

    /// Measurement update for `z = h x + v`, `v ~ N(0, r)`.
    ///
    /// A non-finite `z` is a missing observation. With `gate = Some(g)`, an innovation whose
    /// NIS `nu^2 / S` exceeds `g` (or is NaN) is rejected (chi-square test with one degree of
    /// freedom; tested as `nu^2 / S <= g`, since `nu^2 <= g S` lets an infinite `nu^2` through
    /// when `g S` overflows too).
    ///
    /// The covariance update is Joseph's form `P = (I - K h) P (I - K h)^T + K r K^T`, expanded
    /// for a scalar observation as `P - K a^T - a K^T + S K K^T` with `a = P h^T`: O(n^2)
    /// instead of O(n^3), and still symmetric and positive semi-definite for any gain `K`.
    pub fn update(&mut self, z: T, h: &[T; N], r: T, gate: Option<T>) -> Innovation<T> {
        let n = self.n.min(N);
        let mut a = [T::zero(); N];
        for i in 0..n {
            let mut s = T::zero();
            for k in 0..n {
                s += self.P[i][k] * h[k];
            }
            a[i] = s;
        }
        let mut hx = T::zero();
        let mut hph = T::zero();
        for k in 0..n {
            hx += h[k] * self.x[k];
            hph += h[k] * a[k];
        }
        let s = hph + r;
        let nan = T::lit(f64::NAN);
        let out = |innovation, nis, status| Innovation {
            innovation,
            variance: s,
            nis,
            status,
        };
        if !z.is_finite() {
            return out(nan, nan, UpdateStatus::Missing);
        }
        let nu = z - hx;
        if !(s.is_finite() && s > T::zero()) {
            return out(nu, nan, UpdateStatus::BadInnovationVariance);
        }
        let nis = nu * nu / s;
        if let Some(g) = gate {
            // A NaN NIS or gate fails the test too: only a NIS within the gate passes.
            let within = nis <= g;
            if !within {
                return out(nu, nis, UpdateStatus::Gated);
            }
        }
        let inv = T::one() / s;
        for i in 0..n {
            let ki = a[i] * inv;
            self.x[i] += ki * nu;
            for j in i..n {
                let kj = a[j] * inv;
                // Joseph, expanded: P - K a^T - a K^T + S K K^T (symmetric by construction).
                let v = self.P[i][j] - ki * a[j] - a[i] * kj + s * ki * kj;
                self.P[i][j] = v;
                self.P[j][i] = v;
            }
        }
        out(nu, nis, UpdateStatus::Updated)
    }

    /// Cheap health test: finite state, finite positive diagonal of `P` (active block).
    pub fn diagonal_healthy(&self) -> bool {
        let n = self.n.min(N);
        let mut ok = true;
        for i in 0..n {
            let d = self.P[i][i];
            // `d > 0` is false for NaN; `is_finite` rejects +inf.
            ok &= d > T::zero() && d.is_finite() && self.x[i].is_finite();
        }
        ok
    }

    /// True when `x` and `P` are finite and the active block of `P` is positive definite
    /// (Cholesky test).
    pub fn is_healthy(&self) -> bool {
        self.x.iter().all(|v| v.is_finite()) && is_positive_definite(&self.P, self.n)
    }

    /// Restores a usable covariance after numerical trouble: the estimate is kept if finite
    /// (else zeroed) and `P` is replaced by `fallback`. Returns true if a repair was needed.
    pub fn repair(&mut self, fallback: &Arr<T, N>) -> bool {
        if self.is_healthy() {
            return false;
        }
        if !self.x.iter().all(|v| v.is_finite()) {
            self.x = [T::zero(); N];
        }
        self.P = *fallback;
        self.zero_inactive();
        true
    }

    /// The estimate in physical units, `S x`, for the states' scales `scale` (the filter
    /// runs on scaled states: `x_si = S x`).
    pub fn state_si(&self, scale: &[T; N]) -> [T; N] {
        let mut x = self.x;
        for (v, s) in x.iter_mut().zip(scale.iter()) {
            *v *= *s;
        }
        x
    }

    /// Each state's standard deviation in physical units, `sqrt(P_ii) S_i` (0 where `P_ii`
    /// is not positive).
    pub fn sigma_si(&self, scale: &[T; N]) -> [T; N] {
        let mut out = [T::zero(); N];
        for (i, (o, s)) in out.iter_mut().zip(scale.iter()).enumerate() {
            let p = self.P.get(i).and_then(|r| r.get(i)).copied();
            *o = p.unwrap_or_else(T::zero).max(T::zero()).sqrt() * *s;
        }
        out
    }
}

/// Kalman predict over the leading `K` states of capacity `N`: `x = Phi x`,
/// `P = (Phi P) Phi^T + Qd` with `P` symmetric, so that `(Phi P)_ij = Phi_i . P_j` and every
/// product is a row-by-row dot product. `K^2 + K^3 + K^2 (K+1)/2` multiply-adds.
#[allow(non_snake_case)]
fn predict_c<T: Real, const K: usize, const N: usize>(
    x: &mut [T; N],
    p: &mut Arr<T, N>,
    Phi: &Arr<T, N>,
    Qd: &Arr<T, N>,
) {
    // Temporaries of the active size only (no N x N zero fill).
    let n = K.min(N);
    let mut xn = [T::zero(); K];
    let mut t = [[T::zero(); K]; K];
    for i in 0..n {
        xn[i] = dot_c::<T, K, N, N>(&Phi[i], x);
        for j in 0..n {
            t[i][j] = dot_c::<T, K, N, N>(&Phi[i], &p[j]);
        }
    }
    for i in 0..n {
        for j in i..n {
            let v = dot_c::<T, K, K, N>(&t[i], &Phi[j]) + Qd[i][j];
            p[i][j] = v;
            p[j][i] = v;
        }
    }
    x[..n].copy_from_slice(&xn[..n]);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn predict_matches_the_matrix_product_at_every_active_size() {
        let phi = SMatrix::<f64, 8, 8>::from_fn(|i, j| ((i * 3 + j * 7) % 5) as f64 * 0.1 - 0.2);
        let b = SMatrix::<f64, 8, 8>::from_fn(|i, j| ((i * 5 + j) % 7) as f64 * 0.5);
        let p0 = b * b.transpose() + SMatrix::<f64, 8, 8>::identity();
        let qd = SMatrix::<f64, 8, 8>::identity() * 0.01;
        for n in 1..=8 {
            let mut kf = Kalman::<f64, 8>::new(&crate::linalg::from_mat(&p0), n);
            kf.x[..n].fill(1.0);
            kf.predict(
                &crate::linalg::from_mat(&phi),
                &crate::linalg::from_mat(&qd),
            );
            let pn = p0.view((0, 0), (n, n));
            let fn_ = phi.view((0, 0), (n, n));
            let want = fn_ * pn * fn_.transpose() + qd.view((0, 0), (n, n));
            for i in 0..n {
                for j in 0..n {
                    assert!((kf.P[i][j] - want[(i, j)]).abs() < 1e-9 * want[(i, j)].abs().max(1.0));
                }
                let xi: f64 = (0..n).map(|k| phi[(i, k)]).sum();
                assert!((kf.x[i] - xi).abs() < 1e-12);
            }
        }
    }

    /// The kernel at the active size rounded up to a multiple of 4 gives the bits of the
    /// `N`-state kernel when `Phi`, `Qd`, `x` and `P` are zero outside the active block (the
    /// argument in [`Kalman::predict`]'s docs), at every active size above 8, on products
    /// with cancellations (entries of both signs over eight decades) and exact zeros.
    #[test]
    fn rounded_kernels_give_the_bits_of_the_full_kernel() {
        use rand::{Rng, SeedableRng};
        const N: usize = 24;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(66_001);
        let entry = |rng: &mut rand_chacha::ChaCha8Rng| -> f64 {
            if rng.gen_bool(0.3) {
                0.0
            } else {
                let sign = if rng.gen_bool(0.5) { -1.0 } else { 1.0 };
                sign * 10f64.powf(rng.gen_range(-4.0..4.0))
            }
        };
        for n in 9..=N {
            for _ in 0..20 {
                let mut phi = [[0.0f64; N]; N];
                let mut qd = [[0.0f64; N]; N];
                let mut p = [[0.0f64; N]; N];
                let mut kf = Kalman::<f64, N>::new(&p, n);
                for i in 0..n {
                    kf.x[i] = entry(&mut rng);
                    for j in 0..n {
                        phi[i][j] = entry(&mut rng);
                        p[i][j] = entry(&mut rng);
                    }
                    for j in 0..=i {
                        let q = entry(&mut rng).abs();
                        qd[i][j] = q;
                        qd[j][i] = q;
                    }
                }
                kf.P = p;
                let (mut x_full, mut p_full) = (kf.x, kf.P);
                predict_c::<f64, N, N>(&mut x_full, &mut p_full, &phi, &qd);
                kf.predict(&phi, &qd);
                let bits = |v: &[f64; N]| v.map(f64::to_bits);
                assert_eq!(bits(&kf.x), bits(&x_full), "x, n = {n}");
                for (a, b) in kf.P.iter().zip(p_full.iter()) {
                    assert_eq!(bits(a), bits(b), "P, n = {n}");
                }
            }
        }
    }

    #[test]
    fn gate_missing_and_repair() {
        let mut p0 = [[0.0f64; 3]; 3];
        p0[0][0] = 1.0;
        p0[1][1] = 1.0;
        let mut kf = Kalman::<f64, 3>::new(&p0, 2);
        let h = [1.0, 0.0, 0.0];
        let g = kf.update(100.0, &h, 1.0, Some(30.0));
        assert_eq!(g.status, UpdateStatus::Gated);
        assert_eq!(kf.x, [0.0; 3]);
        assert_eq!(
            kf.update(f64::INFINITY, &h, 1.0, None).status,
            UpdateStatus::Missing
        );
        assert_eq!(
            kf.update(1.0, &h, -5.0, None).status,
            UpdateStatus::BadInnovationVariance
        );
        kf.P[1][1] = -1.0;
        assert!(!kf.is_healthy());
        assert!(kf.repair(&p0));
        assert!(kf.is_healthy());
        assert!(!kf.repair(&p0));
    }
}
