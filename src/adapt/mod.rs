//! Online identification of the sensor noise models by recursive Gauss-Newton maximum likelihood
//! on the filter's own innovations (issue 3; design and measurements in `docs/ADAPTATION.md`).
//!
//! The paper's loop (re-identify `sigma, alpha` from the ACF of the filter's estimates) is biased
//! by the filter's covariance and confirms a too-small `Q` (METHOD.md §4). The innovations are
//! not: their likelihood is maximal at the true model from any start. [`AdaptiveFilter`] runs a
//! [`Bank`](bank::Bank) of `2p + 1` filters (centre and `theta +- h e_i`, `theta` the logarithms
//! of the identified parameters) that gives the score `g` and Fisher information `I` by central
//! differences, and every `block` steps:
//!
//! ```text
//! g_acc = f g_acc + g_block,   I_acc = f I_acc + I_block          (exponential window, f < 1)
//! Delta = (I_acc + lambda diag(I_acc))^-1 g_acc                   (damped Gauss-Newton)
//! Delta_i = 0 if |Delta_i| < c sqrt((I_acc^-1)_ii)                (hysteresis)
//! Delta  *= min(1, max_step / max |Delta_i|)                      (rate limit)
//! theta  = clamp(theta + Delta)                                   (physical bounds)
//! g_acc -= I_acc Delta                                            (re-centre the quadratic model)
//! ```
//!
//! The last line keeps the local quadratic model `l(theta') ~ l + g^T d - d^T I d / 2` of the
//! windowed log-likelihood consistent after the move, so information is neither lost nor counted
//! twice: a step withheld by the hysteresis or the rate limit stays in `g_acc` for later.
//!
//! The likelihood is multi-modal (accelerometer and gyro errors are told apart only by their
//! spectral shapes), so a local recursion alone can settle in the wrong basin. [`probes`] runs a
//! coarse grid of filters around the centre and compares log-likelihoods every epoch: during a
//! search phase (until an epoch ends without a jump) the centre jumps to any better probe and the
//! Gauss-Newton moves are held; afterwards a probe must win by a larger margin.

// Small fixed-size matrix code reads best with explicit indices (they mirror the equations).
#![allow(clippy::needless_range_loop)]

pub mod bank;
pub mod change;
mod config;
pub mod guard;
pub mod identifiable;
pub mod information;
mod jump;
pub mod params;
pub mod probes;
mod report;
pub mod restructure;
pub mod window;

use crate::filter::Estimates;
use crate::linalg::{chol_solve, cholesky, inverse_diagonal};
use crate::model::{ErrorSource, InsModel, ModelError, StateRow, NX};
use crate::Real;
use bank::{Bank, MemberInnovation};
pub use config::AdaptConfig;
use guard::{limit_step, Bounds, Mat};
use information::Information;
use params::{apply, specs, theta_of, Specs, MAXP};
use probes::Probes;
pub use report::{StepReport, StepStatus};
pub use window::WindowSearch;
pub use window::{Found, Switch, WindowConfig};

/// Why the adaptive filter could not be built or moved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AdaptError {
    /// The model (initial or identified) was rejected.
    Model(ModelError),
    /// A parameter value could not be written into the model (not finite, or layout mismatch).
    BadParameter,
    /// The model has nothing to identify.
    NoParameters,
    /// A configuration value is out of range.
    BadConfig,
}

