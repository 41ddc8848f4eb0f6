//! Noise models and the INS error model they compose into.
//!
//! Each sensor-error kind is a small type with its exact discretisation and its analytic
//! autocorrelation ([`GaussMarkov`], [`ExpCosine`], [`RandomWalk`], [`RandomConstant`],
//! [`WhiteNoise`]); [`Component`] puts them behind one interface; [`InsModel`] composes them with
//! the one-channel INS of METHOD.md §5; [`discretise`](discretise::discretise) turns the
//! continuous system into `(Phi, Qd)` exactly.

pub mod component;
pub mod discretise;
pub mod error_model;
pub mod exp_cosine;
pub mod gauss_markov;
pub mod ins;
pub mod random_constant;
pub mod random_walk;
pub mod white;
pub mod wire;

pub use component::{Component, ComponentKind, Quantity, Realisation, Summary, IDENTIFIABLE_SD};
pub use discretise::Discrete;
pub use error_model::{ContinuousSystem, ErrorModel, StateBlock};
pub use exp_cosine::ExpCosine;
pub use gauss_markov::GaussMarkov;
pub use ins::{idx, ErrorSource, InsModel, Scaling, StateMat, StateRow, StateVec, NX};
pub use random_constant::RandomConstant;
pub use random_walk::RandomWalk;
pub use white::WhiteNoise;

/// Why a model was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModelError {
    /// A standard deviation is negative, zero where it must not be, or not finite.
    BadSigma,
    /// A correlation time is not a finite positive number.
    BadTau,
    /// An oscillation frequency is negative or not finite.
    BadBeta,
    /// A noise density is not a finite positive number.
    BadDensity,
    /// The step is not a finite positive number.
    BadDt,
    /// The components need more than [`NX`] states or more slots than allowed.
    TooManyStates,
    /// The continuous system has non-finite entries or is too stiff to discretise.
    NonFinite,
}

impl core::fmt::Display for ModelError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::BadSigma => "a standard deviation must be finite and positive",
            Self::BadTau => "a correlation time tau must be finite and positive",
            Self::BadBeta => "beta must be finite and non-negative",
            Self::BadDensity => "a noise density (q or density) must be finite and positive",
            Self::BadDt => "dt must be finite and positive",
            Self::TooManyStates => "the components need more filter states than NX",
            Self::NonFinite => "the continuous system is not finite or too stiff",
        })
    }
}

impl core::error::Error for ModelError {}
