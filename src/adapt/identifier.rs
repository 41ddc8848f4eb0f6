//! A Kalman filter of any [`IdentifiableModel`] that identifies the model's noise parameters
//! online by recursive Gauss-Newton maximum likelihood on its own innovations (the equations of
//! the [`adapt`](super) module): the [`Bank`] gives the score and Fisher information of each
//! block by central differences, the exponential window sums them, and a damped, rate-limited,
//! bounded step moves `theta` (the logarithms of the parameters).
//!
//! With `probe_factor > 1` it also runs the probe grid ([`probes`](super::probes)): every
//! `epoch` steps the centre jumps to a probe that beats it by the margin, and during the search
//! phase (until an epoch ends without a jump) the Gauss-Newton moves are held. All of it is for
//! a model of `N` states and `Z` observation axes. [`AdaptiveFilter`](super::AdaptiveFilter)
//! runs one and adds the global window search and the structure switch.
//!
//! ```
//! use imu_ident::adapt::identifier::Identifier;
//! use imu_ident::adapt::AdaptConfig;
//! use imu_ident::model::InsModel;
//! let cfg = AdaptConfig { block: 60, probe_factor: 0.0, ..AdaptConfig::default() };
//! let mut f: Identifier<f64> = Identifier::new(InsModel::paper(), cfg).unwrap();
//! assert_eq!(f.specs().len(), 4); // sigma and tau of each sensor's Gauss-Markov drift
//! for _ in 0..60 {
//!     let step = f.step_axes(&[0.0], None); // one velocity observation per second [m/s]
//!     assert!(step.bank.centre[0].is_some() && !step.rejected);
//! }
//! // One block: its score and information are in the window, one term per step.
//! assert_eq!(f.windowed_information().steps, 60);
//! ```

// Small fixed-size matrix code reads best with explicit indices (they mirror the equations).
#![allow(clippy::needless_range_loop)]

use super::bank::{Bank, BankStep, Member};
use super::guard::{limit_step, Bounds, Mat};
use super::identifiable::IdentifiableModel;
use super::information::Information;
use super::params::{flat_coordinates, Specs, MAXP};
use super::probes::{Probes, Winner};
use super::{AdaptConfig, AdaptError};
use crate::linalg::{chol_solve, cholesky, inverse_diagonal, is_positive_definite};
use crate::model::{InsModel, NX};
use crate::Real;

/// What one [`Identifier::step_axes`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentifierStep<T, const Z: usize> {
    /// The bank's step: the centre's innovations, the gated axes, a rolled-back move.
    pub bank: BankStep<T, Z>,
    /// `theta` moved: a Gauss-Newton step at the end of this step's block, or a jump.
    pub moved: bool,
    /// The centre jumped to a winning probe at the end of this step's epoch.
    pub jumped: bool,
    /// A move failed (the bank rolled back, a probe could not be discretised, or the
    /// Gauss-Newton system was not positive definite).
    pub rejected: bool,
}

/// The recursive Gauss-Newton identification of an [`IdentifiableModel`]'s noise parameters,
/// with its probe epochs (module documentation).
#[derive(Debug, Clone)]
pub struct Identifier<T: Real, M = InsModel<T>, const N: usize = NX, const Z: usize = 1>
where
    M: IdentifiableModel<T, N, Z>,
{
    /// The model the filter started from (what `theta` is applied to).
    pub(super) base: M,
    pub(super) specs: Specs,
    pub(super) theta: [T; MAXP],
    pub(super) bounds: Bounds<T>,
    pub(super) cfg: AdaptConfig<T>,
    /// The exponential window's factor per block, `f = exp(-block dt / window)`.
    forget: T,
    pub(super) bank: Bank<T, M, N, Z>,
    /// The current block's score and information (the bank adds to it every step).
    pub(super) block: Information<T>,
    pub(super) acc: Information<T>,
    /// The windowed Fisher information with squared weights (`f^2` per block, `beta^2` per
    /// move): the middle of the sandwich variance of the windowed estimate
    /// ([`windowed_sd`](Self::windowed_sd)).
    pub(super) acc_sq: Mat<T>,
    pub(super) total: Information<T>,
    pub(super) steps: u32,
    updates: u32,
    clamped: bool,
    /// The probe grid around the centre (empty with `probe_factor <= 1`).
    pub(super) probes: Probes<T, N>,
    /// Jumps to another basin so far (a probe, or the parent's global stage).
    pub(super) jumps: u32,
    epochs: u32,
    last_gain: T,
    /// The search phase: no Gauss-Newton moves (with `hold_first_epoch`), the smaller
    /// `first_margin`; it ends with the first epoch without a jump.
    pub(super) searching: bool,
}

impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize>
    Identifier<T, M, N, Z>
{
    /// An empty filter (a compile-time value, all zeros): call [`init`](Self::init) before use.
    pub const BLANK: Self = Self {
        base: M::BLANK,
        specs: Specs::new(),
        theta: [T::ZERO; MAXP],
        bounds: Bounds::BLANK,
        cfg: AdaptConfig::BLANK,
        forget: T::ZERO,
        bank: Bank::BLANK,
        block: Information::BLANK,
        acc: Information::BLANK,
        acc_sq: [[T::ZERO; MAXP]; MAXP],
        total: Information::BLANK,
        steps: 0,
        updates: 0,
        clamped: false,
        probes: Probes::BLANK,
        jumps: 0,
        epochs: 0,
        last_gain: T::ZERO,
        searching: false,
    };

    /// Starts from `model` (its parameters are the initial guess).
    pub fn new(model: M, cfg: AdaptConfig<T>) -> Result<Self, AdaptError> {
        let mut f = Self::BLANK;
        f.init(model, cfg)?;
        Ok(f)
    }

    /// [`new`](Self::new) in place (the firmware's filters live in a `static`). The settings of
    /// `cfg` that are not the recursion's or the probes' (the global stage's) are ignored. On
    /// error the filter must not be stepped (initialise it again).
    pub fn init(&mut self, model: M, cfg: AdaptConfig<T>) -> Result<(), AdaptError> {
        let ok = |v: T| v.is_finite() && v > T::zero();
        // `v >= 0` is false for NaN, so a NaN setting is rejected too.
        let nonneg = |v: T| v >= T::zero();
        if cfg.block == 0
            || cfg.epoch <= cfg.warmup
            || !nonneg(cfg.margin)
            || !nonneg(cfg.first_margin)
            || !(cfg.probe_factor.is_finite())
            || !ok(cfg.h)
            || !ok(cfg.window)
            || !nonneg(cfg.damping)
            || !nonneg(cfg.hysteresis)
            || !ok(cfg.max_step)
            || !ok(cfg.tau_max)
            || !ok(cfg.spread)
            || !nonneg(cfg.move_discount)
            || cfg.move_discount > T::one()
        {
            return Err(AdaptError::BadConfig);
        }
        let specs = model.identified();
        if specs.is_empty() {
            return Err(AdaptError::NoParameters);
        }
        let theta0 = model.parameters(&specs);
        let dt = model.dt();
        let bounds = Bounds::new(&specs, &theta0, dt, cfg.tau_max, cfg.spread, cfg.h);
        let theta = bounds.clamp(&theta0, specs.len());
        self.bank.init(&model, &specs, cfg.h)?;
        self.bank.set_theta(&theta)?;
        self.forget = (-T::lit(f64::from(cfg.block)) * dt / cfg.window).exp();
        if cfg.probe_factor > T::one() {
            self.probes.init(&specs, cfg.probe_factor, self.bank.p0());
        } else {
            self.probes.init(&Specs::new(), T::lit(2.0), self.bank.p0());
        }
        self.probes.anchor(&theta, &bounds, specs.len());
        self.base = model;
        self.specs = specs;
        self.theta = theta;
        self.bounds = bounds;
        self.cfg = cfg;
        self.block = Information::BLANK;
        self.acc = Information::BLANK;
        self.acc_sq = [[T::zero(); MAXP]; MAXP];
        self.total = Information::BLANK;
        self.steps = 0;
        self.updates = 0;
        self.clamped = false;
        self.jumps = 0;
        self.epochs = 0;
        self.last_gain = T::zero();
        self.searching = true;
        Ok(())
    }

    /// One filter cycle of every bank member with the observation `z` (a non-finite axis is
    /// missing), gated per axis by `gate` (see [`Bank::step_axes`]), and of every probe; the
    /// step count advances. When a staggered move could not be discretised, `theta` follows the
    /// bank's roll-back (`failed`). Returns the bank's step and whether a probe failed.
    pub fn observe(
        &mut self,
        z: &[T; Z],
        gate: Option<&dyn Fn(usize) -> T>,
    ) -> (BankStep<T, Z>, bool) {
        let out = self.bank.step_axes(z, &mut self.block, gate);
        if out.failed {
            self.theta = *self.bank.theta();
        }
        let mut probe_failed = false;
        if !self.probes.is_empty() {
            // The probes see what the bank saw: a gated observation is missing for them too.
            let gated = out.gated.iter().any(Option::is_some);
            let z = if gated { [T::lit(f64::NAN); Z] } else { *z };
            let res = self.probes.step(
                &z,
                (self.bank.centre(), &out.centre),
                self.bank.rows(),
                &self.base,
                &self.specs,
                self.bank.scale_array(),
                self.cfg.warmup,
            );
            probe_failed = res.is_err();
        }
        self.steps = self.steps.wrapping_add(1);
        (out, probe_failed)
    }

    /// Whether the step just observed ends a probe epoch (never without probes).
    pub fn epoch_due(&self) -> bool {
        !self.probes.is_empty() && self.steps.checked_rem(self.cfg.epoch) == Some(0)
    }

    /// Whether the step just observed ends a block (`checked_rem`: no division-by-zero panic
    /// path; `block` is validated to be non-zero).
    pub fn block_due(&self) -> bool {
        self.steps.checked_rem(self.cfg.block) == Some(0)
    }

    /// [`observe`](Self::observe); when an epoch ends, the probes' verdict
    /// ([`epoch_end`](Self::epoch_end)); when a block ends, the Gauss-Newton update, held on
    /// the step of a jump and (with `hold_first_epoch`) during the search phase.
    pub fn step_axes(
        &mut self,
        z: &[T; Z],
        gate: Option<&dyn Fn(usize) -> T>,
    ) -> IdentifierStep<T, Z> {
        let (bank, probe_failed) = self.observe(z, gate);
        let mut out = IdentifierStep {
            bank,
            moved: false,
            jumped: false,
            rejected: bank.failed || probe_failed,
        };
        self.conclude(&mut out, false, false);
        out
    }

    /// The rest of a step after [`observe`](Self::observe) (and after whatever the parent did
    /// with the observation, which may already have set `out.jumped`): when an epoch ends, the
    /// probes' verdict ([`epoch_end`](Self::epoch_end)); when a block ends, the Gauss-Newton
    /// update. The update is held on the step of a jump (its information was just discarded),
    /// during the search phase (with `hold_first_epoch`) when probes or the parent's search
    /// (`parent_searches`) choose the basin, and always when `parent_holds`.
    pub(super) fn conclude(
        &mut self,
        out: &mut IdentifierStep<T, Z>,
        parent_searches: bool,
        parent_holds: bool,
    ) {
        if self.epoch_due() {
            match self.epoch_end() {
                Ok(j) => out.jumped |= j,
                Err(_) => out.rejected = true,
            }
        }
        if self.block_due() {
            let holding = self.cfg.hold_first_epoch
                && self.searching
                && (!self.probes.is_empty() || parent_searches);
            match self.update(!holding && !out.jumped && !parent_holds) {
                Ok(m) => out.moved = m,
                Err(_) => out.rejected = true,
            }
        }
        out.moved |= out.jumped;
    }

    /// End of a probe epoch: jump to a winning probe (fresh information, the old one describes
    /// another basin), then re-anchor the grid at the centre. Returns whether it jumped.
    pub fn epoch_end(&mut self) -> Result<bool, AdaptError> {
        self.epochs = self.epochs.saturating_add(1);
        let mut jumped = false;
        if self.cfg.adapt {
            let best = self.probes.best();
            self.last_gain = best.as_ref().map_or(T::zero(), |w| w.gain);
            let margin = if self.searching {
                self.cfg.first_margin
            } else {
                self.cfg.margin
            };
            // A probe whose covariance lost positive definiteness (its health test looks at the
            // diagonal only) is broken and cannot win: the centre would copy its `P`.
            let n = self.bank.active();
            let valid = |w: &Winner<T, N>| {
                w.gain.is_finite() && w.gain > margin && is_positive_definite(&w.p, n)
            };
            if let Some(w) = best.filter(valid) {
                // At once, not staggered like the Gauss-Newton moves: measured, staggering the
                // jump (members keeping their old model for up to 2p steps on the probe's x, P)
                // worsened the worst seeds (10x start: max tilt ratio 1.33 vs 1.18). A jump is
                // rare (0-2 per run) and costs 2p + 1 re-discretisations on that step.
                self.bank.set_theta(&w.theta)?;
                self.bank.reset_states(&w.x, &w.p);
                self.theta = w.theta;
                self.forget_window(true);
                self.jumps = self.jumps.saturating_add(1);
                jumped = true;
            }
            // The search phase (small margin, no Gauss-Newton moves) lasts until an epoch ends
            // without a jump: the centre is then the best point of its grid neighbourhood.
            if !jumped || !self.cfg.search_until_settled {
                self.searching = false;
            }
        }
        self.probes
            .anchor(&self.theta, &self.bounds, self.specs.len());
        Ok(jumped)
    }

    /// The block update (the [`adapt`](super) module's equations): folds the block into the
    /// window and, when `allow_move`, takes the safeguarded step. Returns whether `theta` moved.
    pub fn update(&mut self, allow_move: bool) -> Result<bool, AdaptError> {
        // `Specs` holds at most MAXP; the `min` lets the optimiser drop the bounds checks (and
        // their panics) below.
        let p = self.specs.len().min(MAXP);
        let f = self.forget;
        let b = core::mem::take(&mut self.block);
        for i in 0..p {
            self.acc.score[i] = f * self.acc.score[i] + b.score[i];
            self.total.score[i] += b.score[i];
            for j in 0..p {
                self.acc.fisher[i][j] = f * self.acc.fisher[i][j] + b.fisher[i][j];
                self.acc_sq[i][j] = f * f * self.acc_sq[i][j] + b.fisher[i][j];
                self.total.fisher[i][j] += b.fisher[i][j];
            }
        }
        self.acc.steps = self.acc.steps.saturating_add(b.steps);
        self.total.steps = self.total.steps.saturating_add(b.steps);
        if !self.cfg.adapt || !allow_move || b.steps == 0 {
            return Ok(false);
        }
        let mut a: Mat<T> = self.acc.fisher;
        for (i, row) in a.iter_mut().enumerate().take(p) {
            // Damping relative to the diagonal, plus a tiny absolute floor for a singular I.
            row[i] = row[i] * (T::one() + self.cfg.damping) + T::lit(1e-9);
        }
        let l = cholesky(&a, p).ok_or(AdaptError::BadParameter)?;
        let delta = chol_solve(&l, &self.acc.score, p);
        let var = inverse_diagonal(&l, p);
        let mut se = [T::zero(); MAXP];
        for (s, v) in se.iter_mut().zip(var.iter()) {
            *s = v.max(T::zero()).sqrt();
        }
        let d = limit_step(&delta, &se, self.cfg.hysteresis, self.cfg.max_step, p);
        let mut th = self.theta;
        for i in 0..p {
            th[i] += d[i];
        }
        let raw = th;
        let th = self.bounds.clamp(&th, p);
        self.clamped = raw.iter().zip(th.iter()).take(p).any(|(a, b)| a != b);
        let mut eff = [T::zero(); MAXP];
        let mut any = false;
        for i in 0..p {
            eff[i] = th[i] - self.theta[i];
            any |= eff[i] != T::zero();
        }
        if !any {
            return Ok(false);
        }
        self.bank.request_theta(&th);
        // Re-centre the quadratic model on the new point: `g_acc -= I_acc Delta`.
        for i in 0..p {
            let mut s = T::zero();
            for j in 0..p {
                s += self.acc.fisher[i][j] * eff[j];
            }
            self.acc.score[i] -= s;
        }
        let beta = self.cfg.move_discount;
        for i in 0..p {
            self.acc.score[i] *= beta;
            for j in 0..p {
                self.acc.fisher[i][j] *= beta;
                self.acc_sq[i][j] *= beta * beta;
            }
        }
        self.theta = th;
        self.updates = self.updates.saturating_add(1);
        Ok(true)
    }

    /// Whether the last move was clamped by the physical bounds (cleared by reading).
    pub fn take_clamped(&mut self) -> bool {
        core::mem::take(&mut self.clamped)
    }

    /// Forgets the windowed information (it describes another point or another sensor: after
    /// a jump to another basin, or a change in service); with `block`, the current block's too.
    pub fn forget_window(&mut self, block: bool) {
        self.acc = Information::default();
        self.acc_sq = [[T::zero(); MAXP]; MAXP];
        if block {
            self.block = Information::default();
        }
    }

    /// The identified parameters as `ln` values, in [`specs`](Self::specs) order.
    pub fn theta(&self) -> &[T; MAXP] {
        &self.theta
    }

    /// What each entry of `theta` is.
    pub fn specs(&self) -> &Specs {
        &self.specs
    }

    /// The physical bounds of `theta`.
    pub fn bounds(&self) -> &Bounds<T> {
        &self.bounds
    }

    /// The model this filter started from (what `theta` is applied to).
    pub fn base(&self) -> &M {
        &self.base
    }

    /// The model with the current parameters.
    pub fn model(&self) -> Result<M, AdaptError> {
        self.base
            .with_parameters(&self.specs, &self.theta)
            .ok_or(AdaptError::BadParameter)
    }

    /// The bank of filters (the centre runs `theta`).
    pub fn bank(&self) -> &Bank<T, M, N, Z> {
        &self.bank
    }

    /// Score and Fisher information of the exponential window (what the updates use).
    pub fn windowed_information(&self) -> &Information<T> {
        &self.acc
    }

    /// Score and Fisher information summed over the whole run without forgetting (at the
    /// parameters in use at each step). With `adapt = false` at the true model, its inverse is
    /// the Cramér-Rao bound of `theta` for the observations seen.
    pub fn total_information(&self) -> &Information<T> {
        &self.total
    }

    /// Standard deviations `sqrt((I^-1)_ii)` of `theta` from `info` (`ln` units: relative
    /// standard deviations of the parameters); `None` if `I` is not positive definite.
    pub fn crb(&self, info: &Information<T>) -> Option<[T; MAXP]> {
        let p = self.specs.len();
        let l = cholesky(&info.fisher, p)?;
        let mut d = inverse_diagonal(&l, p);
        for v in d.iter_mut().take(p) {
            *v = v.max(T::zero()).sqrt();
        }
        Some(d)
    }

    /// Standard deviations of `theta` as the window estimates it (`ln` units), the diagonal of
    /// the sandwich `I_w^-1 J_w I_w^-1`. `I_w = sum_b w_b I_b` is the windowed information
    /// ([`windowed_information`](Self::windowed_information), weights `w_b = f^age`) and
    /// `J_w = sum_b w_b^2 I_b`: the covariance of the maximiser of a weighted log-likelihood
    /// whose blocks carry independent scores of covariance `I_b` (the Cramér-Rao bound of the
    /// window's data as this estimator weighs them). In steady state it is
    /// `(1 - f) / ((1 + f) I_b)`, the bound of an unweighted window of `(1 + f) / (1 - f)` blocks,
    /// half the variance that `I_w^-1` alone would claim. `None` until `I_w` is positive
    /// definite.
    pub fn windowed_sd(&self) -> Option<[T; MAXP]> {
        let p = self.specs.len().min(MAXP);
        let l = cholesky(&self.acc.fisher, p)?;
        let mut sd = [T::zero(); MAXP];
        for (i, out) in sd.iter_mut().enumerate().take(p) {
            let mut e = [T::zero(); MAXP];
            if let Some(v) = e.get_mut(i) {
                *v = T::one();
            }
            // u = I_w^-1 e_i, then (I_w^-1 J_w I_w^-1)_ii = u' J_w u.
            let u = chol_solve(&l, &e, p);
            let mut v = T::zero();
            for (a, row) in u.iter().zip(self.acc_sq.iter()).take(p) {
                for (b, x) in u.iter().zip(row.iter()).take(p) {
                    v += *a * *x * *b;
                }
            }
            *out = v.max(T::zero()).sqrt();
        }
        Some(sd)
    }

    /// The coordinates (bit `i`: `theta[i]`) the window does not identify: a
    /// [`windowed_sd`](Self::windowed_sd) above
    /// [`IDENTIFIABLE_SD`](crate::model::IDENTIFIABLE_SD) decades, the global stage's test
    /// ([`Found::flat`](super::Found::flat)); all of them before the window's information is
    /// positive definite.
    pub fn flat(&self) -> u8 {
        flat_coordinates(self.windowed_sd().as_ref(), self.specs.len())
    }

    /// Steps observed so far.
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// Parameter updates applied so far.
    pub fn updates(&self) -> u32 {
        self.updates
    }

    /// Jumps to another basin so far.
    pub fn jumps(&self) -> u32 {
        self.jumps
    }

    /// The best probe's log-likelihood advantage over the centre in the last epoch, in nats
    /// (telemetry: a jump needs more than `margin`).
    pub fn last_gain(&self) -> T {
        self.last_gain
    }

    /// Whether the search phase still runs (no probe epoch has yet ended without a jump, and
    /// the parent's global stage has not finished a search).
    pub fn searching(&self) -> bool {
        self.searching
    }

    /// The centre filter (scaled states; see [`Bank::scale_array`]).
    pub fn centre(&self) -> &Member<T, N> {
        self.bank.centre()
    }
}
