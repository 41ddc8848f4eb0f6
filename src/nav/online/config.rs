//! The settings of the online identification ([`OnlineConfig`]).

#[cfg(doc)]
use super::{OnlineIdent, GNSS_COORDS, IDENTIFIABLE_SD};
use crate::model::ModelError;
#[cfg(doc)]
use crate::nav::navigator::NavObserver;

/// Settings of the online identification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OnlineConfig {
    /// First decision, seconds after the start.
    pub first: f64,
    /// Interval between decisions [s]: each scores the fixes since the last move.
    pub every: f64,
    /// Starting offset `d` of the shadow filters from the current model [decades].
    pub offset: f64,
    /// Smallest offset [decades].
    pub min_offset: f64,
    /// Largest distance of a coordinate from the starting model [decades].
    pub bound: f64,
    /// Likelihood gain [nats] a coordinate's move must promise.
    pub min_gain: f64,
    /// GNSS fixes needed for a decision.
    pub min_fixes: u32,
    /// Time constant [s] with which the window's sums forget: each step multiplies them by
    /// `exp(-dt / memory)`, so a sensor that changes in service is followed sooner. Infinite
    /// (the default): the window keeps every fix since the shadows last moved. With 1800 s
    /// the bank followed a 1.5x rise and a 3x fall of the noise better (tactical attitude
    /// 1.04x against 1.85x the reference), but on stationary noise it passed about as many
    /// runs with longer tails (BENCHMARKS.md "A sensor that changes in service").
    pub memory: f64,
    /// The running filter takes each intensity at the upper end of its one-sigma interval
    /// ([`OnlineIdent::running_model`]), not at the estimate. On by default: on the tactical
    /// IMU the estimate alone left the filter overconfident (up to 5 % of epochs outside
    /// 3 sigma on the development seeds; BENCHMARKS.md "Online identification on the MCU").
    pub conservative: bool,
    /// One coordinate per axis instead of per sensor.
    pub per_axis: bool,
    /// Identify the correlation times too.
    pub taus: bool,
    /// Hold a correlation time whose marginal Cramér-Rao sd in its pair is above
    /// [`IDENTIFIABLE_SD`] (`newton.rs`: the sigma then takes its own step). Off by default:
    /// it cut the tactical attitude tail (worst 1.23x against 1.59x the true-model filter on
    /// seeds 9701-9706) but passed fewer runs, 96 of 144 against 102 (BENCHMARKS.md "Online
    /// identification on the MCU"). `hal-sim nav --adapt-taus tested` with the bank.
    pub hold_flat_taus: bool,
    /// Identify two factors on the GNSS fixes' standard deviations too, one on the position's
    /// and one on the velocity's ([`GNSS_COORDS`] coordinates after the IMU's): each has its
    /// two shadows, which differ from the centre only in the fixes' `R`. The running filter
    /// takes them through [`NavObserver::gnss_sd_factor`]. A receiver's stated standard
    /// deviations were the larger part of the model error on the real drive (BENCHMARKS.md
    /// "The GNSS noise online").
    pub gnss_sd: bool,
    /// A coordinate whose parabola is not concave (the data do not bound it yet) waits while
    /// a coordinate they do bound moves out of the shadows' grid (`newton.rs`). On by default:
    /// where several noise sources explain the same excess innovation variance, each one's
    /// slope is measured with the others at the centre, and all of them stepping `2 d` up
    /// their slopes at once overshot the joint maximum. On the real drive, from the datasheet
    /// model, the bank ended 10.6-22.6 m RMS at the outage ends without it and 7.5-8.3 m with
    /// it (BENCHMARKS.md "Flat coordinates wait in the bank").
    pub flat_waits: bool,
    /// A coordinate the window bounds leaves the shadows' grid (a step over `d`, which
    /// restarts the window) only when its step, the vertex limited to `2 d`, lies beyond the
    /// grid's edge by at least this many of its Cramér-Rao sds (a one-sided Wald test that the
    /// maximum is outside the grid, 2.3 % false alarms at 2; a vertex past `2 d` counts as
    /// `2 d`: the vertex itself was tried, BENCHMARKS.md "Correlation times wrong at the
    /// start"); otherwise it stops at the edge, inside the grid, and the window keeps growing.
    /// A coordinate stopped so while its vertex is this many sds past the edge is pressed,
    /// and pressed at two decisions in a row its limited step leaves (BENCHMARKS.md "Pressed
    /// on the edge at two decisions"). And an estimate
    /// settled inside the grid more than `d / 2` off its centre, with `exit_z` sds under
    /// `d / 2`, is measured again about itself with half the offset
    /// (`newton::settled_off_centre`). 0: every vertex beyond the edge leaves, and an
    /// estimate inside the grid stays in it. 2 by default: without it the
    /// vertex's noise on a 10-min window (0.1-0.2 decade) was larger than the settled offset
    /// (1/16-1/8 decade), so nearly every decision left the grid and no window grew past one
    /// interval; with it 76 of 96 development runs passed against 66 (BENCHMARKS.md "Leaving
    /// the grid on evidence").
    pub exit_z: f64,
}

impl OnlineConfig {
    /// The defaults.
    pub const DEFAULT: Self = Self {
        first: 600.0,
        every: 600.0,
        offset: 0.5,
        min_offset: 0.0625,
        bound: 2.0,
        min_gain: 1.0,
        min_fixes: 60,
        memory: f64::INFINITY,
        conservative: true,
        per_axis: false,
        taus: true,
        hold_flat_taus: false,
        gnss_sd: false,
        flat_waits: true,
        exit_z: 2.0,
    };
}

impl OnlineConfig {
    /// This configuration when every value is usable ([`ModelError::BadDt`] for a time,
    /// [`ModelError::BadSigma`] for an offset, bound or gain that is not).
    pub fn checked(self) -> Result<Self, ModelError> {
        let time = |v: f64| v.is_finite() && v >= 0.0;
        if !(time(self.first) && time(self.every) && self.every > 0.0) {
            return Err(ModelError::BadDt);
        }
        let ok = self.offset.is_finite()
            && self.offset > 0.0
            && self.min_offset > 0.0
            && self.min_offset <= self.offset
            && self.bound.is_finite()
            && self.bound > 0.0
            && self.min_gain.is_finite()
            && self.min_gain >= 0.0
            && self.exit_z.is_finite()
            && self.exit_z >= 0.0
            && self.memory > 0.0;
        if ok {
            Ok(self)
        } else {
            Err(ModelError::BadSigma)
        }
    }
}

impl Default for OnlineConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}
