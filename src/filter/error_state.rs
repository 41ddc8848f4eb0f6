//! A Kalman filter of any [`ErrorModel`]: exact discretisation, the one Kalman kernel, and
//! vector observations fused as sequential scalar updates after a vector chi-square gate, with
//! per-axis flags.
//!
//! ```
//! use imu_ident::filter::{AxisStatus, ErrorStateFilter};
//! use imu_ident::model::{InsModel, NX};
//! let mut f = ErrorStateFilter::<f64, InsModel<f64>, NX, 1>::new(InsModel::paper()).unwrap();
//! let fused = f.step(&[0.01], Some(30.0));
//! assert_eq!(fused.axes[0], AxisStatus::Used);
//! assert!(!fused.gated);
//! let fused = f.step(&[f64::NAN], Some(30.0));
//! assert_eq!(fused.axes[0], AxisStatus::Missing);
//! ```
//!
//! # The vector gate
//!
//! With the `m` finite axes of an observation, `nu` their innovations and
//! `S = H P H^T + R` (`m x m`, before any update), the NIS `nu^T S^-1 nu` is chi-square with `m`
//! degrees of freedom under the model. The whole observation is withheld when it exceeds the
//! gate for `m` degrees of freedom (the caller passes the quantile: `gate(m)`), so that a fault
//! in one axis (a GNSS multipath jump in the north position) does not leak in through the
//! others. Then the axes are fused one by one: the result equals the vector update for
//! independent axes (diagonal `R`), and each scalar update is Joseph-form.

use crate::filter::kalman::{Kalman, UpdateStatus};
use crate::linalg::{cholesky, dot, Arr};
use crate::model::discretise::discretise_block;
use crate::model::{ContinuousSystem, ErrorModel, ModelError};
use crate::Real;
use core::marker::PhantomData;

/// What happened to one axis of a vector observation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AxisStatus {
    /// The axis was used.
    Used,
    /// The axis was NaN or infinite: missing.
    Missing,
    /// The vector gate rejected the observation: the axis was not used.
    Gated,
    /// The axis's innovation variance was not positive and finite: not used.
    BadVariance,
}

impl From<UpdateStatus> for AxisStatus {
    fn from(s: UpdateStatus) -> Self {
        match s {
            UpdateStatus::Updated => Self::Used,
            UpdateStatus::Missing => Self::Missing,
            UpdateStatus::Gated => Self::Gated,
            UpdateStatus::BadInnovationVariance => Self::BadVariance,
        }
    }
}

impl From<AxisStatus> for UpdateStatus {
    fn from(s: AxisStatus) -> Self {
        match s {
            AxisStatus::Used => Self::Updated,
            AxisStatus::Missing => Self::Missing,
            AxisStatus::Gated => Self::Gated,
            AxisStatus::BadVariance => Self::BadInnovationVariance,
        }
    }
}

/// The result of fusing one vector observation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fused<T, const Z: usize> {
    /// Per-axis status.
    pub axes: [AxisStatus; Z],
    /// Per-axis innovation `nu_i = z_i - H_i x` before the update (NaN when missing).
    pub innovation: [T; Z],
    /// Per-axis innovation variance `S_ii` before the update.
    pub variance: [T; Z],
    /// The vector NIS `nu^T S^-1 nu` over the finite axes (NaN if none or if `S` is not
    /// positive definite).
    pub nis: T,
    /// Number of finite axes (the degrees of freedom of `nis`).
    pub dof: usize,
    /// The gate rejected the observation.
    pub gated: bool,
    /// Log-likelihood of the fused axes, the sum of their sequential scalar innovations'
    /// `-1/2 (ln S + nu^2 / S)` (without `ln 2 pi`): with independent axes the exact
    /// Gaussian log-likelihood of the vector. Zero when nothing was fused.
    pub loglik: T,
}

/// A Kalman filter of an [`ErrorModel`] with `N` states and `Z` observation axes.
#[derive(Debug, Clone)]
pub struct ErrorStateFilter<T: Real, M, const N: usize, const Z: usize> {
    model: M,
    scale: [T; N],
    sys: ContinuousSystem<T, N, Z>,
    phi: Arr<T, N>,
    qd: Arr<T, N>,
    kf: Kalman<T, N>,
    _t: PhantomData<T>,
}

