//! What a finished search answers: the best point and its gain over the anchor ([`Found`]), and
//! the best alternative structure the structure test tried ([`Switch`]). The caller (the
//! adaptive filter) decides from them whether to jump or switch; kept apart from the search's
//! state machine that fills them.

use super::structure::Site;
use crate::adapt::params::MAXP;
use crate::Real;

/// The result of a finished search.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Found<T> {
    /// The best point (`ln` parameters).
    pub theta: [T; MAXP],
    /// Its log-likelihood minus the anchor's, over the same window [nats].
    pub gain: T,
    /// Blocks in the window.
    pub blocks: u32,
    /// Likelihood evaluations spent.
    pub evaluations: u32,
    /// The best alternative structure tried (`valid` false when the structure test is off or
    /// nothing is switchable; not an `Option`: its `None` would not be all-zero bits, and the
    /// firmware's estimator would move from `.bss` to `.data`, 56 KB of flash).
    pub switch: Switch<T>,
}

impl<T: Real> Found<T> {
    /// No search yet.
    pub const BLANK: Self = Self {
        theta: [T::ZERO; MAXP],
        gain: T::ZERO,
        blocks: 0,
        evaluations: 0,
        switch: Switch::NONE,
    };
}

/// The best alternative structure of a search: one component's kind replaced.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Switch<T> {
    /// Which component, and its new kind.
    pub site: Site,
    /// Its best point (`ln` parameters in the alternative's own `specs` order).
    pub theta: [T; MAXP],
    /// Its log-likelihood minus that of the search's best point of the filter's model [nats].
    pub gain: T,
    /// Its identified parameters minus the filter model's.
    pub extra: i8,
    /// Whether an alternative was searched (the other fields are meaningful).
    pub valid: bool,
}

impl<T: Real> Switch<T> {
    /// No alternative (all zeros).
    pub const NONE: Self = Self {
        site: Site::BLANK,
        theta: [T::ZERO; MAXP],
        gain: T::ZERO,
        extra: 0,
        valid: false,
    };

    /// `Some` when an alternative was searched.
    pub fn get(&self) -> Option<&Self> {
        self.valid.then_some(self)
    }
}
