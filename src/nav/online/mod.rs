//! Online identification of the navigator's sensor noise with the MCU's memory: a bank of
//! shadow error-state filters that follow the running filter ([`NavObserver`]), scored by the
//! exact innovation likelihood of the fixes, and a pattern search whose steps are Newton steps
//! on the parabolas the shadows measure.
//!
//! # Why a bank, not a window replay
//! `hal-sim nav --adapt` (its default method) replays a buffered 2-h window under each
//! candidate model. The window's linearisation points, observations and corrections are ~190
//! bytes per 1-Hz step, 1.3 MB for 2 h: more than the MCU's RAM. The bank keeps instead, for
//! each coordinate `i` of the model ([`coords`]: tied per sensor by default), two shadow
//! filters at `10^(+-d)` times that quantity of the current model, one at the current model
//! (the centre), and for each pair of one component's quantities (a Gauss-Markov sigma and
//! tau) one at `(+d, +d)`. Each shadow is the running filter's error-state filter under its own
//! model:
//! - **prediction** with its own `Phi, Qd` at the running filter's linearisation point and
//!   step. The mechanisation removes the *running* filter's sensor-error estimate, so the
//!   navigation errors a shadow predicts are driven by its own sensor errors less that: its
//!   navigation block gets `-[Phi x^]_nav` (the term the running filter drops, navigator
//!   docs);
//! - **the same observations**, fused ungated (a gate would make the likelihood
//!   discontinuous in the parameters);
//! - **the same corrections**: when the loop is closed by `dx^`, a shadow's navigation errors
//!   become `dx_s - dx^`.
//!
//! A shadow's innovations are then those of a filter under its model on the running
//! solution, and their summed log-likelihood is the exact innovation likelihood of the fixes
//! under that model (to the linearisation, which all share). A shadow under the running
//! model reproduces the running filter's likelihood to rounding (test `nav_bank`).
//!
//! # The decisions
//! Every [`OnlineConfig::every`] seconds from [`OnlineConfig::first`], from the sums since the
//! shadows last moved (`newton.rs`): each coordinate's parabola through its shadows at
//! `-d, 0, +d` gives its gradient and curvature; a pair's `(+d, +d)` shadow gives the cross
//! curvature, and a pair moves by the 2x2 Newton step. A coordinate's step goes to the vertex,
//! at most `2 d` (a pattern search's extension), or `2 d` up the slope where the parabola is
//! not concave and the shadow on that side measured 1.92 nats over the centre (a
//! likelihood-ratio test at 5 %, `newton.rs`), and only when it promises
//! [`OnlineConfig::min_gain`] nats. The estimate, the
//! centre plus the step, is the running filter's new point ([`OnlineIdent::decide`] hands
//! its model to the caller, [`Navigator::retune_imu_model`]).
//! - **The estimate inside the grid** (every step at most `d`): the shadows stay, and their
//!   sums keep accumulating. A shadow's likelihood does not depend on the running model (it is
//!   its own model's likelihood of each fix given the corrections already made, which are
//!   known when the fix arrives), so the window grows across the running filter's retunes and
//!   the parabolas sharpen: after the first moves, decisions see hours of fixes, as the
//!   host's window replay does.
//! - **The estimate outside the grid**: the shadows take their models about it (their
//!   covariance retuned as the running filter's,
//!   [`StrapdownErrorModel::retune_covariance`]) and the sums restart. The offset `d` doubles
//!   (up to its start) when a step reached `2 d`, and halves (down to
//!   [`OnlineConfig::min_offset`]) when the largest step stayed under `1.5 d`.
//! - **Leaving on evidence** ([`OnlineConfig::exit_z`], on by default): a bounded coordinate
//!   whose step (its vertex, limited to `2 d`) is beyond the edge by fewer than `exit_z`
//!   Cramér-Rao sds stops at the edge, inside the grid (and when it is one quantity of a
//!   pair, the other moves to its maximum given that one, `newton.rs`); one stopped at two
//!   decisions in a row while its vertex was `exit_z` sds past the edge leaves by its limited
//!   step (`newton.rs`: pressed on the edge); and an estimate
//!   settled inside the grid more than `d / 2` off its centre is measured again about
//!   itself with half the offset, as if it had left.
//!
//! Keeping the grid passed 14 of 24 development runs against 9 for moving the shadows at
//! every decision, and with the defaults (decisions every 10 min, the conservative running
//! model) 74 of 96 runs on other seeds against 50 (BENCHMARKS.md "Online identification on
//! the MCU"). Each coordinate's Cramér-Rao sd at a decision is `1 / sqrt(curvature)`; above
//! [`IDENTIFIABLE_SD`] it is flagged "not identifiable from these data yet". With
//! [`OnlineConfig::hold_flat_taus`] a pair's sds are the marginal ones and a correlation
//! time so flagged is held (`newton.rs`).
//!
//! # Cost (p coordinates, q pairs, N filter states)
//! RAM: `2p + 1 + q` filters of `N^2 + N` scalars each, plus each one's model (p = 6, q = 2
//! for a white noise and a Gauss-Markov on each sensor, tied: 15 filters, about 3 kB each in
//! f32 at N = 24; the firmware's 19-filter static is 58.6 kB). Per 1-Hz step:
//! `2p + 1 + q` predictions and, for the `t` correlation-time coordinates, the pairs and the
//! centre, `2t + q + 1` full discretisations; the `p - t` intensity coordinates share the
//! centre's `Phi` and add a multiple of one `Q` series each to its `Qd` (`shared.rs`): all
//! O(N^3), linear in p (p = 6: 12.2M instructions per step on the Cortex-M4 against 16.4M
//! with every shadow discretised in full, BENCHMARKS.md). Per fix: `2p + 1 + q` fusions,
//! O((2p + q) Z N^2).
//!
//! [`Navigator::retune_imu_model`]: crate::nav::Navigator::retune_imu_model