/// An INS filter that identifies its own sensor-noise parameters online.
#[derive(Debug, Clone)]
pub struct AdaptiveFilter<T: Real> {
    base: InsModel<T>,
    specs: Specs,
    theta: [T; MAXP],
    bounds: Bounds<T>,
    cfg: AdaptConfig<T>,
    forget: T,
    bank: Bank<T>,
    probes: Probes<T>,
    global: WindowSearch<T>,
    block: Information<T>,
    acc: Information<T>,
    /// The windowed Fisher information with squared weights (`f^2` per block, `beta^2` per
    /// move): the middle of the sandwich variance of the windowed estimate
    /// ([`windowed_sd`](Self::windowed_sd)).
    acc_sq: Mat<T>,
    total: Information<T>,
    accel_row: StateRow<T>,
    gyro_row: StateRow<T>,
    steps: u32,
    updates: u32,
    jumps: u32,
    epochs: u32,
    last_gain: T,
    searching: bool,
    clamped: bool,
    last_global: Found<T>,
    switches: u32,
    /// The coordinates the last search's window did not identify (bit `i`: `theta[i]`).
    flat: u8,
    /// The filter still runs the start model: nothing has moved it and no change in service
    /// was found ([`WindowConfig::keep_start`](window::WindowConfig::keep_start)).
    at_start: bool,
}

impl<T: Real> AdaptiveFilter<T> {
    /// An empty filter (a compile-time value, all zeros): call [`init`](Self::init) before use.
    /// A `static` initialised with it costs no flash (it goes to `.bss`) and no stack.
    pub const BLANK: Self = Self {
        base: InsModel::BLANK,
        specs: Specs::new(),
        theta: [T::ZERO; MAXP],
        bounds: Bounds::BLANK,
        cfg: AdaptConfig::BLANK,
        forget: T::ZERO,
        bank: Bank::BLANK,
        probes: Probes::BLANK,
        global: WindowSearch::BLANK,
        block: Information::BLANK,
        acc: Information::BLANK,
        acc_sq: [[T::ZERO; MAXP]; MAXP],
        total: Information::BLANK,
        accel_row: StateRow::from_array_storage(nalgebra::ArrayStorage([[T::ZERO; 1]; NX])),
        gyro_row: StateRow::from_array_storage(nalgebra::ArrayStorage([[T::ZERO; 1]; NX])),
        steps: 0,
        updates: 0,
        jumps: 0,
        epochs: 0,
        last_gain: T::ZERO,
        searching: false,
        clamped: false,
        last_global: Found::BLANK,
        switches: 0,
        flat: 0,
        at_start: false,
    };

    /// Starts from `model` (its parameters are the initial guess).
    pub fn new(model: InsModel<T>, cfg: AdaptConfig<T>) -> Result<Self, AdaptError> {
        let mut f = Self::BLANK;
        f.init(model, cfg)?;
        Ok(f)
    }

    /// [`new`](Self::new) in place: the filters (about 21 KB in `f32`) are initialised where
    /// they are, never built on the stack and moved. On error the filter must not be stepped
    /// (initialise it again).
    pub fn init(&mut self, model: InsModel<T>, cfg: AdaptConfig<T>) -> Result<(), AdaptError> {
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
        let specs = specs(&model);
        if specs.is_empty() {
            return Err(AdaptError::NoParameters);
        }
        let theta0 = theta_of(&model, &specs);
        let bounds = Bounds::new(&specs, &theta0, model.dt, cfg.tau_max, cfg.spread, cfg.h);
        let theta = bounds.clamp(&theta0, specs.len());
        let (accel_row, gyro_row) = output_rows(&model)?;
        self.bank.init(&model, &specs, cfg.h)?;
        self.bank.set_theta(&theta)?;
        let forget = (-T::lit(f64::from(cfg.block)) * model.dt / cfg.window).exp();
        if cfg.probe_factor > T::one() {
            self.probes.init(&specs, cfg.probe_factor, self.bank.p0());
        } else {
            self.probes.init(&Specs::new(), T::lit(2.0), self.bank.p0());
        }
        self.probes.anchor(&theta, &bounds, specs.len());
        self.global.init(cfg.global, &theta);
        self.base = model;
        self.specs = specs;
        self.theta = theta;
        self.bounds = bounds;
        self.cfg = cfg;
        self.forget = forget;
        self.block = Information::BLANK;
        self.acc = Information::BLANK;
        self.acc_sq = [[T::zero(); MAXP]; MAXP];
        self.total = Information::BLANK;
        self.accel_row = accel_row;
        self.gyro_row = gyro_row;
        self.steps = 0;
        self.updates = 0;
        self.jumps = 0;
        self.epochs = 0;
        self.last_gain = T::zero();
        self.searching = true;
        self.clamped = false;
        self.last_global = Found::BLANK;
        self.switches = 0;
        self.flat = 0;
        self.at_start = true;
        Ok(())
    }

