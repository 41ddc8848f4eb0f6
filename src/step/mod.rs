//! The 1 Hz step of the firmware: one function call per tick that predicts and updates the
//! filter, gates outliers, feeds the autocorrelators, re-identifies the noise model on schedule
//! and feeds it back into `Phi` and `Q`, and says what it did in a small [`Report`].
//!
//! The [`Estimator`] never reads a clock or touches hardware: the caller passes the time and the
//! observation in (from a timer and a serial port on a board, from a recorded log under QEMU or
//! on the host) and hands the report to a [`TelemetrySink`]. It allocates nothing; it lives in a
//! `static` or in a struct the binary owns (about 32 KB in `f32`, see `BENCHMARKS.md`).
//!
//! Two engines share the interface: a fixed model ([`ErrorStateFilter`]) and the online
//! identification ([`AdaptiveFilter`], issue 3), chosen by [`StepConfig::adapt`].
//!
//! The estimator is generic over the error model like its engines: `Estimator<T, M, N, Z, W>`
//! for any [`IdentifiableModel`] with `N` states and `Z` observation axes (`W`: the global
//! stage's ring). [`tick_axes`](Estimator::tick_axes) and [`push_axes`](Estimator::push_axes)
//! are its step for any model, with per-axis flags, a vector chi-square gate and the
//! [`AxesRecord`](crate::telemetry::AxesRecord) telemetry; the one-channel Schuler model (the
//! default type parameters) keeps its scalar [`tick`](Estimator::tick), [`push`](Estimator::push)
//! and wire [`Record`], which are `tick_axes` with one axis plus the paper's autocorrelation
//! loop. The time rules are [`clock`]'s, the same for both.
//!
//! ```
//! use imu_ident::model::InsModel;
//! use imu_ident::step::{StepConfig, Estimator};
//! use imu_ident::telemetry::{Record, MISSING};
//!
//! let mut nav = Estimator::<f32>::new(InsModel::paper(), StepConfig::default()).unwrap();
//! let first = nav.tick(1.0, 0.02);
//! assert!(first.reidentified); // the starting parameters are reported once
//! let r = nav.tick(2.0, f32::NAN);
//! assert!(r.record.has(MISSING));
//!
//! // A replay: rows with gaps and repeated times, every tick sent to a sink.
//! let mut got: Vec<Record> = Vec::new();
//! let mut sink = |r: &Record| got.push(*r);
//! nav.push(5.0, 0.01, &mut sink); // t = 3, 4 are bridged as missing ticks
//! nav.push(5.0, 0.01, &mut sink); // time does not advance: skipped and flagged
//! assert_eq!(got.len(), 4);
//! ```
//!
//! # Outlier gate
//!
//! An observation is withheld when its NIS exceeds `g s`, with `g` = [`StepConfig::gate`] (a
//! chi-square quantile with one degree of freedom) and `s >= 1` a running scale of the NIS:
//!
//! ```text
//! s <- min(S_MAX, max(1, (1 - a) s + a min(NIS, g s))),   a = 1/64, over every finite innovation
//! ```
//!
//! with `S_MAX` = [`StepConfig::max_gate_scale`]. With `Z` axes, an observation with `m` finite
//! axes is gated on its NIS against `q_m s`, where `q_m` is the chi-square(`m`) quantile at the
//! tail probability of `g` for one axis ([`chi_square`](crate::filter::chi_square); `q_1 = g`),
//! and `s` follows `NIS / m` capped at `q_m s / m` (the NIS per degree of freedom, 1 in the mean
//! under a right model).
//!
//! A fixed threshold would shield a badly wrong model from the very data that must correct it
//! (a model with 10x too small a sigma sees NIS ~ 100 chi-square: most observations would be
//! rejected and the identification would starve). With `s`, isolated outliers (a GNSS jump)
//! are rejected, while a persistent change raises `s` by up to `a g = 47 %` per tick and is
//! accepted after a few ticks.

// The engine enum holds either filter by value (no heap); its size is the adaptive one.
#![allow(clippy::large_enum_variant)]

mod acf;
mod axes;
pub mod clock;
mod one_channel;

pub use crate::telemetry::{model_params, AcfRecord, ParamRecord};
pub use axes::AxesReport;

