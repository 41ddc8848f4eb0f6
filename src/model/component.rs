//! One additive term of a sensor's error, as a small state-space block.
//!
//! Every kind is described to the INS composition by the same five things: how many states it
//! adds (0, 1 or 2), their continuous dynamics `A_c`, their noise intensity `Qc_c` (`G G^T`), the
//! output row `C_c` that maps them to the sensor error, and their initial covariance.

use crate::model::{ExpCosine, GaussMarkov, ModelError, RandomConstant, RandomWalk, WhiteNoise};
use crate::Real;
use nalgebra::{Matrix2, RowVector2};

/// The kinds a sensor error may be built from: the crate's one table of component kinds. The
/// model TOML, the binary model file, the telemetry records, the identification bank and the
/// reports all read kinds, names, codes and parameters from here.
///
/// | kind | name | code | quantities (file order) | identified online | may switch to | telemetry `(tau, sigma, beta)` |
/// |---|---|---|---|---|---|---|
/// | Gauss-Markov | `gauss-markov` | 0 | sigma, tau | sigma, tau | exp-cosine | tau, sigma, - |
/// | exponential-cosine | `exp-cosine` | 1 | sigma, tau, beta | sigma, tau, beta | Gauss-Markov | tau, sigma, beta |
/// | random walk | `random-walk` | 2 | q, sigma0 (optional) | q | - | -, sqrt(q), - |
/// | random constant | `random-constant` | 3 | sigma | - | - | -, sigma, - |
/// | white noise | `white` | 4 | density | density | - | -, density, - |
///
/// ```
/// use imu_ident::model::{Component, ComponentKind, GaussMarkov, Quantity};
/// for k in ComponentKind::ALL {
///     assert_eq!(ComponentKind::from_code(k.code()), Some(k));
///     assert_eq!(ComponentKind::from_name(k.name()), Some(k));
///     for q in k.quantities() {
///         assert_eq!(Quantity::from_name(q.name()), Some(*q));
///     }
/// }
/// assert!(!ComponentKind::RandomWalk.required(Quantity::Sigma0));
/// assert!(ComponentKind::RandomWalk.required(Quantity::Q));
/// let mut c = Component::GaussMarkov(GaussMarkov { sigma: 1e-3, tau: 100.0 });
/// assert!(c.set(Quantity::Tau, 50.0));
/// assert_eq!(c.get(Quantity::Tau), Some(50.0));
/// assert_eq!(c.get(Quantity::Beta), None);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ComponentKind {
    /// `"gauss-markov"`
    GaussMarkov,
    /// `"exp-cosine"`
    ExpCosine,
    /// `"random-walk"`
    RandomWalk,
    /// `"random-constant"`
    RandomConstant,
    /// `"white"`
    White,
}

/// Cramér-Rao standard deviation [decades] of an identified quantity above which it is flagged
/// "not identifiable from these data yet" (issue 13, item 2): a factor of 3 either way at one
/// sigma. The one threshold of the one-channel global stage ([`crate::adapt::window`]) and the
/// navigator's bank ([`crate::nav::online`]).
pub const IDENTIFIABLE_SD: f64 = 0.5;

/// A named parameter of a component.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Quantity {
    /// Stationary standard deviation (Gauss-Markov, exponential-cosine, random constant).
    Sigma,
    /// Correlation time `tau = 1/alpha` [s].
    Tau,
    /// Oscillation frequency `beta` [rad/s] (exponential-cosine).
    Beta,
    /// Random-walk intensity `q` [unit^2/s].
    Q,
    /// Initial standard deviation of a random walk.
    Sigma0,
    /// White-noise density [unit sqrt(s)].
    Density,
}

impl Quantity {
    /// Every quantity.
    pub const ALL: [Self; 6] = [
        Self::Sigma,
        Self::Tau,
        Self::Beta,
        Self::Q,
        Self::Sigma0,
        Self::Density,
    ];