    /// One filter cycle with velocity observation `z` [m/s] (non-finite: missing), then, every
    /// `block` steps, one Gauss-Newton update of the parameters.
    pub fn step(&mut self, z: T) -> StepReport<T> {
        self.step_gated(z, None)
    }

    /// [`step`](Self::step) with a chi-square outlier gate: an observation whose NIS on the
    /// centre filter exceeds `gate` is used by no filter (bank or probes) and reported as
    /// [`StepStatus::Gated`] with its innovation.
    pub fn step_gated(&mut self, z: T, gate: Option<T>) -> StepReport<T> {
        let out = self.bank.step(z, &mut self.block, gate);
        let nan = T::lit(f64::NAN);
        let [centre] = out.centre;
        let [gated] = out.gated;
        let (innovation, variance, status) = match (centre, gated) {
            (Some(MemberInnovation { nu, s }), _) => (nu, s, StepStatus::Updated),
            (None, Some(MemberInnovation { nu, s })) => (nu, s, StepStatus::Gated),
            (None, None) if z.is_finite() => (nan, nan, StepStatus::BadInnovationVariance),
            (None, None) => (nan, nan, StepStatus::Missing),
        };
        // The probes see what the bank saw: a gated observation is missing for them too.
        let z = if gated.is_some() { nan } else { z };
        let (mut moved, mut rejected, mut jumped, mut switched) = (false, false, false, false);
        if out.failed {
            // A staggered move could not be discretised: the bank rolls back; follow it.
            self.theta = *self.bank.theta();
            rejected = true;
        }
        if !self.probes.is_empty() {
            let res = self.probes.step(
                &[z],
                (self.bank.centre(), &[centre]),
                self.bank.rows(),
                &self.base,
                &self.specs,
                self.bank.scale_array(),
                self.cfg.warmup,
            );
            rejected |= res.is_err();
        }
        let changed = self.global.push(z, &self.base, &self.specs);
        if changed {
            // The windowed information describes the sensor before the change.
            self.acc = Information::default();
            self.acc_sq = [[T::zero(); MAXP]; MAXP];
        }
        if self.global.due() {
            self.global.start(&self.theta);
        }
        if let Some(found) = self.global.work(&self.base, &self.specs, &self.bounds) {
            let switches = self.switches;
            jumped |= self.global_end(&found);
            switched = self.switches != switches;
            // The model the filter now runs is watched for a change in service.
            self.global.watch(&self.theta);
        }
        self.steps = self.steps.wrapping_add(1);
        if !self.probes.is_empty() && self.steps.checked_rem(self.cfg.epoch) == Some(0) {
            match self.epoch_end() {
                Ok(j) => jumped = j,
                Err(_) => rejected = true,
            }
        }
        // `checked_rem`: no division-by-zero panic path (`block` and `epoch` are validated to be
        // non-zero, so this is `steps % block == 0`).
        if self.steps.checked_rem(self.cfg.block) == Some(0) {
            // No Gauss-Newton move on the step of a jump (its information was just discarded),
            // nor before the first epoch has chosen the basin.
            let holding = self.cfg.hold_first_epoch
                && self.searching
                && (!self.probes.is_empty() || self.cfg.global.enabled());
            let held = self.cfg.global.enabled() && self.cfg.global.hold_recursion;
            let allow = !holding && !jumped && !held;
            match self.update(allow) {
                Ok(m) => moved = m,
                Err(_) => rejected = true,
            }
        }
        moved |= jumped;
        if moved || switched || changed {
            self.at_start = false;
        }
        let clamped = moved && core::mem::take(&mut self.clamped);
        StepReport {
            innovation,
            variance,
            status,
            moved,
            jumped,
            rejected,
            clamped,
            switched,
            changed,
        }
    }

