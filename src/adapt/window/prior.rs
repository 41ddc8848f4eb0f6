//! A weak prior on the searched parameters ([`WindowConfig::prior`](super::WindowConfig::prior)):
//! each `ln` parameter normal about the start model's value (the datasheet's), with a standard
//! deviation of `prior` decades. The search then maximises the window's log-likelihood plus
//! the log-prior (a maximum a posteriori estimate).
//!
//! Why: where the window identifies a parameter, its information dwarfs the prior's
//! (a Cramér-Rao deviation of half a decade is 16 times the information of a 2-decade prior),
//! and the answer barely moves. Where the window is flat along a direction ([`Found::flat`]),
//! its maximum is wherever the flat ridge happens to end, and there the prior decides: the
//! start model's value, not an end of the ridge. Measured (`change_bench` development seeds,
//! after a change in service): the ridge ended at a gyro Gauss-Markov sigma of 5.9e-10 rad/s
//! against 1.3e-7 true (seed 31009: 61 % of the next hours outside 3 sigma), and at an
//! accelerometer Gauss-Markov of 0.13 m/s^2 over 9 days against 2.8e-3 over 6 min (seed 31008,
//! continuous: 2.85x oracle B, 0 % outside 3 sigma).
//!
//! An exponential-cosine's `beta` has no prior (the start model has none; the structure test
//! scans it). The answer's information ([`Found::fisher`]) is the window's plus the prior's,
//! so a flat coordinate's deviation (in the records and telemetry) is now at most the prior's
//! 2 decades instead of unbounded. It is still above
//! [`IDENTIFIABLE_SD`](crate::model::IDENTIFIABLE_SD) (half a decade): the flag
//! ([`Found::flat`]) and what it changes are as before, except for a window's own deviation
//! between 0.50 and 0.52 decade, which the 2-decade prior brings under the threshold.
//!
//! [`Found::flat`]: super::Found::flat
//! [`Found::fisher`]: super::Found::fisher

use super::WindowSearch;
use crate::adapt::identifiable::IdentifiableModel;
use crate::adapt::params::{Specs, MAXP};
use crate::model::Quantity;
use crate::Real;

/// The prior of the running pass, in the layout it searches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Prior<T> {
    /// Its centre: the start model's point (`ln`).
    pub(super) centre: [T; MAXP],
    /// Each coordinate's weight, `1 / sd^2` (`ln`), zero for none.
    pub(super) weight: [T; MAXP],
}

impl<T: Real> Prior<T> {
    /// None.
    pub(super) const BLANK: Self = Self {
        centre: [T::ZERO; MAXP],
        weight: [T::ZERO; MAXP],
    };

    /// The log-prior of `theta` (zero without a prior).
    pub(super) fn log(&self, theta: &[T; MAXP]) -> T {
        let mut s = T::zero();
        for ((t, c), w) in theta.iter().zip(self.centre.iter()).zip(self.weight.iter()) {
            let d = *t - *c;
            s += *w * d * d;
        }
        -T::lit(0.5) * s
    }

    /// Adds the log-prior's gradient and information at `theta` to a pass's score and Fisher
    /// information.
    pub(super) fn add(
        &self,
        theta: &[T; MAXP],
        score: &mut [T; MAXP],
        fisher: &mut [[T; MAXP]; MAXP],
    ) {
        for (i, (((g, row), t), (c, w))) in score
            .iter_mut()
            .zip(fisher.iter_mut())
            .zip(theta.iter())
            .zip(self.centre.iter().zip(self.weight.iter()))
            .enumerate()
        {
            *g -= *w * (*t - *c);
            if let Some(v) = row.get_mut(i) {
                *v += *w;
            }
        }
    }
}

impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize, const W: usize>
    WindowSearch<T, M, N, Z, W>
{
    /// Sets the prior of the pass about to start: the start model's point in the layout the
    /// pass searches (the structure test's alternative, or the filter's model `specs`) and the
    /// weight of each coordinate.
    pub(super) fn set_prior(&mut self, specs: &Specs) {
        let sd = self.cfg.prior * T::lit(core::f64::consts::LN_10);
        let w = if sd > T::zero() {
            T::one() / (sd * sd)
        } else {
            T::zero()
        };
        let (centre, specs) = if self.in_alternative() {
            (self.alt.origin, &self.alt.specs)
        } else {
            (self.centre, specs)
        };
        self.prior.centre = centre;
        for (i, v) in self.prior.weight.iter_mut().enumerate() {
            let kind = specs.get(i).map(|s| s.kind);
            *v = match kind {
                Some(Quantity::Beta) | None => T::zero(),
                Some(_) => w,
            };
        }
    }
}
