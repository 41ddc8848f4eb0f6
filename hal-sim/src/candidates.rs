//! The library of candidate effects a model may be missing, shared by `diagnose` (fitted by
//! innovation likelihood) and `identify` (fitted to Allan deviation / ACF).
//!
//! Each candidate is a (sensor, kind) pair with its free parameters in log space, a set of
//! starting points scaled to the model at hand, and a one-line physical explanation.
//!
//! `diagnose` also proposes *replacing* a component of the model by another kind
//! ([`Replacement`], over the core kind table's `ComponentKind::alternative`): a gyro drift that is an
//! exponential-cosine, modelled as a Gauss-Markov, can otherwise only be named as an addition
//! on top of the wrong component. [`Proposal`] is either change, with one interface for the fit.

use imu_ident::model::{
    Component, ComponentKind, ErrorSource, ExpCosine, GaussMarkov, InsModel, Quantity,
    RandomConstant, RandomWalk, WhiteNoise,
};
use std::f64::consts::PI;

/// One candidate effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Candidate {
    /// Where it enters.
    pub sensor: ErrorSource,
    /// What it is (the model-TOML kind; observation terms are Gauss-Markov).
    pub kind: ComponentKind,
}

/// The candidate library: white noise on either sensor, a second Gauss-Markov, exponential-
/// cosine, random walk and random constant on either sensor, and coloured observation noise.
pub const LIBRARY: [Candidate; 11] = {
    use ComponentKind as K;
    use ErrorSource as S;
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
pub fn sensor_scale(model: &InsModel<f64>, sensor: ErrorSource) -> f64 {
    let sum = |cs: &[Component<f64>]| cs.iter().map(|c| c.magnitude()).sum::<f64>();
    let (s, default) = match sensor {
        ErrorSource::Accel => (sum(&model.accel), 1e-3),
        ErrorSource::Gyro => (sum(&model.gyro), 0.1 * PI / 180.0 / 3600.0),
        ErrorSource::Observation => (model.sigma_v, 0.03),
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

    /// The indices of the log-parameters of [`component`](Self::component) that are times: a
    /// Gauss-Markov's tau, an exponential-cosine's tau and period (searched within a range of
    /// times, not about their start).
    pub fn time_params(&self) -> std::ops::Range<usize> {
        match self.kind {
            ComponentKind::GaussMarkov => 1..2,
            ComponentKind::ExpCosine => 1..3,
            _ => 1..1,
        }
    }

    /// The `(sigma, tau)` pairs of [`component`](Self::component)'s log-parameters that a
    /// pattern search also moves along `sigma^2 / tau` = const ([`crate::nav::pattern`]): a
    /// Gauss-Markov's. Not an exponential-cosine's: its low-frequency level also depends on
    /// the period, so that line is not its ridge.
    pub fn ridges(&self) -> &'static [(usize, usize)] {
        match self.kind {
            ComponentKind::GaussMarkov => &[(0, 1)],
            _ => &[],
        }
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
            (ErrorSource::Accel, c) => m.accel.push(c).ok()?,
            (ErrorSource::Gyro, c) => m.gyro.push(c).ok()?,
            (ErrorSource::Observation, Component::GaussMarkov(g)) => m.colored.push(g).ok()?,
            (ErrorSource::Observation, _) => return None,
        }
        m.layout().ok()?;
        Some(m)
    }

    /// Starting points in log space, scaled to the model's own magnitudes.
    pub fn starts(&self, model: &InsModel<f64>) -> Vec<Vec<f64>> {
        self.starts_at(sensor_scale(model, self.sensor))
    }

    /// Starting points in log space for a sensor whose typical error magnitude is `scale`
    /// (the sensor's units; `nav --diagnose` takes it from the navigator's model).
    pub fn starts_at(&self, scale: f64) -> Vec<Vec<f64>> {
        let s = scale.ln();
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
            ErrorSource::Accel => "accelerometer error",
            ErrorSource::Gyro => "gyro drift",
            ErrorSource::Observation => "reference-velocity error",
        };
        match (*c, self.sensor) {
            (Component::White(w), ErrorSource::Gyro) => format!(
                "gyro white noise (angle random walk) of {:.3e} deg/sqrt(h): rate noise the drift model lacks",
                w.density * 180.0 / PI * 60.0
            ),
            (Component::White(w), _) => format!(
                "accelerometer white noise (velocity random walk) of {:.3e} m/s/sqrt(s): vibration or electronic noise",
                w.density
            ),
            (Component::GaussMarkov(g), ErrorSource::Observation) => format!(
                "reference velocity error correlated over {:.0} s (sigma {:.3e} m/s): GNSS multipath or reference filter lag",
                g.tau, g.sigma
            ),
            (Component::GaussMarkov(g), s) => format!(
                "a second correlated {sensor} with tau {:.3e} s (sigma {:.3e} {}): e.g. a thermal transient on another time scale",
                g.tau,
                g.sigma,
                if s == ErrorSource::Gyro { "rad/s" } else { "m/s^2" }
            ),
            (Component::ExpCosine(e), _) => format!(
                "{sensor} oscillates with period {:.3e} s, envelope {:.3e} s (thermal cycling, DTG nutation, platform sway)",
                2.0 * PI / e.beta.max(1e-300),
                e.tau
            ),
            (Component::RandomWalk(r), ErrorSource::Gyro) => format!(
                "gyro rate random walk, {:.3e} deg/h/sqrt(h): drift instability that grows with time",
                r.q.sqrt() * deg_h * 60.0
            ),
            (Component::RandomWalk(r), _) => format!(
                "{sensor} random walk, {:.3e} m/s^2/sqrt(s): bias instability that grows with time",
                r.q.sqrt()
            ),
            (Component::RandomConstant(r), ErrorSource::Gyro) => format!(
                "gyro turn-on bias of about {:.3e} deg/h, constant over the run",
                r.sigma * deg_h
            ),
            (Component::RandomConstant(r), _) => {
                format!("{sensor} turn-on bias of about {:.3e}, constant over the run", r.sigma)
            }
        }
    }
}

