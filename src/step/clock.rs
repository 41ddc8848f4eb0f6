//! The step's time rules: which log rows are ticked, how many missing-observation ticks bridge
//! a gap, and what a suspect time stamp does. One set of rules for every estimator, whatever
//! its error model ([`Estimator::push`](super::Estimator::push) and
//! [`push_axes`](super::Estimator::push_axes)).
//!
//! ```
//! use imu_ident::step::clock::{Clock, Plan};
//! let mut clock = Clock::default();
//! assert_eq!(clock.plan(10.0, 1.0, 100), Plan::Run { start: 10.0, bridged: 0, jump: false });
//! clock.ticked(10.0);
//! // Two rows lost: two bridged ticks, then the row.
//! assert_eq!(clock.plan(13.0, 1.0, 100), Plan::Run { start: 10.0, bridged: 2, jump: false });
//! clock.ticked(13.0);
//! assert!(matches!(clock.plan(13.0, 1.0, 100), Plan::Skip(_))); // time does not advance
//! ```

use crate::telemetry::{time_flags, SKIPPED};

/// What to do with one log row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Plan {
    /// Do not tick: report the row with these flags ([`SKIPPED`] and the time's flags).
    Skip(u16),
    /// Tick `bridged` missing-observation ticks at `start + i dt` (`i = 1..=bridged`), then the
    /// row; `jump`: the gap was longer than the bridge (the row's tick carries `TIME_JUMP`).
    Run {
        /// The time the bridged ticks count from (the last ticked time).
        start: f64,
        /// Missing-observation ticks before the row.
        bridged: u32,
        /// The gap was longer than what was bridged.
        jump: bool,
    },
}

/// The last ticked time and a suspect time stamp waiting for confirmation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Clock {
    prev_t: Option<f64>,
    /// A row time more than `max_bridge` steps from `prev_t`, waiting for the next row to
    /// confirm it as the new time base ([`plan`](Self::plan)).
    suspect_t: Option<f64>,
}

impl Clock {
    /// No row seen yet.
    pub const BLANK: Self = Self {
        prev_t: None,
        suspect_t: None,
    };

    /// The time of the last tick with a finite time.
    pub fn last(&self) -> Option<f64> {
        self.prev_t
    }

    /// The flags of a tick at `t` for the filter step `dt` ([`time_flags`]).
    pub fn flags(&self, t: f64, dt: f64) -> u16 {
        time_flags(self.prev_t, t, dt)
    }

    /// A tick ran at `t` (a non-finite `t` does not move the clock).
    pub fn ticked(&mut self, t: f64) {
        if t.is_finite() {
            self.prev_t = Some(t);
        }
    }

    /// The plan for a row at `t`, for the filter step `dt` and at most `max_bridge` bridged
    /// ticks. A non-finite, non-advancing or suspect time is skipped, never misread.
    ///
    /// A time more than `max_bridge` steps away from the previous one, ahead or behind, is
    /// *suspect*: one corrupted time stamp must neither make every later row look as if it
    /// went backwards nor bridge a day of blind prediction. The row is skipped (`SKIPPED`,
    /// `TIME_JUMP`, and `BAD_INPUT` when behind) and its time remembered; when the next row
    /// follows it (at least half a step and at most `max_bridge` steps after it), the clock
    /// really jumped (a long outage, a reset clock): that row becomes the new time base,
    /// ticked with `TIME_JUMP` after `max_bridge` bridged ticks when the jump was forward. A
    /// row that follows the old time base instead is ticked as usual and the suspect time
    /// forgotten. The cost of a genuine jump is one row.
    pub fn plan(&mut self, t: f64, dt: f64, max_bridge: u32) -> Plan {
        let span = f64::from(max_bridge) * dt;
        // Not `<= span` written as a negation: NaN is caught by `is_finite` first.
        let far = |p: f64| (t - p).abs() > span;
        let confirms = |c: f64| t - c >= 0.5 * dt && t - c <= span;
        let steps: f64 = match self.prev_t {
            None => 1.0,
            Some(p) if t.is_finite() && far(p) => {
                if self.suspect_t.is_some_and(confirms) {
                    // Forward: bridge the most we may (the outage was at least that long);
                    // backward: a reset clock, nothing to bridge.
                    if t > p {
                        f64::from(max_bridge) + 2.0
                    } else {
                        1.0
                    }
                } else {
                    self.suspect_t = Some(t);
                    0.0
                }
            }
            Some(p) => libm::round((t - p) / dt),
        };
        let advances = steps >= 1.0 && t.is_finite();
        if !advances {
            return Plan::Skip(self.flags(t, dt) | SKIPPED);
        }
        self.suspect_t = None;
        let gap = steps - 1.0;
        let bridged = gap.min(f64::from(max_bridge)) as u32;
        Plan::Run {
            start: self.prev_t.unwrap_or(t),
            bridged,
            jump: gap > f64::from(bridged),
        }
    }
}
