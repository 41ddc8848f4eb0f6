//! The records the 1 Hz step sends besides the per-tick [`Record`](super::Record): the model's
//! parameters at each re-identification, and the paper's autocorrelation identification of the
//! estimates.

use crate::model::{ComponentKind, ErrorSource, InsModel, Summary};
use crate::Real;

/// One component of the model in use, sent at each re-identification (and at the first tick).
/// The list of records of one tick is the selected structure: kinds in state order.
///
/// `tau`, `sigma`, `beta` follow the parameters file of `hal-sim run`: `sigma` is the standard
/// deviation, or `sqrt(q)` for a random walk, or the density for white noise; NaN where a kind
/// has no such parameter.
///
/// `sd_tau`, `sd_sigma`, `sd_beta` are the Cramér-Rao standard deviations of the *natural
/// logarithms* of those values (relative standard deviations), from the Fisher information the
/// online identification gathered over its exponential window, as that window weighs it (the
/// adaptive filter's `windowed_sd`): the interval `value * exp(±1.96 sd)` is its approximate
/// 95 % Cramér-Rao interval. NaN when the quantity is not identified online (a fixed model, a quantity beyond
/// the identification's capacity), or while the information is not yet positive definite.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParamRecord {
    /// Tick index.
    pub k: u32,
    /// Time [s].
    pub t: f64,
    /// Which error source the component models.
    pub sensor: ErrorSource,
    /// Index of the component within the sensor.
    pub component: u8,
    /// Its kind.
    pub kind: ComponentKind,
    /// Correlation time [s].
    pub tau: f32,
    /// Standard deviation (see above).
    pub sigma: f32,
    /// Oscillation frequency [rad/s].
    pub beta: f32,
    /// Cramér-Rao standard deviation of `ln tau` (see above; NaN: not identified).
    pub sd_tau: f32,
    /// Cramér-Rao standard deviation of `ln sigma` (NaN: not identified).
    pub sd_sigma: f32,
    /// Cramér-Rao standard deviation of `ln beta` (NaN: not identified).
    pub sd_beta: f32,
    /// The quantities the online identification's last window search did not identify (issue
    /// 13, item 2: "not identifiable from these data yet"; Cramér-Rao sd above
    /// [`IDENTIFIABLE_SD`](crate::model::IDENTIFIABLE_SD) decades): bits [`FLAT_TAU`],
    /// [`FLAT_SIGMA`], [`FLAT_BETA`].
    pub flat: u8,
}

/// [`ParamRecord::flat`]: the correlation time is not identifiable from these data yet.
pub const FLAT_TAU: u8 = 1 << 0;
/// [`ParamRecord::flat`]: the standard deviation (or density, or random-walk intensity) is not.
pub const FLAT_SIGMA: u8 = 1 << 1;
/// [`ParamRecord::flat`]: the oscillation frequency is not.
pub const FLAT_BETA: u8 = 1 << 2;

impl ParamRecord {
    /// Sets the parameters of the component this record describes in `m` (the inverse of
    /// [`model_params`]: a model rebuilt from a telemetry log's last parameter records).
    /// Returns `false`, leaving `m` unchanged, when `m` has no such component or its kind
    /// differs from the record's.
    pub fn apply_to<T: Real>(&self, m: &mut InsModel<T>) -> bool {
        let v = |x: f32| x.is_finite().then(|| T::lit(f64::from(x)));
        let i = usize::from(self.component);
        if self.sensor == ErrorSource::Observation {
            return match m.colored.get_mut(i) {
                Some(g) if self.kind == ComponentKind::GaussMarkov => {
                    g.tau = T::lit(f64::from(self.tau));
                    g.sigma = T::lit(f64::from(self.sigma));
                    true
                }
                _ => false,
            };
        }
        let comps = if self.sensor == ErrorSource::Accel {
            &mut m.accel
        } else {
            &mut m.gyro
        };
        let Some(c) = comps.get_mut(i).filter(|c| c.kind() == self.kind) else {
            return false;
        };
        c.set_summary(&Summary {
            tau: v(self.tau),
            sigma: v(self.sigma),
            beta: v(self.beta),
        });
        true
    }
}

