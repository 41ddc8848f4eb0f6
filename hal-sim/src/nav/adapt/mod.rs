//! Online identification of the navigator's sensor noise (`hal-sim nav --adapt`): issue 13's
//! global stage (the exact innovation likelihood of a buffered window, searched from the
//! current model) run causally inside the navigation loop.
//!
//! Every [`AdaptConfig::every`] seconds from [`AdaptConfig::first`], at time `t`:
//! 1. the window is `[t - window, t]` (from the start while the run is shorter): the loop's
//!    state kept at the window's start ([`NavLoop`] is a value) is replayed to `t` under each
//!    candidate model, ungated, and scored by the sum of the fused fixes' innovation
//!    log-likelihoods (the same likelihood as `nav --identify`, on data up to `t` only);
//! 2. the candidates are the current model with every identified quantity
//!    ([`ComponentKind::identified`], less the exp-cosine's `beta`, which is held) scaled by a
//!    factor, searched in the base-10 logarithm by a pattern search (steps 1, 0.5, 0.25,
//!    0.125 decades and up to 6 passes on the first search; 0.25 and 0.125 and up to 3 passes
//!    afterwards; a move is kept when the likelihood rises), bounded to two decades either
//!    side of the starting model; with [`AdaptConfig::gnss_sd`], also factors on the fixes'
//!    position and velocity standard deviations (the measurement noise, as `nav --identify`
//!    searches it offline);
//! 3. the running filter takes the best model (`Navigator::retune_imu_model`: the states
//!    kept, the covariance of a component whose magnitude grew inflated by the ratio), which
//!    every later window starts from. Later windows replay from the state kept at their start
//!    under each candidate, retuned the same way; a window from the run's start replays a
//!    fresh run under the candidate (its own prior on the sensor states).
//!
//! Each search also records, at the maximum, the Cramér-Rao standard deviation of every log10
//! factor ([`cramer_rao_sd`]) and flags the coordinates the window cannot bound
//! ([`Search::identifiable`], sd above [`IDENTIFIABLE_SD`]): "not identifiable from these data
//! yet", in `adapt.json`, `adapt.csv` and the report.
//!
//! The quantities are tied across the three axes of a sensor (one value per sensor and
//! component: the starting model's values are first replaced by their geometric mean over the
//! axes, [`tie`]) unless [`AdaptConfig::per_axis`] is set.
//!
//! Nothing after `t` is read at `t`: the test `nav_adapt` checks that a log cut at `t` gives
//! the same decisions up to `t`.

mod bank;
mod coords;
mod record;
mod tied_first;

pub use bank::{bank_log, start_bank};
use coords::Target;
pub use coords::{apply, coordinates, gnss_factors, tie, Coordinate, GNSS_SD, GNSS_SD_DEFAULT};
pub use tied_first::switch_if_settled;

pub use super::information::cramer_rao_sd;
pub use record::value;

use super::drive::{Discard, NavLoop};
use super::pattern;
use super::NavArgs;
use crate::nav_io::{GnssFix, ImuSample};
use anyhow::Result;
use imu_ident::model::Quantity;
use imu_ident::nav::ImuErrorModel;
use imu_ident::Real;
use serde::Serialize;
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// Settings of the online identification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptConfig {
    /// First search, seconds after the start.
    pub first: f64,
    /// Interval between searches [s].
    pub every: f64,
    /// Window length [s].
    pub window: f64,
    /// One factor per axis instead of per sensor.
    pub per_axis: bool,
    /// With the bank and [`per_axis`](Self::per_axis): tied until the bank settles, then per
    /// axis from there ([`tied_first`]; host only). Off by default: it helps a MEMS IMU whose
    /// axes differ and costs a tactical one whose axes are alike (BENCHMARKS.md "Tied first,
    /// then per axis").
    pub tied_first: bool,
    /// What the searches do with the correlation times.
    pub taus: TauMode,
    /// Move intensities along flat directions to the upper end of their one-sigma interval
    /// ([`FLAT_NATS`]).
    pub conservative: bool,
    /// How the likelihood is maximised: window replays (the host's search) or the core's bank
    /// of shadow filters ([`imu_ident::nav::online`], the MCU's method).
    pub method: AdaptMethod,
    /// The bank's settings ([`AdaptMethod::Bank`]; its `per_axis` and `taus` are taken from
    /// this configuration).
    pub bank: imu_ident::nav::OnlineConfig,
    /// The window search ([`AdaptMethod::Replay`]) also identifies factors on the GNSS
    /// position and velocity standard deviations ([`GNSS_SD`]; the measurement noise `R`,
    /// on top of `--gnss-sd-factor`). The bank ignores it: it keeps `--gnss-sd-factor`.
    pub gnss_sd: bool,
}

