//! The global stage (issue 13): maximum likelihood over a buffered window of block means,
//! searched from a grid that does not depend on where the recursion happens to be.
//!
//! # Why
//! The recursive Gauss-Newton of [`super`] climbs locally, and the likelihood of one velocity
//! channel is multi-modal (accelerometer and gyro errors reach `z` through the same state and
//! are told apart only by their spectra). Measured on the host (`examples/ml_probe.rs`,
//! `docs/ADAPTATION.md` §7): a compass search on the window's likelihood from the start still
//! ends in the wrong basin from 2 of 8 starts, while a grid of factors `10^{-1, 0, 1}` in every
//! parameter followed by a local polish reaches, from all 8, the maximum that an offline fit
//! to the same hours reaches.
//!
//! The search is generic over the error model ([`IdentifiableModel`]): the window holds one
//! block mean per observation axis, and the model says where its prior does not hold at a
//! window's start ([`IdentifiableModel::window_start`]; the one-channel INS's diffuse velocity
//! and tilt below).
//!
//! # What
//! - Every `block` ticks the mean of the observations is pushed into a ring of `W` (by default
//!   [`WINDOW_CAP`]) block means (a block with a missing observation is missing on its axis).
//! - A search evaluates, each over the same frozen window of the most recent `window` blocks,
//!   the exact innovation log-likelihood (Schweppe) of the block means: the model over one
//!   block is the exact system of the block sums ([`pass::block_system`]), so nothing is
//!   approximated but the information the averaging removes (frequencies above `1 / (2 block
//!   dt)`). The velocity and tilt errors start loose (the window begins hours into the run).
//! - Points: the anchor (the filter's current `theta`), the last search's answer and polished
//!   list when that answer was identified (at most [`TOP`]; `polish.rs`, `carry`), then the
//!   `3^p` grid around the start model (spacing `spacing` in `ln`: factors 0.1, 1, 10; shifted
//!   by half a spacing every other search), then a brief polish (4 iterations) of the best
//!   [`TOP`] = 6 of them (no more than 3 sharing one component's values) and a polish to
//!   convergence of the best and of the most promising of the others (likelihood plus the gain
//!   its next step promises), by Levenberg-Marquardt Fisher scoring on the window: each
//!   iteration is one pass of `2p + 1` filters giving the score and the Fisher information by central
//!   differences ([`pass::Pass`]), the step `(I + lambda diag I)^-1 g` is accepted when the
//!   next pass's likelihood is not lower, and `lambda` grows tenfold when it is.
//! - The work is time-sliced: [`WindowSearch::work`] spends at most `budget` filter steps per
//!   tick, a filter construction counted as [`PREPARE_COST`] of them (at most one per tick), so
//!   a tick's cost is bounded whatever the window.
//!
//! The answer is the best point and its advantage over the anchor on the same window; the
//! caller decides whether to jump (a likelihood-ratio margin).
//!
//! # Cost law (`p` identified parameters, window `W` blocks, `n` states)
//! Filter steps per search: `W (1 + TOP + G + (4 TOP + 2 c) (2p + 1))` at most, with `c` about
//! 3-8 scoring iterations and `G` grid points; each is a step of an `n + 1`-state filter.
//! RAM: the ring, `WINDOW_CAP` values, plus `2p + 1` filters.
//! A grid over all `p` would be exponential in `p` (`3^p`): it is the price of not depending on
//! the start. So the grid spans at most [`GRID_DIMS`] = 4 coordinates at a time, one group
//! after another ([`grid_points`]): `G = 81` up to p = 5, `81 + 3^(p - 4)` for p = 6-8 (162 at
//! p = 8, the feature `params8`). The search's cost is then linear in `p` beyond 4.

// Small fixed-size code reads best with explicit indices.
#![allow(clippy::needless_range_loop)]

mod config;
mod found;
mod grid;
mod monitor;
pub mod pass;
mod phases;
mod polish;
mod prior;
mod ring;
pub mod structure;
#[cfg(test)]
mod tests;

