//! The filter's jump at the end of a global search (its best point or a structure switch,
//! [`window`](super::window)); the probes' jumps are the [`Identifier`](super::Identifier)'s
//! (`epoch_end`). Apart from the step loop (the parent module) because a jump replaces the
//! windowed information instead of refining it. This module is a child of [`super`], so it
//! reads the filter's fields.

use super::identifiable::IdentifiableModel;
use super::params::{has_coordinate, MAXP};
use super::window::CONSERVATIVE_CAP;
use super::{AdaptiveFilter, Found};
use crate::model::Quantity;
use crate::Real;

/// Half the 95 % quantiles of chi-square with 1 to 8 degrees of freedom [nats] (up to the
/// `params8` capacity): how much holding `k` flat coordinates may cost the window's
/// log-likelihood, and (at `k = p`) what a search must gain to leave a kept model
/// (`keep_start`, `keep_identified`).
const HOLD_QUANTILE: [f64; 8] = [1.921, 2.996, 3.907, 4.744, 5.535, 6.296, 7.034, 7.754];

impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize, const W: usize>
    AdaptiveFilter<T, M, N, Z, W>
{
    /// The window's answer with each identified intensity raised by
    /// [`WindowConfig::conservative`](super::window::WindowConfig::conservative) of its
    /// Cramér-Rao standard deviations (at most `CONSERVATIVE_CAP`), flat coordinates left; the
    /// answer itself when that is 0 or the window's information is not positive definite.
    fn raised(&self, found: &Found<T>, p: usize) -> [T; MAXP] {
        let k = self.id.cfg.global.conservative;
        // Checked first: the deviations cost a Cholesky factorisation. Off also for a NaN or
        // infinite setting.
        if !k.is_finite() || k <= T::zero() {
            return found.theta;
        }
        let Some(sd) = found.sd(p) else {
            return found.theta;
        };
        let flat = found.flat(p);
        let mut t = found.theta;
        for (i, ((v, s), spec)) in t
            .iter_mut()
            .zip(sd.iter())
            .zip(self.id.specs.iter())
            .enumerate()
        {
            let intensity = !matches!(spec.kind, Quantity::Tau | Quantity::Beta);
            if intensity && !has_coordinate(flat, i) && s.is_finite() {
                *v += (k * *s).min(T::lit(CONSERVATIVE_CAP));
            }
        }
        self.id.bounds.clamp(&t, p)
    }

    /// End of a global search: jump to its best point when it beats the anchor by the margin.
    /// Unlike a probe, the point has no 1-Hz filter state: the centre keeps its `x, P`, and the
    /// windowed information is discarded (it was gathered at another point).
    pub(super) fn global_end(&mut self, found: &Found<T>) -> bool {
        self.last_global = *found;
        if !self.id.cfg.adapt {
            return false;
        }
        // The first finished search ends the search phase (the recursion, when not held,
        // then climbs from the basin the window chose).
        self.id.searching = false;
        let p = self.id.specs.len().min(MAXP);
        // Issue 13, item 2: what the window does not bound is flagged, not left to wander.
        let was_flat = self.flat;
        self.flat = found.flat(p);
        let pen = self.id.cfg.global.structure;
        if let Some(sw) = found.switch.get().filter(|s| s.wins(pen)) {
            if self.switch_structure(sw, found.blocks).is_ok() {
                self.id.jumps = self.id.jumps.saturating_add(1);
                self.switches = self.switches.saturating_add(1);
                self.at_start = false;
                // The window's information describes the old structure's parameters.
                self.last_global.fisher = [[T::zero(); MAXP]; MAXP];
                self.flat = 0;
                return true;
            }
        }
        // The start model is left only when the window rejects it (`keep_start`): the
        // likelihood-ratio statistic of the start against the window's maximum, `2 gain`,
        // beyond its 95 % chi-square quantile with `p` degrees of freedom.
        // And an identified model is not left for an answer with a flat coordinate unless the
        // window rejects it (`keep_identified`): the likelihood is flat along that direction,
        // so the move would be the wandering issue 13's item 2 forbids. Not after a change in
        // service, like the revisit of a flat answer (§7.8): the models since are fitted to
        // windows of a few hours.
        let keep_flat = self.id.cfg.global.keep_identified
            && self.flat != 0
            && was_flat == 0
            && self.global.changes() == 0;
        let margin = if (self.id.cfg.global.keep_start && self.at_start) || keep_flat {
            let q = HOLD_QUANTILE.get(p.wrapping_sub(1)).copied().unwrap_or(0.0);
            self.id.cfg.global.margin.max(T::lit(q))
        } else {
            self.id.cfg.global.margin
        };
        if !(found.gain.is_finite() && found.gain > margin) {
            if keep_flat {
                // The filter still runs the identified model: its flags stay.
                self.flat = was_flat;
            }
            return false;
        }
        self.at_start = false;
        // Held only where the window cannot tell the held values from its best point: the
        // likelihood-ratio statistic of the hold (the profile likelihood's, `hold_cost`
        // halved) within its 95 % chi-square quantile for k held coordinates. Beyond it the
        // data speak against the held values, whatever the marginal deviations say.
        let k = self.flat.count_ones() as usize;
        let quantile = HOLD_QUANTILE.get(k.wrapping_sub(1)).copied().unwrap_or(0.0);
        let target = if self.id.cfg.global.hold_flat
            && self.flat != 0
            && found.hold_cost <= T::lit(quantile)
        {
            let kept = found.gain - found.hold_cost;
            if kept.partial_cmp(&self.id.cfg.global.margin) != Some(core::cmp::Ordering::Greater) {
                // The held point is no better than where the filter is.
                return false;
            }
            self.id.bounds.clamp(&found.held, p)
        } else {
            self.raised(found, p)
        };
        // Staggered (one member re-discretised per tick, the centre first), unlike a probe's
        // jump: the recursion is held, so only the information waits for the members, and the
        // tick that ends a search does not add the 2p + 1 re-discretisations of a jump at once
        // (about 230k instructions on the Cortex-M4, §5 of docs/ADAPTATION.md) to its share
        // of the search.
        self.id.bank.request_theta(&target);
        // A move within a factor two keeps the windowed information (it still describes the
        // likelihood near the new point, as after a Gauss-Newton move); a longer one is a jump to
        // another basin, where it does not.
        let far = self
            .id
            .theta
            .iter()
            .zip(target.iter())
            .take(p)
            .any(|(a, b)| (*a - *b).abs() > T::lit(core::f64::consts::LN_2));
        self.id.theta = target;
        if far {
            self.id.forget_window(true);
        }
        self.id.jumps = self.id.jumps.saturating_add(1);
        if !self.id.probes.is_empty() {
            self.id
                .probes
                .anchor(&self.id.theta, &self.id.bounds, self.id.specs.len());
        }
        true
    }
}
