//! Basin selection: a few fixed "probe" filters at coarse multiples of the correlation times
//! around the current parameters, compared with the centre filter by log-likelihood.
//!
//! Why: the innovation likelihood of the paper model is multi-modal. Accelerometer and gyro
//! errors are told apart only by their spectral shapes (both end up in the velocity error, the
//! gyro through the tilt), so from a start with correlation times 10x too short the local ascent
//! settles on "white accelerometer + fast gyro" (tau_a at its lower bound), 30-45 nats below the
//! true model over 12 h (measured, BENCHMARKS.md). A local method cannot leave that basin;
//! comparing a handful of distant points by their likelihood can (a small MMAE bank used only
//! to choose where the Gauss-Newton recursion starts from).
//!
//! The grid: for each (sigma, tau) pair of the first two Gauss-Markov-like components,
//! `tau * M^s` with `sigma * M^(-s/2)`, i.e. keeping the low-frequency power `2 sigma^2 tau` of
//! the component, which long data pin down well; `s` on two rings, `{-1, 0, 1}^2` and
//! `{-2, 0, 2}^2` without the centre: 16 probes for the paper model (`M = 3`: multipliers 3 and
//! 9, so that any start within 30x has a probe within a factor 1.7 of the truth on each axis;
//! a single 8x ring failed from 3x starts, between its points). Every `epoch` steps the probes
//! are re-anchored at the centre (their `x, P` copied from it, one discretisation per step to
//! bound the worst step), and after a warm-up the log-likelihoods `sum l_k` of the centre and of
//! each probe are accumulated until the end of the epoch, when the best probe wins if it beats
//! the centre by the margin.

use crate::adapt::bank::{Member, MemberInnovation};
use crate::adapt::guard::Bounds;
use crate::adapt::identifiable::IdentifiableModel;
use crate::adapt::params::{Specs, MAXP};
use crate::adapt::AdaptError;
use crate::filter::UpdateStatus;
use crate::linalg::Arr;
use crate::model::Quantity;
use crate::model::NX;
use crate::Real;

/// Largest number of probes: two rings (multipliers `M` and `M^2`) of `3^2 - 1` each.
pub const PROBES: usize = 16;

/// The probe filters and their likelihood sums, for an error model with `N` states (default:
/// the one-channel model's).
#[derive(Debug, Clone)]
pub struct Probes<T: Real, const N: usize = NX> {
    members: [Member<T, N>; PROBES],
    theta: [[T; MAXP]; PROBES],
    ll: [T; PROBES],
    ll_centre: T,
    count: usize,
    /// Probes `ready..count` still wait for their discretisation.
    ready: usize,
    age: u32,
    offsets: [[i8; 2]; PROBES],
    pairs: [(usize, usize); 2],
    npairs: usize,
    log_m: T,
}

/// A probe that beat the centre.
#[derive(Debug, Clone, PartialEq)]
pub struct Winner<T: Real, const N: usize = NX> {
    /// Its parameters.
    pub theta: [T; MAXP],
    /// Its state estimate (scaled states).
    pub x: [T; N],
    /// Its covariance (row-major).
    pub p: Arr<T, N>,
    /// Its log-likelihood advantage over the centre in the epoch [nats].
    pub gain: T,
}

impl<T: Real, const N: usize> Probes<T, N> {
    /// No probes (a compile-time value): call [`init`](Self::init) before use.
    pub const BLANK: Self = Self {
        members: [Member::BLANK; PROBES],
        theta: [[T::ZERO; MAXP]; PROBES],
        ll: [T::ZERO; PROBES],
        ll_centre: T::ZERO,
        count: 0,
        ready: 0,
        age: 0,
        offsets: [[0; 2]; PROBES],
        pairs: [(0, 0); 2],
        npairs: 0,
        log_m: T::ZERO,
    };

    /// Probes for `specs` with multiplier `m` (> 1) on the correlation times.
    pub fn new(specs: &Specs, m: T, p0: &Arr<T, N>) -> Self {
        let mut p = Self::BLANK;
        p.init(specs, m, p0);
        p
    }

    /// [`new`](Self::new) in place (no copy of the probe filters on the stack).
    pub fn init(&mut self, specs: &Specs, m: T, p0: &Arr<T, N>) {
        let mut pairs = [(0usize, 0usize); 2];
        let mut npairs = 0;
        for (i, s) in specs.iter().enumerate() {
            if s.kind != Quantity::Tau || npairs >= 2 {
                continue;
            }
            let sig = specs
                .iter()
                .position(|o| o.kind == Quantity::Sigma && o.same_component(s));
            if let Some(j) = sig {
                pairs[npairs] = (i, j);
                npairs += 1;
            }
        }
        let mut offsets = [[0i8; 2]; PROBES];
        let mut count = 0;
        let range: &[i8] = &[-1, 0, 1];
        let second: &[i8] = if npairs >= 2 { range } else { &[0] };
        for ring in [1i8, 2] {
            for &a in range {
                for &b in second {
                    if (a, b) != (0, 0) && npairs > 0 && count < PROBES {
                        offsets[count] = [a * ring, b * ring];
                        count += 1;
                    }
                }
            }
        }
        for mem in self.members.iter_mut() {
            // Each probe takes the centre's filter (and its active size) when it is readied.
            mem.reset(p0, 0);
        }
        self.theta = [[T::zero(); MAXP]; PROBES];
        self.ll = [T::zero(); PROBES];
        self.ll_centre = T::zero();
        self.count = count;
        self.ready = count;
        self.age = 0;
        self.offsets = offsets;
        self.pairs = pairs;
        self.npairs = npairs;
        self.log_m = m.ln();
    }