use crate::adapt::guard::{Bounds, Mat};
use crate::adapt::identifiable::IdentifiableModel;
use crate::adapt::params::{Specs, MAXP};
use crate::model::{InsModel, NX};
use crate::Real;
use monitor::Monitor;
use pass::Pass;
use structure::Alternative;

pub use config::{
    WindowConfig, AFTER_CHANGE, CHANGE_THRESHOLD, CONSERVATIVE_CAP, FILLING_EVERY, FLAT_EVERY,
    PRIOR_DECADES, STRUCTURE_FILLING_EVERY, STRUCTURE_FIRST, STRUCTURE_PENALTY,
};
pub use found::{Found, Switch};
use grid::GRID;
pub use grid::{grid_points, GRID_DIMS};

/// Capacity of the ring of block means: 8 h of 60-s blocks (480) plus the blocks that arrive
/// while a search over a full window runs (a tenth of the ring, 1 h).
pub const WINDOW_CAP: usize = 600;
/// Points of the anchor and the grid that are polished briefly (multi-start: measured, one
/// polish from the best grid point, or three, end on the accelerometer's random-walk ridge from
/// some starts: the grid point nearest the maximum need not be among the best three). 8 until
/// the list was made diverse ([`CROWD`]) and the brief polish longer ([`SHORT_ITERATIONS`]);
/// with both, 6 keeps the brief polishes' cost (`6 x 4` passes against `8 x 3`). Development
/// seeds 83500-83519 (640 runs, firmware pace): 8, 6 and 5 all gave 20 of 20 seeds within 1.05x
/// of the ML reference; tilt / oracle median 1.0066, 1.0079, 1.0094, worst 3-sigma fraction
/// 3.05, 3.10, 3.26 %.
pub const TOP: usize = 6;
/// Entries of the `TOP` list that may share one component's values (`offer_diverse`, which
/// says why). Measured at firmware pace on development seeds 83500-83519 (640 runs from any
/// start, `TOP` = 8, searches every 2 h while the window fills): 3 and 2 both gave 19 of 20
/// seeds with every run within 1.05x of the ML reference, with 3 or 4 brief iterations, and 3
/// kept the worst 3-sigma fraction lower (2.88-2.98 % against 2.88-6.87 %); with the search
/// when the window first fills too, 3 gave 20 of 20 (BENCHMARKS.md "Searches while the window
/// fills; a diverse multi-start").
const CROWD: usize = 3;
/// Scoring iterations of the brief polish. 4, not 3: from a diverse list the point nearest the
/// maximum can start far down (seed 83512: 15x off in the accelerometer's `tau`), and after 3
/// iterations it was still 11 nats below a polished wrong basin, so it was not refined (19 of
/// 20 seeds within 1.05x with 3, 20 of 20 with 4).
const SHORT_ITERATIONS: u32 = 4;
/// Points refined to convergence after the brief polishes: the best, and the most promising
/// of the others (`rank_for_refinement`).
const FINAL: usize = 2;
/// Scoring iterations per polish at most.
const MAX_ITERATIONS: u32 = 12;
/// Filter steps one filter's construction (a discretisation and a block system of 60 ticks) is
/// counted as in the budget: about 40 filter steps' instructions on the Cortex-M4.
pub const PREPARE_COST: usize = 40;
/// Finite-difference step of the polish's derivatives (`ln`), as the bank's.
const DIFF_STEP: f64 = 0.1;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Idle,
    Anchor,
    /// The `k`-th point carried from the previous search's list ([`WindowSearch::carry`]).
    Carried(usize),
    Grid(usize),
    /// Brief polish of the `k`-th best point of the grid.
    Polish(usize),
    /// Polish to convergence of the `k`-th best point after the brief polishes.
    Refine(usize),
    /// Structure test: the `j`-th scan point of the current alternative.
    AltScan(usize),
    /// Structure test: the polish of the current alternative.
    AltRefine,
    /// Structure test: the filter model polished again from the alternative's point mapped
    /// back (so that a gain is not merely a better polish).
    NestRefine,
    /// The flat coordinates held at the anchor's values, the others polished: the profile
    /// likelihood of the hold ([`WindowConfig::hold_flat`]).
    HoldRefine,
}