mod config;
pub mod coords;
mod gnss;
mod newton;
mod shadow;
mod shared;
#[cfg(test)]
mod tests;

use crate::linalg::Arr;
use crate::model::{ModelError, Quantity};
use crate::nav::error_model::StrapdownErrorModel;
use crate::nav::navigator::{NavObserver, Navigator, ObservationKind};
use crate::nav::ImuErrorModel;
use crate::Real;
use coords::{Coordinate, GNSS_COORDS, MAX_COORDS, MAX_PARAMS};
use heapless::Vec;
use newton::{Marks, Quad};
use shadow::Shadow;

pub use config::OnlineConfig;

/// Shadow filters in the firmware's bank (`imu-ident-nav-qemu`): two per coordinate, the
/// centre and one per pair, for a white noise and a Gauss-Markov on each sensor, tied, and the
/// two GNSS factors (`2 (6 + 2) + 1 + 2`; 58.6 kB in `f32` at 24 states).
pub const FIRMWARE_BANK: usize = 19;

/// Cramér-Rao standard deviation [decades] above which a coordinate is flagged "not
/// identifiable from these data yet" (the component table's threshold). The flag is
/// reported (and with [`OnlineConfig::hold_flat_taus`] a correlation time so flagged is
/// held); what moves a coordinate is the likelihood gain its parabola promises
/// ([`OnlineConfig::min_gain`]).
pub use crate::model::IDENTIFIABLE_SD;