    /// Number of probes.
    pub fn len(&self) -> usize {
        self.count
    }

    /// True when there is no probe (nothing to identify a correlation time of).
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Parameters of probe `j`.
    pub fn theta(&self, j: usize) -> Option<&[T; MAXP]> {
        self.theta.get(j).filter(|_| j < self.count)
    }

    /// Re-anchors the grid at `centre` (clamped into `bounds`); the members are re-discretised
    /// one per step by [`step`](Self::step) and start from the centre's `x, P` then.
    pub fn anchor(&mut self, centre: &[T; MAXP], bounds: &Bounds<T>, p: usize) {
        for (th, off) in self
            .theta
            .iter_mut()
            .zip(self.offsets.iter())
            .take(self.count)
        {
            let mut t = *centre;
            // `get_mut`: the pair indices are < MAXP by construction; no bounds-check panic.
            for (&(it, is), &o) in self.pairs.iter().zip(off.iter()).take(self.npairs) {
                let s = T::lit(f64::from(o)) * self.log_m;
                if let Some(v) = t.get_mut(it) {
                    *v += s;
                }
                if let Some(v) = t.get_mut(is) {
                    *v -= T::lit(0.5) * s;
                }
            }
            *th = bounds.clamp(&t, p);
        }
        self.ready = 0;
        self.age = 0;
        self.ll = [T::zero(); PROBES];
        self.ll_centre = T::zero();
    }

    /// One step of every ready probe with the observation `z` of `Z` axes (rows `h`, noise
    /// variances `r`; non-finite axes missing), one pending discretisation of `base` at a
    /// probe's parameters in the states scaled by `scale`, and the likelihood sums after
    /// `warmup` steps of the epoch. `centre` is the centre filter and its sequential innovation
    /// on each axis this step.
    #[allow(clippy::too_many_arguments)]
    pub fn step<M: IdentifiableModel<T, N, Z>, const Z: usize>(
        &mut self,
        z: &[T; Z],
        centre: (&Member<T, N>, &[Option<MemberInnovation<T>>; Z]),
        rows: (&[[T; N]; Z], &[T; Z]),
        base: &M,
        specs: &Specs,
        scale: &[T; N],
        warmup: u32,
    ) -> Result<(), AdaptError> {
        let (h, r) = rows;
        if self.ready < self.count {
            let j = self.ready;
            self.ready += 1;
            let th = self.theta.get(j).ok_or(AdaptError::BadParameter)?;
            let model = base
                .with_parameters(specs, th)
                .ok_or(AdaptError::BadParameter)?;
            let (phi, qd) = model.discrete(scale).map_err(AdaptError::Model)?;
            if let Some(m) = self.members.get_mut(j) {
                m.set_system(&phi, &qd);
                m.kf = centre.0.kf.clone();
            }
        }
        self.age = self.age.saturating_add(1);
        let finite = z.iter().any(|v| v.is_finite());
        let counting = self.age > warmup && self.ready >= self.count && finite;
        // Sums only over steps on which the centre used every finite axis (one axis: the step
        // had an observation and the centre updated with it).
        let used = z
            .iter()
            .zip(centre.1.iter())
            .all(|(v, c)| !v.is_finite() || c.is_some());
        let all = counting && used;
        if all {
            for ci in centre.1.iter().flatten() {
                self.ll_centre += ci.loglik();
            }
        }
        for (m, ll) in self
            .members
            .iter_mut()
            .zip(self.ll.iter_mut())
            .take(self.ready)
        {
            m.predict();
            for (zk, (hk, rk)) in z.iter().zip(h.iter().zip(r.iter())) {
                if !zk.is_finite() {
                    continue;
                }
                let i = m.update(*zk, hk, *rk, None);
                match i.status {
                    UpdateStatus::Updated if all => *ll += i.loglik(),
                    UpdateStatus::Updated | UpdateStatus::Missing => {}
                    // A broken probe can never win.
                    UpdateStatus::Gated | UpdateStatus::BadInnovationVariance => {
                        *ll = T::lit(-1e30)
                    }
                }
            }
            if !m.kf.diagonal_healthy() {
                m.kf = centre.0.kf.clone();
                *ll = T::lit(-1e30);
            }
        }
        Ok(())
    }

    /// The best probe and its log-likelihood advantage over the centre in the epoch (may be
    /// negative); `None` before any probe has run.
    pub fn best(&self) -> Option<Winner<T, N>> {
        let mut best: Option<(usize, T)> = None;
        for (j, &l) in self.ll.iter().enumerate().take(self.ready.min(self.count)) {
            if best.map_or(true, |(_, b)| l > b) {
                best = Some((j, l));
            }
        }
        let (j, l) = best?;
        let gain = l - self.ll_centre;
        let m = self.members.get(j)?;
        Some(Winner {
            theta: *self.theta.get(j)?,
            x: m.kf.x,
            p: m.kf.P,
            gain,
        })
    }
}