/// How the online identification maximises the likelihood.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum AdaptMethod {
    /// A pattern search over replays of a buffered window (host only: the window is ~1.3 MB).
    Replay,
    /// The core's bank of shadow filters and parabola steps (what the MCU runs).
    Bank,
}

impl AdaptConfig {
    /// The defaults (also `hal-sim nav`'s): searches every 20 min from 10 min over a 2-h
    /// window, axes tied, correlation times free, the flat-direction move on.
    pub const DEFAULT: Self = Self {
        first: 600.0,
        every: 1200.0,
        window: 7200.0,
        per_axis: false,
        tied_first: false,
        taus: TauMode::Free,
        conservative: true,
        method: AdaptMethod::Replay,
        bank: imu_ident::nav::OnlineConfig::DEFAULT,
        gnss_sd: GNSS_SD_DEFAULT,
    };
}

impl Default for AdaptConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What the online searches do with the correlation times.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum TauMode {
    /// Held at the starting model's values (tied); only the intensities are searched.
    Held,
    /// Searched, but a search's moves of them are taken only when the window rejects the
    /// held values: the intensities are searched first with the correlation times held, then
    /// everything from there, and the second answer is taken when it gains more than half the
    /// chi-square(k) 0.99 quantile (`TAU_TEST_LEVEL`), k the number of correlation times: a
    /// likelihood-ratio test of the held values against the free ones. With the bank
    /// (`--adapt-method bank`) the correlation times are searched but held while their
    /// marginal Cramér-Rao sd is above 0.5 decade (`OnlineConfig::hold_flat_taus`).
    Tested,
    /// Searched like the intensities.
    Free,
}

/// Level of [`TauMode::Tested`]'s likelihood-ratio test.
pub const TAU_TEST_LEVEL: f64 = 0.99;

/// Likelihood loss [nats] that bounds the conservative move along a flat direction: half the
/// chi-square(1) 0.68 quantile (0.99/2), the end of a one-sigma likelihood interval.
pub const FLAT_NATS: f64 = 0.5;

/// Cramér-Rao sd [decades] above which a coordinate is flagged as not identifiable from the
/// window (its one-sigma interval then spans more than a factor 10): the core's, the same
/// flag for the window search and the bank.
pub use imu_ident::nav::online::IDENTIFIABLE_SD;

/// Bound on every log10 factor, relative to the starting model.
pub const MAX_DECADES: f64 = 2.0;

/// One search.
#[derive(Debug, Clone, Serialize)]
pub struct Search {
    /// Time of the decision [s] (the log's time scale).
    pub t: f64,
    /// Start of its window [s] (the log's time scale).
    pub window_start: f64,
    /// Fixes in the window.
    pub fixes: usize,
    /// Window log-likelihood of the model in use before the search.
    pub loglik_before: f64,
    /// Window log-likelihood of the model taken.
    pub loglik: f64,
    /// The highest window log-likelihood the search found (the model taken is below it by at
    /// most [`FLAT_NATS`]: every move along a flat direction is checked against it).
    pub loglik_max: f64,
    /// Window replays made.
    pub evaluations: usize,
    /// [`TauMode::Tested`]: the test of the held correlation times.
    pub tau_test: Option<TauTest>,
    /// log10 factors at the likelihood's maximum (before the flat-direction moves).
    pub ml_log10_factors: Vec<f64>,
    /// Cramér-Rao standard deviation of each log10 factor at the maximum
    /// ([`cramer_rao_sd`]); infinite (`null` in JSON) where the window does not bound it.
    pub cr_sd_log10: Vec<f64>,
    /// Each coordinate is identifiable from the window: its Cramér-Rao sd is at most
    /// [`IDENTIFIABLE_SD`]. A `false` is the flag "not identifiable from these data yet".
    pub identifiable: Vec<bool>,
    /// log10 factors on the starting model after the search (coordinate order).
    pub log10_factors: Vec<f64>,
}

/// The likelihood-ratio test of one search's correlation times ([`TauMode::Tested`]).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TauTest {
    /// Window log-likelihood gained by freeing the correlation times [nats].
    pub gain: f64,
    /// The gain that rejects the held values: half the chi-square(k) quantile at
    /// [`TAU_TEST_LEVEL`] [nats].
    pub threshold: f64,
    /// The correlation times moved (`gain > threshold`).
    pub moved: bool,
}

