//! The window search's multi-start polish: the best `TOP` points of the anchor and the grid,
//! each polished briefly by Levenberg-Marquardt Fisher scoring, then `FINAL` of them (the best
//! and the most promising) to convergence (module documentation of [`super`]). A child of
//! [`super`]: it works on the search's own state.

// Small fixed-size code reads best with explicit indices.
#![allow(clippy::needless_range_loop)]

use super::{Phase, WindowSearch, CROWD, FINAL, MAX_ITERATIONS, SHORT_ITERATIONS, TOP};
use crate::adapt::guard::Bounds;
use crate::adapt::identifiable::IdentifiableModel;
use crate::adapt::params::{has_coordinate, ParamSpec, Specs, MAXP};
use crate::linalg::{chol_solve, cholesky};
use crate::Real;

impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize, const W: usize>
    WindowSearch<T, M, N, Z, W>
{
    /// Keeps `theta` (with its gain still `ahead`: zero before the brief polishes) among the
    /// `TOP` best points by likelihood.
    pub(super) fn offer(&mut self, ll: T, theta: &[T; MAXP], ahead: T) {
        // Insertion into a sorted array of TOP entries (best first).
        let mut cand = (ll, *theta, ahead);
        for ((l, t), a) in self
            .top_ll
            .iter_mut()
            .zip(self.top.iter_mut())
            .zip(self.top_ahead.iter_mut())
        {
            if cand.0 > *l {
                core::mem::swap(l, &mut cand.0);
                core::mem::swap(t, &mut cand.1);
                core::mem::swap(a, &mut cand.2);
            }
        }
    }

    /// [`offer`](Self::offer) for the anchor and the grid, then the list thinned so that no
    /// component's values are shared by more than [`CROWD`] of its points: an entry is dropped
    /// when `CROWD` better entries have the same value (to a quarter spacing) in every
    /// coordinate of one of its components.
    ///
    /// Why: on one velocity channel a component that fits well scores about the same whatever
    /// the other sensor's levels, so a `3^4` grid repeats each well-fitting component 9 times,
    /// and the best 8 points could all be one hypothesis about the gyro. Measured on seed
    /// 83512 from the start (0.53, 0.20, 1.86, 0.13): the 8 best grid points of the 8-h window
    /// all had the gyro at (2.85e-6 rad/s, 5 s), a white-noise basin 4 nats below the window's
    /// maximum; the grid point nearest that maximum ranked 9th, was never polished, and the run
    /// ended at 1.12x the oracle against the ML reference's 1.01x.
    ///
    /// In a stream an entry dropped for a better one stays dropped if that one is later itself
    /// dropped: the list is the greedy choice up to that rare order effect.
    pub(super) fn offer_diverse(&mut self, ll: T, theta: &[T; MAXP], specs: &Specs) {
        self.offer(ll, theta, T::zero());
        let p = specs.len().min(MAXP);
        let tol = self.cfg.spacing * T::lit(0.25);
        let mut i = 1;
        // Each turn either keeps entry `i` or drops it (the list shifts up): at most TOP turns.
        for _ in 0..TOP {
            if i >= TOP || !self.top_ll[i].is_finite() {
                break;
            }
            // Entry `j` shares the component of coordinate `c` with entry `i`: every coordinate
            // `k` of that component within `tol`.
            let shares = |j: usize, c: &ParamSpec| {
                specs.iter().enumerate().take(p).all(|(k, s)| {
                    !s.same_component(c) || (self.top[j][k] - self.top[i][k]).abs() <= tol
                })
            };
            let crowded = specs
                .iter()
                .take(p)
                .any(|c| (0..i).filter(|&j| shares(j, c)).count() >= CROWD);
            if crowded {
                for j in i..TOP - 1 {
                    self.top[j] = self.top[j + 1];
                    self.top_ll[j] = self.top_ll[j + 1];
                    self.top_ahead[j] = self.top_ahead[j + 1];
                }
                self.top_ll[TOP - 1] = T::lit(f64::NEG_INFINITY);
            } else {
                i += 1;
            }
        }
    }

    /// At the start of a search anchored at `anchor`: the previous search's answer and its
    /// polished list become candidates of this one ([`Phase::Carried`]), evaluated after the
    /// anchor and offered like grid points, when that search ran to an answer its window
    /// identifies (none of its coordinates [`Found::flat`](super::Found::flat); not abandoned,
    /// no structure switch or change in service since). Points within a quarter spacing of the
    /// anchor or of one already carried are skipped.
    ///
    /// Why: consecutive windows overlap by hours, so a point that climbed towards a maximum on
    /// the last window is a good start on this one, but the grid forgets it. Measured on seed
    /// 95517 from a 10x accelerometer sigma: on the first full (8-h) window no grid point
    /// near the maximum ranked in the list; the search ended in a white-noise gyro basin 3.3
    /// nats above the anchor, which `keep_identified` rejected, and the filter ran the 6-h
    /// answer (gyro `tau` 1 864 s) until the revisit found the maximum at 10.9 h (`tau` 326 s,
    /// 9.8 nats up). The 6-h search's list held points on their way there (`tau` 418 and
    /// 690 s).
    ///
    /// Not after a flat answer: its list is the crowd of a basin the window does not bound,
    /// and carried, it kept the next searches there instead of the grid's other points.
    /// Measured on development seed 83502 from (1.29, 8.68, 4.43, 0.11): every search's answer
    /// was flat on the accelerometer's random-walk ridge, and the run ended at 4.9x the oracle
    /// (0.99x without carrying); two seeds of 95500-95519 lost runs to a white-noise gyro
    /// basin in the same way.
    pub(super) fn carry(&mut self, anchor: &[T; MAXP]) {
        self.carried_len = 0;
        if !self.carry_list {
            return;
        }
        self.carry_list = false;
        let tol = self.cfg.spacing * T::lit(0.25);
        let near = |a: &[T; MAXP], b: &[T; MAXP]| {
            a.iter().zip(b.iter()).all(|(x, y)| (*x - *y).abs() <= tol)
        };
        let previous = core::iter::once((self.best_ll, self.best))
            .chain(self.top_ll.iter().copied().zip(self.top.iter().copied()));
        for (ll, t) in previous {
            if self.carried_len >= TOP {
                break;
            }
            let seen = self
                .carried
                .iter()
                .take(self.carried_len)
                .any(|c| near(c, &t));
            if !ll.is_finite() || near(&t, anchor) || seen {
                continue;
            }
            if let Some(slot) = self.carried.get_mut(self.carried_len) {
                *slot = t;
                self.carried_len += 1;
            }
        }
    }

    /// The phase after the carried points before `k`: the next carried one, or the grid.
    pub(super) fn after_carried(&self, k: usize) -> Phase {
        if k < self.carried_len {
            Phase::Carried(k)
        } else {
            Phase::Grid(0)
        }
    }

    /// Starts a Levenberg-Marquardt polish from `start` in `phase` (every polish: the model's,
    /// an alternative's, the nested one); the first pass runs at the point itself.
    pub(super) fn begin_polish(&mut self, start: &[T; MAXP], phase: Phase) -> Phase {
        self.acc_theta = *start;
        self.acc_ll = T::lit(f64::NEG_INFINITY);
        self.lambda = T::lit(0.1);
        self.iterations = 0;
        self.pass.theta = *start;
        phase
    }

    /// Starts polishing the `k`-th best point (`refine`: to convergence), or ends the stage.
    pub(super) fn start_polish(&mut self, k: usize, refine: bool) -> Phase {
        match (self.top.get(k), self.top_ll.get(k)) {
            (Some(&t), Some(&l)) if l.is_finite() => {
                let phase = if refine {
                    Phase::Refine(k)
                } else {
                    Phase::Polish(k)
                };
                self.begin_polish(&t, phase)
            }
            _ if !refine => {
                self.rank_for_refinement();
                self.start_polish(0, true)
            }
            _ => Phase::Idle,
        }
    }

    /// After the brief polishes: the entries ranked by likelihood, then the most promising of
    /// the others second, so that the [`FINAL`] refinements go to the best point and to the one
    /// whose likelihood plus the gain still ahead of it ([`step_gain`](Self::step_gain)) is
    /// highest.
    ///
    /// Why: a brief polish stops after [`SHORT_ITERATIONS`], and a point that started a decade
    /// or two away in one coordinate may still be climbing steeply, below points that have
    /// converged in a worse basin. Measured on fresh seed 92718 from (0.63, 0.13, 4.97, 0.64):
    /// on the 8-h window the point that led to the maximum ended its brief polish 6.3 nats
    /// below the anchor (a white-noise gyro basin), ranked 5th of 6 and was not refined, while
    /// its next step was predicted to gain 17.8 nats; the second refinement went to a
    /// converged point of the same basin 1.9 nats below the anchor. From there the maximum
    /// was 19.5 nats above the anchor.
    pub(super) fn rank_for_refinement(&mut self) {
        let (l0, t0, a0) = (self.top_ll, self.top, self.top_ahead);
        self.top_ll = [T::lit(f64::NEG_INFINITY); TOP];
        for ((l, t), a) in l0.iter().zip(t0.iter()).zip(a0.iter()) {
            self.offer(*l, t, *a);
        }
        // The most promising after the best moves up to second place.
        let promise = |k: usize| self.top_ll[k] + self.top_ahead[k];
        let mut j = 1;
        for k in 2..TOP {
            if self.top_ll[k].is_finite() && promise(k) > promise(j) {
                j = k;
            }
        }
        for k in (1..j.min(TOP - 1)).rev() {
            self.top.swap(k, k + 1);
            self.top_ll.swap(k, k + 1);
            self.top_ahead.swap(k, k + 1);
        }
    }

    /// The log-likelihood gain that the quadratic model at the last accepted point (its score
    /// `g` and Fisher information `I`) predicts for the next damped scoring step `d`:
    /// `g' d - d' I d / 2`; zero when there is no step. Bounded by the step's limit, unlike
    /// the undamped Newton gain `g' I^-1 g / 2`, which a flat direction makes arbitrarily
    /// large (measured on seed 92718: up to 28 000 nats at converged white-noise points).
    pub(super) fn step_gain(&self, p: usize, bounds: &Bounds<T>) -> T {
        let Some(t) = self.scoring_step(p, bounds) else {
            return T::zero();
        };
        let mut d = [T::zero(); MAXP];
        for ((v, a), b) in d
            .iter_mut()
            .zip(t.iter())
            .zip(self.acc_theta.iter())
            .take(p)
        {
            *v = *a - *b;
        }
        let mut gain = T::zero();
        for ((di, gi), row) in d
            .iter()
            .zip(self.acc_score.iter())
            .zip(self.acc_fisher.iter())
            .take(p)
        {
            let fd = row
                .iter()
                .zip(d.iter())
                .take(p)
                .fold(T::zero(), |m, (f, dj)| m + *f * *dj);
            gain += *di * (*gi - fd * T::lit(0.5));
        }
        if gain.is_finite() {
            gain.max(T::zero())
        } else {
            T::zero()
        }
    }

    /// The damped scoring step from the last accepted point, limited to half the grid spacing
    /// per parameter (direction kept).
    pub(super) fn scoring_step(&self, p: usize, bounds: &Bounds<T>) -> Option<[T; MAXP]> {
        let mut a = self.acc_fisher;
        let mut g = self.acc_score;
        for (i, row) in a.iter_mut().enumerate().take(p) {
            row[i] = row[i] * (T::one() + self.lambda) + T::lit(1e-9);
        }
        // A fixed coordinate (the hold's) does not move: its row and column decouple.
        for i in (0..p.min(MAXP)).filter(|&i| has_coordinate(self.fixed, i)) {
            for (j, row) in a.iter_mut().enumerate() {
                for (k, v) in row.iter_mut().enumerate() {
                    if j == i || k == i {
                        *v = if j == k { T::one() } else { T::zero() };
                    }
                }
            }
            if let Some(v) = g.get_mut(i) {
                *v = T::zero();
            }
        }
        let l = cholesky(&a, p)?;
        let mut d = chol_solve(&l, &g, p);
        let big = d.iter().take(p).fold(T::zero(), |m, v| m.max(v.abs()));
        let limit = self.cfg.spacing * T::lit(0.5);
        if !big.is_finite() {
            return None;
        }
        if big > limit {
            for v in d.iter_mut() {
                *v *= limit / big;
            }
        }
        let mut t = self.acc_theta;
        for i in 0..p {
            t[i] += d[i];
        }
        Some(bounds.clamp(&t, p))
    }

    /// One Levenberg-Marquardt decision after a polish pass at `theta` with likelihood `ll`.
    pub(super) fn polish_step(
        &mut self,
        k: usize,
        refine: bool,
        theta: [T; MAXP],
        ll: T,
        p: usize,
        bounds: &Bounds<T>,
    ) -> Phase {
        self.iterations += 1;
        let most = if refine {
            MAX_ITERATIONS
        } else {
            SHORT_ITERATIONS
        };
        if ll.is_finite() && ll >= self.acc_ll {
            // Accepted: the new point, its score and information.
            let moved = theta
                .iter()
                .zip(self.acc_theta.iter())
                .take(p)
                .fold(T::zero(), |m, (a, b)| m.max((*a - *b).abs()));
            self.acc_theta = theta;
            self.acc_ll = ll;
            self.acc_score = self.pass.info.score;
            self.acc_fisher = self.pass.info.fisher;
            self.prior
                .add(&theta, &mut self.acc_score, &mut self.acc_fisher);
            self.lambda = (self.lambda / T::lit(3.0)).max(T::lit(1e-3));
            let converged = self.iterations > 1 && moved < self.cfg.min_step;
            if converged || self.iterations >= most {
                return self.end_polish(k, refine, p, bounds);
            }
        } else {
            self.lambda *= T::lit(10.0);
            if self.lambda > T::lit(1e4) || self.iterations >= most {
                return self.end_polish(k, refine, p, bounds);
            }
        }
        match self.scoring_step(p, bounds) {
            Some(t) => {
                self.pass.theta = t;
                if matches!(
                    self.phase,
                    Phase::AltRefine | Phase::NestRefine | Phase::HoldRefine
                ) {
                    self.phase
                } else if refine {
                    Phase::Refine(k)
                } else {
                    Phase::Polish(k)
                }
            }
            None => self.end_polish(k, refine, p, bounds),
        }
    }

    /// The polish's result becomes the search's answer when its likelihood is higher. The
    /// window's information goes with it; also when the polish ended where the answer already
    /// is (a polish of the anchor that accepted no step leaves the anchor the best point, whose
    /// information only the polish computed).
    fn offer_best(&mut self) {
        if self.acc_ll > self.best_ll {
            self.best_ll = self.acc_ll;
            self.best = self.acc_theta;
            self.best_fisher = self.acc_fisher;
        } else if self.acc_theta == self.best && self.acc_ll.is_finite() {
            self.best_fisher = self.acc_fisher;
        }
    }

    /// Ends a polish: a brief one stores its result in place of its start point; a refinement
    /// competes for the answer.
    pub(super) fn end_polish(
        &mut self,
        k: usize,
        refine: bool,
        p: usize,
        bounds: &Bounds<T>,
    ) -> Phase {
        if self.phase == Phase::AltRefine {
            // The alternative's result is kept by `end_alternative`, not as the model's best.
            return Phase::Idle;
        }
        if self.phase == Phase::HoldRefine {
            // The hold's profile maximum: kept apart, never the search's best.
            self.held = self.acc_theta;
            self.held_ll = self.acc_ll;
            return Phase::Idle;
        }
        if self.phase == Phase::NestRefine {
            // A better point of the filter's model: it becomes the answer.
            self.offer_best();
            return Phase::Idle;
        }
        self.offer_best();
        if refine {
            if k + 1 < FINAL {
                self.start_polish(k + 1, true)
            } else {
                Phase::Idle
            }
        } else {
            let ahead = self.step_gain(p, bounds);
            if let (Some(t), Some(l), Some(a)) = (
                self.top.get_mut(k),
                self.top_ll.get_mut(k),
                self.top_ahead.get_mut(k),
            ) {
                if self.acc_ll.is_finite() && self.acc_ll >= *l {
                    *t = self.acc_theta;
                    *l = self.acc_ll;
                    *a = ahead;
                }
            }
            self.start_polish(k + 1, false)
        }
    }
}