    /// The quantity spelled `name` in a model TOML.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|q| q.name() == name)
    }

    /// Whether the quantity scales the noise's power (a standard deviation, a density, a
    /// random-walk intensity), not its spectrum's shape (a correlation time, a frequency): the
    /// quantities a conservative model raises.
    pub const fn is_intensity(self) -> bool {
        matches!(self, Self::Sigma | Self::Q | Self::Sigma0 | Self::Density)
    }

    /// The model-TOML spelling.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Sigma => "sigma",
            Self::Tau => "tau",
            Self::Beta => "beta",
            Self::Q => "q",
            Self::Sigma0 => "sigma0",
            Self::Density => "density",
        }
    }
}

impl ComponentKind {
    /// Every kind, in code order.
    pub const ALL: [Self; 5] = [
        Self::GaussMarkov,
        Self::ExpCosine,
        Self::RandomWalk,
        Self::RandomConstant,
        Self::White,
    ];

    /// The model-TOML spelling of the kind.
    pub const fn name(self) -> &'static str {
        match self {
            Self::GaussMarkov => "gauss-markov",
            Self::ExpCosine => "exp-cosine",
            Self::RandomWalk => "random-walk",
            Self::RandomConstant => "random-constant",
            Self::White => "white",
        }
    }

    /// The kind spelled `name` in a model TOML.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Code of the kind in the binary model file and the telemetry frames.
    pub const fn code(self) -> u8 {
        match self {
            Self::GaussMarkov => 0,
            Self::ExpCosine => 1,
            Self::RandomWalk => 2,
            Self::RandomConstant => 3,
            Self::White => 4,
        }
    }

    /// The kind of a code.
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.get(usize::from(code)).copied()
    }

    /// The quantities that define a component of this kind, in file order.
    pub const fn quantities(self) -> &'static [Quantity] {
        match self {
            Self::GaussMarkov => &[Quantity::Sigma, Quantity::Tau],
            Self::ExpCosine => &[Quantity::Sigma, Quantity::Tau, Quantity::Beta],
            Self::RandomWalk => &[Quantity::Q, Quantity::Sigma0],
            Self::RandomConstant => &[Quantity::Sigma],
            Self::White => &[Quantity::Density],
        }
    }

    /// Whether a model file must give quantity `q` of this kind. An optional quantity (a
    /// random walk's initial sigma) is zero when absent, and a file writer leaves it out when
    /// it is zero.
    pub const fn required(self, q: Quantity) -> bool {
        !matches!((self, q), (Self::RandomWalk, Quantity::Sigma0))
    }

    /// The quantities the online identification estimates (in the logarithm), in `theta`
    /// order. A random constant has no intensity to identify; beta is held (issue 13).
    pub const fn identified(self) -> &'static [Quantity] {
        match self {
            Self::GaussMarkov => &[Quantity::Sigma, Quantity::Tau],
            // beta is identified too (issue 13): the global stage finds it by a scan of periods.
            Self::ExpCosine => &[Quantity::Sigma, Quantity::Tau, Quantity::Beta],
            Self::RandomWalk => &[Quantity::Q],
            Self::White => &[Quantity::Density],
            Self::RandomConstant => &[],
        }
    }

    /// The kind the global stage's structure test may replace this one by (issue 13: the
    /// paper's structural identification): a Gauss-Markov process and an exponential-cosine
    /// differ by `beta` alone (`beta = 0` is Gauss-Markov), so either can stand in for the
    /// other with the same `sigma, tau`.
    pub const fn alternative(self) -> Option<Self> {
        match self {
            Self::GaussMarkov => Some(Self::ExpCosine),
            Self::ExpCosine => Some(Self::GaussMarkov),
            _ => None,
        }
    }

    /// How the telemetry summary's `sigma` ([`Summary`]) relates to the sensor's unit: the
    /// suffix to append to it (`sqrt(q)` of a random walk is per `sqrt(s)`, a white noise's
    /// density per `sqrt(Hz)`, a stationary standard deviation is in the unit itself).
    pub const fn summary_sigma_per(self) -> &'static str {
        match self {
            Self::RandomWalk => "/sqrt(s)",
            Self::White => "/sqrt(Hz)",
            Self::GaussMarkov | Self::ExpCosine | Self::RandomConstant => "",
        }
    }

    /// A component of this kind from its quantities in file order (missing ones zero). Not
    /// validated: the filter validates when it is built.
    pub fn with_quantities<T: Real>(self, v: &[T]) -> Component<T> {
        let g = |i: usize| v.get(i).copied().unwrap_or_else(T::zero);
        match self {
            Self::GaussMarkov => Component::GaussMarkov(GaussMarkov {
                sigma: g(0),
                tau: g(1),
            }),
            Self::ExpCosine => Component::ExpCosine(ExpCosine {
                sigma: g(0),
                tau: g(1),
                beta: g(2),
            }),
            Self::RandomWalk => Component::RandomWalk(RandomWalk {
                q: g(0),
                sigma0: g(1),
            }),
            Self::RandomConstant => Component::RandomConstant(RandomConstant { sigma: g(0) }),
            Self::White => Component::White(WhiteNoise { density: g(0) }),
        }
    }
}

