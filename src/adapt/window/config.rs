//! Tuning of the global stage ([`WindowConfig`]: block, window, schedule, per-tick budget, grid
//! spacing, margin, and the structure test's penalty [`STRUCTURE_PENALTY`]). Plain data with the
//! measured defaults (`docs/ADAPTATION.md` §7), kept apart from the search that reads it.

use crate::Real;

/// The structure test's penalty [nats per parameter] when it is switched on: see
/// `docs/ADAPTATION.md` §7.6 (the statistic on `paper` data, without oscillation, stayed at or
/// below 4.3 nats on 80 logs; a switch to one more parameter needs 1.5 times this, 4.5 nats).
pub const STRUCTURE_PENALTY: f64 = 3.0;

/// Blocks before the first search when the structure test is on
/// ([`WindowConfig::with_structure`]): 3 h, not 4. The test runs only after a settled search
/// (`structure::SETTLED`: one whose answer the next barely improves), so a switch needs two
/// searches, and with the first at 4 h and the next 2 h later the earliest switch came near
/// 7 h: 0 of 20 gyros switched within 6 h at firmware pace, the bar being 90 %.
/// Measured on seeds 94800-94819 (exp-cosine gyro, firmware pace; `docs/ADAPTATION.md`
/// §7.14): with searches every hour while the window fills, the first at 2, 2.5, 3 or 4 h:
/// 12, 12, 11 and 0 of 20 within 6 h; `paper` logs 0 of 20 switched in each case. Since
/// §7.15 the search after a settled one tests structure first, on its own window.
pub const STRUCTURE_FIRST: u32 = 180;
/// Blocks between searches while the window fills when the structure test is on (1 h; see
/// [`STRUCTURE_FIRST`]). With the first search at 3 h: every 1, 1.5 or 2 h gave 11, 11 and
/// 10 of 20 within 6 h, and the largest `beta` error 10.0, 9.9 and 194 %.
pub const STRUCTURE_FILLING_EVERY: u32 = 60;

/// The change monitor's alarm threshold [nats] when on. Lorden's bound (at least `e^h` blocks
/// between false alarms) holds for the right model; the watched model is a search's estimate
/// from a window as short as 4 h. Measured on stationary `paper` logs at firmware pace (seeds
/// 9100-9119, 8 starts each): 16 nats raised 7 false alarms in 160 runs (all on one seed), 20
/// and 24 none; 24 leaves a margin (`docs/ADAPTATION.md` §7.7).
pub const CHANGE_THRESHOLD: f64 = 24.0;
/// Blocks after an estimated change before the first search on the data since it. Measured on
/// 10 development seeds per case (BENCHMARKS.md "With the change monitor"): 240 (4 h) followed
/// worst; 30, 60 and 120 were within one or two runs of each other; 60 is kept.
pub const AFTER_CHANGE: u32 = 60;

/// Blocks between searches while the window fills (2 h; then every 4 h), and a search when it
/// first fills. The filter had run the 4-h window's answer until the 8-h search ended, about
/// 9.3 h into the run; a 4-h window is sometimes far from what 8 h say (seed 83500: its answer
/// alone, fixed, 1.38x the oracle over hours 8-12, the 8-h answer 1.09x). Measured at firmware
/// pace on development seeds 83500-83519 (640 runs from any start): the worst run 1.226x ->
/// 1.133x, seeds with every run within 1.05x of the ML reference 14 -> 17 of 20
/// (BENCHMARKS.md "Searches while the window fills").
pub const FILLING_EVERY: u32 = 120;

/// Blocks after a search whose answer the window does not identify before the next search
/// (1 h; the usual pace is 4 h). Measured at firmware pace on development seeds 1000-1009 (320
/// runs from any start): the 4-h window's answer was flat on about a fifth of the runs and
/// was run until the 8-h search ended near hour 9; searching again 1 h later brought the 95th
/// percentile of the tilt ratio from 1.11-1.16 to 1.02-1.03 and the worst from 5-17x to
/// 1.05x (BENCHMARKS.md "Flat answers searched again sooner").
pub const FLAT_EVERY: u32 = 60;