impl<T: Real, M: ErrorModel<T, N, Z>, const N: usize, const Z: usize> ErrorStateFilter<T, M, N, Z> {
    /// Validates `model`, chooses the scaling, discretises, and starts from a zero estimate
    /// with the model's initial covariance.
    pub fn new(model: M) -> Result<Self, ModelError> {
        let scale = model.scaling()?;
        let sys = model.system(&scale)?;
        let (phi, qd) = discretise_block(&sys.A, &sys.Qc, model.dt(), sys.n)?;
        let kf = Kalman::new(&sys.P0, sys.n);
        Ok(Self {
            model,
            scale,
            sys,
            phi,
            qd,
            kf,
            _t: PhantomData,
        })
    }

    /// Replaces the model, keeping the estimate, covariance and scaling; the new model must
    /// have the same layout ([`ModelError::TooManyStates`] otherwise, nothing changed).
    pub fn set_model(&mut self, model: M) -> Result<(), ModelError> {
        if !self.model.same_layout(&model) {
            return Err(ModelError::TooManyStates);
        }
        let sys = model.system(&self.scale)?;
        let (phi, qd) = discretise_block(&sys.A, &sys.Qc, model.dt(), sys.n)?;
        self.sys = sys;
        self.phi = phi;
        self.qd = qd;
        self.model = model;
        Ok(())
    }

    /// The model in use.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// The state scaling `S`.
    pub fn scale(&self) -> &[T; N] {
        &self.scale
    }

    /// The Kalman filter, in scaled states.
    pub fn kalman(&self) -> &Kalman<T, N> {
        &self.kf
    }

    /// The continuous system, in scaled states.
    pub fn system(&self) -> &ContinuousSystem<T, N, Z> {
        &self.sys
    }

    /// The discrete system `(Phi, Qd)` over the active states, in scaled states.
    pub fn discrete(&self) -> (&Arr<T, N>, &Arr<T, N>) {
        (&self.phi, &self.qd)
    }

    /// Propagates one step.
    pub fn predict(&mut self) {
        self.kf.predict(&self.phi, &self.qd);
    }

    /// Fuses the vector observation `z` (non-finite axes missing) after the vector gate
    /// `gate(m)` on the NIS of its `m` finite axes (`None`: no gate).
    pub fn update(&mut self, z: &[T; Z], gate: Option<&dyn Fn(usize) -> T>) -> Fused<T, Z> {
        fuse(&mut self.kf, z, &self.sys.H, &self.sys.R, gate)
    }

    /// One cycle: predict, then fuse `z`.
    pub fn step(&mut self, z: &[T; Z], gate: Option<T>) -> Fused<T, Z> {
        self.predict();
        match gate {
            // One fixed threshold whatever the number of finite axes.
            Some(g) => self.update(z, Some(&move |_| g)),
            None => self.update(z, None),
        }
    }

    /// Repairs `P` if it lost positive definiteness (reset to the initial covariance).
    pub fn repair(&mut self) -> bool {
        self.kf.repair(&self.sys.P0)
    }

    /// Physical state estimate `S x` ([`Kalman::state_si`]).
    pub fn state_si(&self) -> [T; N] {
        self.kf.state_si(&self.scale)
    }

    /// Physical standard deviation of each state, `sqrt(P_ii) S_i` ([`Kalman::sigma_si`]).
    pub fn sigma_si(&self) -> [T; N] {
        self.kf.sigma_si(&self.scale)
    }
}

/// The innovations of a vector observation's finite axes before any update, and their NIS.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Joint<T, const Z: usize> {
    /// Per-axis innovation `nu_i = z_i - H_i x` (NaN when missing).
    pub innovation: [T; Z],
    /// Per-axis innovation variance `S_ii = H_i P H_i^T + R_i`.
    pub variance: [T; Z],
    /// `nu^T S^-1 nu` over the finite axes, `S` their joint covariance (NaN if none or if `S`
    /// is not positive definite).
    pub nis: T,
    /// Number of finite axes (the degrees of freedom of `nis`).
    pub dof: usize,
    /// The finite axes' numbers, in order (the first `dof` entries).
    pub axes: [usize; Z],
}

impl<T: Real, const Z: usize> Joint<T, Z> {
    /// Whether the gate `gate(dof)` accepts the observation (no gate, or no finite axis: yes; a
    /// NaN NIS, from an `S` that is not positive definite, fails it).
    pub fn within(&self, gate: Option<&dyn Fn(usize) -> T>) -> bool {
        match gate {
            Some(g) if self.dof > 0 => self.nis <= g(self.dof),
            _ => true,
        }
    }
}