/// The log-parameter of quantity `q` at value `v`, as [`Candidate::component`] takes it (the
/// exp-cosine's `beta` is carried as `ln period`).
pub(crate) fn log_param(q: Quantity, v: f64) -> f64 {
    match q {
        Quantity::Beta => (2.0 * PI / v).ln(),
        _ => v.ln(),
    }
}

/// "Replace component `index` of `sensor` (of kind `old.kind()`) by one of kind `kind`".
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Replacement {
    /// The sensor whose component is replaced (accelerometer or gyro).
    pub sensor: ErrorSource,
    /// Position of the replaced component in the model's list for that sensor.
    pub index: usize,
    /// The replaced component as the model has it.
    pub old: Component<f64>,
    /// The kind that replaces it.
    pub kind: ComponentKind,
}

impl Replacement {
    /// The new component's library entry (its parameters, their order and ranges).
    pub fn target(&self) -> Candidate {
        Candidate {
            sensor: self.sensor,
            kind: self.kind,
        }
    }

    /// Every replacement the core kind table allows (`ComponentKind::alternative`, the same
    /// table the online structure test reads: Gauss-Markov <-> exponential-cosine, the pair a
    /// model gets wrong most easily, the Gauss-Markov being the exp-cosine's infinite-period
    /// limit) on `model`'s accelerometer and gyro components. A new pair is added there: the
    /// starts, the fit and the penalty follow from the kinds.
    /// (Observation noise is Gauss-Markov by construction and is not swapped.)
    pub fn all(model: &InsModel<f64>) -> Vec<Replacement> {
        let sensors = [
            (ErrorSource::Accel, &model.accel),
            (ErrorSource::Gyro, &model.gyro),
        ];
        let mut out = Vec::new();
        for (sensor, comps) in sensors {
            for (index, old) in comps.iter().enumerate() {
                if let Some(to) = old.kind().alternative() {
                    out.push(Replacement {
                        sensor,
                        index,
                        old: *old,
                        kind: to,
                    });
                }
            }
        }
        out
    }