/// Standard deviation [decades] of the default prior on each searched parameter about the
/// start model ([`WindowConfig::prior`]): weak, a factor 100 at one sigma. An identified
/// parameter (Cramér-Rao deviation at most half a decade) has at least 16 times its
/// information, so the prior moves it by less than a sixteenth of its distance from the start.
pub const PRIOR_DECADES: f64 = 2.0;

/// Tuning of the global stage.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WindowConfig<T> {
    /// Ticks per block mean (`0`: the global stage is off).
    pub block: u32,
    /// Blocks in the searched window (at most `WINDOW_CAP` minus the blocks that arrive during
    /// a search).
    pub window: u32,
    /// Blocks before the first search.
    pub first: u32,
    /// Blocks between the starts of two searches.
    pub every: u32,
    /// Blocks between the starts of two searches while the window is still filling (the data
    /// since the start, or since a change found, are shorter than `window`; `0`: `every`).
    /// Without a change found, a search is also due when the window first fills, and one
    /// that would start within half this pace before that waits for it: the first answer
    /// from a full window comes as early as the data allow.
    pub filling_every: u32,
    /// Decimated filter steps per tick.
    pub budget: u32,
    /// Grid spacing in `ln` (`ln 10`: factors 0.1, 1, 10).
    pub spacing: T,
    /// The polish stops when its step falls below this (`ln`).
    pub min_step: T,
    /// Advantage [nats] over the anchor the best point needs before the filter jumps to it.
    pub margin: T,
    /// `true`: the recursive Gauss-Newton does not move the parameters between searches (it
    /// still accumulates the information for the Cramér-Rao deviations); the window's polish is
    /// the local refinement.
    pub hold_recursion: bool,
    /// Complexity penalty [nats per identified parameter] of the structure test
    /// ([`structure`](super::structure)); `0`: no structure test.
    pub structure: T,
    /// Alarm threshold [nats] of the change monitor ([`change`](crate::adapt::change)); `0`:
    /// no monitor, the windows span changes in service.
    pub change: T,
    /// Blocks after an estimated change before the first search on the data since it.
    pub after_change: u32,
    /// Hold the parameters a search's window does not identify (Cramér-Rao sd above
    /// [`IDENTIFIABLE_SD`](crate::model::IDENTIFIABLE_SD) decades, [`Found::flat`]) at the
    /// values the filter runs, the others moved along the ridge ([`Found::held`]). They are
    /// flagged either way.
    ///
    /// [`Found::flat`]: super::Found::flat
    /// [`Found::held`]: super::Found::held
    pub hold_flat: bool,
    /// Blocks after a search whose answer the window does not identify ([`Found::flat`])
    /// before the next search, when sooner than the usual pace (`0`: the usual pace). Not
    /// after a change in service (`docs/ADAPTATION.md` §7.8).
    ///
    /// [`Found::flat`]: super::Found::flat
    pub flat_every: u32,
    /// Keep the start model until a search's window rejects it: the best point must beat it
    /// by half the 95 % chi-square quantile with `p` degrees of freedom (the likelihood-ratio
    /// test of the start), not by [`margin`](Self::margin) alone. Once the filter has moved, or a
    /// change in service was found, the margin alone applies.
    pub keep_start: bool,
    /// Keep an identified model (the filter's last answer had no [`Found::flat`]
    /// coordinate, or the filter still runs its start) against an answer with a flat
    /// coordinate, by the same test as [`keep_start`](Self::keep_start): a window that does not
    /// bound its answer moves the filter only when it rejects the model the filter runs.
    ///
    /// [`Found::flat`]: super::Found::flat
    pub keep_identified: bool,
    /// Cramér-Rao standard deviations (of the window's answer, marginal) added to each
    /// identified intensity (a standard deviation, a random-walk `q`, a white-noise density)
    /// before the filter runs it, at most [`CONSERVATIVE_CAP`] in `ln`; flat coordinates are
    /// not raised. `0`: the filter runs the window's maximum.
    pub conservative: T,
    /// Standard deviation [decades] of a normal prior on each searched `ln` parameter about
    /// the start model's value (`prior.rs`); `0`: none, the window's maximum likelihood.
    pub prior: T,
}

/// Largest raise of one intensity by [`WindowConfig::conservative`] (`ln`: a factor 1.42).
pub const CONSERVATIVE_CAP: f64 = 0.35;

