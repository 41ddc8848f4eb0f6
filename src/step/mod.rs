//! The 1 Hz step of the firmware: one function call per tick that predicts and updates the
//! filter, gates outliers, feeds the autocorrelators, re-identifies the noise model on schedule
//! and feeds it back into `Phi` and `Q`, and says what it did in a small [`Report`].
//!
//! The [`Estimator`] never reads a clock or touches hardware: the caller passes the time and the
//! observation in (from a timer and a serial port on a board, from a recorded log under QEMU or
//! on the host) and hands the report to a [`TelemetrySink`]. It allocates nothing; it lives in a
//! `static` or in a struct the binary owns (about 32 KB in `f32`, see `BENCHMARKS.md`).
//!
//! Two engines share the interface: a fixed model ([`InsFilter`]) and the online identification
//! ([`AdaptiveFilter`], issue 3), chosen by [`StepConfig::adapt`].
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
//! with `S_MAX` = [`StepConfig::max_gate_scale`].
//!
//! A fixed threshold would shield a badly wrong model from the very data that must correct it
//! (a model with 10x too small a sigma sees NIS ~ 100 chi-square: most observations would be
//! rejected and the identification would starve). With `s`, isolated outliers (a GNSS jump)
//! are rejected, while a persistent change raises `s` by up to `a g = 47 %` per tick and is
//! accepted after a few ticks.

// The engine enum holds either filter by value (no heap); its size is the adaptive one.
#![allow(clippy::large_enum_variant)]

mod acf;

pub use crate::telemetry::{model_params, AcfRecord, ParamRecord};
use crate::telemetry::{FLAT_BETA, FLAT_SIGMA, FLAT_TAU};

use crate::adapt::params::{Specs, MAXP};
use crate::adapt::{AdaptConfig, AdaptError, AdaptiveFilter, StepStatus};
use crate::autocorr::Autocorrelator;
use crate::filter::{Estimates, InsFilter};
use crate::model::{ErrorSource, InsModel, ModelError, Quantity, StateMat};
use crate::telemetry::{
    status_flags, time_flags, Record, TelemetrySink, BAD_INPUT, BRIDGED, GATED_OUTLIER, MISSING,
    NOT_IDENTIFIABLE, PARAM_CLAMPED, P_REPAIRED, SENSOR_CHANGE, SKIPPED, TIME_JUMP,
};
use crate::Real;

/// Window of the estimate autocorrelators [samples].
pub const ACF_WINDOW: usize = 1024;
/// Lags kept by the estimate autocorrelators.
pub const ACF_LAGS: usize = 16;

/// The estimate autocorrelator of one sensor.
pub type EstimateAcf<T> = Autocorrelator<T, ACF_WINDOW, ACF_LAGS>;

/// Why a estimator could not be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StepError {
    /// The model was rejected by the fixed filter.
    Model(ModelError),
    /// The adaptive filter rejected the model or its configuration.
    Adapt(AdaptError),
    /// A estimator setting is out of range.
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
enum Engine<T: Real> {
    Adaptive(AdaptiveFilter<T>),
    Fixed(InsFilter<T>),
}

/// The estimator of the firmware: filter, identification, gate and bookkeeping.
#[derive(Debug, Clone)]
pub struct Estimator<T: Real> {
    engine: Engine<T>,
    cfg: StepConfig<T>,
    dt: T,
    acf: [EstimateAcf<T>; 2],
    /// Running mean of each estimate's variance `P` over the ACF window (`sigma^2` correction).
    p_mean: [T; 2],
    nis_scale: T,
    prev_t: Option<f64>,
    /// A row time more than `max_bridge` steps from `prev_t`, waiting for the next row to
    /// confirm it as the new time base ([`push`](Self::push)).
    suspect_t: Option<f64>,
    k: u32,
    repairs: u32,
}