/// The innovations of `z = H x + v`, `v ~ N(0, diag(R))` (non-finite axes missing), on `kf`
/// before any update, and their vector NIS (module docs): what the vector gate tests. Used by
/// [`fuse`] and by the identification bank's gate on its centre filter.
#[allow(non_snake_case)]
pub fn joint<T: Real, const N: usize, const Z: usize>(
    kf: &Kalman<T, N>,
    z: &[T; Z],
    H: &[[T; N]; Z],
    R: &[T; Z],
) -> Joint<T, Z> {
    let nan = T::lit(f64::NAN);
    let mut out = Joint {
        innovation: [nan; Z],
        variance: [nan; Z],
        nis: nan,
        dof: 0,
        axes: [0; Z],
    };
    // Innovations and their joint covariance over the finite axes, before any update.
    let mut nu = [T::zero(); Z];
    let mut s = [[T::zero(); Z]; Z];
    let idx = &mut out.axes;
    let mut m = 0;
    for (i, zi) in z.iter().enumerate() {
        let (v, var) = kf.innovation(*zi, &H[i], R[i]);
        out.variance[i] = var;
        if zi.is_finite() {
            out.innovation[i] = v;
            if let (Some(slot), Some(n)) = (idx.get_mut(m), nu.get_mut(m)) {
                *slot = i;
                *n = v;
                m += 1;
            }
        }
    }
    out.dof = m;
    let n = kf.active();
    for b in 0..m {
        // Checked and zipped rather than indexed: no bounds check left for the firmware's
        // no-panic link check (the axis numbers in `idx` are data to the optimiser).
        let Some(&ib) = idx.get(b) else {
            continue;
        };
        let Some(hb) = H.get(ib) else {
            continue;
        };
        // P H_b^T over the active block, once per column of S: each entry the same sum in the
        // same order as the row-by-row H_a P H_b^T it replaces, so S is the same bit for bit,
        // at n^2 per axis instead of n^2 per pair of axes (BENCHMARKS.md "CI time: bit-exact
        // kernels").
        let mut ph = [T::zero(); N];
        for (v, prow) in ph.iter_mut().zip(kf.P.iter()).take(n) {
            *v = dot(prow, hb, n);
        }
        for a in 0..m {
            let Some(&ia) = idx.get(a) else {
                continue;
            };
            let Some(ha) = H.get(ia) else {
                continue;
            };
            let r = R.get(ia).copied().unwrap_or_else(T::zero);
            let mut v = if ia == ib { r } else { T::zero() };
            // H_a (P H_b^T), summed from v as before.
            for (hk, phk) in ha.iter().zip(ph.iter()).take(n) {
                v += *hk * *phk;
            }
            if let Some(slot) = s.get_mut(a).and_then(|row| row.get_mut(b)) {
                *slot = v;
            }
        }
    }
    if m > 0 {
        if let Some(l) = cholesky(&s, m) {
            // nu^T S^-1 nu = |L^-1 nu|^2 (forward substitution).
            let mut y = [T::zero(); Z];
            let mut nis = T::zero();
            // Zipped and checked (no bounds checks for the no-panic firmware; same order).
            for (a, (la, na)) in l.iter().zip(nu.iter()).enumerate().take(m) {
                let mut v = *na;
                for (lab, yb) in la.iter().zip(y.iter()).take(a) {
                    v -= *lab * *yb;
                }
                let ya = v / la.get(a).copied().unwrap_or(nan);
                if let Some(slot) = y.get_mut(a) {
                    *slot = ya;
                }
                nis += ya * ya;
            }
            out.nis = nis;
        }
    }
    out
}

/// One axis through the kernel's own gate: [`fuse`]'s result for `Z = 1`, with the NIS
/// `nu^2 / S` (NaN when the axis is missing or `S` is not positive).
fn scalar<T: Real, const N: usize, const Z: usize>(
    kf: &mut Kalman<T, N>,
    z: T,
    h: &[T; N],
    r: T,
    gate: Option<T>,
) -> Fused<T, Z> {
    let nan = T::lit(f64::NAN);
    let i = kf.update(z, h, r, gate);
    let mut out = Fused {
        axes: [AxisStatus::Missing; Z],
        innovation: [nan; Z],
        variance: [nan; Z],
        nis: i.nis,
        dof: usize::from(z.is_finite()),
        gated: i.status == UpdateStatus::Gated,
        loglik: T::zero(),
    };
    if i.status == UpdateStatus::Updated {
        out.loglik = i.loglik();
    }
    if let (Some(a), Some(nu), Some(s)) = (
        out.axes.first_mut(),
        out.innovation.first_mut(),
        out.variance.first_mut(),
    ) {
        *a = i.status.into();
        *nu = i.innovation;
        *s = i.variance;
    }
    out
}