/// The telemetry summary of a component: correlation time, a standard deviation (the stationary
/// one, `sqrt(q)` for a random walk, the density for white noise) and beta; `None` where the
/// kind has no such quantity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary<T> {
    /// Correlation time [s].
    pub tau: Option<T>,
    /// Standard deviation (see above).
    pub sigma: Option<T>,
    /// Oscillation frequency [rad/s].
    pub beta: Option<T>,
}

/// One component of a sensor error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Component<T> {
    /// First-order Gauss-Markov.
    GaussMarkov(GaussMarkov<T>),
    /// Exponential-cosine (two states, the error is the second).
    ExpCosine(ExpCosine<T>),
    /// Random walk.
    RandomWalk(RandomWalk<T>),
    /// Random constant.
    RandomConstant(RandomConstant<T>),
    /// White noise on the integrating INS state (no state of its own).
    White(WhiteNoise<T>),
}

/// Which state-space realisation of a component's process (the same process either way; they
/// differ only for an exponential-cosine, `model::exp_cosine` docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Realisation {
    /// The filters' (every estimator in the crate): well conditioned for every parameter.
    #[default]
    Filter,
    /// The paper's shaping filter (eq. 16-17, corrected), singular as `beta -> 0`. The host's
    /// truth simulator draws with it, so that a seed draws the same log as before the filters
    /// changed realisation.
    Paper,
}

/// The state-space block of one component (only the leading `states` rows/columns are used).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Block<T: Real> {
    /// Number of states the component adds: 0, 1 or 2.
    pub states: usize,
    /// Continuous dynamics.
    pub a: Matrix2<T>,
    /// Continuous noise intensity `G G^T`.
    pub qc: Matrix2<T>,
    /// Output row: sensor error = `c x`.
    pub c: RowVector2<T>,
    /// Initial (for stationary kinds: stationary) covariance.
    pub p0: Matrix2<T>,
}

impl<T: Real> Component<T> {
    /// The value of quantity `q`, `None` if this kind has no such quantity.
    pub fn get(&self, q: Quantity) -> Option<T> {
        match (*self, q) {
            (Self::GaussMarkov(g), Quantity::Sigma) => Some(g.sigma),
            (Self::GaussMarkov(g), Quantity::Tau) => Some(g.tau),
            (Self::ExpCosine(e), Quantity::Sigma) => Some(e.sigma),
            (Self::ExpCosine(e), Quantity::Tau) => Some(e.tau),
            (Self::ExpCosine(e), Quantity::Beta) => Some(e.beta),
            (Self::RandomWalk(r), Quantity::Q) => Some(r.q),
            (Self::RandomWalk(r), Quantity::Sigma0) => Some(r.sigma0),
            (Self::RandomConstant(r), Quantity::Sigma) => Some(r.sigma),
            (Self::White(w), Quantity::Density) => Some(w.density),
            _ => None,
        }
    }