    /// Structure switches so far.
    pub fn switches(&self) -> u32 {
        self.switches
    }

    /// The global stage's window and search state.
    pub fn global(&self) -> &WindowSearch<T> {
        &self.global
    }

    /// The model this filter started from (what `theta` is applied to).
    pub fn base(&self) -> &InsModel<T> {
        &self.base
    }

    /// The last finished global search (zero gain and no evaluations before the first).
    pub fn last_global(&self) -> &Found<T> {
        &self.last_global
    }

    /// The identified coordinates (bit `i`: `theta[i]`, in [`specs`](Self::specs) order)
    /// the last global search's window did not identify: "not identifiable from these data
    /// yet" (issue 13, item 2; [`Found::flat`]). Zero before the first search and after a
    /// structure switch.
    pub fn flat(&self) -> u8 {
        self.flat
    }

    /// The Cramér-Rao standard deviations (`ln`) of the parameters the filter runs, as the
    /// step reports them: with the global stage, from the last search's window
    /// ([`Found::sd`]: the data that chose them); otherwise, or before the first search, the
    /// recursion's [`windowed_sd`](Self::windowed_sd).
    pub fn cr_sd(&self) -> Option<[T; MAXP]> {
        if self.cfg.global.enabled() && self.last_global.evaluations > 0 {
            self.last_global.sd(self.specs.len())
        } else {
            self.windowed_sd()
        }
    }

    /// The block update (module documentation). Returns whether `theta` moved.
    fn update(&mut self, allow_move: bool) -> Result<bool, AdaptError> {
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

    /// The identified parameters as `ln` values, in [`specs`](Self::specs) order.
    pub fn theta(&self) -> &[T; MAXP] {
        &self.theta
    }

    /// What each entry of `theta` is.
    pub fn specs(&self) -> &Specs {
        &self.specs
    }

    /// The model with the current parameters.
    pub fn model(&self) -> Result<InsModel<T>, AdaptError> {
        apply(&self.base, &self.specs, &self.theta).ok_or(AdaptError::BadParameter)
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

    /// Parameter updates applied so far.
    pub fn updates(&self) -> u32 {
        self.updates
    }

    /// Jumps to a probe so far.
    pub fn jumps(&self) -> u32 {
        self.jumps
    }

    /// The best probe's log-likelihood advantage over the centre in the last epoch [nats]
    /// (telemetry: a jump needs more than `margin`).
    pub fn last_gain(&self) -> T {
        self.last_gain
    }

    /// The centre filter (scaled states; see [`Bank::scale`](bank::Bank::scale)).
    pub fn centre(&self) -> &bank::Member<T> {
        self.bank.centre()
    }

    /// Number of active states of the filters.
    pub fn active(&self) -> usize {
        self.bank.active()
    }

    /// Member repairs so far.
    pub fn repairs(&self) -> u32 {
        self.bank.repairs
    }

    /// The centre filter's estimates in SI units.
    pub fn estimates(&self) -> Estimates<T> {
        let c = self.bank.centre();
        Estimates::from_kalman(&c.kf, &self.bank.scale(), &self.accel_row, &self.gyro_row)
    }
}

/// The rows that sum each sensor's component states (for [`Estimates`]), in the scaling the bank
/// chooses from the same model.
fn output_rows<T: Real>(model: &InsModel<T>) -> Result<(StateRow<T>, StateRow<T>), AdaptError> {
    let scale = model.scaling().map_err(AdaptError::Model)?;
    let accel = model
        .output_row(ErrorSource::Accel, &scale)
        .map_err(AdaptError::Model)?;
    let gyro = model
        .output_row(ErrorSource::Gyro, &scale)
        .map_err(AdaptError::Model)?;
    Ok((accel, gyro))
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod vector_bank_tests;