/// The online identification with a bank of at most `M` shadow filters of `N` states
/// (`M >= 2 p + 1 + q` for `p` coordinates and `q` pairs).
#[derive(Debug, Clone)]
pub struct OnlineIdent<T: Real, const N: usize, const M: usize> {
    cfg: OnlineConfig,
    coords: Vec<Coordinate, MAX_COORDS>,
    /// Coordinates on the GNSS fixes' standard deviations after the IMU's (0 or
    /// [`GNSS_COORDS`]: position, velocity; [`OnlineConfig::gnss_sd`]).
    gnss: usize,
    /// The coordinate pairs of one component (a Gauss-Markov sigma and tau), each with a
    /// shadow at `(+d, +d)` for their cross curvature.
    pairs: Vec<(usize, usize), MAX_COORDS>,
    base: ImuErrorModel<T>,
    /// The shadows' centre: log10 factors on `base`, one per coordinate.
    x: [f64; MAX_PARAMS],
    /// The estimate, the running filter's point: the centre plus the last decision's step.
    est: [f64; MAX_PARAMS],
    /// The running filter's GNSS factors (log10, position and velocity) on
    /// [`gnss_ref`](Self::gnss_ref): what it was last handed
    /// ([`running_gnss`](Self::running_gnss)).
    run_gnss: [f64; GNSS_COORDS],
    /// The navigator's GNSS factors when the bank started (log10; zeros unless an earlier
    /// bank had set them): the GNSS coordinates' reference, so that a bank started in the
    /// middle of a run continues from them.
    gnss_ref: [f64; GNSS_COORDS],
    shadows: Vec<Shadow<T, N>, M>,
    /// Each shadow's summed log-likelihood of the GNSS fixes since the last move [nats].
    sums: [f64; M],
    /// Time of the last move (or the start) [s]: where the sums begin.
    since: f64,
    /// The offset of the shadows [decades].
    d: f64,
    /// Each coordinate's Cramér-Rao sd and whether it was pressed on the grid's edge, at the
    /// last decision (`newton::step`).
    marks: Marks,
    next: f64,
    fixes: u32,
    decisions: u32,
    faults: u32,
}

impl<T: Real, const N: usize, const M: usize> OnlineIdent<T, N, M> {
    /// An empty bank, all zeros (a static on the firmware, started in place by
    /// [`start`](Self::start)).
    pub const BLANK: Self = Self {
        cfg: OnlineConfig {
            first: 0.0,
            every: 0.0,
            offset: 0.0,
            min_offset: 0.0,
            bound: 0.0,
            min_gain: 0.0,
            min_fixes: 0,
            memory: 0.0,
            conservative: false,
            per_axis: false,
            taus: false,
            hold_flat_taus: false,
            flat_waits: false,
            gnss_sd: false,
            exit_z: 0.0,
        },
        coords: Vec::new(),
        gnss: 0,
        pairs: Vec::new(),
        base: ImuErrorModel::EMPTY,
        x: [0.0; MAX_PARAMS],
        est: [0.0; MAX_PARAMS],
        run_gnss: [0.0; GNSS_COORDS],
        gnss_ref: [0.0; GNSS_COORDS],
        shadows: Vec::new(),
        sums: [0.0; M],
        since: 0.0,
        d: 0.0,
        marks: Marks::NONE,
        next: 0.0,
        fixes: 0,
        decisions: 0,
        faults: 0,
    };

    /// The identification of `nav`'s noise model from now (time `t` [s]): the shadows start
    /// from its filter's `x, P`, about its model tied ([`coords::tie`]).
    /// [`ModelError::TooManyStates`] when the bank needs more than `M` filters.
    pub fn new<O: NavObserver<T, N>>(
        cfg: OnlineConfig,
        nav: &Navigator<T, N, O>,
        t: f64,
    ) -> Result<Self, ModelError> {
        let mut s = Self::BLANK;
        s.start(cfg, nav, t)?;
        Ok(s)
    }

    /// [`new`](Self::new) about the IMU model `start` rather than the navigator's (a bank
    /// that takes over from another starts at that one's estimate, not at its running model,
    /// which [`OnlineConfig::conservative`] raised). The running filter keeps its model until
    /// the first decision.
    pub fn new_about<O: NavObserver<T, N>>(
        cfg: OnlineConfig,
        nav: &Navigator<T, N, O>,
        t: f64,
        start: &ImuErrorModel<T>,
    ) -> Result<Self, ModelError> {
        let mut s = Self::BLANK;
        s.start_about(cfg, nav, t, start)?;
        Ok(s)
    }