    /// `gyro/gauss-markov->exp-cosine`; the component's position is added when it is not the
    /// sensor's first (`gyro/gauss-markov[1]->exp-cosine`).
    pub fn label(&self) -> String {
        let at = if self.index == 0 {
            String::new()
        } else {
            format!("[{}]", self.index)
        };
        format!(
            "{}/{}{at}->{}",
            self.sensor.name(),
            self.old.kind().name(),
            self.kind.name()
        )
    }

    /// `model` with the component replaced by the one of log-parameters `p`; `None` if the
    /// model no longer has that component, `p` is bad or the result does not fit.
    pub fn apply(&self, model: &InsModel<f64>, p: &[f64]) -> Option<InsModel<f64>> {
        let comp = self.target().component(p)?;
        let mut m = model.clone();
        let slot = match self.sensor {
            ErrorSource::Accel => m.accel.get_mut(self.index)?,
            ErrorSource::Gyro => m.gyro.get_mut(self.index)?,
            ErrorSource::Observation => return None,
        };
        if *slot != self.old {
            return None;
        }
        *slot = comp;
        m.layout().ok()?;
        Some(m)
    }

    /// Starting points: the new kind's own starts (as an addition would use them), with every
    /// quantity the replaced component also has set to its value (log-parameter `i` is the
    /// kind's `quantities()[i]`, the order [`Candidate::component`] reads them in). Gauss-Markov ->
    /// exp-cosine keeps sigma and tau and tries the additions' grid of periods; the reverse
    /// keeps sigma and tau (one start).
    pub fn starts(&self, model: &InsModel<f64>) -> Vec<Vec<f64>> {
        let qs = self.kind.quantities();
        let mut out: Vec<Vec<f64>> = Vec::new();
        for mut p in self.target().starts(model) {
            for (v, q) in p.iter_mut().zip(qs) {
                if let Some(old) = self.old.get(*q).filter(|o| *o > 0.0 && o.is_finite()) {
                    *v = log_param(*q, old);
                }
            }
            if !out.contains(&p) {
                out.push(p);
            }
        }
        out
    }

    /// One line naming the change with its fitted parameters, then what it means physically,
    /// e.g. `replace gyro Gauss-Markov by exp-cosine (period 6.000e2 s, tau 1.200e3 s,
    /// sigma 4.848e-7 rad/s): ...`.
    pub fn explain(&self, c: &Component<f64>) -> String {
        let (sensor, unit) = match self.sensor {
            ErrorSource::Accel => ("accelerometer", "m/s^2"),
            ErrorSource::Gyro => ("gyro", "rad/s"),
            ErrorSource::Observation => ("observation", "m/s"),
        };
        let params = match *c {
            Component::ExpCosine(e) => format!(
                "period {:.3e} s, tau {:.3e} s, sigma {:.3e} {unit}",
                2.0 * PI / e.beta.max(1e-300),
                e.tau,
                e.sigma
            ),
            Component::GaussMarkov(g) => {
                format!("tau {:.3e} s, sigma {:.3e} {unit}", g.tau, g.sigma)
            }
            other => {
                let kind = other.kind();
                let parts: Vec<String> = kind
                    .quantities()
                    .iter()
                    .filter_map(|&q| other.get(q).map(|v| format!("{} {v:.3e}", q.name())))
                    .collect();
                parts.join(", ")
            }
        };
        let at = if self.index == 0 {
            String::new()
        } else {
            format!(" (component {})", self.index)
        };
        let old = match self.old.kind() {
            ComponentKind::GaussMarkov => "Gauss-Markov",
            other => other.name(),
        };
        let why = match self.kind {
            ComponentKind::ExpCosine => "the error oscillates rather than decaying monotonically (thermal cycling, DTG nutation, platform sway)",
            ComponentKind::GaussMarkov => "the error decays without oscillating: the model's period is not in the data",
            _ => "the model has the right sensor but the wrong kind of process",
        };
        format!(
            "replace {sensor} {old}{at} by {} ({params}): {why}",
            self.kind.name()
        )
    }
}

