//! The global stage's ring of block means (module documentation of [`super`]): each tick's
//! observation into the current block, each block's mean into the ring, the change monitor on
//! every new block, and the frozen window a search reads. A child of [`super`]: it works on the
//! search's own state.

use super::{Phase, WindowSearch};
use crate::adapt::identifiable::IdentifiableModel;
use crate::adapt::params::Specs;
use crate::Real;

impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize, const W: usize>
    WindowSearch<T, M, N, Z, W>
{
    /// Adds one tick's observation (per axis; non-finite: missing) to the current block, in
    /// which an axis is missing if it was missing on any tick; `base`/`specs` describe the
    /// filter's model (as for [`work`](Self::work)). Returns whether the change monitor found a
    /// change in service at this tick.
    pub fn push(&mut self, z: &[T; Z], base: &M, specs: &Specs) -> bool {
        if !self.cfg.enabled() {
            return false;
        }
        for ((a, m), v) in self
            .acc
            .iter_mut()
            .zip(self.missing.iter_mut())
            .zip(z.iter())
        {
            if v.is_finite() {
                *a += *v;
            } else {
                *m = true;
            }
        }
        self.acc_n += 1;
        if self.acc_n >= self.cfg.block {
            let mut mean = [T::zero(); Z];
            for ((v, a), m) in mean
                .iter_mut()
                .zip(self.acc.iter())
                .zip(self.missing.iter())
            {
                *v = if *m {
                    T::lit(f64::NAN)
                } else {
                    *a / T::lit(f64::from(self.acc_n))
                };
            }
            if let Some(v) = self.ring.get_mut(self.head) {
                *v = mean;
            }
            self.head = (self.head + 1) % W.max(1);
            self.pushed = self.pushed.saturating_add(1);
            self.acc = [T::zero(); Z];
            self.acc_n = 0;
            self.missing = [false; Z];
            let (alarm, built) = self.monitor.push(&mean, self.cfg.block, base, specs);
            self.monitor_built = built;
            if let Some(blocks) = alarm {
                self.changed(blocks);
                return true;
            }
        }
        false
    }

    /// Whether the window is still filling (fewer blocks since the start, or since the last
    /// change found, than a full window) with [`WindowConfig::filling_every`] on.
    pub(super) fn filling(&self) -> bool {
        self.cfg.filling_every > 0 && self.pushed.saturating_sub(self.floor) < self.cfg.window
    }

    /// Whether a search should start now (enough new blocks since the last one).
    pub fn due(&self) -> bool {
        self.cfg.enabled() && self.phase == Phase::Idle && self.pushed >= self.next_search
    }

    /// The block means of the last search's window, oldest first (host tools and tests).
    pub fn window_blocks(&self) -> impl Iterator<Item = [T; Z]> + '_ {
        (0..self.wlen).map(move |i| self.block(i))
    }

    /// The `i`-th block mean of the window (NaN outside it).
    pub(super) fn block(&self, i: usize) -> [T; Z] {
        self.ring
            .get((self.w0 + i) % W.max(1))
            .copied()
            .unwrap_or([T::lit(f64::NAN); Z])
    }

    pub(super) fn window_intact(&self) -> bool {
        let arrived = self.pushed.saturating_sub(self.started_at) as usize;
        arrived + self.wlen <= W
    }

    /// The window's first finite block mean on each axis (zero on an axis with none).
    pub(super) fn first_finite(&self) -> [T; Z] {
        let mut z0 = [T::zero(); Z];
        for (k, v) in z0.iter_mut().enumerate() {
            *v = self
                .window_blocks()
                .filter_map(|b| b.get(k).copied())
                .find(|v| v.is_finite())
                .unwrap_or(T::zero());
        }
        z0
    }
}