/// Fuses the vector observation `z = H x + v`, `v ~ N(0, diag(R))` (non-finite axes missing)
/// into `kf` after the vector gate `gate(m)` on the NIS of its `m` finite axes (`None`: no
/// gate), as sequential scalar Joseph updates (module docs). The one fusion routine of the
/// crate: [`ErrorStateFilter::update`] and the strapdown navigator both call it.
#[allow(non_snake_case)]
pub fn fuse<T: Real, const N: usize, const Z: usize>(
    kf: &mut Kalman<T, N>,
    z: &[T; Z],
    H: &[[T; N]; Z],
    R: &[T; Z],
    gate: Option<&dyn Fn(usize) -> T>,
) -> Fused<T, Z> {
    // One axis keeps the kernel's scalar test `nu^2 / S <= g(1)`, like the identification
    // bank: the same decision without a Cholesky factor, and bit for bit the one-channel
    // filter's (the vector NIS of one axis, `(nu / sqrt(S))^2`, can differ in the last bit).
    if Z == 1 {
        if let (Some(&z0), Some(h0), Some(&r0)) = (z.first(), H.first(), R.first()) {
            return scalar(kf, z0, h0, r0, gate.map(|g| g(1)));
        }
    }
    let j = joint(kf, z, H, R);
    let mut out = Fused {
        axes: [AxisStatus::Missing; Z],
        innovation: j.innovation,
        variance: j.variance,
        nis: j.nis,
        dof: j.dof,
        gated: false,
        loglik: T::zero(),
    };
    if !j.within(gate) {
        out.gated = true;
        for &i in j.axes.iter().take(j.dof) {
            if let Some(a) = out.axes.get_mut(i) {
                *a = AxisStatus::Gated;
            }
        }
        return out;
    }
    out.loglik = sequential(kf, z, H, R, |i, status| {
        if let Some(a) = out.axes.get_mut(i) {
            *a = status.into();
        }
    });
    out
}

/// [`fuse`] without a gate and without the vector NIS it reports: the same sequential scalar
/// updates, so the same `x`, `P` and summed log-likelihood, bit for bit. For a bank's shadow
/// filters, which fuse every observation ungated and keep only the sum: the joint innovation
/// covariance (`P H^T` for every axis and its Cholesky factor) was a third of their fusion.
#[allow(non_snake_case)]
pub fn fuse_ungated<T: Real, const N: usize, const Z: usize>(
    kf: &mut Kalman<T, N>,
    z: &[T; Z],
    H: &[[T; N]; Z],
    R: &[T; Z],
) -> T {
    sequential(kf, z, H, R, |_, _| {})
}