/// The online identification's record of a run.
#[derive(Debug, Clone, Serialize)]
pub struct AdaptLog {
    /// The coordinates.
    pub coordinates: Vec<Coordinate>,
    /// Every search, in time order.
    pub searches: Vec<Search>,
    /// The model in use at the end.
    #[serde(skip)]
    pub model: ImuErrorModel<f64>,
    /// The starting model, tied ([`tie`]): the factors' reference.
    #[serde(skip)]
    pub base: ImuErrorModel<f64>,
    /// The factors on the GNSS standard deviations the run started with
    /// (`--gnss-sd-factor`): the GNSS coordinates' reference.
    pub gnss_sd_factor_start: [f64; 2],
    /// With `--adapt-tied-first`: when the per-axis bank took over from the tied one [s]
    /// (the searches before it are the tied bank's, in the per-axis coordinates).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tied_until: Option<f64>,
}

/// The online identification's state inside a run.
pub struct Adapter<T: Real> {
    cfg: AdaptConfig,
    args: NavArgs,
    base: ImuErrorModel<f64>,
    coords: Vec<Coordinate>,
    x: Vec<f64>,
    /// Loop states kept at the decision times (and the start), oldest first.
    checkpoints: std::collections::VecDeque<NavLoop<T>>,
    next: f64,
    t0: f64,
    log: Vec<Search>,
}

impl<T: Real> Adapter<T> {
    /// The identification of a run whose loop `lp` starts at `t0`, from `args.model`.
    pub fn new(args: &NavArgs, cfg: AdaptConfig, lp: &NavLoop<T>, t0: f64) -> Self {
        let coords = coordinates(&args.model, &cfg);
        Self {
            cfg,
            args: args.clone(),
            base: tie(&args.model, &coords),
            x: vec![0.0; coords.len()],
            coords,
            checkpoints: [lp.clone()].into(),
            next: t0 + cfg.first,
            t0,
            log: Vec::new(),
        }
    }

    /// Time of the next search [s].
    pub fn next_time(&self) -> f64 {
        self.next
    }