/// A change the diagnosis proposes: add a library candidate, or replace a component's kind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Proposal {
    /// Add a component ([`LIBRARY`]).
    Add(Candidate),
    /// Replace one of the model's components by another kind (`ComponentKind::alternative`).
    Replace(Replacement),
}

impl From<Candidate> for Proposal {
    fn from(c: Candidate) -> Self {
        Self::Add(c)
    }
}

impl Proposal {
    /// Every proposal for `model`: the library's additions, then the replacements.
    pub fn all(model: &InsModel<f64>) -> Vec<Proposal> {
        LIBRARY
            .iter()
            .copied()
            .map(Proposal::Add)
            .chain(Replacement::all(model).into_iter().map(Proposal::Replace))
            .collect()
    }

    /// The library entry of the component the proposal fits (sensor, kind, parameters).
    pub fn target(&self) -> Candidate {
        match self {
            Self::Add(c) => *c,
            Self::Replace(r) => r.target(),
        }
    }

    /// `sensor/kind` for an addition, `sensor/old->new` for a replacement.
    pub fn label(&self) -> String {
        match self {
            Self::Add(c) => c.label(),
            Self::Replace(r) => r.label(),
        }
    }

    /// The `k` of the BIC penalty `k/2 ln n`: the parameters the fit is free to choose, i.e.
    /// the new component's own, for a replacement as for an addition (exp-cosine: 3).
    ///
    /// Why not the difference of the two kinds (Gauss-Markov -> exp-cosine: +1, the period)?
    /// That is BIC's count when both models' parameters are fitted to the data; here the input
    /// model's parameters are given, not fitted (an addition is charged for its own parameters
    /// only, for the same reason). A replacement refits the replaced component's sigma and tau
    /// too, so with k = 1 two of its three fitted parameters went unpaid, and it became a free
    /// three-parameter effect that dropped a component nobody had fitted: measured, with k = 1
    /// an exp-cosine of period 2.8e5 s "replacing" the gyro Gauss-Markov tied with a hidden gyro
    /// random walk (2.7 nats behind, so within the tie), and one of period 19 s beat hidden gyro
    /// white noise by 0.7 nats. With k = 3, "add X" and "replace Y by X" pay the same, and the
    /// likelihood alone decides whether the old component stays; on the case (gyro drift
    /// that is an exp-cosine) the replacement still wins by 20 nats or more (BENCHMARKS.md).
    pub fn free_params(&self) -> usize {
        self.target().n_params()
    }

    /// The fitted component for log-parameters `p`.
    pub fn component(&self, p: &[f64]) -> Option<Component<f64>> {
        self.target().component(p)
    }

    /// `model` changed by the proposal with log-parameters `p`.
    pub fn apply(&self, model: &InsModel<f64>, p: &[f64]) -> Option<InsModel<f64>> {
        match self {
            Self::Add(c) => c.add_to(model, p),
            Self::Replace(r) => r.apply(model, p),
        }
    }

    /// Starting points in log space.
    pub fn starts(&self, model: &InsModel<f64>) -> Vec<Vec<f64>> {
        match self {
            Self::Add(c) => c.starts(model),
            Self::Replace(r) => r.starts(model),
        }
    }