    /// [`new`](Self::new) in place (the bank is tens of kB in `f32`: the firmware must not
    /// build it on its stack).
    pub fn start<O: NavObserver<T, N>>(
        &mut self,
        cfg: OnlineConfig,
        nav: &Navigator<T, N, O>,
        t: f64,
    ) -> Result<(), ModelError> {
        self.start_about(cfg, nav, t, &nav.model().imu)
    }

    fn start_about<O: NavObserver<T, N>>(
        &mut self,
        cfg: OnlineConfig,
        nav: &Navigator<T, N, O>,
        t: f64,
        start: &ImuErrorModel<T>,
    ) -> Result<(), ModelError> {
        let cfg = cfg.checked()?;
        let coords = coords::coordinates(start, cfg.per_axis, cfg.taus)?;
        let pairs = newton::pairs(&coords);
        let gnss = if cfg.gnss_sd { GNSS_COORDS } else { 0 };
        if 2 * (coords.len() + gnss) + 1 + pairs.len() > M {
            return Err(ModelError::TooManyStates);
        }
        self.base = coords::tie(start, &coords);
        self.cfg = cfg;
        self.coords = coords;
        self.gnss = gnss;
        self.pairs = pairs;
        self.x = [0.0; MAX_PARAMS];
        self.est = [0.0; MAX_PARAMS];
        self.run_gnss = [0.0; GNSS_COORDS];
        self.gnss_ref = nav.gnss_sd_factor().map(|f| {
            let f = f.as_f64();
            if f > 0.0 && f.is_finite() {
                libm::log10(f)
            } else {
                0.0
            }
        });
        self.sums = [0.0; M];
        self.since = t;
        self.d = cfg.offset;
        self.marks = Marks::NONE;
        self.next = t + cfg.first;
        self.fixes = 0;
        self.decisions = 0;
        self.faults = 0;
        self.shadows.clear();
        for k in 0..=2 * self.p() + self.pairs.len() {
            let mut model = nav.model().clone();
            model.imu = self.shadow_imu(k);
            self.shadows
                .push(Shadow::new(model, nav.kalman().clone()))
                .map_err(|_| ModelError::TooManyStates)?;
        }
        self.sync_gnss();
        Ok(())
    }

    /// The number of coordinates: the IMU's and the GNSS factors.
    fn p(&self) -> usize {
        self.coords.len() + self.gnss
    }

    /// The starting model, tied: the factors' reference.
    pub fn base(&self) -> &ImuErrorModel<T> {
        &self.base
    }

    /// The IMU's coordinates; with [`OnlineConfig::gnss_sd`] the factors, estimates and
    /// sds below have [`gnss_coordinates`](Self::gnss_coordinates) more after them.
    pub fn coordinates(&self) -> &[Coordinate] {
        &self.coords
    }

    /// The estimate: log10 factors on the starting model (tied), one per coordinate.
    pub fn log10_factors(&self) -> &[f64] {
        self.est.get(..self.p()).unwrap_or(&[])
    }

    /// The shadows' centre: log10 factors on the starting model, one per coordinate.
    pub fn centre(&self) -> &[f64] {
        self.x.get(..self.p()).unwrap_or(&[])
    }

    /// The Cramér-Rao standard deviation of each coordinate [decades] at the last decision
    /// (infinite before the first, or where the data do not bound it).
    pub fn cr_sd(&self) -> &[f64] {
        self.marks.cr_sd.get(..self.p()).unwrap_or(&[])
    }

    /// Coordinate `i` is identifiable from the data so far (its Cramér-Rao sd is at most
    /// [`IDENTIFIABLE_SD`]).
    pub fn identifiable(&self, i: usize) -> bool {
        self.marks
            .cr_sd
            .get(i)
            .is_some_and(|sd| *sd <= IDENTIFIABLE_SD)
    }