use crate::adapt::identifiable::IdentifiableModel;
use crate::adapt::{AdaptConfig, AdaptError, AdaptiveFilter, WINDOW_CAP};
use crate::autocorr::Autocorrelator;
use crate::filter::{chi_square, ErrorStateFilter, Kalman};
use crate::model::{InsModel, ModelError, NX};
use crate::telemetry::Record;
use crate::Real;
use clock::Clock;
use nalgebra::SMatrix;

/// Window of the estimate autocorrelators [samples].
pub const ACF_WINDOW: usize = 1024;
/// Lags kept by the estimate autocorrelators.
pub const ACF_LAGS: usize = 16;

/// The estimate autocorrelator of one sensor.
pub type EstimateAcf<T> = Autocorrelator<T, ACF_WINDOW, ACF_LAGS>;

/// Why an estimator could not be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StepError {
    /// The model was rejected by the fixed filter.
    Model(ModelError),
    /// The adaptive filter rejected the model or its configuration.
    Adapt(AdaptError),
    /// An estimator setting is out of range.
    BadConfig,
}

/// Settings of the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepConfig<T> {
    /// `None`: run the model as given; `Some`: identify it online.
    pub adapt: Option<AdaptConfig<T>>,
    /// Base outlier gate on the NIS (module documentation). `30` is the chi-square(1) quantile
    /// at `1 - 4.3e-8`: about one false rejection per 270 days at 1 Hz under a right model.
    pub gate: T,
    /// Upper bound `S_MAX` of the gate's NIS scale `s` (module documentation); default `1e6`.
    /// The threshold `g s` must stay finite (an infinite one lets an infinite NIS through), and
    /// an innovation beyond about `sqrt(g S_MAX)` standard deviations (5500 by default) is never
    /// taken, however long it persists: while it is gated the filter only predicts, `P` and so
    /// `S` grow, and a genuine change is taken once `S` has grown to it.
    pub max_gate_scale: T,
    /// Longest gap in the observation times bridged by missing-observation ticks. A longer gap
    /// bridges this many ticks and flags [`TIME_JUMP`]; it bounds the work of one
    /// [`push`](Estimator::push).
    pub max_bridge: u32,
    /// Ticks between autocorrelation identifications of the estimates (the paper's loop, kept
    /// as telemetry for comparison).
    pub acf_every: u32,
}

impl<T: Real> Default for StepConfig<T> {
    fn default() -> Self {
        Self {
            adapt: None,
            gate: T::lit(30.0),
            max_gate_scale: T::lit(1.0e6),
            max_bridge: 86_400,
            acf_every: 600,
        }
    }
}

impl<T: Real> StepConfig<T> {
    /// The default settings with the default online identification.
    pub fn adaptive() -> Self {
        Self {
            adapt: Some(AdaptConfig::default()),
            ..Self::default()
        }
    }

    /// The default settings with the online identification's global stage
    /// ([`AdaptConfig::global`]).
    pub fn adaptive_global() -> Self {
        Self {
            adapt: Some(AdaptConfig::global()),
            ..Self::default()
        }
    }

    /// [`adaptive_global`](Self::adaptive_global) with the structure test on
    /// (Gauss-Markov <-> exp-cosine switching; off by default, `docs/ADAPTATION.md` §7.6).
    pub fn adaptive_structure() -> Self {
        let mut a = AdaptConfig::global();
        a.global = crate::adapt::window::WindowConfig::with_structure();
        Self {
            adapt: Some(a),
            ..Self::default()
        }
    }
}

/// What one tick did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Report {
    /// The telemetry record of the tick.
    pub record: Record,
    /// The parameters changed at this tick (or it is the first tick): send them.
    pub reidentified: bool,
    /// The identification jumped to another basin (a probe won).
    pub jumped: bool,
    /// The estimate autocorrelators were evaluated at this tick.
    pub acf: bool,
}

// Adaptive first: the all-zero `BLANK` estimator holds it, and an all-zero-bits `static`
// goes to `.bss` (no flash image).
#[derive(Debug, Clone)]
enum Engine<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize, const W: usize>
{
    Adaptive(AdaptiveFilter<T, M, N, Z, W>),
    Fixed(ErrorStateFilter<T, M, N, Z>),
}