impl<T: Real> Estimator<T> {
    /// An uninitialised estimator (a compile-time value, all zeros): the firmware keeps one in
    /// a `static` (no flash, no stack) and calls [`init`](Self::init) on it.
    pub const BLANK: Self = Self {
        engine: Engine::Adaptive(AdaptiveFilter::BLANK),
        cfg: StepConfig {
            // `Some`: `None` would be stored as a non-zero niche value, which would put the
            // whole blank estimator in `.data` (30 KB of flash).
            adapt: Some(AdaptConfig::BLANK),
            gate: T::ZERO,
            max_gate_scale: T::ZERO,
            max_bridge: 0,
            acf_every: 0,
        },
        dt: T::ZERO,
        acf: [EstimateAcf::new(), EstimateAcf::new()],
        p_mean: [T::ZERO; 2],
        nis_scale: T::ZERO,
        prev_t: None,
        suspect_t: None,
        k: 0,
        repairs: 0,
    };

    /// A estimator starting from `model`.
    pub fn new(model: InsModel<T>, cfg: StepConfig<T>) -> Result<Self, StepError> {
        let mut nav = Self::BLANK;
        nav.init(model, cfg)?;
        Ok(nav)
    }

    /// [`new`](Self::new) in place, for a estimator in a `static`: nothing of its ~32 KB is
    /// built on the stack and moved (measured: by-value construction peaked at 94 KB of stack
    /// on the Cortex-M4, in place 18 KB; `BENCHMARKS.md`). On error it must not be ticked.
    pub fn init(&mut self, model: InsModel<T>, cfg: StepConfig<T>) -> Result<(), StepError> {
        let gate_ok = cfg.gate.is_finite()
            && cfg.gate > T::one()
            && cfg.max_gate_scale >= T::one()
            && (cfg.gate * cfg.max_gate_scale).is_finite();
        if !gate_ok || cfg.acf_every == 0 || cfg.max_bridge == 0 {
            return Err(StepError::BadConfig);
        }
        let dt = model.dt;
        match cfg.adapt {
            None => {
                // Small (about 2 KB): built by value.
                self.engine = Engine::Fixed(InsFilter::new(model).map_err(StepError::Model)?);
            }
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
        self.prev_t = None;
        self.suspect_t = None;
        self.k = 0;
        self.repairs = 0;
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

    /// The current outlier threshold on the NIS, `g s`.
    pub fn gate_threshold(&self) -> T {
        self.cfg.gate * self.nis_scale
    }

    /// The model in use (with the identified parameters when adapting).
    pub fn model(&self) -> Result<InsModel<T>, StepError> {
        match &self.engine {
            Engine::Fixed(f) => Ok(f.model().clone()),
            Engine::Adaptive(a) => a.model().map_err(StepError::Adapt),
        }
    }

    /// The adaptive filter, when identifying online.
    pub fn adaptive(&self) -> Option<&AdaptiveFilter<T>> {
        match &self.engine {
            Engine::Adaptive(a) => Some(a),
            Engine::Fixed(_) => None,
        }
    }

    /// The covariance of the (centre) filter in its scaled states, and the number of active
    /// states (the leading block; the rest is zero).
    pub fn covariance_scaled(&self) -> (StateMat<T>, usize) {
        match &self.engine {
            Engine::Fixed(f) => (f.kalman().covariance(), f.kalman().active()),
            Engine::Adaptive(a) => (a.centre().covariance(), a.active()),
        }
    }

    /// Estimates in SI units.
    pub fn estimates(&self) -> Estimates<T> {
        match &self.engine {
            Engine::Fixed(f) => f.estimates(),
            Engine::Adaptive(a) => a.estimates(),
        }
    }

    /// One tick at time `t` [s] with observation `z` [m/s] (non-finite: missing): exactly one
    /// prediction and at most one update, so its cost is bounded whatever the input.
    pub fn tick(&mut self, t: f64, z: T) -> Report {
        let mut flags = time_flags(self.prev_t, t, self.dt.as_f64());
        // Infinite (not NaN, which means missing): `z == z` is false only for NaN.
        #[allow(clippy::eq_op)]
        let infinite = !z.is_finite() && z == z;
        if infinite {
            flags |= BAD_INPUT;
        }
        let threshold = self.gate_threshold();
        let (nu, s, mut reidentified, jumped) = match &mut self.engine {
            Engine::Fixed(f) => {
                f.set_gate(Some(threshold));
                let inn = f.step(z);
                flags |= status_flags(inn.status);
                if f.repair() {
                    flags |= P_REPAIRED;
                }
                (inn.innovation, inn.variance, false, false)
            }
            Engine::Adaptive(a) => {
                let before = a.repairs();
                let rep = a.step_gated(z, Some(threshold));
                flags |= match rep.status {
                    StepStatus::Updated => 0,
                    StepStatus::Missing => MISSING,
                    StepStatus::Gated => GATED_OUTLIER,
                    StepStatus::BadInnovationVariance => P_REPAIRED,
                };
                if a.repairs() != before {
                    flags |= P_REPAIRED;
                }
                if rep.clamped {
                    flags |= PARAM_CLAMPED;
                }
                if rep.changed {
                    flags |= SENSOR_CHANGE;
                }
                if a.flat() != 0 {
                    flags |= NOT_IDENTIFIABLE;
                }
                (rep.innovation, rep.variance, rep.moved, rep.jumped)
            }
        };
        self.track_scale(nu * nu / s, threshold);
        let est = self.estimates();
        self.feed_acf(&est);
        if t.is_finite() {
            self.prev_t = Some(t);
        }
        reidentified |= self.k == 0;
        let record = Record::new(self.k, t, z, nu, s, &est, flags);
        self.k = self.k.wrapping_add(1);
        if flags & P_REPAIRED != 0 {
            self.repairs = self.repairs.saturating_add(1);
        }
        Report {
            record,
            reidentified,
            jumped,
            // `checked_rem`: a BLANK estimator (acf_every = 0) ticked without `init` must not panic.
            acf: self.k.checked_rem(self.cfg.acf_every) == Some(0),
        }
    }

    /// The NIS scale `s` of the gate (module documentation).
    fn track_scale(&mut self, nis: T, threshold: T) {
        if !nis.is_finite() {
            return;
        }
        let a = T::lit(1.0 / 64.0);
        let s = (T::one() - a) * self.nis_scale + a * nis.min(threshold);
        self.nis_scale = s.max(T::one()).min(self.cfg.max_gate_scale);
    }

    fn feed_acf(&mut self, est: &Estimates<T>) {
        let w = T::lit(1.0 / ACF_WINDOW as f64);
        let pairs = [(est.da, est.sigma_da), (est.dw, est.sigma_dw)];
        for ((acf, pm), (x, sd)) in self.acf.iter_mut().zip(self.p_mean.iter_mut()).zip(pairs) {
            // A rejected sample (non-finite after a repair) leaves the window as it was.
            if acf.push(x).is_ok() {
                let first = acf.len() == 1;
                *pm = if first {
                    sd * sd
                } else {
                    *pm + w * (sd * sd - *pm)
                };
            }
        }
    }

    /// One log row: bridges a gap in time with missing-observation ticks (at most
    /// [`StepConfig::max_bridge`]), skips a row whose time does not advance or is not finite,
    /// then ticks with the row. Every tick's record goes to `sink`, followed by the parameters
    /// when they changed and the autocorrelation identification when it ran.
    ///
    /// A time more than `max_bridge` steps away from the previous one, ahead or behind, is
    /// *suspect*: one corrupted time stamp must neither make every later row look as if it
    /// went backwards nor bridge a day of blind prediction. The row is skipped (`SKIPPED`,
    /// `TIME_JUMP`, and `BAD_INPUT` when behind) and its time remembered; when the next row
    /// follows it (at least half a step and at most `max_bridge` steps after it), the clock
    /// really jumped (a long outage, a reset clock): that row becomes the new time base,
    /// ticked with `TIME_JUMP` after `max_bridge` bridged ticks when the jump was forward. A
    /// row that follows the old time base instead is ticked as usual and the suspect time
    /// forgotten. The cost of a genuine jump is one row.
    pub fn push(&mut self, t: f64, z: T, sink: &mut impl TelemetrySink) {
        let dt = self.dt.as_f64();
        let span = f64::from(self.cfg.max_bridge) * dt;
        // Not `<= span` written as a negation: NaN is caught by `is_finite` first.
        let far = |p: f64| (t - p).abs() > span;
        let confirms = |c: f64| t - c >= 0.5 * dt && t - c <= span;
        let steps: f64 = match self.prev_t {
            None => 1.0,
            Some(p) if t.is_finite() && far(p) => {
                if self.suspect_t.is_some_and(confirms) {
                    // Forward: bridge the most we may (the outage was at least that long);
                    // backward: a reset clock, nothing to bridge.
                    if t > p {
                        f64::from(self.cfg.max_bridge) + 2.0
                    } else {
                        1.0
                    }
                } else {
                    self.suspect_t = Some(t);
                    0.0
                }
            }
            Some(p) => libm::round((t - p) / dt),
        };
        // Non-finite t (NaN, +-Inf), non-advancing and suspect times are skipped, never
        // misread.
        let advances = steps >= 1.0 && t.is_finite();
        if !advances {
            let nan = T::lit(f64::NAN);
            let flags = time_flags(self.prev_t, t, dt) | SKIPPED;
            sink.record(&Record::new(
                self.k,
                t,
                z,
                nan,
                nan,
                &self.estimates(),
                flags,
            ));
            return;
        }
        self.suspect_t = None;
        let gap = steps - 1.0;
        let bridged = gap.min(f64::from(self.cfg.max_bridge)) as u32;
        let start = self.prev_t.unwrap_or(t);
        for i in 1..=bridged {
            let mut r = self.tick(start + f64::from(i) * dt, T::lit(f64::NAN));
            r.record.flags |= BRIDGED;
            self.emit(&r, sink);
        }
        let mut r = self.tick(t, z);
        if gap > f64::from(bridged) {
            r.record.flags |= TIME_JUMP;
        }
        self.emit(&r, sink);
    }

    /// Sends a tick's record and what came with it.
    pub fn emit(&self, r: &Report, sink: &mut impl TelemetrySink) {
        sink.record(&r.record);
        if r.reidentified {
            if let Ok(m) = self.model() {
                // One factorisation per re-identification, shared by the records.
                let ident = self.adaptive().map(|a| (a.specs(), a.cr_sd(), a.flat()));
                model_params(&m, r.record.k, r.record.t, |p| {
                    let mut p = *p;
                    if let Some((specs, sd, flat)) = &ident {
                        add_crb(&mut p, specs, sd.as_ref(), *flat);
                    }
                    sink.params(&p);
                });
            }
        }
        if r.acf {
            for sensor in [ErrorSource::Accel, ErrorSource::Gyro] {
                sink.acf(&self.acf_identify(sensor, r.record.k, r.record.t));
            }
        }
    }

    /// The paper's identification from the estimates' autocorrelation (lag-1 bias-corrected
    /// `alpha`, `sigma^2 = R_0 + mean(P)`); NaN fields when the window cannot support it.
    pub fn acf_identify(&self, sensor: ErrorSource, k: u32, t: f64) -> AcfRecord {
        let i = usize::from(sensor == ErrorSource::Gyro);
        let (acf, pm) = (&self.acf[i], self.p_mean[i]);
        acf::acf_record(acf, pm, self.dt, sensor, k, t)
    }
}

/// Fills a parameter record's Cramér-Rao standard deviations (of `ln` of each value) from the
/// adaptive filter's [`AdaptiveFilter::cr_sd`] `sd` of its identified `specs`, and its flags
/// from [`AdaptiveFilter::flat`] (bit `i`: `specs[i]` not identifiable). A random walk's record
/// carries `sqrt(q)`, so its `ln` standard deviation is half that of the identified `ln q`.
fn add_crb<T: Real>(p: &mut ParamRecord, specs: &Specs, sd: Option<&[T; MAXP]>, flat: u8) {
    for (i, spec) in specs.iter().enumerate().take(MAXP) {
        if spec.sensor != p.sensor || spec.index != p.component {
            continue;
        }
        let s = sd
            .and_then(|sd| sd.get(i))
            .map_or(f32::NAN, |s| s.as_f64() as f32);
        let bit = if crate::adapt::params::has_coordinate(flat, i) {
            match spec.kind {
                Quantity::Tau => FLAT_TAU,
                Quantity::Beta => FLAT_BETA,
                Quantity::Sigma0 => 0,
                _ => FLAT_SIGMA,
            }
        } else {
            0
        };
        p.flat |= bit;
        match spec.kind {
            Quantity::Tau => p.sd_tau = s,
            Quantity::Sigma | Quantity::Density => p.sd_sigma = s,
            Quantity::Q => p.sd_sigma = 0.5 * s,
            Quantity::Beta => p.sd_beta = s,
            Quantity::Sigma0 => {}
        }
    }
}

#[cfg(test)]
mod tests;