    /// Each shadow's summed log-likelihood of the GNSS fixes since the last move [nats]:
    /// shadow `2i` at `+d` and `2i + 1` at `-d` on coordinate `i`, `2p` the centre, then one
    /// per pair of a component's quantities at `(+d, +d)`.
    pub fn window_sums(&self) -> &[f64] {
        self.sums.get(..self.shadows.len()).unwrap_or(&[])
    }

    /// Time of the last move, or of the start [s]: where [`window_sums`](Self::window_sums)
    /// begin.
    pub fn window_start(&self) -> f64 {
        self.since
    }

    /// The shadows' offset from the centre [decades].
    pub fn offset(&self) -> f64 {
        self.d
    }

    /// GNSS fixes scored since the last move.
    pub fn fixes(&self) -> u32 {
        self.fixes
    }

    /// Decisions taken so far.
    pub fn decisions(&self) -> u32 {
        self.decisions
    }

    /// Shadow operations that failed (a model that could not be discretised, a non-finite
    /// likelihood) and were skipped.
    pub fn faults(&self) -> u32 {
        self.faults
    }

    /// The factors of shadow `k`: for `k < 2p` coordinate `k / 2` offset by `+d` for even `k`,
    /// `-d` for odd; `k = 2p` the centre; for `k > 2p` both coordinates of pair `k - 2p - 1`
    /// offset by `+d`.
    fn factors(&self, k: usize) -> [T; MAX_PARAMS] {
        let p2 = 2 * self.p();
        let mut f = [T::zero(); MAX_PARAMS];
        for (fi, xi) in f.iter_mut().zip(self.x.iter()) {
            *fi = T::lit(*xi);
        }
        if let Some(&(i, j)) = k.checked_sub(p2 + 1).and_then(|q| self.pairs.get(q)) {
            for c in [i, j] {
                if let (Some(fi), Some(xi)) = (f.get_mut(c), self.x.get(c)) {
                    *fi = T::lit(*xi + self.d);
                }
            }
            return f;
        }
        if k < p2 {
            let d = if k % 2 == 0 { self.d } else { -self.d };
            if let (Some(fi), Some(xi)) = (f.get_mut(k / 2), self.x.get(k / 2)) {
                *fi = T::lit(*xi + d);
            }
        }
        f
    }

    fn shadow_imu(&self, k: usize) -> ImuErrorModel<T> {
        coords::apply(&self.base, &self.coords, &self.factors(k))
    }