/// The estimator of the firmware: filter, identification, gate and bookkeeping, for any
/// error model (module documentation); the one-channel Schuler model by default.
#[derive(Debug, Clone)]
pub struct Estimator<
    T: Real,
    M = InsModel<T>,
    const N: usize = NX,
    const Z: usize = 1,
    const W: usize = WINDOW_CAP,
> where
    M: IdentifiableModel<T, N, Z>,
{
    engine: Engine<T, M, N, Z, W>,
    /// The fixed engine's [`Outputs`](IdentifiableModel::Outputs) (the adaptive filter keeps
    /// its own).
    outputs: M::Outputs,
    cfg: StepConfig<T>,
    /// `q_m` for `m = 1..=Z` finite axes: the chi-square(`m`) quantile at the tail of the
    /// gate `g = q_1` (module documentation).
    quantiles: [T; Z],
    dt: T,
    acf: [EstimateAcf<T>; 2],
    /// Running mean of each estimate's variance `P` over the ACF window (`sigma^2` correction).
    p_mean: [T; 2],
    nis_scale: T,
    clock: Clock,
    k: u32,
    repairs: u32,
}

impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize, const W: usize>
    Estimator<T, M, N, Z, W>
{
    /// An uninitialised estimator (a compile-time value, all zeros): the firmware keeps one in
    /// a `static` (no flash, no stack) and calls [`init`](Self::init) on it.
    pub const BLANK: Self = Self {
        engine: Engine::Adaptive(AdaptiveFilter::BLANK),
        outputs: M::NO_OUTPUTS,
        cfg: StepConfig {
            // `Some`: `None` would be stored as a non-zero niche value, which would put the
            // whole blank estimator in `.data` (30 KB of flash).
            adapt: Some(AdaptConfig::BLANK),
            gate: T::ZERO,
            max_gate_scale: T::ZERO,
            max_bridge: 0,
            acf_every: 0,
        },
        quantiles: [T::ZERO; Z],
        dt: T::ZERO,
        acf: [EstimateAcf::new(), EstimateAcf::new()],
        p_mean: [T::ZERO; 2],
        nis_scale: T::ZERO,
        clock: Clock::BLANK,
        k: 0,
        repairs: 0,
    };

    /// An estimator starting from `model`. For the one-channel model,
    /// [`new`](Estimator::new) says the same without naming the type's parameters.
    pub fn from_model(model: M, cfg: StepConfig<T>) -> Result<Self, StepError> {
        let mut nav = Self::BLANK;
        nav.init(model, cfg)?;
        Ok(nav)
    }

    /// [`from_model`](Self::from_model) in place, for an estimator in a `static`: nothing of
    /// its ~32 KB is built on the stack and moved (measured: by-value construction peaked at
    /// 94 KB of stack on the Cortex-M4, in place 18 KB; `BENCHMARKS.md`). On error it must not
    /// be ticked.
    pub fn init(&mut self, model: M, cfg: StepConfig<T>) -> Result<(), StepError> {
        let gate_ok = cfg.gate.is_finite()
            && cfg.gate > T::one()
            && cfg.max_gate_scale >= T::one()
            && (cfg.gate * cfg.max_gate_scale).is_finite();
        if !gate_ok || cfg.acf_every == 0 || cfg.max_bridge == 0 {
            return Err(StepError::BadConfig);
        }
        // `q_1 = g` itself; more axes get the chi-square quantile at the tail of the one-axis
        // gate (computed only when there are more: a one-axis firmware links no `erfc`). A gate
        // beyond about 1400, whose tail underflows an `f64`, keeps `q_m = g`: the quantiles'
        // ratio tends to 1 there (`q_2 - q_1 ~ ln q_1` against `q_1`).
        let mut quantiles = [cfg.gate; Z];
        let tail = if Z > 1 {
            chi_square::survival(1, cfg.gate.as_f64())
        } else {
            0.0
        };
        if tail > 0.0 {
            for (m, q) in quantiles.iter_mut().enumerate().skip(1) {
                *q = T::lit(chi_square::quantile(m + 1, tail));
            }
        }
        self.quantiles = quantiles;
        if !self.quantiles.iter().all(|q| q.is_finite()) {
            return Err(StepError::BadConfig);
        }
        let dt = model.dt();
        match cfg.adapt {
            None => self.init_fixed(model)?,
            Some(a) => {
                if !matches!(self.engine, Engine::Adaptive(_)) {
                    self.engine = Engine::Adaptive(AdaptiveFilter::BLANK);
                }
                if let Engine::Adaptive(f) = &mut self.engine {
                    f.init(model, a).map_err(StepError::Adapt)?;
                }
            }
        }
        self.cfg = cfg;
        self.dt = dt;
        for acf in self.acf.iter_mut() {
            acf.reset();
        }
        self.p_mean = [T::zero(); 2];
        self.nis_scale = T::one();
        self.clock = Clock::BLANK;
        self.k = 0;
        self.repairs = 0;
        Ok(())
    }

    /// The fixed engine, small (a few KB), built in place. Not inlined: its frame would
    /// otherwise add to the stack of every [`init`](Self::init), the adaptive one's too
    /// (measured: the adaptive firmware's start-up at 20.7 KB of stack with it inlined, 10.6 KB
    /// without; `BENCHMARKS.md`).
    #[inline(never)]
    fn init_fixed(&mut self, model: M) -> Result<(), StepError> {
        self.engine = Engine::Fixed(ErrorStateFilter::new(model).map_err(StepError::Model)?);
        if let Engine::Fixed(f) = &self.engine {
            self.outputs = f.model().outputs(f.scale()).map_err(StepError::Model)?;
        }
        Ok(())
    }

    /// The settings.
    pub fn config(&self) -> &StepConfig<T> {
        &self.cfg
    }

    /// Ticks so far.
    pub fn ticks(&self) -> u32 {
        self.k
    }

    /// The current outlier threshold on the NIS of one axis, `g s`.
    pub fn gate_threshold(&self) -> T {
        self.cfg.gate * self.nis_scale
    }

    /// The threshold on the NIS of `m` finite axes, `q_m s` (NaN for `m` outside `1..=Z`).
    pub fn gate_threshold_axes(&self, m: usize) -> T {
        let q = m.checked_sub(1).and_then(|i| self.quantiles.get(i));
        q.map_or(T::lit(f64::NAN), |q| *q * self.nis_scale)
    }

    /// The model in use (with the identified parameters when adapting).
    pub fn model(&self) -> Result<M, StepError> {
        match &self.engine {
            Engine::Fixed(f) => Ok(f.model().clone()),
            Engine::Adaptive(a) => a.model().map_err(StepError::Adapt),
        }
    }

    /// The adaptive filter, when identifying online.
    pub fn adaptive(&self) -> Option<&AdaptiveFilter<T, M, N, Z, W>> {
        match &self.engine {
            Engine::Adaptive(a) => Some(a),
            Engine::Fixed(_) => None,
        }
    }

    /// The (centre) filter's kernel, in scaled states.
    pub fn kalman(&self) -> &Kalman<T, N> {
        match &self.engine {
            Engine::Fixed(f) => f.kalman(),
            Engine::Adaptive(a) => &a.centre().kf,
        }
    }

    /// The state scaling `S` (physical = `S` x scaled).
    pub fn scale(&self) -> &[T; N] {
        match &self.engine {
            Engine::Fixed(f) => f.scale(),
            Engine::Adaptive(a) => a.scale(),
        }
    }

    /// The covariance of the (centre) filter in its scaled states, and the number of active
    /// states (the leading block; the rest is zero).
    pub fn covariance_scaled(&self) -> (SMatrix<T, N, N>, usize) {
        let kf = self.kalman();
        (kf.covariance(), kf.active())
    }

    /// The state estimate in physical units, `S x`.
    pub fn state_si(&self) -> [T; N] {
        self.kalman().state_si(self.scale())
    }

    /// Each state's standard deviation in physical units.
    pub fn sigma_si(&self) -> [T; N] {
        self.kalman().sigma_si(self.scale())
    }

    /// The NIS scale `s` of the gate (module documentation), fed the NIS per degree of
    /// freedom and the threshold per degree of freedom.
    fn track_scale(&mut self, nis: T, threshold: T) {
        if !nis.is_finite() {
            return;
        }
        let a = T::lit(1.0 / 64.0);
        let s = (T::one() - a) * self.nis_scale + a * nis.min(threshold);
        self.nis_scale = s.max(T::one()).min(self.cfg.max_gate_scale);
    }
}

#[cfg(test)]
mod axes_tests;
#[cfg(test)]
mod tests;