    /// One line on what the fitted change means.
    pub fn explain(&self, c: &Component<f64>) -> String {
        match self {
            Self::Add(a) => a.explain(c),
            Self::Replace(r) => r.explain(c),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Gauss-Markov candidate's ridge pair is its `(ln sigma, ln tau)`: moving it by `(h, 2h)`
    /// keeps `sigma^2 / tau`, the low-frequency level that short data bound. The other kinds
    /// offer none.
    #[test]
    fn a_gauss_markov_ridge_keeps_sigma_squared_over_tau() {
        let gm = Candidate {
            sensor: ErrorSource::Gyro,
            kind: ComponentKind::GaussMarkov,
        };
        let level = |p: &[f64]| match gm.component(p) {
            Some(Component::GaussMarkov(g)) => g.sigma * g.sigma / g.tau,
            other => panic!("{other:?}"),
        };
        let p = [(1e-5f64).ln(), (300f64).ln()];
        let &[(s, t)] = gm.ridges() else {
            panic!("{:?}", gm.ridges())
        };
        let mut q = p;
        q[s] += 0.7;
        q[t] += 1.4;
        assert!((level(&q) / level(&p) - 1.0).abs() < 1e-12);
        assert!((q[t] - p[t] - 1.4).abs() < 1e-12 && gm.time_params().contains(&t));
        for kind in [
            ComponentKind::White,
            ComponentKind::ExpCosine,
            ComponentKind::RandomWalk,
            ComponentKind::RandomConstant,
        ] {
            let c = Candidate { kind, ..gm };
            assert!(c.ridges().is_empty(), "{kind:?}");
        }
    }

    /// The swaps of `paper` (one Gauss-Markov per sensor) and of a model whose gyro is an
    /// exp-cosine: starts keep sigma and tau, an exp-cosine tries the additions' periods, and
    /// `apply` changes only the named component.
    #[test]
    fn replacements_start_from_the_replaced_component_and_change_only_it() {
        let paper = InsModel::<f64>::paper();
        let swaps = Replacement::all(&paper);
        let labels: Vec<String> = swaps.iter().map(|r| r.label()).collect();
        assert_eq!(
            labels,
            [
                "accel/gauss-markov->exp-cosine",
                "gyro/gauss-markov->exp-cosine"
            ]
        );
        let gyro = swaps[1];
        let Component::GaussMarkov(old) = paper.gyro[0] else {
            panic!("paper gyro is a Gauss-Markov")
        };
        let starts = gyro.starts(&paper);
        let periods: Vec<f64> = starts.iter().map(|p| p[2].exp().round()).collect();
        assert_eq!(periods, [120.0, 600.0, 3000.0]);
        for p in &starts {
            assert!((p[0] - old.sigma.ln()).abs() < 1e-12 && (p[1] - old.tau.ln()).abs() < 1e-12);
        }
        let m = gyro.apply(&paper, &starts[1]).unwrap();
        assert_eq!(m.accel, paper.accel);
        assert_eq!(m.gyro.len(), 1);
        let Component::ExpCosine(e) = m.gyro[0] else {
            panic!("replaced by an exp-cosine")
        };
        assert!((2.0 * PI / e.beta - 600.0).abs() < 1e-6 && (e.tau - old.tau).abs() < 1e-9);
        // The reverse swap on that model: one start, sigma and tau kept; the penalty counts
        // the new component's parameters in both directions.
        let back = Replacement::all(&m)
            .into_iter()
            .find(|r| r.sensor == ErrorSource::Gyro)
            .unwrap();
        assert_eq!(back.label(), "gyro/exp-cosine->gauss-markov");
        assert_eq!(back.starts(&m), [vec![e.sigma.ln(), e.tau.ln()]]);
        assert_eq!(Proposal::Replace(back).free_params(), 2);
        assert_eq!(Proposal::Replace(gyro).free_params(), 3);
        // A stale replacement (the model's component changed) applies to nothing.
        assert!(back.apply(&paper, &back.starts(&m)[0]).is_none());
    }
}