/// The buffered window and the time-sliced search over it, for the error model `M` with `N`
/// states and `Z` observation axes (the one-channel INS by default), in a ring of `W` block
/// means (a window holds at most nine tenths of it; the rest takes the blocks that arrive
/// while a search runs). Its passes are filters of `n + Z` states (the model's `n` and one
/// block sum per axis), so `n + Z <= N`.
#[derive(Debug, Clone)]
pub struct WindowSearch<
    T: Real,
    M = InsModel<T>,
    const N: usize = NX,
    const Z: usize = 1,
    const W: usize = WINDOW_CAP,
> {
    cfg: WindowConfig<T>,
    /// Block means, one per axis (NaN: missing on that axis).
    ring: [[T; Z]; W],
    /// Index the next block mean goes to.
    head: usize,
    /// Block means pushed since the start.
    pushed: u32,
    /// Block means pushed before the last change in service: no window reaches before it.
    floor: u32,
    /// Changes in service found by the monitor.
    changes: u32,
    /// Watches the filter's model on the new blocks for a change in service.
    monitor: Monitor<T, N, Z>,
    acc: [T; Z],
    acc_n: u32,
    missing: [bool; Z],
    /// Frozen window of the running search: first block (ring index) and length.
    w0: usize,
    wlen: usize,
    /// Blocks pushed when the running search started.
    started_at: u32,
    /// The window's first finite block mean on each axis.
    z0: [T; Z],
    phase: Phase,
    /// Centre of the grid: the start model (fixed, so that the grid covers the same region
    /// whatever happened since).
    centre: [T; MAXP],
    anchor: [T; MAXP],
    anchor_ll: T,
    best: [T; MAXP],
    best_ll: T,
    /// The window's Fisher information at `best` (zero until a polish reaches it).
    best_fisher: Mat<T>,
    /// Coordinates the polish does not move (bit `i`: `theta[i]`; the hold's).
    fixed: u8,
    /// The hold's polished point and its log-likelihood (NaN: no hold evaluated).
    held: [T; MAXP],
    held_ll: T,
    /// The best `TOP` points of the anchor and the grid, best first.
    top: [[T; MAXP]; TOP],
    top_ll: [T; TOP],
    /// After the brief polishes: each entry's gain still ahead, as its last quadratic model
    /// predicts for one more step ([`step_gain`](Self::step_gain)).
    top_ahead: [T; TOP],
    /// The previous search's answer and polished list, offered to this search beside the grid
    /// (`carry`); `carried_len` of them.
    carried: [[T; MAXP]; TOP],
    carried_len: usize,
    /// The last search ran to an answer the window identifies: its list is carried to the next.
    carry_list: bool,
    /// The last search settled (its answer beat its anchor by at most `structure::SETTLED`
    /// nats) and its best alternative structure beat that answer (a positive gain, before
    /// the penalty), with no structure switch or change in service since: the next search
    /// tests structure first.
    test_first: bool,
    /// The running search tests structure first, from its anchor ([`phases`]: after a settled
    /// answer an alternative beat), and has not finished that test yet.
    early: bool,
    /// The running search's structure test has run (it runs once per window).
    tested: bool,
    /// Active states of the model's block filters (the last model pass's): the unit of the
    /// budget's steps.
    model_states: usize,
    /// The change monitor built its filter on this tick's block (`push`): the search's share
    /// of the tick then holds no construction of its own.
    monitor_built: bool,
    /// Polish: the last accepted point, its likelihood, score and information; the damping.
    acc_theta: [T; MAXP],
    acc_ll: T,
    acc_score: [T; MAXP],
    acc_fisher: Mat<T>,
    lambda: T,
    iterations: u32,
    pass: Pass<T, N, Z>,
    running: bool,
    evaluations: u32,
    next_search: u32,
    /// Searches started.
    searches: u32,
    /// Structure test: the alternative being searched, its index among the model's switchable
    /// components, its best scan point, and the best alternative so far.
    alt: Alternative<T, M, N, Z>,
    alt_k: usize,
    scan_best: [T; MAXP],
    scan_ll: T,
    switch: Switch<T>,
    /// The best alternative's log-likelihood.
    switch_ll: T,
    /// Seconds per block (for the scan's periods).
    block_s: T,
    /// The running pass's prior ([`WindowConfig::prior`]).
    prior: prior::Prior<T>,
}

impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize, const W: usize>
    WindowSearch<T, M, N, Z, W>
{
    /// Nothing buffered, off (a compile-time value).
    pub const BLANK: Self = Self {
        cfg: WindowConfig::OFF,
        ring: [[T::ZERO; Z]; W],
        head: 0,
        pushed: 0,
        floor: 0,
        changes: 0,
        monitor: Monitor::BLANK,
        acc: [T::ZERO; Z],
        acc_n: 0,
        missing: [false; Z],
        w0: 0,
        wlen: 0,
        started_at: 0,
        z0: [T::ZERO; Z],
        phase: Phase::Idle,
        centre: [T::ZERO; MAXP],
        anchor: [T::ZERO; MAXP],
        anchor_ll: T::ZERO,
        best: [T::ZERO; MAXP],
        best_ll: T::ZERO,
        best_fisher: [[T::ZERO; MAXP]; MAXP],
        fixed: 0,
        held: [T::ZERO; MAXP],
        held_ll: T::ZERO,
        top: [[T::ZERO; MAXP]; TOP],
        top_ll: [T::ZERO; TOP],
        top_ahead: [T::ZERO; TOP],
        carried: [[T::ZERO; MAXP]; TOP],
        carried_len: 0,
        carry_list: false,
        test_first: false,
        early: false,
        tested: false,
        model_states: 0,
        monitor_built: false,
        acc_theta: [T::ZERO; MAXP],
        acc_ll: T::ZERO,
        acc_score: [T::ZERO; MAXP],
        acc_fisher: [[T::ZERO; MAXP]; MAXP],
        lambda: T::ZERO,
        iterations: 0,
        pass: Pass::BLANK,
        running: false,
        evaluations: 0,
        next_search: 0,
        searches: 0,
        alt: Alternative::BLANK,
        alt_k: 0,
        scan_best: [T::ZERO; MAXP],
        scan_ll: T::ZERO,
        switch: Switch::NONE,
        switch_ll: T::ZERO,
        block_s: T::ZERO,
        prior: prior::Prior::BLANK,
    };

    /// Starts empty with `cfg`, the grid centred on `centre` (the start model's parameters), in
    /// place like the rest of the adaptive filter.
    pub fn init(&mut self, cfg: WindowConfig<T>, centre: &[T; MAXP]) {
        *self = Self::BLANK;
        self.centre = *centre;
        // The window leaves a tenth of the ring for the blocks that arrive during a search.
        self.cfg = WindowConfig {
            window: cfg
                .window
                .min(u32::try_from(W / 10 * 9).unwrap_or(u32::MAX)),
            block: cfg.block.min(pass::MAX_BLOCK),
            ..cfg
        };
        self.next_search = cfg.first.max(2);
        self.monitor = Monitor::new(cfg.change);
    }

    /// After a structure switch: the grid's centre (the start model's parameters) in the new
    /// layout `to` (a parameter new to the model is centred where the switch put it, `theta`);
    /// a running search is abandoned (its window is searched again at the next one).
    pub fn restructure(&mut self, from: &Specs, to: &Specs, theta: &[T; MAXP]) {
        self.centre = crate::adapt::params::remap(from, &self.centre, to, theta);
        // The last search's points are in the old layout, and its model is not the filter's.
        self.carry_list = false;
        self.test_first = false;
        self.phase = Phase::Idle;
        self.running = false;
    }

    /// The sensor changed in service `blocks` block means ago: no window reaches before that, a
    /// running search (whose window spans the change) is abandoned, and the next one starts
    /// `after_change` blocks after the change.
    fn changed(&mut self, blocks: u32) {
        self.floor = self.floor.max(self.pushed.saturating_sub(blocks));
        self.changes = self.changes.saturating_add(1);
        // The last search's points and answer describe the sensor before the change.
        self.carry_list = false;
        self.test_first = false;
        self.phase = Phase::Idle;
        self.running = false;
        self.next_search = self.floor.saturating_add(self.cfg.after_change.max(2));
    }

    /// Watches the model `theta` (the filter's, after a search) for a change in service from
    /// the next block on ([`monitor`]).
    pub fn watch(&mut self, theta: &[T; MAXP]) {
        self.monitor.watch(theta);
    }

    /// Block means pushed before the last change found (`0`: none found): the first block any
    /// window may hold.
    pub fn floor(&self) -> u32 {
        self.floor
    }

    /// Changes in service reported so far.
    pub fn changes(&self) -> u32 {
        self.changes
    }

    /// Seconds per block mean (the block length times the model's `dt`; zero before the first
    /// search).
    pub fn block_seconds(&self) -> T {
        self.block_s
    }

    /// Whether a search is running.
    pub fn searching(&self) -> bool {
        self.phase != Phase::Idle
    }

    /// Passes of the last or running search.
    pub fn evaluations(&self) -> u32 {
        self.evaluations
    }

    /// The log-likelihood of `theta` over the window of the last (or running) search, computed
    /// at once (for tests and host tools: it costs a whole window). `None` if the model cannot be
    /// discretised or the window was overwritten since.
    pub fn window_loglik(&self, base: &M, specs: &Specs, theta: &[T; MAXP]) -> Option<T> {
        if !self.window_intact() {
            return None;
        }
        let mut p = self.pass.clone();
        p.start(theta, specs.len(), None, self.cfg.block, &self.z0);
        p.prepare(base, specs).ok()?;
        for z in self.window_blocks() {
            p.push(&z);
        }
        Some(p.ll)
    }

    /// Starts a search anchored at `anchor` over the most recent blocks.
    pub fn start(&mut self, anchor: &[T; MAXP]) {
        let since_change = self.pushed.saturating_sub(self.floor) as usize;
        let avail = (self.pushed as usize).min(W).min(since_change);
        self.wlen = avail.min(self.cfg.window as usize);
        self.w0 = (self.head + W - self.wlen) % W.max(1);
        self.started_at = self.pushed;
        // Structure first when the last answer settled and its best alternative beat it, with
        // the test on. Not after every settled answer: one can be a wrong basin's, and the
        // test first delayed the search that leaves it (development seed 83517: two starts
        // at 2.2x the oracle against 1.02x; `docs/ADAPTATION.md` §7.15).
        self.early = self.cfg.structure > T::zero() && self.test_first;
        self.tested = false;
        self.carry(anchor);
        // The window is frozen: its first finite mean (every pass's velocity start) once.
        self.z0 = self.first_finite();
        self.anchor = *anchor;
        self.best = *anchor;
        self.best_fisher = [[T::zero(); MAXP]; MAXP];
        self.fixed = 0;
        self.held = *anchor;
        self.held_ll = T::lit(f64::NAN);
        self.anchor_ll = T::lit(f64::NEG_INFINITY);
        self.best_ll = T::lit(f64::NEG_INFINITY);
        self.top = [*anchor; TOP];
        self.top_ll = [T::lit(f64::NEG_INFINITY); TOP];
        self.top_ahead = [T::zero(); TOP];
        self.phase = Phase::Anchor;
        self.running = false;
        self.evaluations = 0;
        self.alt_k = 0;
        self.switch = Switch::NONE;
        self.searches = self.searches.wrapping_add(1);
        // After a change the window since it doubles from one search to the next until the
        // usual pace is reached: the first answers on the new sensor come from short windows.
        let every = if self.changes > 0 {
            self.cfg.every.min(since_change as u32)
        } else if self.filling() {
            self.cfg.filling_every
        } else {
            self.cfg.every
        };
        self.next_search = self.pushed.saturating_add(every.max(1));
        let full = self.floor.saturating_add(self.cfg.window);
        if self.changes == 0
            && self.filling()
            && self.next_search.saturating_add(self.cfg.filling_every / 2) > full
        {
            // A search as soon as the window is full (FILLING_EVERY); one due within half the
            // filling pace of that waits for it, so that it is not still running then (seed
            // 92718: a revisit at 5.7 h put the next search at 7.7 h, and the first full
            // window's answer came at 9.8 h).
            self.next_search = full;
        }
    }

    /// Runs at most `budget` filter steps (a pass with derivatives counts `2p + 1` per block).
    /// Returns the result when the search ends on this tick. `base`/`specs`/`bounds` describe
    /// the model (as the bank's).
    pub fn work(&mut self, base: &M, specs: &Specs, bounds: &Bounds<T>) -> Option<Found<T>> {
        // A filter the change monitor built on this tick counts as the tick's construction
        // (measured: with hourly searches the next search ran beside the monitor's rebuild
        // after the last one, and that tick reached 641k Cortex-M4 instructions). Taken on
        // every tick, so that it never outlives its tick.
        let monitor_built = core::mem::take(&mut self.monitor_built);
        if self.phase == Phase::Idle {
            return None;
        }
        if !self.window_intact() {
            // The ring wrapped onto the window: abandon the search.
            self.phase = Phase::Idle;
            return None;
        }
        let p = specs.len().min(MAXP);
        self.block_s = T::lit(f64::from(self.cfg.block)) * base.dt();
        let mut budget = self.cfg.budget as usize;
        let mut prepared_this_tick = monitor_built;
        // Each turn starts a pass, runs some blocks, or ends one: a pass takes at most three
        // turns on a tick, and a tick ends when the budget is spent.
        for _ in 0..(3 * GRID + 64 + 2 * pass::MEMBERS_MAX) {
            if !self.running {
                let (theta, derivs) = self.next_point(p, bounds)?;
                let h = derivs.then(|| T::lit(DIFF_STEP));
                let np = if self.in_alternative() {
                    self.alt.specs.len()
                } else {
                    p
                };
                self.pass.start(&theta, np, h, self.cfg.block, &self.z0);
                self.set_prior(specs);
                self.running = true;
            }
            if !self.pass.ready() {
                // Building a filter (a discretisation and a block system, about as costly as
                // PREPARE_COST filter steps) happens at most once per tick, and only while
                // PREPARE_COST of the budget is left (or on the tick's first turn, so a budget
                // below PREPARE_COST still advances): the tick then stays within its budget.
                // Charging the construction after the steps had spent the budget let the worst
                // tick reach 64 steps plus a construction, 568k Cortex-M4 instructions with the
                // structure test on (BENCHMARKS.md, "The window search's budget kept").
                let fresh = budget == self.cfg.budget as usize;
                if prepared_this_tick || (budget < PREPARE_COST && !fresh) {
                    return None;
                }
                prepared_this_tick = true;
                budget = budget.saturating_sub(PREPARE_COST);
                let prepared = if self.in_alternative() {
                    self.pass.prepare(&self.alt.base, &self.alt.specs)
                } else {
                    self.pass.prepare(base, specs)
                };
                if prepared.is_err() {
                    // A point that cannot be discretised counts as evaluated, with no likelihood.
                    self.pass.ll = T::lit(f64::NEG_INFINITY);
                    self.running = false;
                    if let Some(done) = self.complete(base, specs, bounds) {
                        return Some(done);
                    }
                }
                continue;
            }
            let cost = if self.in_alternative() {
                self.pass.cost(self.model_states)
            } else {
                self.model_states = self.pass.states();
                self.pass.count().max(1)
            };
            let steps = budget
                .checked_div(cost)
                .unwrap_or(0)
                .min(self.wlen.saturating_sub(self.pass.pos));
            if steps == 0 && self.pass.pos < self.wlen {
                return None;
            }
            for _ in 0..steps {
                let z = self.block(self.pass.pos);
                self.pass.push(&z);
            }
            budget = budget.saturating_sub(steps * cost);
            if self.pass.pos >= self.wlen {
                self.running = false;
                if let Some(done) = self.complete(base, specs, bounds) {
                    return Some(done);
                }
            }
        }
        None
    }
}
