//! The likelihood bank: the centre filter at `theta` and `2p` filters at `theta +- h e_i`, all
//! run on the same observations, and the finite-difference score and Fisher information of the
//! innovation log-likelihood they give.
//!
//! For a linear Gaussian model the log-likelihood of the observations is the sum over steps of
//! (Schweppe 1965; Gupta & Mehra 1974)
//!
//! ```text
//! l_k(theta) = -1/2 (ln S_k + nu_k^2 / S_k),   nu_k = z_k - H x_k|k-1,  S_k = H P_k|k-1 H^T + R
//! ```
//!
//! and its expected Hessian per step (the Fisher information of one scalar innovation) is
//!
//! ```text
//! I_ij = dS_i dS_j / (2 S^2) + dnu_i dnu_j / S.
//! ```
//!
//! Each bank member is a Kalman filter that has run with its own parameters on all the data, so
//! its innovations are the innovations of that model: the central differences
//! `(l(theta + h e_i) - l(theta - h e_i)) / 2h`, `dnu_i = (nu_i+ - nu_i-) / 2h` and
//! `dS_i = (S_i+ - S_i-) / 2h` include the sensitivity of the state estimate to `theta` (what
//! the sensitivity equations of a Kalman filter would propagate), at the cost of one filter per
//! perturbation instead of `n x p` sensitivity states.
//!
//! Members run the crate's one Kalman kernel ([`Kalman`]), which loops over the `n` active
//! states only (4 for the paper model, out of `NX = 8`).
//!
//! The bank is generic over the error model ([`IdentifiableModel`]: `N` states, `Z`
//! observation axes); its defaults are the one-channel [`InsModel`] (`N = NX`, `Z = 1`). A
//! vector observation passes the vector chi-square gate on the centre filter
//! ([`joint`](crate::filter::joint)) and is then fused by every member as `Z` sequential scalar
//! updates, each adding its own term to the likelihood derivatives
//! ([`information`](super::information)).

// Small fixed-size matrix code reads best with explicit indices (they mirror the equations).
#![allow(clippy::needless_range_loop)]

use crate::adapt::identifiable::IdentifiableModel;
pub use crate::adapt::information::{accumulate, Information, MemberInnovation, MEMBERS};
use crate::adapt::params::{Specs, MAXP};
use crate::adapt::AdaptError;
use crate::filter::{joint, AxisStatus, Innovation, Kalman, UpdateStatus};
use crate::linalg::{is_positive_definite, to_vec, zeros, Arr};
use crate::model::{InsModel, Scaling, NX};
use crate::Real;
use nalgebra::{SMatrix, SVector};

/// One filter of the bank: the crate's [`Kalman`] kernel in scaled states with its own
/// `(Phi, Qd)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Member<T: Real, const N: usize = NX> {
    /// The filter (estimate and covariance; only the leading `n` states are used).
    pub kf: Kalman<T, N>,
    phi: Arr<T, N>,
    qd: Arr<T, N>,
}

impl<T: Real, const N: usize> Member<T, N> {
    /// All zeros (a compile-time value: see [`Bank::BLANK`]).
    pub const BLANK: Self = Self {
        kf: Kalman::BLANK,
        phi: [[T::ZERO; N]; N],
        qd: [[T::ZERO; N]; N],
    };

    /// Zero state, covariance `p0` over `n` states, identity transition, no process noise
    /// (in place).
    pub(crate) fn reset(&mut self, p0: &Arr<T, N>, n: usize) {
        self.kf.reset(p0, n);
        for (i, row) in self.phi.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = if i == j { T::one() } else { T::zero() };
            }
        }
        for row in self.qd.iter_mut() {
            row.fill(T::zero());
        }
    }

    /// Time update with the member's own `(Phi, Qd)`.
    pub(crate) fn predict(&mut self) {
        self.kf.predict(&self.phi, &self.qd);
    }

    /// Scalar update with `z`, row `h`, noise variance `r` and an optional gate on the NIS.
    pub(crate) fn update(&mut self, z: T, h: &[T; N], r: T, gate: Option<T>) -> Innovation<T> {
        self.kf.update(z, h, r, gate)
    }

    /// Sets the transition and process noise.
    pub(crate) fn set_system(&mut self, phi: &Arr<T, N>, qd: &Arr<T, N>) {
        self.phi = *phi;
        self.qd = *qd;
    }

    /// The state estimate as an nalgebra vector.
    pub fn state(&self) -> SVector<T, N> {
        self.kf.state()
    }

    /// The covariance as an nalgebra matrix.
    pub fn covariance(&self) -> SMatrix<T, N, N> {
        self.kf.covariance()
    }
}