    /// Sets quantity `q`; false (nothing changed) if this kind has no such quantity.
    pub fn set(&mut self, q: Quantity, v: T) -> bool {
        let slot = match (self, q) {
            (Self::GaussMarkov(g), Quantity::Sigma) => &mut g.sigma,
            (Self::GaussMarkov(g), Quantity::Tau) => &mut g.tau,
            (Self::ExpCosine(e), Quantity::Sigma) => &mut e.sigma,
            (Self::ExpCosine(e), Quantity::Tau) => &mut e.tau,
            (Self::ExpCosine(e), Quantity::Beta) => &mut e.beta,
            (Self::RandomWalk(r), Quantity::Q) => &mut r.q,
            (Self::RandomWalk(r), Quantity::Sigma0) => &mut r.sigma0,
            (Self::RandomConstant(r), Quantity::Sigma) => &mut r.sigma,
            (Self::White(w), Quantity::Density) => &mut w.density,
            _ => return false,
        };
        *slot = v;
        true
    }

    /// The telemetry summary `(tau, sigma, beta)` (see [`Summary`]).
    pub fn summary(&self) -> Summary<T> {
        let sigma = match *self {
            Self::RandomWalk(r) => Some(r.q.max(T::zero()).sqrt()),
            Self::White(w) => Some(w.density),
            _ => self.get(Quantity::Sigma),
        };
        Summary {
            tau: self.get(Quantity::Tau),
            sigma,
            beta: self.get(Quantity::Beta),
        }
    }

    /// Sets the quantities a telemetry summary carries (the inverse of [`summary`]; a random
    /// walk's `q` becomes `sigma^2`). Absent entries are left as they are.
    ///
    /// [`summary`]: Self::summary
    pub fn set_summary(&mut self, s: &Summary<T>) {
        if let Some(t) = s.tau {
            self.set(Quantity::Tau, t);
        }
        if let Some(b) = s.beta {
            self.set(Quantity::Beta, b);
        }
        if let Some(v) = s.sigma {
            match self {
                Self::RandomWalk(r) => r.q = v * v,
                Self::White(w) => w.density = v,
                _ => {
                    self.set(Quantity::Sigma, v);
                }
            }
        }
    }

    /// The same component in another precision.
    pub fn cast<U: Real>(&self) -> Component<U> {
        let c = |x: T| U::lit(x.as_f64());
        match *self {
            Self::GaussMarkov(g) => Component::GaussMarkov(GaussMarkov {
                sigma: c(g.sigma),
                tau: c(g.tau),
            }),
            Self::ExpCosine(e) => Component::ExpCosine(ExpCosine {
                sigma: c(e.sigma),
                tau: c(e.tau),
                beta: c(e.beta),
            }),
            Self::RandomWalk(r) => Component::RandomWalk(RandomWalk {
                q: c(r.q),
                sigma0: c(r.sigma0),
            }),
            Self::RandomConstant(r) => {
                Component::RandomConstant(RandomConstant { sigma: c(r.sigma) })
            }
            Self::White(w) => Component::White(WhiteNoise {
                density: c(w.density),
            }),
        }
    }

    /// The kind of this component.
    pub fn kind(&self) -> ComponentKind {
        match self {
            Self::GaussMarkov(_) => ComponentKind::GaussMarkov,
            Self::ExpCosine(_) => ComponentKind::ExpCosine,
            Self::RandomWalk(_) => ComponentKind::RandomWalk,
            Self::RandomConstant(_) => ComponentKind::RandomConstant,
            Self::White(_) => ComponentKind::White,
        }
    }

    /// Number of filter states the component adds.
    pub fn states(&self) -> usize {
        match self {
            Self::ExpCosine(_) => 2,
            Self::White(_) => 0,
            _ => 1,
        }
    }