impl<T: Real> WindowConfig<T> {
    /// Off.
    pub const OFF: Self = Self {
        block: 0,
        window: 0,
        first: 0,
        every: 0,
        filling_every: 0,
        budget: 0,
        spacing: T::ZERO,
        min_step: T::ZERO,
        margin: T::ZERO,
        hold_recursion: false,
        structure: T::ZERO,
        change: T::ZERO,
        after_change: 0,
        hold_flat: false,
        flat_every: 0,
        keep_start: false,
        keep_identified: false,
        conservative: T::ZERO,
        prior: T::ZERO,
    };

    /// The measured default (`docs/ADAPTATION.md` §7): 60-s blocks, 8-h window, first search
    /// after 4 h, then every 4 h, 64 filter steps and at most one filter construction per tick
    /// (a search over a full window takes about 1.3 h; the Cortex-M4's mean and worst tick stay
    /// within 50k and 500k instructions); margin 0 (the filter runs at the window's maximum: the
    /// search replaces the recursion, which is held); an answer the window does not identify
    /// is searched again after [`FLAT_EVERY`] blocks.
    pub fn default_on() -> Self {
        Self {
            block: 60,
            window: 480,
            first: 240,
            every: 240,
            filling_every: FILLING_EVERY,
            budget: 64,
            spacing: T::lit(core::f64::consts::LN_10),
            min_step: T::lit(0.05),
            margin: T::lit(0.0),
            hold_recursion: true,
            // Off by default: it does no measured harm, but it misses its own bars (weak evidence
            // at the amplitude, `docs/ADAPTATION.md` §7.6). Opt in with
            // `structure: STRUCTURE_PENALTY`.
            structure: T::ZERO,
            change: T::lit(CHANGE_THRESHOLD),
            after_change: AFTER_CHANGE,
            // Off: measured neutral from any start (development seeds 1000-1009) and harmful
            // after a change in service, where the values held are the old sensor's (seed
            // 31008: 1.67x oracle B against 1.01x; `docs/ADAPTATION.md` §7.8).
            hold_flat: false,
            flat_every: FLAT_EVERY,
            // On: from the truth the filter stays at the truth (from-truth median 1.000 against
            // 1.015 on seeds 70100-70119), and every wrong start of the any-start bench was
            // rejected by the first search (its 640 runs unchanged to the digit;
            // `docs/ADAPTATION.md` §7.9).
            keep_start: true,
            // On: at host pace on seeds 78200-78219 the tilt p95 fell from 1.073 to 1.047 and
            // the runs flagged in the scored hours from 12 to 2; no set got worse (fresh seeds
            // 79300-79319: unchanged to the digit; `docs/ADAPTATION.md` §7.9).
            keep_identified: true,
            // Off: at one deviation the worst 3-sigma fraction fell under 3 % on four 640-run
            // sets of five, but rose from 2.45 to 4.09 % on the fifth, and the tilt p95 rose on
            // three (`docs/ADAPTATION.md` §7.12).
            conservative: T::ZERO,
            // On, 2 decades: after a change in service the windows' flat ridges ended far
            // from the truth either way (a gyro sigma 3 decades low, an accelerometer bias of
            // 13 mg); with the prior, fresh seeds 98300-98319 at firmware pace went from 10 to
            // 12 of 20 runs within 1.10x oracle B (tilt p95 4.21 -> 1.72x), and the any-start
            // bench did not move (`docs/ADAPTATION.md` §7.16).
            prior: T::lit(PRIOR_DECADES),
        }
    }

    /// [`default_on`](Self::default_on) with the structure test on ([`STRUCTURE_PENALTY`]) and
    /// its schedule: the first search after [`STRUCTURE_FIRST`] blocks, then every
    /// [`STRUCTURE_FILLING_EVERY`] while the window fills.
    pub fn with_structure() -> Self {
        Self {
            structure: T::lit(STRUCTURE_PENALTY),
            first: STRUCTURE_FIRST,
            filling_every: STRUCTURE_FILLING_EVERY,
            ..Self::default_on()
        }
    }

    /// Whether the global stage runs.
    pub fn enabled(&self) -> bool {
        self.block > 0 && self.window > 1 && self.budget > 0
    }
}
