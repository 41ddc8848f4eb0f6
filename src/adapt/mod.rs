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
//!
//! The recursion and the probe epochs are [`Identifier`], generic over the error model like the
//! bank. [`AdaptiveFilter`] runs one and adds the global stage ([`window`]) and the structure
//! switch ([`restructure`]), generic the same way; the one-channel model is its default.

// Small fixed-size matrix code reads best with explicit indices (they mirror the equations).
#![allow(clippy::needless_range_loop)]

pub mod bank;
pub mod change;
mod config;
pub mod guard;
pub mod identifiable;
pub mod identifier;
pub mod information;
mod jump;
pub mod params;
pub mod probes;
mod report;
pub mod restructure;
pub mod window;

use crate::filter::Estimates;
use crate::model::{InsModel, ModelError, NX};
use crate::Real;
pub use config::AdaptConfig;
use identifiable::IdentifiableModel;
use identifier::{Identifier, IdentifierStep};
use information::Information;
use params::{Specs, MAXP};
pub use report::{StepReport, StepStatus};
pub use window::{Found, Switch, WindowConfig};
pub use window::{WindowSearch, WINDOW_CAP};

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

/// An INS filter that identifies its own sensor-noise parameters online: the recursive
/// [`Identifier`], with the probe grid, the global window search and the structure switch that
/// choose its basin. Generic over the error model like them (and over the capacity `W` of the
/// global stage's ring of block means); the one-channel model is the default, with its scalar
/// [`step`](Self::step) and [`estimates`](Self::estimates).
#[derive(Debug, Clone)]
pub struct AdaptiveFilter<
    T: Real,
    M = InsModel<T>,
    const N: usize = NX,
    const Z: usize = 1,
    const W: usize = WINDOW_CAP,
> where
    M: IdentifiableModel<T, N, Z>,
{
    /// The bank, `theta`, the windowed information, the Gauss-Newton recursion and the probes.
    id: Identifier<T, M, N, Z>,
    global: WindowSearch<T, M, N, Z, W>,
    /// The model's [`Outputs`](IdentifiableModel::Outputs) (for the one-channel model, the rows
    /// of [`estimates`](Self::estimates)).
    outputs: M::Outputs,
    last_global: Found<T>,
    switches: u32,
    /// The coordinates the last search's window did not identify (bit `i`: `theta[i]`).
    flat: u8,
    /// The filter still runs the start model: nothing has moved it and no change in service
    /// was found ([`WindowConfig::keep_start`](window::WindowConfig::keep_start)).
    at_start: bool,
}

/// What one [`AdaptiveFilter::step_axes`] did: the identifier's step (the centre's innovations
/// on each axis, the gated axes, the moves) and the global stage's events.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxesStep<T, const Z: usize> {
    /// The bank's step and the moves.
    pub step: IdentifierStep<T, Z>,
    /// A move ended at a physical bound.
    pub clamped: bool,
    /// A global search ended in a structure switch.
    pub switched: bool,
    /// The change monitor found a change in service.
    pub changed: bool,
}

impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize, const W: usize>
    AdaptiveFilter<T, M, N, Z, W>
{
    /// An empty filter (a compile-time value, all zeros): call [`init`](Self::init) before use.
    /// A `static` initialised with it costs no flash (it goes to `.bss`) and no stack.
    pub const BLANK: Self = Self {
        id: Identifier::BLANK,
        global: WindowSearch::BLANK,
        outputs: M::NO_OUTPUTS,
        last_global: Found::BLANK,
        switches: 0,
        flat: 0,
        at_start: false,
    };

    /// Starts from `model` (its parameters are the initial guess). For the one-channel model,
    /// [`new`](AdaptiveFilter::new) says the same without naming the type's parameters.
    pub fn from_model(model: M, cfg: AdaptConfig<T>) -> Result<Self, AdaptError> {
        let mut f = Self::BLANK;
        f.init(model, cfg)?;
        Ok(f)
    }

    /// [`from_model`](Self::from_model) in place: the filters (about 21 KB in `f32`) are
    /// initialised where they are, never built on the stack and moved. On error the filter must not
    /// be stepped (initialise it again).
    pub fn init(&mut self, model: M, cfg: AdaptConfig<T>) -> Result<(), AdaptError> {
        // The settings are checked by `Identifier::init` (the recursion's and the probes') and
        // `WindowSearch::init` (the global stage's).
        self.id.init(model, cfg)?;
        // The bank's scaling is the model's (`Bank::init`).
        self.outputs = (self.id.base)
            .outputs(self.id.bank.scale_array())
            .map_err(AdaptError::Model)?;
        self.global.init(cfg.global, &self.id.theta);
        self.last_global = Found::BLANK;
        self.switches = 0;
        self.flat = 0;
        self.at_start = true;
        Ok(())
    }

    /// One filter cycle with the observation `z` (per axis; non-finite: missing on that axis)
    /// and an optional outlier gate (`gate(k)`: the chi-square bound for `k` axes; see
    /// [`Bank::step_axes`](bank::Bank::step_axes)), then the identifier's moves and the global
    /// stage's share of the tick. A gated axis is missing for the global stage too.
    pub fn step_axes(&mut self, z: &[T; Z], gate: Option<&dyn Fn(usize) -> T>) -> AxesStep<T, Z> {
        let (out, probe_failed) = self.id.observe(z, gate);
        // The global stage sees what the bank saw: a gated observation is missing for it too.
        let mut seen = *z;
        for (v, g) in seen.iter_mut().zip(out.gated.iter()) {
            if g.is_some() {
                *v = T::lit(f64::NAN);
            }
        }
        // A staggered move that could not be discretised (the identifier followed the bank's
        // roll-back), or a probe that could not be.
        let mut step = IdentifierStep {
            bank: out,
            moved: false,
            jumped: false,
            rejected: out.failed || probe_failed,
        };
        let mut switched = false;
        let changed = self.global.push(&seen, &self.id.base, &self.id.specs);
        if changed {
            // The windowed information describes the sensor before the change.
            self.id.forget_window(false);
        }
        if self.global.due() {
            self.global.start(&self.id.theta);
        }
        if let Some(found) = self
            .global
            .work(&self.id.base, &self.id.specs, &self.id.bounds)
        {
            let switches = self.switches;
            step.jumped |= self.global_end(&found);
            switched = self.switches != switches;
            // The model the filter now runs is watched for a change in service.
            self.global.watch(&self.id.theta);
        }
        // The global stage chooses the basin like the probes, and may hold the recursion.
        let global = self.id.cfg.global;
        let held = global.enabled() && global.hold_recursion;
        self.id.conclude(&mut step, global.enabled(), held);
        if step.moved || switched || changed {
            self.at_start = false;
        }
        let clamped = step.moved && self.id.take_clamped();
        AxesStep {
            step,
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
    pub fn global(&self) -> &WindowSearch<T, M, N, Z, W> {
        &self.global
    }

    /// The model this filter started from (what `theta` is applied to).
    pub fn base(&self) -> &M {
        self.id.base()
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
        if self.id.cfg.global.enabled() && self.last_global.evaluations > 0 {
            self.last_global.sd(self.id.specs.len())
        } else {
            self.windowed_sd()
        }
    }

    /// The recursion: the bank, `theta` and the windowed information.
    pub fn identifier(&self) -> &Identifier<T, M, N, Z> {
        &self.id
    }

    /// The identified parameters as `ln` values, in [`specs`](Self::specs) order.
    pub fn theta(&self) -> &[T; MAXP] {
        self.id.theta()
    }

    /// What each entry of `theta` is.
    pub fn specs(&self) -> &Specs {
        self.id.specs()
    }

    /// The model with the current parameters.
    pub fn model(&self) -> Result<M, AdaptError> {
        self.id.model()
    }

    /// Score and Fisher information of the exponential window (what the updates use).
    pub fn windowed_information(&self) -> &Information<T> {
        self.id.windowed_information()
    }

    /// Score and Fisher information summed over the whole run without forgetting
    /// ([`Identifier::total_information`]).
    pub fn total_information(&self) -> &Information<T> {
        self.id.total_information()
    }

    /// Standard deviations of `theta` from `info` ([`Identifier::crb`]).
    pub fn crb(&self, info: &Information<T>) -> Option<[T; MAXP]> {
        self.id.crb(info)
    }

    /// Standard deviations of `theta` as the window estimates it
    /// ([`Identifier::windowed_sd`]).
    pub fn windowed_sd(&self) -> Option<[T; MAXP]> {
        self.id.windowed_sd()
    }

    /// Parameter updates applied so far.
    pub fn updates(&self) -> u32 {
        self.id.updates()
    }

    /// Jumps to another basin so far (a probe or a global search).
    pub fn jumps(&self) -> u32 {
        self.id.jumps()
    }

    /// The best probe's log-likelihood advantage over the centre in the last epoch [nats]
    /// ([`Identifier::last_gain`]).
    pub fn last_gain(&self) -> T {
        self.id.last_gain()
    }

    /// The state scaling `S` of every filter (physical = `S` x scaled), the model's.
    pub fn scale(&self) -> &[T; N] {
        self.id.bank.scale_array()
    }

    /// The centre filter (scaled states; see [`Bank::scale`](bank::Bank::scale)).
    pub fn centre(&self) -> &bank::Member<T, N> {
        self.id.centre()
    }

    /// Number of active states of the filters.
    pub fn active(&self) -> usize {
        self.id.bank.active()
    }

    /// Member repairs so far.
    pub fn repairs(&self) -> u32 {
        self.id.bank.repairs
    }
}

/// The one-channel filter's constructor, scalar step and estimates.
impl<T: Real> AdaptiveFilter<T> {
    /// Starts from `model` (its parameters are the initial guess).
    pub fn new(model: InsModel<T>, cfg: AdaptConfig<T>) -> Result<Self, AdaptError> {
        Self::from_model(model, cfg)
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
        let g = gate.map(|g| move |_: usize| g);
        let AxesStep {
            step,
            clamped,
            switched,
            changed,
        } = self.step_axes(&[z], g.as_ref().map(|f| f as &dyn Fn(usize) -> T));
        let nan = T::lit(f64::NAN);
        let (inn, status) = step.bank.axis(0, z.is_finite());
        let (innovation, variance) = inn.map_or((nan, nan), |i| (i.nu, i.s));
        StepReport {
            innovation,
            variance,
            status: status.into(),
            moved: step.moved,
            jumped: step.jumped,
            rejected: step.rejected,
            clamped,
            switched,
            changed,
        }
    }

    /// The centre filter's estimates in SI units.
    pub fn estimates(&self) -> Estimates<T> {
        let c = self.id.bank.centre();
        let (accel, gyro) = &self.outputs;
        Estimates::from_kalman(&c.kf, &self.id.bank.scale(), accel, gyro)
    }
}

#[cfg(test)]
mod global_tests;
#[cfg(test)]
mod identifier_tests;
#[cfg(test)]
mod tests;
#[cfg(test)]
pub(crate) mod vector_bank_tests;
