//! One additive term of a sensor's error, as a small state-space block.
//!
//! Every kind is described to the INS composition by the same five things: how many states it
//! adds (0, 1 or 2), their continuous dynamics `A_c`, their noise intensity `Qc_c` (`G G^T`), the
//! output row `C_c` that maps them to the sensor error, and their initial covariance.

use crate::model::{ExpCosine, GaussMarkov, ModelError, RandomConstant, RandomWalk, WhiteNoise};
use crate::Real;
use nalgebra::{Matrix2, RowVector2};

/// The kinds a sensor error may be built from; the names match the model-TOML `kind` field.
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

impl ComponentKind {
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

    /// The state-space block of the component.
    pub fn block(&self) -> Block<T> {
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
            Self::ExpCosine(e) => {
                let g = e.g_vector();
                Block {
                    states: 2,
                    a: e.a_matrix(),
                    qc: g * g.transpose(),
                    c: RowVector2::new(T::zero(), T::one()),
                    p0: e.p_inf(),
                }
            }
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
