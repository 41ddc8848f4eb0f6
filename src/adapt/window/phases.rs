//! The search's phases: the point each phase evaluates next and what a finished pass moves
//! the search on to (the anchor, the carried points, the grid, the polishes, the structure
//! test, the hold). A child of [`super`]: it works on the search's own state.

use super::{grid_points, structure, Found, Phase, Switch, WindowSearch};
use crate::adapt::guard::Bounds;
use crate::adapt::identifiable::IdentifiableModel;
use crate::adapt::params::{Specs, MAXP};
use crate::Real;

impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize, const W: usize>
    WindowSearch<T, M, N, Z, W>
{
    /// Whether the running phase is the structure test's.
    pub(super) fn in_alternative(&self) -> bool {
        matches!(self.phase, Phase::AltScan(_) | Phase::AltRefine)
    }

    /// The point to evaluate next and whether with derivatives; `None` only when idle.
    pub(super) fn next_point(&self, p: usize, bounds: &Bounds<T>) -> Option<([T; MAXP], bool)> {
        match self.phase {
            Phase::Idle => None,
            Phase::Anchor => Some((self.anchor, false)),
            Phase::Carried(k) => Some((*self.carried.get(k)?, false)),
            Phase::Grid(k) => Some((self.grid_point(k, p, bounds), false)),
            Phase::Polish(_)
            | Phase::Refine(_)
            | Phase::AltRefine
            | Phase::NestRefine
            | Phase::HoldRefine => Some((self.pass.theta, true)),
            Phase::AltScan(j) => Some((self.alt.scan_point(j)?, false)),
        }
    }

    /// Records the finished pass and moves on; the result when the search ends.
    pub(super) fn complete(
        &mut self,
        base: &M,
        specs: &Specs,
        bounds: &Bounds<T>,
    ) -> Option<Found<T>> {
        self.evaluations = self.evaluations.saturating_add(1);
        let p = specs.len().min(MAXP);
        let (first, second) = grid_points(p);
        let grid_len = first + second;
        let theta = self.pass.theta;
        let ll = self.pass.ll + self.prior.log(&theta);
        let next = match self.phase {
            Phase::Idle => Phase::Idle,
            Phase::Anchor => {
                self.anchor_ll = ll;
                self.best_ll = ll;
                self.offer_diverse(ll, &theta, specs);
                if self.early {
                    self.tested = true;
                    self.after_alternative(base, specs, bounds)
                } else {
                    self.after_carried(0)
                }
            }
            Phase::Carried(k) => {
                self.offer_diverse(ll, &theta, specs);
                self.after_carried(k + 1)
            }
            Phase::Grid(k) => {
                self.offer_diverse(ll, &theta, specs);
                if k + 1 < grid_len {
                    Phase::Grid(k + 1)
                } else {
                    self.start_polish(0, false)
                }
            }
            Phase::Polish(k) => self.polish_step(k, false, theta, ll, p, bounds),
            Phase::Refine(k) => match self.polish_step(k, true, theta, ll, p, bounds) {
                // The model's search is over: the structure test follows on the same window,
                // once the model has settled (`structure::SETTLED`), unless it ran first.
                Phase::Idle if !self.tested && self.settled() => {
                    self.tested = true;
                    self.next_alternative(base, specs, bounds)
                }
                Phase::Idle => Phase::Idle,
                next => next,
            },
            Phase::AltScan(j) => {
                if ll.is_finite() && ll > self.scan_ll {
                    self.scan_ll = ll;
                    self.scan_best = theta;
                }
                if j + 1 < self.alt.scan_len() {
                    Phase::AltScan(j + 1)
                } else {
                    let start = self.scan_best;
                    self.begin_polish(&start, Phase::AltRefine)
                }
            }
            Phase::AltRefine => {
                let (ap, ab) = (self.alt.specs.len().min(MAXP), self.alt.bounds);
                match self.polish_step(0, true, theta, ll, ap, &ab) {
                    Phase::Idle => {
                        let could_win = self.end_alternative(p);
                        if self.early && !could_win {
                            // Tested first, the nested polish only confirms a winner (it can
                            // only lower the gain), and the model's own search follows.
                            self.after_alternative(base, specs, bounds)
                        } else {
                            // The filter model again, from the alternative's point without its
                            // extra parameters: measured, from wrong starts the alternative's
                            // two scan origins sometimes found a better Gauss-Markov fit than
                            // the search's own polish, and that difference passed for
                            // structure (`docs/ADAPTATION.md` §7.6).
                            let back = crate::adapt::params::remap(
                                &self.alt.specs,
                                &self.acc_theta,
                                specs,
                                &self.best,
                            );
                            self.begin_polish(&bounds.clamp(&back, p), Phase::NestRefine)
                        }
                    }
                    next => next,
                }
            }
            Phase::NestRefine => match self.polish_step(0, true, theta, ll, p, bounds) {
                Phase::Idle => self.after_alternative(base, specs, bounds),
                next => next,
            },
            Phase::HoldRefine => self.polish_step(0, true, theta, ll, p, bounds),
        };
        // The search's last phase: what the window does not identify is held at the anchor's
        // values and the rest polished, once (the profile likelihood of the hold).
        let next = if next == Phase::Idle && self.cfg.hold_flat && self.fixed == 0 {
            self.begin_hold(p, bounds)
        } else {
            next
        };
        self.phase = next;
        if next == Phase::Idle {
            self.fixed = 0;
            if !self.settled() {
                // The rule of the test run after the search: no switch from a model that moved
                // (a test run first, on a model the rest of the search then moved, is void).
                self.switch = Switch::NONE;
            }
            let found = Found {
                theta: self.best,
                gain: self.best_ll - self.anchor_ll,
                blocks: u32::try_from(self.wlen).unwrap_or(u32::MAX),
                evaluations: self.evaluations,
                fisher: self.best_fisher,
                held: self.held,
                hold_cost: self.best_ll - self.held_ll,
                // The gain against the final best (a nested polish may have raised it).
                switch: Switch {
                    gain: self.switch_ll - self.best_ll,
                    ..self.switch
                },
            };
            // An answer the window does not identify is revisited sooner, on more data. Not
            // after a change in service: the windows since it already double from 1 h, and
            // measured, moving those searches re-armed the change monitor on a wrong answer
            // before it could alarm again (fresh seed 70216 of `change_bench`, host pace:
            // 8.3x oracle B against 1.02x).
            // With the structure test on too. Measured at firmware pace (BENCHMARKS.md
            // "Structure online, 2026-11-27"): without the revisit, the any-start bench with
            // the test on (seeds 9100-9119, 640 runs) had 2 of 20 seeds with every run within
            // 1.05x and a worst run of 8.1x; with it, 18 of 20 and 1.26x. The cost: the test
            // also runs on the revisit's shorter window, and switches sooner with a wider beta
            // (worst 16 % off against 10 % on seeds 9300-9319, host pace). Skipping the test
            // on revisits was tried: then 3 of 60 logs of the switched at all.
            self.carry_list = found.flat(p) == 0;
            // (An unsettled search holds no switch: see above.)
            self.test_first = found.switch.valid && found.switch.gain > T::zero();
            if self.cfg.flat_every > 0 && self.changes == 0 && found.flat(p) != 0 {
                let soon = self.pushed.saturating_add(self.cfg.flat_every);
                self.next_search = self.next_search.min(soon);
            }
            return Some(found);
        }
        None
    }

    /// The next alternative's scan or polish, or the end of the structure test.
    fn after_alternative(&mut self, base: &M, specs: &Specs, bounds: &Bounds<T>) -> Phase {
        match self.next_alternative(base, specs, bounds) {
            Phase::Idle => self.structure_done(specs),
            next => next,
        }
    }

    /// Whether the search's answer beats its anchor by at most `structure::SETTLED` nats.
    pub(super) fn settled(&self) -> bool {
        self.best_ll - self.anchor_ll <= T::lit(structure::SETTLED)
    }

    /// The end of the structure test. Run after the search (`early` off): the search ends.
    /// Run first (`early`): the search ends when the best alternative already wins against
    /// the filter's model as polished so far (the anchor and the nested polish), with that
    /// model settled; otherwise the model's search goes on (carried points, grid, polishes),
    /// with the nested polish's point in its list, and the switch is decided again at its end
    /// against its answer (`Found::switch`'s gain is against the final best).
    ///
    /// Why first: at 64 filter steps per tick a search over a 4-5-h window (120-210 passes,
    /// most of them polish iterations of `2p + 1` filters) ends 1-1.5 h after its window froze,
    /// and the test after it decided on data that old. First, the decision comes after the
    /// test alone (20-40 min). Measured, `docs/ADAPTATION.md` §7.15.
    pub(super) fn structure_done(&mut self, specs: &Specs) -> Phase {
        if !core::mem::take(&mut self.early) {
            return Phase::Idle;
        }
        let now = Switch {
            gain: self.switch_ll - self.best_ll,
            ..self.switch
        };
        if self.settled() && now.wins(self.cfg.structure) {
            return Phase::Idle;
        }
        let (ll, best) = (self.best_ll, self.best);
        self.offer_diverse(ll, &best, specs);
        self.after_carried(0)
    }

    /// Starts the hold's polish when the best point has flat coordinates; `Idle` otherwise.
    fn begin_hold(&mut self, p: usize, bounds: &Bounds<T>) -> Phase {
        let probe = Found {
            theta: self.best,
            fisher: self.best_fisher,
            ..Found::BLANK
        };
        let flat = probe.flat(p);
        if flat == 0 {
            return Phase::Idle;
        }
        self.fixed = flat;
        let start = bounds.clamp(&probe.held(&self.anchor, flat, p), p);
        self.begin_polish(&start, Phase::HoldRefine)
    }
}
