//! The library of candidate effects a model may be missing, shared by `diagnose` (fitted by
//! innovation likelihood) and `identify` (fitted to Allan deviation / ACF).
//!
//! Each candidate is a (sensor, kind) pair with its free parameters in log space, a set of
//! starting points scaled to the model at hand, and a one-line physical explanation.

use imu_ident::model::{
    Component, ComponentKind, ExpCosine, GaussMarkov, InsModel, RandomConstant, RandomWalk, Sensor,
    WhiteNoise,
};
use std::f64::consts::PI;

/// One candidate effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Candidate {
    /// Where it enters.
    pub sensor: Sensor,
    /// What it is (the model-TOML kind; observation terms are Gauss-Markov).
    pub kind: ComponentKind,
}

/// The candidate library: white noise on either sensor, a second Gauss-Markov, exponential-
/// cosine, random walk and random constant on either sensor, and coloured observation noise.
pub const LIBRARY: [Candidate; 11] = {
    use ComponentKind as K;
    use Sensor as S;
    [
        Candidate {
            sensor: S::Accel,
            kind: K::White,
        },
        Candidate {
            sensor: S::Gyro,
            kind: K::White,
        },
        Candidate {
            sensor: S::Accel,
            kind: K::GaussMarkov,
        },
        Candidate {
            sensor: S::Gyro,
            kind: K::GaussMarkov,
        },
        Candidate {
            sensor: S::Accel,
            kind: K::ExpCosine,
        },
        Candidate {
            sensor: S::Gyro,
            kind: K::ExpCosine,
        },
        Candidate {
            sensor: S::Accel,
            kind: K::RandomWalk,
        },
        Candidate {
            sensor: S::Gyro,
            kind: K::RandomWalk,
        },
        Candidate {
            sensor: S::Accel,
            kind: K::RandomConstant,
        },
        Candidate {
            sensor: S::Gyro,
            kind: K::RandomConstant,
        },
        Candidate {
            sensor: S::Observation,
            kind: K::GaussMarkov,
        },
    ]
};

/// Typical magnitude of a sensor's error in `model` (sum of its components' magnitudes), with
/// tactical-grade defaults when the model has none: 1e-3 m/s^2, 0.1 deg/h, sigma_v.
pub fn sensor_scale(model: &InsModel<f64>, sensor: Sensor) -> f64 {
    let sum = |cs: &[Component<f64>]| cs.iter().map(|c| c.magnitude()).sum::<f64>();
    let (s, default) = match sensor {
        Sensor::Accel => (sum(&model.accel), 1e-3),
        Sensor::Gyro => (sum(&model.gyro), 0.1 * PI / 180.0 / 3600.0),
        Sensor::Observation => (model.sigma_v, 0.03),
    };
    if s > 0.0 && s.is_finite() {
        s
    } else {
        default
    }
}

impl Candidate {
    /// Short identifier, e.g. `gyro/exp-cosine`.
    pub fn label(&self) -> String {
        format!("{}/{}", self.sensor.name(), self.kind.name())
    }

    /// Number of free parameters (the complexity penalty counts these).
    pub fn n_params(&self) -> usize {
        match self.kind {
            ComponentKind::White | ComponentKind::RandomWalk | ComponentKind::RandomConstant => 1,
            ComponentKind::GaussMarkov => 2,
            ComponentKind::ExpCosine => 3,
        }
    }

    /// The component for log-parameters `p`: white `[ln density]`, Gauss-Markov
    /// `[ln sigma, ln tau]`, exp-cosine `[ln sigma, ln tau, ln period]` (beta = 2 pi / period),
    /// random walk `[ln q]`, random constant `[ln sigma]`. `None` when `p` is out of range.
    pub fn component(&self, p: &[f64]) -> Option<Component<f64>> {
        let e = |i: usize| {
            p.get(i)
                .map(|v| v.exp())
                .filter(|v| v.is_finite() && *v > 0.0)
        };
        let c = match self.kind {
            ComponentKind::White => Component::White(WhiteNoise::new(e(0)?).ok()?),
            ComponentKind::GaussMarkov => {
                Component::GaussMarkov(GaussMarkov::new(e(0)?, e(1)?).ok()?)
            }
            ComponentKind::ExpCosine => {
                Component::ExpCosine(ExpCosine::new(e(0)?, e(1)?, 2.0 * PI / e(2)?).ok()?)
            }
            ComponentKind::RandomWalk => Component::RandomWalk(RandomWalk::new(e(0)?, 0.0).ok()?),
            ComponentKind::RandomConstant => {
                Component::RandomConstant(RandomConstant::new(e(0)?).ok()?)
            }
        };
        Some(c)
    }