/// The `2p + 1` filters and their finite-difference likelihood derivatives, for an error model
/// `M` with `N` states and `Z` observation axes (defaults: the one-channel [`InsModel`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Bank<T: Real, M = InsModel<T>, const N: usize = NX, const Z: usize = 1> {
    members: [Member<T, N>; MEMBERS],
    p0: Arr<T, N>,
    h: [[T; N]; Z],
    r: [T; Z],
    n: usize,
    np: usize,
    step: T,
    scale: [T; N],
    base: M,
    specs: Specs,
    /// Parameters every member has been discretised for.
    applied: [T; MAXP],
    /// Parameters being moved to; members `next..` still have the `applied` ones.
    target: [T; MAXP],
    next: usize,
    /// Member repairs since the start (a member's `x, P` replaced by the centre's).
    pub repairs: u32,
}

/// What the bank did with one observation of `Z` axes.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BankStep<T, const Z: usize = 1> {
    /// The centre filter's sequential innovation on each axis (`None`: missing axis, bad `S`,
    /// or the observation was gated).
    pub centre: [Option<MemberInnovation<T>>; Z],
    /// Whether the step's derivatives were added to the information (every finite axis was
    /// used by every member).
    pub accumulated: bool,
    /// A staggered re-discretisation failed: the bank rolls back to the last parameters every
    /// member had (see [`Bank::theta`]).
    pub failed: bool,
    /// The observation failed the outlier gate on the centre and no member used it: the
    /// centre's (rejected) innovation on each finite axis (`None` on every axis when it passed).
    pub gated: [Option<MemberInnovation<T>>; Z],
}

impl<T: Copy, const Z: usize> BankStep<T, Z> {
    /// Axis `k` of the step: the centre's innovation (used, or rejected by the gate) and what
    /// happened to the axis, `finite` saying whether its observation was (no innovation and
    /// a finite observation: the centre's variance was bad).
    pub fn axis(&self, k: usize, finite: bool) -> (Option<MemberInnovation<T>>, AxisStatus) {
        let centre = self.centre.get(k).copied().flatten();
        match (centre, self.gated.get(k).copied().flatten()) {
            (Some(i), _) => (Some(i), AxisStatus::Used),
            (None, Some(i)) => (Some(i), AxisStatus::Gated),
            (None, None) if finite => (None, AxisStatus::BadVariance),
            (None, None) => (None, AxisStatus::Missing),
        }
    }
}

impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize> Bank<T, M, N, Z> {
    /// An empty bank (a compile-time value, all zeros): call [`init`](Self::init) before use.
    pub const BLANK: Self = Self {
        members: [Member::BLANK; MEMBERS],
        p0: [[T::ZERO; N]; N],
        h: [[T::ZERO; N]; Z],
        r: [T::ZERO; Z],
        n: 0,
        np: 0,
        step: T::ZERO,
        scale: [T::ZERO; N],
        base: M::BLANK,
        specs: Specs::new(),
        applied: [T::ZERO; MAXP],
        target: [T::ZERO; MAXP],
        next: 0,
        repairs: 0,
    };

    /// A bank for `model` with `np` parameters perturbed by `+-step` (log scale). The state
    /// scaling is chosen once from `model` and kept, so that `x, P` stay meaningful when the
    /// parameters move.
    pub fn new(model: &M, specs: &Specs, step: T) -> Result<Self, AdaptError> {
        let mut b = Self::BLANK;
        b.init(model, specs, step)?;
        Ok(b)
    }

    /// [`new`](Self::new) in place: the firmware builds its filters inside a `static`, since
    /// by-value construction would put several copies of the bank on the stack. On error
    /// nothing is changed.
    pub fn init(&mut self, model: &M, specs: &Specs, step: T) -> Result<(), AdaptError> {
        let scale = model.scaling().map_err(AdaptError::Model)?;
        let sys = model.system(&scale).map_err(AdaptError::Model)?;
        for m in self.members.iter_mut() {
            m.reset(&sys.P0, sys.n);
        }
        self.h = sys.H;
        self.p0 = sys.P0;
        self.r = sys.R;
        self.n = sys.n;
        self.np = specs.len().min(MAXP);
        self.step = step;
        self.scale = scale;
        self.base = model.clone();
        self.specs = specs.clone();
        self.applied = [T::zero(); MAXP];
        self.target = [T::zero(); MAXP];
        self.next = MEMBERS;
        self.repairs = 0;
        Ok(())
    }

    /// The parameters the bank is at (or moving to, while [`moving`](Self::moving)).
    pub fn theta(&self) -> &[T; MAXP] {
        &self.target
    }

    /// True while a staggered move is in progress (some members still have the old parameters).
    pub fn moving(&self) -> bool {
        self.next < 2 * self.np + 1
    }

    /// The state scaling (physical = scale x scaled), as the kernel's array.
    pub fn scale_array(&self) -> &[T; N] {
        &self.scale
    }

    /// Number of active states.
    pub fn active(&self) -> usize {
        self.n
    }

    /// The centre filter.
    pub fn centre(&self) -> &Member<T, N> {
        &self.members[0]
    }

    /// The initial covariance.
    pub fn p0(&self) -> &Arr<T, N> {
        &self.p0
    }

    /// The observation rows and their noise variances.
    pub fn rows(&self) -> (&[[T; N]; Z], &[T; Z]) {
        (&self.h, &self.r)
    }

    /// Copies `x, P` into every member (after a jump to another parameter point).
    pub fn reset_states(&mut self, x: &[T; N], p: &Arr<T, N>) {
        for m in self.members.iter_mut() {
            m.kf.x = *x;
            m.kf.P = *p;
        }
    }

    /// `(Phi, Qd)` of member `m` for the centre `theta`: member `2i+1` at `+h e_i`, `2i+2` at
    /// `-h e_i`.
    fn member_system(
        &self,
        m: usize,
        theta: &[T; MAXP],
    ) -> Result<(Arr<T, N>, Arr<T, N>), AdaptError> {
        let mut th = *theta;
        if m > 0 {
            let i = (m - 1) / 2;
            let sign = if m % 2 == 1 { self.step } else { -self.step };
            if let Some(t) = th.get_mut(i) {
                *t += sign;
            }
        }
        let model = self
            .base
            .with_parameters(&self.specs, &th)
            .ok_or(AdaptError::BadParameter)?;
        // The one discretisation, over the active block, in the scaling the bank started with.
        model.discrete(&self.scale).map_err(AdaptError::Model)
    }

    /// Re-discretises every member for the centre `theta` at once, keeping each member's `x`
    /// and `P`. On error nothing is changed. (At start-up and on a jump to a probe; the
    /// Gauss-Newton moves use [`request_theta`](Self::request_theta).)
    pub fn set_theta(&mut self, theta: &[T; MAXP]) -> Result<(), AdaptError> {
        // One pass, each member's system applied as it is computed. Holding all of them first
        // would put `2 MAXP + 1` pairs of matrices on the stack (5.6 KB in f32, the firmware's
        // deepest frame), and computing them twice (check, then apply) made a jump's tick cost
        // 2 (2p + 1) discretisations: 812k Cortex-M4 instructions against issue 5's 500k bar
        // (BENCHMARKS.md, "One discretisation per member on a jump"). A failure instead
        // restores the members already changed, by recomputing the systems they had.
        let used = (2 * self.np + 1).min(MEMBERS);
        for m in 0..used {
            match self.member_system(m, theta) {
                Ok((phi, qd)) => {
                    if let Some(mem) = self.members.get_mut(m) {
                        mem.set_system(&phi, &qd);
                    }
                }
                Err(e) => {
                    self.restore(m);
                    return Err(e);
                }
            }
        }
        let zero = zeros();
        for mem in self.members.iter_mut().skip(used) {
            mem.set_system(&zero, &zero);
        }
        self.applied = *theta;
        self.target = *theta;
        self.next = MEMBERS;
        Ok(())
    }

    /// Gives members `0..upto` back the systems they had before a failed
    /// [`set_theta`](Self::set_theta): those a staggered move has reached are at `target`, the
    /// others at `applied`. The discretisation is deterministic, so they are the same bits; it
    /// succeeded for those points, so it cannot fail here (were it to, that member would keep
    /// the new point's system; the caller sees the error either way).
    fn restore(&mut self, upto: usize) {
        for m in 0..upto.min(MEMBERS) {
            let theta = if m < self.next {
                self.target
            } else {
                self.applied
            };
            if let Ok((phi, qd)) = self.member_system(m, &theta) {
                if let Some(mem) = self.members.get_mut(m) {
                    mem.set_system(&phi, &qd);
                }
            }
        }
    }

    /// Moves to `theta` one member per step (centre first), so that no step pays for more than
    /// one re-discretisation; the derivatives are not accumulated until every member has moved
    /// (`2p + 1` steps), since until then they would mix two parameter points.
    pub fn request_theta(&mut self, theta: &[T; MAXP]) {
        self.target = *theta;
        self.next = 0;
    }

    /// One staggered re-discretisation; false if it failed (then the bank rolls back to the
    /// parameters every member had, again one member per step).
    fn advance(&mut self, used: usize) -> bool {
        if self.next >= used {
            return true;
        }
        let m = self.next;
        match self.member_system(m, &self.target) {
            Ok((phi, qd)) => {
                if let Some(mem) = self.members.get_mut(m) {
                    mem.set_system(&phi, &qd);
                }
                self.next += 1;
                if self.next >= used {
                    self.applied = self.target;
                    self.next = MEMBERS;
                }
                true
            }
            Err(_) => {
                self.target = self.applied;
                self.next = 0;
                false
            }
        }
    }

    /// Runs every member one step with the observation `z` of `Z` axes (non-finite axes are
    /// missing; none finite: predict only) and adds the step's score and Fisher information to
    /// `info`, one term per axis, for each axis that every member used.
    ///
    /// With a gate `Some(g)`, an observation whose NIS on the centre filter exceeds `g(m)` for
    /// its `m` finite axes (or is NaN) is withheld from every member, so that the members stay
    /// comparable and the likelihood derivatives are not polluted by the outlier. One axis is
    /// tested by the kernel's scalar NIS, several by the vector chi-square gate
    /// ([`joint`](crate::filter::joint)).
    pub fn step_axes(
        &mut self,
        z: &[T; Z],
        info: &mut Information<T>,
        gate: Option<&dyn Fn(usize) -> T>,
    ) -> BankStep<T, Z> {
        let used = 2 * self.np + 1;
        let failed = !self.advance(used);
        let mut inn = [[MemberInnovation::<T>::default(); MEMBERS]; Z];
        let mut out = BankStep {
            centre: [None; Z],
            accumulated: false,
            failed,
            gated: [None; Z],
        };
        let mut z = *z;
        let moving = self.moving();
        // Axis `k` adds to the information when it is finite and every member used it.
        let finite = z.map(|v| v.is_finite());
        let mut use_axis = finite.map(|f| f && !moving);
        for (m, mem) in self.members.iter_mut().enumerate() {
            if m >= used {
                break;
            }
            mem.predict();
            // The gate is decided on the centre (member 0) before any other member sees `z`. One
            // axis keeps the kernel's scalar test `nu^2 / S <= g(1)`: the same decision without
            // a Cholesky per tick, and bit for bit the one-channel loop's (the vector NIS of one
            // axis, `(nu / sqrt(S))^2`, can differ from it in the last bit).
            let mut scalar_gate = None;
            if let (0, Some(g)) = (m, gate) {
                if Z == 1 {
                    scalar_gate = Some(g(1));
                } else {
                    let j = joint(&mem.kf, &z, &self.h, &self.r);
                    if !j.within(Some(g)) {
                        let rejected = (j.innovation.iter()).zip(j.variance.iter());
                        for ((zk, o), (nu, s)) in
                            z.iter_mut().zip(out.gated.iter_mut()).zip(rejected)
                        {
                            if zk.is_finite() {
                                *o = Some(MemberInnovation { nu: *nu, s: *s });
                            }
                            *zk = T::lit(f64::NAN);
                        }
                        use_axis = [false; Z];
                    }
                }
            }
            let axes = z.iter_mut().zip(self.h.iter().zip(self.r.iter()));
            for (k, (zk, (h, r))) in axes.enumerate() {
                let i = mem.update(*zk, h, *r, scalar_gate);
                let mi = MemberInnovation {
                    nu: i.innovation,
                    s: i.variance,
                };
                let (Some(slot), Some(ok)) = (
                    inn.get_mut(k).and_then(|a| a.get_mut(m)),
                    use_axis.get_mut(k),
                ) else {
                    continue;
                };
                match i.status {
                    UpdateStatus::Updated => {
                        *slot = mi;
                        if let (0, Some(c)) = (m, out.centre.get_mut(k)) {
                            *c = Some(mi);
                        }
                    }
                    UpdateStatus::Gated => {
                        if let Some(o) = out.gated.get_mut(k) {
                            *o = Some(mi);
                        }
                        *zk = T::lit(f64::NAN);
                        *ok = false;
                    }
                    UpdateStatus::BadInnovationVariance => *ok = false,
                    UpdateStatus::Missing => {}
                }
            }
        }
        self.repair(used);
        let mut all = finite.iter().any(|f| *f) && !moving;
        for ((axis, ok), f) in inn.iter().zip(use_axis.iter()).zip(finite.iter()) {
            if *f {
                all &= *ok && accumulate(axis, self.np, self.step, info);
            }
        }
        out.accumulated = all;
        out
    }

    /// Replaces an unhealthy member's `x, P` by the centre's (or every member's by the initial
    /// covariance if the centre itself is unhealthy). The centre, whose covariance is reported
    /// and copied, must also pass a Cholesky test: rounding in `P - a a^T / S` can make a nearly
    /// singular `P` indefinite with a positive diagonal (issue 7 fuzz, f32). The other members
    /// keep the cheap diagonal test.
    fn repair(&mut self, used: usize) {
        let n = self.n;
        let c = &self.members[0].kf;
        if !c.diagonal_healthy() || !is_positive_definite(&c.P, n) {
            for m in self.members.iter_mut() {
                m.kf.x = [T::zero(); N];
                m.kf.P = self.p0;
            }
            self.repairs = self.repairs.saturating_add(1);
            return;
        }
        let (x0, p0) = (self.members[0].kf.x, self.members[0].kf.P);
        for m in self.members.iter_mut().take(used).skip(1) {
            if !m.kf.diagonal_healthy() {
                m.kf.x = x0;
                m.kf.P = p0;
                self.repairs = self.repairs.saturating_add(1);
            }
        }
    }
}