    /// At time `t` [s], after a filter step or a fix: when a decision is due, moves the
    /// coordinates (module docs) and returns the new model for the running filter
    /// ([`Navigator::retune_imu_model`](crate::nav::Navigator::retune_imu_model)); `None`
    /// when no decision is due or nothing moved.
    pub fn decide(&mut self, t: f64) -> Option<ImuErrorModel<T>> {
        // A non-finite time decides nothing.
        if !t.is_finite() || t < self.next {
            return None;
        }
        // The next decision after t, in one step (no loop over a long gap).
        let every = self.cfg.every.max(1.0);
        self.next += (libm::floor((t - self.next) / every) + 1.0) * every;
        if self.fixes < self.cfg.min_fixes {
            return None;
        }
        self.decisions = self.decisions.saturating_add(1);
        let p = self.p();
        let q = Quad::from_sums(self.d, p, &self.pairs, &self.sums);
        let step = newton::step(
            &self.cfg,
            p,
            &self.coords,
            &self.pairs,
            &q,
            &self.x,
            &mut self.marks,
        );
        let big = step
            .iter()
            .take(p)
            .fold(0.0f64, |m, v| m.max(libm::fabs(*v)));
        let mut est = self.x;
        for (e, s) in est.iter_mut().zip(step.iter()).take(p) {
            *e += s;
        }
        let settled =
            newton::settled_off_centre(&self.cfg, self.d, p, &est, &self.x, &self.marks.cr_sd);
        if big <= self.d && !settled {
            // The estimate is inside the shadows' grid: the running filter takes it, and the
            // shadows stay where they are, so the sums keep accumulating (the window grows and
            // the parabolas sharpen). Their likelihoods do not depend on the running model:
            // each is its own model's exact likelihood of the fixes given the running
            // solution's corrections, which are known when the fix arrives.
            let moved = est != self.est;
            self.est = est;
            return (moved || self.cfg.conservative).then(|| self.hand_over());
        }
        // The estimate is outside the grid: the shadows move about it and the window restarts.
        // The pattern search's offset doubles (up to the start's) when the move reached its
        // end, halves when the move stayed within 1.5 offsets.
        if big >= 2.0 * self.d - 1e-12 {
            self.d = (self.d * 2.0).min(self.cfg.offset);
        } else if big < 1.5 * self.d {
            self.d = (self.d / 2.0).max(self.cfg.min_offset);
        }
        self.x = est;
        self.est = est;
        self.sums = [0.0; M];
        self.since = t;
        self.fixes = 0;
        for k in 0..self.shadows.len() {
            let imu = self.shadow_imu(k);
            if let Some(sh) = self.shadows.get_mut(k) {
                sh.retune(imu);
            }
        }
        Some(self.hand_over())
    }

    /// The running model handed to the caller at a decision; the running filter's GNSS
    /// factors move with it, and the shadows' relative factors follow.
    fn hand_over(&mut self) -> ImuErrorModel<T> {
        self.run_gnss = self.running_gnss();
        self.sync_gnss();
        self.running_model()
    }

    /// How far [`OnlineConfig::conservative`] raises coordinate `i` in the running model: its
    /// Cramér-Rao sd, at most the offset `d`, for an intensity (a GNSS factor is one); 0 for
    /// a correlation time or without the option.
    fn raise(&self, i: usize) -> f64 {
        let intensity = self
            .coords
            .get(i)
            .map_or(i < self.p(), |c| c.quantity.is_intensity());
        match self.marks.cr_sd.get(i) {
            Some(sd) if self.cfg.conservative && intensity => sd.min(self.d),
            _ => 0.0,
        }
    }

    /// The running filter's model: the bank's point, with [`OnlineConfig::conservative`] each
    /// intensity (not a correlation time) raised to the upper end of its one-sigma interval,
    /// by its Cramér-Rao sd, at most the current offset `d` (the same offset where the
    /// likelihood is not concave or not bounded). The bank keeps searching about its point.
    pub fn running_model(&self) -> ImuErrorModel<T> {
        self.model_at(true)
    }

    /// The model at the estimate ([`log10_factors`](Self::log10_factors)), without the
    /// conservative raise of [`running_model`](Self::running_model).
    pub fn estimate_model(&self) -> ImuErrorModel<T> {
        self.model_at(false)
    }

    /// The model at the estimate, each coordinate `raised` by [`raise`](Self::raise) or not.
    fn model_at(&self, raised: bool) -> ImuErrorModel<T> {
        let mut f = [T::zero(); MAX_PARAMS];
        for (i, (fi, xi)) in f.iter_mut().zip(self.est.iter()).enumerate() {
            let up = if raised { self.raise(i) } else { 0.0 };
            *fi = T::lit(*xi + up);
        }
        coords::apply(&self.base, &self.coords, &f)
    }

    /// Scores one GNSS fix: adds each shadow's log-likelihood to its sum.
    fn score(&mut self) {
        if self.shadows.iter().any(|s| !s.loglik.is_finite()) {
            self.faults = self.faults.saturating_add(1);
            return;
        }
        for (sum, sh) in self.sums.iter_mut().zip(self.shadows.iter()) {
            *sum += sh.loglik;
        }
        self.fixes = self.fixes.saturating_add(1);
    }
}

