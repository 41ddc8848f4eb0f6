//! The change monitor of the global stage: the filter's model, run as the exact filter of the
//! block means ([`pass::block_filter`](super::pass::block_filter)) on every new block, with
//! Page's CUSUM ([`ChangeDetector`]) on its normalised block innovations.
//!
//! # Why on block means
//! Measured (`docs/ADAPTATION.md` §7.7, `examples/change_bench.rs seamless=1`): when a sensor's
//! noise changes in service with the states continuous, the 1-Hz innovations do not show it;
//! their variance is the observation noise's. A sensor's noise reaches `z` through the Schuler
//! loop, below `1 / (2 block)` Hz, where the block means carry it and the observation noise is
//! averaged down by the block length. The window search reads the same block means.
//!
//! The monitor starts at each model a search chooses ([`watch`](Monitor::watch)); its filter is
//! built on the next block (a discretisation and a block system: not on the tick that ends a
//! search, whose cost is bounded with the search's own). Its first [`BURN`] innovations, set by
//! the diffuse start, are not tested.

use super::pass::{block_filter, BURN};
use crate::adapt::bank::Member;
use crate::adapt::change::ChangeDetector;
use crate::adapt::identifiable::IdentifiableModel;
use crate::adapt::params::{Specs, MAXP};
use crate::filter::UpdateStatus;
use crate::model::NX;
use crate::Real;

/// What the monitor is doing.
#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    /// Not watching (no model chosen yet, or after an alarm).
    Off,
    /// A model to watch; the filter is built at the next block.
    Pending,
    /// Watching: blocks filtered so far.
    On(u32),
}

/// One block filter at the filter's model and the CUSUM on its innovations.
#[derive(Debug, Clone)]
pub struct Monitor<T: Real, const N: usize = NX, const Z: usize = 1> {
    member: Member<T, N>,
    h: [[T; N]; Z],
    r: [T; Z],
    theta: [T; MAXP],
    state: State,
    detector: ChangeDetector<T>,
}

impl<T: Real, const N: usize, const Z: usize> Monitor<T, N, Z> {
    /// Off (a compile-time value).
    pub const BLANK: Self = Self {
        member: Member::BLANK,
        h: [[T::ZERO; N]; Z],
        r: [T::ZERO; Z],
        theta: [T::ZERO; MAXP],
        state: State::Off,
        detector: ChangeDetector::BLANK,
    };

    /// A monitor that alarms at `threshold` nats (`0`: never watches).
    pub fn new(threshold: T) -> Self {
        Self {
            detector: ChangeDetector::new(threshold),
            ..Self::BLANK
        }
    }

    /// Watches the model `theta` from the next block on.
    pub fn watch(&mut self, theta: &[T; MAXP]) {
        if self.detector.enabled() {
            self.theta = *theta;
            self.state = State::Pending;
        }
    }

    /// One block mean `z` (per axis; non-finite: missing) of `block` ticks. On an alarm,
    /// returns the blocks since the estimated change and stops watching; and whether it built
    /// its filter (a discretisation and a block system) on this block.
    ///
    /// With several axes each axis's normalised innovation enters the CUSUM in turn (each is
    /// chi-square with one degree of freedom under the model, as one axis's), and the age of a
    /// change is counted in blocks (rounded up).
    pub fn push<M: IdentifiableModel<T, N, Z>>(
        &mut self,
        z: &[T; Z],
        block: u32,
        base: &M,
        specs: &Specs,
    ) -> (Option<u32>, bool) {
        match self.state {
            State::Off => (None, false),
            State::Pending => {
                // The filter starts at this block's mean; a missing one waits for the next.
                if z.iter().all(|v| v.is_finite()) {
                    self.state =
                        match block_filter(base, specs, &self.theta, block, z, &mut self.member) {
                            Ok((h, r)) => {
                                (self.h, self.r) = (h, r);
                                self.detector.arm();
                                State::On(0)
                            }
                            // A model that cannot be built is not watched.
                            Err(_) => State::Off,
                        };
                    return (None, true);
                }
                (None, false)
            }
            State::On(n) => {
                self.member.predict();
                let n = n.saturating_add(1);
                self.state = State::On(n);
                let mut e2 = [None; Z];
                for (e, (zk, (h, r))) in e2.iter_mut().zip(z.iter().zip(self.h.iter().zip(self.r)))
                {
                    let inn = self.member.update(*zk, h, r, None);
                    *e = match inn.status {
                        UpdateStatus::Updated if n as usize > BURN => {
                            Some(inn.innovation * inn.innovation / inn.variance)
                        }
                        _ => None,
                    };
                }
                if !self.member.kf.diagonal_healthy() {
                    // A broken filter says nothing about the sensor: stop watching.
                    self.state = State::Off;
                    return (None, false);
                }
                for e in e2 {
                    if let Some(age) = self.detector.push(e) {
                        self.state = State::Off;
                        let axes = u32::try_from(Z.max(1)).unwrap_or(1);
                        return (Some(age.div_ceil(axes)), false);
                    }
                }
                (None, false)
            }
        }
    }
}