    /// Re-checks the parameters (they are public fields and may have been edited).
    pub fn validate(&self) -> Result<(), ModelError> {
        match *self {
            Self::GaussMarkov(c) => GaussMarkov::new(c.sigma, c.tau).map(|_| ()),
            Self::ExpCosine(c) => ExpCosine::new(c.sigma, c.tau, c.beta).map(|_| ()),
            Self::RandomWalk(c) => RandomWalk::new(c.q, c.sigma0).map(|_| ()),
            Self::RandomConstant(c) => RandomConstant::new(c.sigma).map(|_| ()),
            Self::White(c) => WhiteNoise::new(c.density).map(|_| ()),
        }
    }

    /// White-noise intensity this component puts on the integrating INS state.
    pub fn white_qc(&self) -> T {
        match self {
            Self::White(w) => w.qc(),
            _ => T::zero(),
        }
    }

    /// The state-space block of the component, in the filter's realisation.
    pub fn block(&self) -> Block<T> {
        self.block_in(Realisation::Filter)
    }

    /// The state-space block of the component in realisation `r` (they differ only for an
    /// exponential-cosine).
    pub fn block_in(&self, r: Realisation) -> Block<T> {
        let z = Matrix2::zeros();
        let c1 = RowVector2::new(T::one(), T::zero());
        let scalar = |a: T, qc: T, p0: T| Block {
            states: 1,
            a: Matrix2::new(a, T::zero(), T::zero(), T::zero()),
            qc: Matrix2::new(qc, T::zero(), T::zero(), T::zero()),
            c: c1,
            p0: Matrix2::new(p0, T::zero(), T::zero(), T::zero()),
        };
        match self {
            Self::GaussMarkov(g) => scalar(-g.alpha(), g.qc(), g.sigma * g.sigma),
            Self::ExpCosine(e) if r == Realisation::Paper => {
                let g = e.g_vector();
                Block {
                    states: 2,
                    a: e.a_matrix(),
                    qc: g * g.transpose(),
                    c: RowVector2::new(T::zero(), T::one()),
                    p0: e.p_inf(),
                }
            }
            // The damped-rotation realisation: well conditioned for every beta, where the
            // paper's becomes singular as beta -> 0 (`model::exp_cosine` docs).
            Self::ExpCosine(e) => Block {
                states: 2,
                a: e.rotation_a(),
                qc: Matrix2::identity() * e.rotation_qc(),
                c: c1,
                p0: Matrix2::identity() * (e.sigma * e.sigma),
            },
            Self::RandomWalk(r) => scalar(T::zero(), r.q, r.sigma0 * r.sigma0),
            Self::RandomConstant(r) => scalar(T::zero(), T::zero(), r.sigma * r.sigma),
            Self::White(_) => Block {
                states: 0,
                a: z,
                qc: z,
                c: RowVector2::zeros(),
                p0: z,
            },
        }
    }

    /// A characteristic magnitude of the component's states, used to scale them to O(1).
    pub fn magnitude(&self) -> T {
        match self {
            Self::GaussMarkov(g) => g.sigma,
            Self::ExpCosine(e) => e.sigma,
            // A random walk is scaled by its growth over one hour, or its initial sigma.
            Self::RandomWalk(r) => (r.q * T::lit(3600.0)).sqrt().max(r.sigma0),
            Self::RandomConstant(r) => r.sigma,
            Self::White(w) => w.density,
        }
    }

    /// Analytic autocorrelation `K(t)` of a stationary component; `None` for a random walk
    /// (non-stationary) and for white noise (a Dirac at zero).
    pub fn acf(&self, t: T) -> Option<T> {
        match self {
            Self::GaussMarkov(g) => Some(g.acf(t)),
            Self::ExpCosine(e) => Some(e.acf(t)),
            Self::RandomConstant(r) => Some(r.acf(t)),
            Self::RandomWalk(_) | Self::White(_) => None,
        }
    }
}