/// Field names of the defmt parameter frame, in order (see [`ParamRecord::log`]).
pub const PARAM_WIRE_FIELDS: [&str; 12] = [
    "k", "t", "sensor", "comp", "kind", "tau", "sigma", "beta", "sd_tau", "sd_sigma", "sd_beta",
    "flat",
];

/// First word of the defmt parameter frame.
pub const PARAM_WIRE_TAG: &str = "par";

/// The paper's identification of one sensor from the autocorrelation of its estimates.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AcfRecord {
    /// Tick index.
    pub k: u32,
    /// Time [s].
    pub t: f64,
    /// The sensor.
    pub sensor: ErrorSource,
    /// `1 / alpha` from the bias-corrected lag-1 estimator [s] (NaN: no estimate).
    pub tau: f32,
    /// `sqrt(R_0 + mean(P))` (NaN: no estimate).
    pub sigma: f32,
}

/// First word of the defmt autocorrelation frame.
pub const ACF_WIRE_TAG: &str = "acf";

/// Wire code of an error source (its position in `accel, gyro, observation`).
pub const fn sensor_code(s: ErrorSource) -> u8 {
    match s {
        ErrorSource::Accel => 0,
        ErrorSource::Gyro => 1,
        ErrorSource::Observation => 2,
    }
}

impl ParamRecord {
    /// Writes the record as one flat defmt frame (fields as in [`PARAM_WIRE_FIELDS`]; sensor
    /// and kind as their wire codes).
    #[cfg(feature = "defmt")]
    pub fn log(&self) {
        defmt::info!(
            "par k={=u32} t={=f64} sensor={=u8} comp={=u8} kind={=u8} tau={=f32} sigma={=f32} beta={=f32} sd_tau={=f32} sd_sigma={=f32} sd_beta={=f32} flat={=u8}",
            self.k,
            self.t,
            sensor_code(self.sensor),
            self.component,
            self.kind.code(),
            self.tau,
            self.sigma,
            self.beta,
            self.sd_tau,
            self.sd_sigma,
            self.sd_beta,
            self.flat
        );
    }
}

impl AcfRecord {
    /// Writes the record as one flat defmt frame.
    #[cfg(feature = "defmt")]
    pub fn log(&self) {
        defmt::info!(
            "acf k={=u32} t={=f64} sensor={=u8} tau={=f32} sigma={=f32}",
            self.k,
            self.t,
            sensor_code(self.sensor),
            self.tau,
            self.sigma
        );
    }
}

/// Calls `out` with one [`ParamRecord`] per component of `m` (accelerometer, gyro, then the
/// coloured observation noise), in state order.
pub fn model_params<T: Real>(m: &InsModel<T>, k: u32, t: f64, mut out: impl FnMut(&ParamRecord)) {
    let f = |x: T| x.as_f64() as f32;
    let nan = f32::NAN;
    for (sensor, comps) in [(ErrorSource::Accel, &m.accel), (ErrorSource::Gyro, &m.gyro)] {
        for (i, c) in comps.iter().enumerate() {
            let s = c.summary();
            let g = |x: Option<T>| x.map_or(nan, f);
            out(&ParamRecord {
                k,
                t,
                sensor,
                component: i as u8,
                kind: c.kind(),
                tau: g(s.tau),
                sigma: g(s.sigma),
                beta: g(s.beta),
                sd_tau: nan,
                sd_sigma: nan,
                sd_beta: nan,
                flat: 0,
            });
        }
    }
    for (i, g) in m.colored.iter().enumerate() {
        out(&ParamRecord {
            k,
            t,
            sensor: ErrorSource::Observation,
            component: i as u8,
            kind: ComponentKind::GaussMarkov,
            tau: f(g.tau),
            sigma: f(g.sigma),
            beta: nan,
            sd_tau: nan,
            sd_sigma: nan,
            sd_beta: nan,
            flat: 0,
        });
    }
}
