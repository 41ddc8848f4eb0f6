//! The records a [`Navigator`](super::Navigator) sends besides the per-tick
//! [`Record`](crate::telemetry::Record): the model's parameters at each re-identification, and
//! the paper's autocorrelation identification of the estimates.

use super::EstimateAcf;
use crate::ident::{lag1_corrected, sigma2, SampleAcf};
use crate::model::{Component, ComponentKind, InsModel, Sensor};
use crate::Real;

/// One component of the model in use, sent at each re-identification (and at the first tick).
/// The list of records of one tick is the selected structure: kinds in state order.
///
/// `tau`, `sigma`, `beta` follow the parameters file of `hal-sim run`: `sigma` is the standard
/// deviation, or `sqrt(q)` for a random walk, or the density for white noise; NaN where a kind
/// has no such parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParamRecord {
    /// Tick index.
    pub k: u32,
    /// Time [s].
    pub t: f64,
    /// Which sensor the component models.
    pub sensor: Sensor,
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
}

impl ParamRecord {
    /// Sets the parameters of the component this record describes in `m` (the inverse of
    /// [`model_params`]: a model rebuilt from a telemetry log's last parameter records).
    /// Returns `false`, leaving `m` unchanged, when `m` has no such component or its kind
    /// differs from the record's.
    pub fn apply_to<T: Real>(&self, m: &mut InsModel<T>) -> bool {
        let v = |x: f32| T::lit(f64::from(x));
        let (tau, sigma, beta) = (v(self.tau), v(self.sigma), v(self.beta));
        let i = usize::from(self.component);
        if self.sensor == Sensor::Observation {
            return match m.colored.get_mut(i) {
                Some(g) if self.kind == ComponentKind::GaussMarkov => {
                    g.tau = tau;
                    g.sigma = sigma;
                    true
                }
                _ => false,
            };
        }
        let comps = if self.sensor == Sensor::Accel {
            &mut m.accel
        } else {
            &mut m.gyro
        };
        let Some(c) = comps.get_mut(i).filter(|c| c.kind() == self.kind) else {
            return false;
        };
        match c {
            Component::GaussMarkov(g) => {
                g.tau = tau;
                g.sigma = sigma;
            }
            Component::ExpCosine(e) => {
                e.tau = tau;
                e.sigma = sigma;
                e.beta = beta;
            }
            Component::RandomWalk(r) => r.q = sigma * sigma,
            Component::RandomConstant(r) => r.sigma = sigma,
            Component::White(w) => w.density = sigma,
        }
        true
    }
}

/// Field names of the defmt parameter frame, in order (see [`ParamRecord::log`]).
pub const PARAM_WIRE_FIELDS: [&str; 8] =
    ["k", "t", "sensor", "comp", "kind", "tau", "sigma", "beta"];

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
    pub sensor: Sensor,
    /// `1 / alpha` from the bias-corrected lag-1 estimator [s] (NaN: no estimate).
    pub tau: f32,
    /// `sqrt(R_0 + mean(P))` (NaN: no estimate).
    pub sigma: f32,
}

/// First word of the defmt autocorrelation frame.
pub const ACF_WIRE_TAG: &str = "acf";

/// Wire code of a sensor (its position in `accel, gyro, observation`).
pub const fn sensor_code(s: Sensor) -> u8 {
    match s {
        Sensor::Accel => 0,
        Sensor::Gyro => 1,
        Sensor::Observation => 2,
    }
}

/// Wire code of a component kind (its position in the model-TOML list of kinds).
pub const fn kind_code(k: ComponentKind) -> u8 {
    match k {
        ComponentKind::GaussMarkov => 0,
        ComponentKind::ExpCosine => 1,
        ComponentKind::RandomWalk => 2,
        ComponentKind::RandomConstant => 3,
        ComponentKind::White => 4,
    }
}

impl ParamRecord {
    /// Writes the record as one flat defmt frame (fields as in [`PARAM_WIRE_FIELDS`]; sensor
    /// and kind as their wire codes).
    #[cfg(feature = "defmt")]
    pub fn log(&self) {
        defmt::info!(
            "par k={=u32} t={=f64} sensor={=u8} comp={=u8} kind={=u8} tau={=f32} sigma={=f32} beta={=f32}",
            self.k,
            self.t,
            sensor_code(self.sensor),
            self.component,
            kind_code(self.kind),
            self.tau,
            self.sigma,
            self.beta
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
    for (sensor, comps) in [(Sensor::Accel, &m.accel), (Sensor::Gyro, &m.gyro)] {
        for (i, c) in comps.iter().enumerate() {
            let (tau, sigma, beta) = match c {
                Component::GaussMarkov(g) => (f(g.tau), f(g.sigma), nan),
                Component::ExpCosine(e) => (f(e.tau), f(e.sigma), f(e.beta)),
                Component::RandomConstant(r) => (nan, f(r.sigma), nan),
                Component::RandomWalk(r) => (nan, f(r.q.sqrt()), nan),
                Component::White(w) => (nan, f(w.density), nan),
            };
            out(&ParamRecord {
                k,
                t,
                sensor,
                component: i as u8,
                kind: c.kind(),
                tau,
                sigma,
                beta,
            });
        }
    }
    for (i, g) in m.colored.iter().enumerate() {
        out(&ParamRecord {
            k,
            t,
            sensor: Sensor::Observation,
            component: i as u8,
            kind: ComponentKind::GaussMarkov,
            tau: f(g.tau),
            sigma: f(g.sigma),
            beta: nan,
        });
    }
}

/// The identification of one sensor from its estimate autocorrelator and mean variance.
pub(super) fn acf_record<T: Real>(
    acf: &EstimateAcf<T>,
    p_mean: T,
    dt: T,
    sensor: Sensor,
    k: u32,
    t: f64,
) -> AcfRecord {
    let mut r = [T::zero(); 2];
    let mut out = AcfRecord {
        k,
        t,
        sensor,
        tau: f32::NAN,
        sigma: f32::NAN,
    };
    // Only a full window: a partial one after start-up would report the transient.
    if !acf.is_full() || acf.acf(&mut r).is_err() {
        return out;
    }
    let n = acf.len() as u32;
    if let Ok(a) = SampleAcf::new(&r, dt, n).and_then(|s| lag1_corrected(&s)) {
        out.tau = (T::one() / a.alpha).as_f64() as f32;
    }
    if let Ok(v) = sigma2(r[0], p_mean) {
        out.sigma = v.corrected.max(T::zero()).sqrt().as_f64() as f32;
    }
    out
}
