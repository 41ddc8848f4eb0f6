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
use crate::linalg::{cholesky, Arr};
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
    for a in 0..m {
        for b in 0..m {
            // Checked and zipped rather than indexed: the same sums in the same order, and no
            // bounds check left for the firmware's no-panic link check (the axis numbers in
            // `idx` are data to the optimiser).
            let (Some(&ia), Some(&ib)) = (idx.get(a), idx.get(b)) else {
                continue;
            };
            let (Some(ha), Some(hb)) = (H.get(ia), H.get(ib)) else {
                continue;
            };
            let r = R.get(ia).copied().unwrap_or_else(T::zero);
            let mut v = if ia == ib { r } else { T::zero() };
            // H_a P H_b^T over the active block.
            for (prow, hk) in kf.P.iter().zip(ha.iter()).take(n) {
                let mut ph = T::zero();
                for (p, hl) in prow.iter().zip(hb.iter()).take(n) {
                    ph += *p * *hl;
                }
                v += *hk * ph;
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
    for (i, zi) in z.iter().enumerate() {
        if !zi.is_finite() {
            continue;
        }
        let r = kf.update(*zi, &H[i], R[i], None);
        if r.status == UpdateStatus::Updated {
            out.loglik += r.loglik();
        }
        out.axes[i] = r.status.into();
    }
    out
}