#[allow(non_snake_case)]
impl<T: Real, const N: usize, const M: usize> NavObserver<T, N> for OnlineIdent<T, N, M> {
    fn propagated(
        &mut self,
        model: &StrapdownErrorModel<T>,
        scale: &[T; N],
        x: &[T; N],
        p0: &Arr<T, N>,
    ) {
        let p2 = 2 * self.p();
        let mut faults = 0u32;
        // Shadows `0..2p` are the coordinates' `+d, -d`, then the centre and the pairs'.
        if let Some((coords, rest)) = self.shadows.split_at_mut_checked(p2) {
            let mut tail = rest.iter_mut();
            // The centre's discretisation, shared by the shadows that differ from it in one
            // intensity only (`shared.rs`): their Phi is the centre's, and Qd is linear in Qc.
            let centre = tail
                .next()
                .and_then(|sh| shared::Centre::propagate(sh, model, scale, x, p0));
            if centre.is_none() {
                faults += 1;
            }
            for (i, two) in coords.chunks_exact_mut(2).enumerate() {
                let [plus, minus] = two else {
                    continue;
                };
                let coord = self.coords.get(i);
                // A GNSS factor's shadows have the centre's noise model: its Phi and Qd.
                if coord.is_none() {
                    match centre.as_ref() {
                        Some(c) => c.propagate_same([plus, minus], x, p0),
                        None => {
                            faults += shared::propagate_each([plus, minus], model, scale, x, p0)
                        }
                    }
                    continue;
                }
                // A correlation time moves `A`: its shadows are not offered for sharing (the
                // test would build a continuous system only to refuse it).
                let tau = coord.is_some_and(|c| c.quantity == Quantity::Tau);
                faults += match centre.as_ref().filter(|_| !tau) {
                    Some(c) => c.propagate_coordinate(plus, minus, model, scale, x, p0),
                    None => shared::propagate_each([plus, minus], model, scale, x, p0),
                };
            }
            for sh in tail {
                faults += u32::from(sh.propagate(model, scale, x, p0).is_err());
            }
        }
        self.faults = self.faults.saturating_add(faults);
        // Forgetting (`OnlineConfig::memory`): NaN-free, since memory > 0 (`checked`).
        if self.cfg.memory.is_finite() {
            let keep = libm::exp(-model.dt.as_f64() / self.cfg.memory);
            for s in self.sums.iter_mut() {
                *s *= keep;
            }
        }
    }

    fn observed<const Z: usize>(
        &mut self,
        kind: ObservationKind,
        z: &[T; Z],
        H: &[[T; N]; Z],
        R: &[T; Z],
    ) {
        let gnss = kind == ObservationKind::Gnss;
        for sh in self.shadows.iter_mut() {
            sh.fuse(z, H, R, gnss);
        }
        // Only measured data score the models: the pseudo-observations' standard deviations
        // are the user's assumptions, not the sensors'.
        if kind == ObservationKind::Gnss {
            self.score();
        }
    }

    fn corrected(&mut self, x: &[T; N], p0: &Arr<T, N>) {
        for sh in self.shadows.iter_mut() {
            sh.correct(x, p0);
        }
    }

    fn heading_restarted(&mut self, scale: &[T; N], sd: T, vel: bool) {
        for sh in self.shadows.iter_mut() {
            crate::nav::navigator::restart_heading(&mut sh.kf, scale, sd, vel);
        }
    }

    fn sensors_seeded(&mut self, x: &[T; N]) {
        for sh in self.shadows.iter_mut() {
            sh.seed_sensors(x);
        }
    }

    fn decide(&mut self, t: f64) -> Option<ImuErrorModel<T>> {
        OnlineIdent::decide(self, t)
    }

    fn gnss_sd_factor(&self) -> Option<[f64; 2]> {
        (self.gnss == GNSS_COORDS).then(|| self.running_gnss_sd())
    }
}