    /// `model` with the candidate added; `None` if it does not fit (state count) or `p` is bad.
    pub fn add_to(&self, model: &InsModel<f64>, p: &[f64]) -> Option<InsModel<f64>> {
        let comp = self.component(p)?;
        let mut m = model.clone();
        match (self.sensor, comp) {
            (Sensor::Accel, c) => m.accel.push(c).ok()?,
            (Sensor::Gyro, c) => m.gyro.push(c).ok()?,
            (Sensor::Observation, Component::GaussMarkov(g)) => m.colored.push(g).ok()?,
            (Sensor::Observation, _) => return None,
        }
        m.layout().ok()?;
        Some(m)
    }

    /// Starting points in log space, scaled to the model's own magnitudes.
    pub fn starts(&self, model: &InsModel<f64>) -> Vec<Vec<f64>> {
        let s = sensor_scale(model, self.sensor).ln();
        let ln = f64::ln;
        match self.kind {
            // A white density comparable to the low-frequency level of a 100 s process of the
            // sensor's magnitude, sqrt(2 tau) sigma, and a tenth of it.
            ComponentKind::White => vec![vec![s + ln(14.0)], vec![s + ln(1.4)]],
            ComponentKind::GaussMarkov => [30.0, 300.0, 3000.0]
                .iter()
                .map(|t| vec![s, ln(*t)])
                .collect(),
            ComponentKind::ExpCosine => [120.0, 600.0, 3000.0]
                .iter()
                .map(|per| vec![s, ln(2.0 * per), ln(*per)])
                .collect(),
            // Growth of one sensor magnitude over an hour, and over ten hours.
            ComponentKind::RandomWalk => {
                vec![vec![2.0 * s - ln(3600.0)], vec![2.0 * s - ln(36000.0)]]
            }
            ComponentKind::RandomConstant => vec![vec![s], vec![s - ln(10.0)]],
        }
    }

    /// One line on what the fitted effect means physically.
    pub fn explain(&self, c: &Component<f64>) -> String {
        let deg_h = 180.0 / PI * 3600.0;
        let sensor = match self.sensor {
            Sensor::Accel => "accelerometer error",
            Sensor::Gyro => "gyro drift",
            Sensor::Observation => "reference-velocity error",
        };
        match (*c, self.sensor) {
            (Component::White(w), Sensor::Gyro) => format!(
                "gyro white noise (angle random walk) of {:.3e} deg/sqrt(h): rate noise the drift model lacks",
                w.density * 180.0 / PI * 60.0
            ),
            (Component::White(w), _) => format!(
                "accelerometer white noise (velocity random walk) of {:.3e} m/s/sqrt(s): vibration or electronic noise",
                w.density
            ),
            (Component::GaussMarkov(g), Sensor::Observation) => format!(
                "reference velocity error correlated over {:.0} s (sigma {:.3e} m/s): GNSS multipath or reference filter lag",
                g.tau, g.sigma
            ),
            (Component::GaussMarkov(g), s) => format!(
                "a second correlated {sensor} with tau {:.3e} s (sigma {:.3e} {}): e.g. a thermal transient on another time scale",
                g.tau,
                g.sigma,
                if s == Sensor::Gyro { "rad/s" } else { "m/s^2" }
            ),
            (Component::ExpCosine(e), _) => format!(
                "{sensor} oscillates with period {:.3e} s, envelope {:.3e} s (thermal cycling, DTG nutation, platform sway)",
                2.0 * PI / e.beta.max(1e-300),
                e.tau
            ),
            (Component::RandomWalk(r), Sensor::Gyro) => format!(
                "gyro rate random walk, {:.3e} deg/h/sqrt(h): drift instability that grows with time",
                r.q.sqrt() * deg_h * 60.0
            ),
            (Component::RandomWalk(r), _) => format!(
                "{sensor} random walk, {:.3e} m/s^2/sqrt(s): bias instability that grows with time",
                r.q.sqrt()
            ),
            (Component::RandomConstant(r), Sensor::Gyro) => format!(
                "gyro turn-on bias of about {:.3e} deg/h, constant over the run",
                r.sigma * deg_h
            ),
            (Component::RandomConstant(r), _) => {
                format!("{sensor} turn-on bias of about {:.3e}, constant over the run", r.sigma)
            }
        }
    }
}