/// Sequential scalar updates of `z`'s finite axes in order (PX4's fusion), `axis(i, status)`
/// told of each; returns the summed log-likelihood of the axes updated.
#[allow(non_snake_case)]
fn sequential<T: Real, const N: usize, const Z: usize>(
    kf: &mut Kalman<T, N>,
    z: &[T; Z],
    H: &[[T; N]; Z],
    R: &[T; Z],
    mut axis: impl FnMut(usize, UpdateStatus),
) -> T {
    let mut loglik = T::zero();
    for (i, ((zi, h), r)) in z.iter().zip(H.iter()).zip(R.iter()).enumerate() {
        if !zi.is_finite() {
            continue;
        }
        let u = kf.update(*zi, h, *r, None);
        if u.status == UpdateStatus::Updated {
            loglik += u.loglik();
        }
        axis(i, u.status);
    }
    loglik
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::zeros;
    use rand::{Rng, SeedableRng};

    const N: usize = 24;
    const Z: usize = 6;

    /// A random filter of `n` active states (a covariance `B B^T + 1e-3 I`), six observation
    /// rows with zeros, and an observation with missing axes.
    #[allow(non_snake_case, clippy::type_complexity)]
    fn random_case(
        rng: &mut rand_chacha::ChaCha8Rng,
        n: usize,
    ) -> (Kalman<f64, N>, [[f64; N]; Z], [f64; Z], [f64; Z]) {
        let mut b = zeros::<f64, N>();
        for row in b.iter_mut().take(n) {
            for v in row.iter_mut().take(n) {
                *v = rng.gen_range(-1.0..1.0);
            }
        }
        let mut p = crate::linalg::mul_t_sym(&b, &b, &zeros(), n);
        for (i, row) in p.iter_mut().enumerate().take(n) {
            row[i] += 1e-3;
        }
        let mut kf = Kalman::<f64, N>::new(&p, n);
        for x in kf.x.iter_mut().take(n) {
            *x = rng.gen_range(-1.0..1.0);
        }
        let mut H = [[0.0; N]; Z];
        for row in H.iter_mut() {
            for v in row.iter_mut().take(n) {
                if rng.gen_bool(0.3) {
                    *v = rng.gen_range(-2.0..2.0);
                }
            }
        }
        let R = [0.5, 0.7, 1.1, 0.05, 0.06, 0.08];
        let mut z = [0.0; Z];
        for v in z.iter_mut() {
            *v = if rng.gen_bool(0.2) {
                f64::NAN
            } else {
                rng.gen_range(-3.0..3.0)
            };
        }
        (kf, H, R, z)
    }

    /// The shadows' [`fuse_ungated`] is [`fuse`] without a gate, bit for bit: the state, the
    /// covariance and the summed log-likelihood, with missing axes, and on one axis (where
    /// `fuse` takes its scalar path).
    #[test]
    #[allow(non_snake_case)]
    fn ungated_fusion_has_the_bits_of_fuse() {
        let bits =
            |kf: &Kalman<f64, N>| (kf.x.map(f64::to_bits), kf.P.map(|r| r.map(f64::to_bits)));
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(66_101);
        let mut updated = 0;
        for n in [4, 9, 15, 21, 24] {
            for _ in 0..40 {
                let (kf, H, R, z) = random_case(&mut rng, n);
                let (mut a, mut b) = (kf.clone(), kf.clone());
                let f = fuse(&mut a, &z, &H, &R, None);
                let l = fuse_ungated(&mut b, &z, &H, &R);
                assert_eq!(bits(&a), bits(&b), "n = {n}");
                assert_eq!(f.loglik.to_bits(), l.to_bits(), "n = {n}");
                updated += f.axes.iter().filter(|s| **s == AxisStatus::Used).count();
                let (mut a, mut b) = (kf.clone(), kf);
                let (z1, H1, R1) = ([z[0]], [H[0]], [R[0]]);
                let f = fuse(&mut a, &z1, &H1, &R1, None);
                let l = fuse_ungated(&mut b, &z1, &H1, &R1);
                assert_eq!(bits(&a), bits(&b), "n = {n}, one axis");
                assert_eq!(f.loglik.to_bits(), l.to_bits(), "n = {n}, one axis");
            }
        }
        // Most axes were fused (a fifth are missing): the comparison is not of untouched filters.
        assert!(updated > 700, "{updated} axes updated");
    }

    /// [`joint`]'s vector NIS from `S` formed pair by pair as before (`H_a P H_b^T` with the
    /// row sums of `P H_b^T` recomputed for every pair): the same bits, on random covariances,
    /// observation rows with zeros and missing axes.
    #[test]
    #[allow(non_snake_case, clippy::needless_range_loop)]
    fn the_joint_nis_has_the_bits_of_the_pairwise_sums() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(66_003);
        for n in [9, 15, 18, 21, 24] {
            for _ in 0..50 {
                let (kf, H, R, z) = random_case(&mut rng, n);
                let j = joint(&kf, &z, &H, &R);
                // The reference: S pair by pair, then the same factor and substitution.
                let idx = &j.axes[..j.dof];
                let mut s = [[0.0; Z]; Z];
                for (a, &ia) in idx.iter().enumerate() {
                    for (bb, &ib) in idx.iter().enumerate() {
                        let mut v = if ia == ib { R[ia] } else { 0.0 };
                        for k in 0..n {
                            let mut ph = 0.0;
                            for l in 0..n {
                                ph += kf.P[k][l] * H[ib][l];
                            }
                            v += H[ia][k] * ph;
                        }
                        s[a][bb] = v;
                    }
                }
                let m = j.dof;
                let want = if m == 0 {
                    f64::NAN
                } else {
                    let l = cholesky(&s, m).expect("S positive definite");
                    let (mut y, mut nis) = ([0.0; Z], 0.0);
                    for a in 0..m {
                        let mut v = j.innovation[idx[a]];
                        for bb in 0..a {
                            v -= l[a][bb] * y[bb];
                        }
                        y[a] = v / l[a][a];
                        nis += y[a] * y[a];
                    }
                    nis
                };
                assert_eq!(j.nis.to_bits(), want.to_bits(), "n = {n}, dof = {m}");
            }
        }
    }
}