    /// The search at the loop's time (`lp` has mechanised every sample up to
    /// [`next_time`](Self::next_time)); updates the running loop's model.
    pub fn search(
        &mut self,
        lp: &mut NavLoop<T>,
        imu: &[ImuSample],
        fixes: &[GnssFix],
        imu_name: &str,
    ) -> Result<()> {
        let t = self.next;
        self.next += self.cfg.every;
        // The window's start: the oldest checkpoint not before t - window.
        while self.checkpoints.len() > 1
            && self.checkpoints.front().map_or(f64::NAN, |c| c.time(imu))
                < t - self.cfg.window - 1e-6
        {
            self.checkpoints.pop_front();
        }
        let Some(start) = self.checkpoints.front().cloned() else {
            return Ok(());
        };
        let window_start = start.time(imu);
        // A window from the run's start replays a fresh run under the candidate (its own
        // prior on the sensor states); a later one starts from the state kept there, whose
        // covariance the models in use so far built.
        let from_start = window_start <= self.t0;
        let mut evaluations = 0usize;
        let mut fixes_in = 0usize;
        let args = &self.args;
        let mut eval = |x: &[f64]| -> Result<f64> {
            evaluations += 1;
            let model = apply(&self.base, &self.coords, x);
            let sd_factor = gnss_factors(args.gnss_sd_factor, &self.coords, x);
            let mut w = if from_start {
                let mut a = args.clone();
                a.model = model;
                a.gnss_sd_factor = sd_factor;
                match NavLoop::<T>::start(&a, imu, fixes) {
                    Ok((w, _)) => w,
                    Err(_) => return Ok(f64::NEG_INFINITY),
                }
            } else {
                let mut w = start.clone();
                if w.nav_mut().retune_imu_model(model.cast()).is_err()
                    || w.set_gnss_sd_factor(sd_factor).is_err()
                {
                    return Ok(f64::NEG_INFINITY);
                }
                w
            };
            w.nav_mut().set_gate(None);
            w.loglik = 0.0;
            w.fused = 0;
            w.advance(imu, fixes, t, &mut Discard, imu_name, &|| {})?;
            fixes_in = w.fused;
            Ok(if w.loglik.is_finite() {
                w.loglik
            } else {
                f64::NEG_INFINITY
            })
        };
        // The search revisits points (a pattern search's neighbours, the curvature below):
        // each distinct point is replayed once. Points are multiples of 1/8 decade.
        let mut seen = std::collections::HashMap::<Vec<i64>, f64>::new();
        let mut eval = |x: &[f64]| -> Result<f64> {
            let key: Vec<i64> = x.iter().map(|v| (v * 8.0).round() as i64).collect();
            if let Some(&ll) = seen.get(&key) {
                return Ok(ll);
            }
            let ll = eval(x)?;
            seen.insert(key, ll);
            Ok(ll)
        };
        let before = eval(&self.x)?;
        let mut best = before;
        let mut x = self.x.clone();
        // The first search is global over the bounds (steps from a decade); later ones track
        // from the current point (steps from a quarter decade, fewer passes).
        let (steps, max_passes): (&[f64], usize) = if self.log.is_empty() {
            (&[1.0, 0.5, 0.25, 0.125], 6)
        } else {
            (&[0.25, 0.125], 3)
        };
        let is_tau: Vec<bool> = self
            .coords
            .iter()
            .map(|c| c.imu().is_some_and(|k| k.quantity == Quantity::Tau))
            .collect();
        let n_tau = is_tau.iter().filter(|&&t| t).count();
        let tested = self.cfg.taus == TauMode::Tested && n_tau > 0;
        // Tested: the intensities first, the correlation times held where they are.
        let held_taus = |i: usize| (!is_tau[i]).then_some((-MAX_DECADES, MAX_DECADES));
        let all = |_: usize| Some((-MAX_DECADES, MAX_DECADES));
        let ridges = coords::ridges(&self.coords);
        pattern::maximise(
            &mut x,
            &mut best,
            steps,
            max_passes,
            if tested { &held_taus } else { &all },
            &ridges,
            &mut eval,
        )?;
        let mut tau_test = None;
        if tested {
            // Then everything from there; the moves of the correlation times are taken only
            // when the held values are rejected at TAU_TEST_LEVEL (Wilks: twice the gain is
            // chi-square(n_tau) under the held values).
            let mut y = x.clone();
            let mut best_free = best;
            pattern::maximise(
                &mut y,
                &mut best_free,
                steps,
                max_passes,
                &all,
                &ridges,
                &mut eval,
            )?;
            let threshold = ChiSquared::new(n_tau as f64)
                .map(|d| 0.5 * d.inverse_cdf(TAU_TEST_LEVEL))
                .unwrap_or(f64::INFINITY);
            let gain = best_free - best;
            let moved = gain > threshold;
            if moved {
                x = y;
                best = best_free;
            }
            tau_test = Some(TauTest {
                gain,
                threshold,
                moved,
            });
        }
        let loglik_max = best;
        let ml_log10_factors = x.clone();
        let cr_sd_log10 = cramer_rao_sd(&x, best, &all, &mut eval)?;
        // Flat directions: an intensity the window cannot pin down is moved up to the upper
        // end of its one-sigma likelihood interval (the largest value, in steps of 0.125
        // decade, that costs less than FLAT_NATS against the best point), not left wherever
        // the search stopped. An intensity too small makes the filter overconfident in the
        // states it drives (a tactical IMU's accelerometer bias over a 30-min window: tilt
        // outside 3 sigma in 5 % of epochs); one too large only costs accuracy. Correlation
        // times are left at the maximum.
        if self.cfg.conservative {
            let mut ll_x = best;
            for i in (0..x.len()).filter(|&i| !is_tau[i]) {
                loop {
                    let mut y = x.clone();
                    y[i] = (y[i] + 0.125).min(MAX_DECADES);
                    if y[i] == x[i] {
                        break;
                    }
                    let ll = eval(&y)?;
                    if ll >= best - FLAT_NATS {
                        x = y;
                        ll_x = ll;
                    } else {
                        break;
                    }
                }
            }
            best = ll_x;
        }
        self.x = x;
        let model = apply(&self.base, &self.coords, &self.x);
        lp.nav_mut()
            .retune_imu_model(model.cast())
            .map_err(|e| anyhow::anyhow!("nav --adapt: model at t = {t}: {e:?}"))?;
        lp.set_gnss_sd_factor(gnss_factors(
            self.args.gnss_sd_factor,
            &self.coords,
            &self.x,
        ))?;
        self.checkpoints.push_back(lp.clone());
        self.log.push(Search {
            t,
            window_start,
            fixes: fixes_in,
            loglik_before: before,
            loglik: best,
            loglik_max,
            evaluations,
            tau_test,
            identifiable: cr_sd_log10
                .iter()
                .map(|sd| *sd <= IDENTIFIABLE_SD)
                .collect(),
            ml_log10_factors,
            cr_sd_log10,
            log10_factors: self.x.clone(),
        });
        Ok(())
    }

    /// The record of the run.
    pub fn finish(self) -> AdaptLog {
        AdaptLog {
            model: apply(&self.base, &self.coords, &self.x),
            gnss_sd_factor_start: self.args.gnss_sd_factor,
            base: self.base,
            coordinates: self.coords,
            searches: self.log,
            tied_until: None,
        }
    }
}