impl<T: Real> Bank<T> {
    /// The state scaling (physical = scale x scaled).
    pub fn scale(&self) -> Scaling<T> {
        to_vec(&self.scale)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::adapt::params::{specs, theta_of};
    use crate::model::Quantity;

    /// A [`Bank::set_theta`] that fails part-way leaves every member's system as it was, also in
    /// the middle of a staggered move (members `0..3` at the new point, the others at the old).
    /// The failure: a correlation time at `e^709.7` (finite in f64) whose `+h` member,
    /// `e^709.9`, overflows; the centre and the members before it discretise.
    #[test]
    fn failed_set_theta_changes_nothing() {
        let model = InsModel::<f64>::paper();
        let sp = specs(&model);
        let theta0 = theta_of(&model, &sp);
        let mut bank = Bank::new(&model, &sp, 0.2).unwrap();
        bank.set_theta(&theta0).unwrap();
        let mut moved = theta0;
        moved[0] += 0.1;
        bank.request_theta(&moved);
        let mut info = Information::default();
        for _ in 0..3 {
            let _ = bank.step_axes(&[0.0], &mut info, None);
        }
        assert!(bank.moving());
        let i = sp.iter().rposition(|s| s.kind == Quantity::Tau).unwrap();
        let mut bad = theta0;
        bad[i] = 709.7;
        let failing = 2 * i + 1;
        assert!(bank.member_system(0, &bad).is_ok());
        assert!(bank.member_system(failing - 1, &bad).is_ok());
        assert!(bank.member_system(failing, &bad).is_err());
        let before = bank.clone();
        assert!(bank.set_theta(&bad).is_err());
        assert_eq!(bank, before);
        // A set_theta that succeeds does change the bank: the equality above is not vacuous.
        bank.set_theta(&moved).unwrap();
        assert_ne!(bank, before);
    }
}
